// Display transform: linear camera RGB -> sRGB-encoded RGBA8 (one invocation per pixel).
//
// Twin of aquaspec/display.py (to_display, float64 NumPy reference). White
// balance gains, the camera -> sRGB matrix and the exposure scale 2^EV are
// all linear, so the host folds them into one 3x3 matrix (rows m0..m2, xyz);
// automatic exposure and grey-world gains are measured on the host
// (display.display_settings). Then: tone map (ids = aquaspec.gpu.display_pass
// TONEMAP_IDS, curves as in display.TONEMAPS), IEC 61966-2-1 sRGB encoding,
// rounding to 8 bits.
//
// Non-finite input, or overflow after scaling, is counted in status[0] and
// the pixel is written black; the host refuses to return such an image.
// WGSL lets implementations assume floats are finite, so the test looks at
// the exponent bits instead of using x != x.

{{ display_struct }}

// The tone map id is a compile-time constant (one pipeline per tone map,
// aquaspec.gpu.display_pass): a switch on the uniform ran every curve for
// every pixel on lavapipe. params.tonemap holds the same id.
const TONEMAP: u32 = {{ tonemap_id }}u;

@group(0) @binding(0) var<uniform> params: {{ display_struct_name }};
@group(0) @binding(1) var<storage, read> rgb_in: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rgba_out: array<u32>;
@group(0) @binding(3) var<storage, read_write> status: array<atomic<u32>>;

const EXP_MASK: u32 = 0x7f800000u;
// The filmic curves are at 1 long before this; the clamp keeps x * x finite.
const SATURATED: f32 = 1e6;

fn any_non_finite(v: vec3<f32>) -> bool {
    let bits = bitcast<vec3<u32>>(v) & vec3<u32>(EXP_MASK);
    return any(bits == vec3<u32>(EXP_MASK));
}

// Narkowicz 2015 ACES fit: x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14).
fn tonemap_filmic(x: vec3<f32>) -> vec3<f32> {
    let y = clamp(x, vec3<f32>(0.0), vec3<f32>(SATURATED));
    return y * (2.51 * y + 0.03) / (y * (2.43 * y + 0.59) + 0.14);
}

// Hable 2010 ("Uncharted 2") with its published constants.
fn hable_partial(x: vec3<f32>) -> vec3<f32> {
    let a = 0.15; let b = 0.50; let c = 0.10; let d = 0.20; let e = 0.02; let f = 0.30;
    return (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f;
}

fn tonemap_hable(x: vec3<f32>) -> vec3<f32> {
    let y = clamp(x, vec3<f32>(0.0), vec3<f32>(SATURATED));
    let white = hable_partial(vec3<f32>(11.2));
    return hable_partial(2.0 * y) / white;
}

fn tonemap(x: vec3<f32>, id: u32) -> vec3<f32> {
    var y: vec3<f32>;
    switch id {
        case 1u: { y = tonemap_filmic(x); }
        case 2u: { y = tonemap_hable(x); }
        case 3u: { let p = max(x, vec3<f32>(0.0)); y = p / (1.0 + p); }
        default: { y = x; }
    }
    return clamp(y, vec3<f32>(0.0), vec3<f32>(1.0));
}

fn srgb_encode(x: vec3<f32>) -> vec3<f32> {
    let lo = 12.92 * x;
    let hi = 1.055 * pow(x, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}

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
    // round() in WGSL rounds half to even, like numpy.rint in display.quantize.
    let q = vec3<u32>(round(srgb_encode(tonemap(x, TONEMAP)) * 255.0));
    rgba_out[p] = q.x | (q.y << 8u) | (q.z << 16u) | (255u << 24u);
}
