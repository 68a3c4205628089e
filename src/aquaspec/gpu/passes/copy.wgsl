// The "memory floor" pass for benchmarks: reads every G-buffer input of one
// pixel and writes one vec4 to the output, with the same bindings and output
// size as deferred.wgsl but no shading. The deferred pass cannot be faster
// than this on the same device; aquaspec.gpu.passes.copy.CopyPass runs it.
//
// Output: (distance, normal.y, sigmoid.z, f32(material)) so a test can check
// that what was read is what was written.

{{ camera_struct }}

@group(0) @binding(0) var<uniform> cam: {{ camera_struct_name }};
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
@group(0) @binding(6) var<storage, read_write> rgb_out: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= cam.width || gid.y >= cam.height) {
        return;
    }
    let surf = textureLoad(gb_surface, gid.xy, 0);
    var sig_z = 0.0;
    if (cam.per_pixel != 0u) {   // uniform: the same for every pixel
        sig_z = textureLoad(gb_sigmoid, gid.xy, 0).z;
    }
    rgb_out[gid.y * cam.width + gid.x] = vec4<f32>(bitcast<f32>(surf.x), bitcast<f32>(surf.y),
                                                   sig_z, f32(surf.w));
}
