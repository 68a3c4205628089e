// The half-and-half frame's sky: twin of aquaspec.rendering.above.waterline_sky
// in camera RGB. A camera on the surface (its lens half in water) sees the
// sky in air along every ray going up (v.y > 0): those pixels of the frame's
// linear image (rendered as from depth 0) become the sky's camera RGB
// (uniform, or with a sun the CIE clear sky about it); the others are kept.

{{ params_struct }}

#include "clear_sky.wgsl"

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var<storage, read_write> rgb: array<vec4<f32>>;

#include "camera_ray.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.width || gid.y >= prm.height) {
        return;
    }
    let v = camera_ray(f32(gid.x), f32(gid.y));
    if (v.y > 0.0) {
        let p = gid.y * prm.width + gid.x;
        var sky = prm.sky_rgb;
        if (prm.sun_on != 0u) {
            sky = sky * clear_sky(v, prm.sun_air, prm.sky_norm);
        }
        rgb[p] = vec4<f32>(sky, rgb[p].w);
    }
}
