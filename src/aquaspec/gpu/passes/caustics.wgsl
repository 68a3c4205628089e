// The caustic factor at the waves' current time: two frames of a loop
// (aquaspec.light.caustics.CausticLoop, NumPy twin CausticLoop.levels_at)
// mixed linearly in time. Each frame is every mip level of every slice as
// half floats, two per u32 (rows padded for the copy into the texture; the
// mix does not need to know the layout: it is the same for every word).
// aquaspec.gpu.passes.caustics.CausticLoopPass runs it.
//
// The factor is finite but may be negative (carried into the scattered
// light, aquaspec.light.caustic_scatter), so the halves are converted by
// hand with their sign, four words at a time (round to nearest even, as
// NumPy's float16): on lavapipe this was about twice as fast as
// unpack2x16float / pack2x16float.

struct LoopParams {
    mix_a: f32,
    words: u32,
    row_words: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> prm: LoopParams;
@group(0) @binding(1) var<storage, read> frame0: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> frame1: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<u32>>;

// Half floats (bits h, finite) as f32: the magnitude m = h & 0x7fff of a
// normal one by moving the exponent's bias (127 - 15 = 112), of a subnormal
// one (m < 0x400) as m 2^-24; the sign bit moved to bit 31.
fn from_half(h: vec4<u32>) -> vec4<f32> {
    let m = h & vec4<u32>(0x7fffu);
    let normal = bitcast<vec4<f32>>((m << vec4<u32>(13u)) + vec4<u32>(0x38000000u));
    let mag = select(normal, vec4<f32>(m) * 5.9604644775390625e-8, m < vec4<u32>(0x400u));
    return bitcast<vec4<f32>>(bitcast<vec4<u32>>(mag) | ((h & vec4<u32>(0x8000u)) << vec4<u32>(16u)));
}

// f32 in [-65504, 65504] to half bits, rounded to nearest, ties to even.
fn to_half(x: vec4<f32>) -> vec4<u32> {
    let sign = (bitcast<vec4<u32>>(x) >> vec4<u32>(16u)) & vec4<u32>(0x8000u);
    let ax = abs(x);
    let b = bitcast<vec4<u32>>(ax);
    let normal = (b - vec4<u32>(0x38000000u) + vec4<u32>(0xfffu)
                  + ((b >> vec4<u32>(13u)) & vec4<u32>(1u))) >> vec4<u32>(13u);
    let small = vec4<u32>(round(ax * 16777216.0));
    return select(normal, small, ax < vec4<f32>(6.103515625e-5)) | sign;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.y * prm.row_words + gid.x;
    if (gid.x >= prm.row_words || i >= prm.words) {
        return;
    }
    let p = frame0[i];
    let q = frame1[i];
    let lo_mask = vec4<u32>(0xffffu);
    let a = prm.mix_a;
    let lo = from_half(p & lo_mask) * (1.0 - a) + from_half(q & lo_mask) * a;
    let hi = from_half(p >> vec4<u32>(16u)) * (1.0 - a) + from_half(q >> vec4<u32>(16u)) * a;
    out[i] = to_half(lo) | (to_half(hi) << vec4<u32>(16u));
}
