// Display transform: linear camera RGB -> sRGB-encoded RGBA8 (one invocation per pixel).
//
// Twin of aquaspec.colour.display (to_display, float64 NumPy reference). White
// balance gains, the camera -> sRGB matrix and the exposure scale 2^EV are
// all linear, so the host folds them into one 3x3 matrix (rows m0..m2, xyz);
// automatic exposure and grey-world gains are measured on the host
// (display.display_settings). Then: tone map (ids = aquaspec.gpu.display_transform
// TONEMAP_IDS, curves as in display.TONEMAPS), IEC 61966-2-1 sRGB encoding,
// rounding to 8 bits.
//
// Non-finite input, or overflow after scaling, is counted in status[0] and
// the pixel is written black; the host refuses to return such an image.
// WGSL lets implementations assume floats are finite, so the test looks at
// the exponent bits instead of using x != x.

{{ display_struct }}

// The tone map id is a compile-time constant (one pipeline per tone map,
// aquaspec.gpu.display_transform): a switch on the uniform ran every curve for
// every pixel on lavapipe. params.tonemap holds the same id.
const TONEMAP: u32 = {{ tonemap_id }}u;

@group(0) @binding(0) var<uniform> params: {{ display_struct_name }};
@group(0) @binding(1) var<storage, read> rgb_in: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rgba_out: array<u32>;
@group(0) @binding(3) var<storage, read_write> status: array<atomic<u32>>;

#include "tonemap.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.width || gid.y >= params.height) {
        return;
    }
    let p = gid.y * params.width + gid.x;
    let c = max(rgb_in[p].xyz, vec3<f32>(0.0));
    let x = vec3<f32>(dot(params.m0, c), dot(params.m1, c), dot(params.m2, c));
    if (any_non_finite(rgb_in[p].xyz) || any_non_finite(x)) {
        atomicAdd(&status[0], 1u);
        // Row-major index of the first bad pixel (atomicMin over all of them).
        atomicMin(&status[1], p);
        rgba_out[p] = 0xff000000u;
        return;
    }
    rgba_out[p] = display_rgba8(x);
}
