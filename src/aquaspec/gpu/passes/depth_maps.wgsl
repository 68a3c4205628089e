// One orthographic depth map (aquaspec.gpu.passes.depth_maps): the scene
// rasterised along a direction w into a layer of a depth texture array, depth
// (h_max - h) / (h_max - h_min) with h = p . w
// (aquaspec.scene.shadowmap.ShadowMapSpec.clip_matrix). Depth only: no fragment stage.

struct DepthClip {
    clip: mat4x4<f32>,
};

@group(0) @binding(0) var<uniform> dc: DepthClip;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return dc.clip * vec4<f32>(position, 1.0);
}
