// Marine snow composed over the shaded image and shown, in one pass
// (aquaspec.gpu.passes.particles.ParticlePass.encode with a display):
// rgb = L max(1 - alpha, 0) + S / max(alpha, 1) (aquaspec.shading.particles.composite),
// then the display transform of display.wgsl (folded matrix, tone map, sRGB, 8 bits).
// Non-finite values are counted in status[0] (first pixel in status[1]) and shown black.

{{ display_struct }}
{{ params_struct }}

const TONEMAP: u32 = {{ tonemap_id }}u;

@group(0) @binding(0) var<uniform> display: {{ display_struct_name }};
@group(0) @binding(1) var<storage, read> rgb_in: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rgba_out: array<u32>;
@group(0) @binding(3) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(4) var snow_tex: texture_2d<u32>;
@group(0) @binding(5) var<uniform> snow_prm: {{ params_name }};

#include "tonemap.wgsl"
#include "snow_accum.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= display.width || gid.y >= display.height) {
        return;
    }
    let p = gid.y * display.width + gid.x;
    let acc = snow_accumulated(gid.x, gid.y);
    let lin = rgb_in[p].xyz * max(1.0 - acc.w, 0.0) + acc.xyz / max(acc.w, 1.0);
    let c = max(lin, vec3<f32>(0.0));
    let x = vec3<f32>(dot(display.m0, c), dot(display.m1, c), dot(display.m2, c));
    if (any_non_finite(lin) || any_non_finite(x)) {
        atomicAdd(&status[0], 1u);
        atomicMin(&status[1], p);
        rgba_out[p] = 0xff000000u;
        return;
    }
    rgba_out[p] = display_rgba8(x);
}
