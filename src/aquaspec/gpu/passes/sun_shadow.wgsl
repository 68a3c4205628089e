// The sun's shadow map (aquaspec.gpu.passes.sun_shadow): the scene rasterised
// orthographically along the refracted beam into a depth texture, depth
// (h_max - h) / (h_max - h_min) with h = p . to_sun (aquaspec.scene.shadowmap.ShadowMapSpec.clip_matrix).
// Depth only: no fragment stage.

struct ShadowClip {
    clip: mat4x4<f32>,
};

@group(0) @binding(0) var<uniform> sc: ShadowClip;

@vertex
fn vs_main(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return sc.clip * vec4<f32>(position, 1.0);
}
