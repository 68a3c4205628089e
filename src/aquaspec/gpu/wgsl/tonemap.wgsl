// The display transform's per-pixel curves (aquaspec.colour.display, TONEMAPS and
// the sRGB encoding), shared by display.wgsl and the fused display of the
// shading passes (shading4.wgsl). The including file defines TONEMAP (the
// tone map id, aquaspec.gpu.display_transform.TONEMAP_IDS, a compile-time
// constant: a switch on a uniform ran every curve for every pixel on lavapipe).

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

// IEC 61966-2-1 sRGB encoding of x in [0, 1] (the tone map clamps).
// Above the linear segment x^(1/2.4) = q^(5/3), q = x^(1/4) in [0.2365, 1],
// is a degree-6 polynomial in q (Chebyshev fit made for aquaspec, max error
// 3.9e-6, i.e. 1.0e-3 of an 8-bit code): two square roots and six
// multiply-adds instead of pow's log2 and exp2 (about 1 ms of a 1280x720
// frame on lavapipe). display.to_display uses the exact power; 8-bit codes agree
// except where a value lies within 1e-3 of a rounding boundary.
fn srgb_encode(x: vec3<f32>) -> vec3<f32> {
    let lo = 12.92 * x;
    let q = sqrt(sqrt(max(x, vec3<f32>(0.0031308))));
    let p = -0.004528 + q * (0.13480164 + q * (1.28363907 + q * (-0.7833771 + q * (0.59233126
            + q * (-0.28274339 + q * 0.05987887)))));
    let hi = 1.055 * p - 0.055;
    return select(hi, lo, x <= vec3<f32>(0.0031308));
}

// Tone map, encode and round an exposed, matrixed camera RGB to packed
// RGBA8 (r | g << 8 | b << 16 | 255 << 24). round() in WGSL rounds half to
// even, like numpy.rint in display.quantize.
fn display_rgba8(x: vec3<f32>) -> u32 {
    let q = vec3<u32>(round(srgb_encode(tonemap(x, TONEMAP)) * 255.0));
    return q.x | (q.y << 8u) | (q.z << 16u) | (255u << 24u);
}
