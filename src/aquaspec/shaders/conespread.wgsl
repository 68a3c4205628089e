// The forward cone's light spread over the image with a pyramid: the GPU twin
// of aquaspec/conespread.py (spread, float64 NumPy reference; its module
// docstring has the maths), run on the spread's start level written by the
// light-field pass's COARSE pipeline (aquaspec/lightfield_compiled.py). Two
// entry points, one dispatch per level:
//   down     P_l = halving of P_{l-1} with weights [1, 3, 3, 1] / 8 per axis
//            (four bilinear samples at fine index coordinates 2i - 0.25 and
//            2i + 1.25: each pair of taps is one sample, edges clamped);
//   compose  U_l = a P_l + b up(C), C = U_{l+1} (b = 1) or, for the
//            coarsest, P_L (b = alpha_L); up = one bilinear sample at
//            (x + 0.5) / 2 - 0.5. U_0 is the result, which the light-field
//            pass adds at full resolution.
// Without FILTER (no float32-filterable) the bilinear samples are four fetches.
// Layouts: aquaspec/gpu/conespread_pass.py.

{{ params_struct }}

const FILTER: bool = {{ filter }};

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
// down: P_{l-1}; compose: P_l.
@group(0) @binding(1) var src: texture_2d<f32>;
// compose: the coarser level read through up().
@group(0) @binding(2) var coarse: texture_2d<f32>;
@group(0) @binding(3) var smp: sampler;
@group(0) @binding(4) var dst: texture_storage_2d<rgba32float, write>;

// Bilinear value of texture t (size n) at index coordinates c (texel k at
// k), clamped to the edge: a sampler's linear filtering at (c + 0.5) / n.
fn bilinear(t: texture_2d<f32>, c: vec2<f32>, n: vec2<u32>) -> vec4<f32> {
    let nf = vec2<f32>(n);
    if (FILTER) {
        return textureSampleLevel(t, smp, (c + 0.5) / nf, 0.0);
    }
    let cc = clamp(c, vec2<f32>(0.0), nf - 1.0);
    let i0 = vec2<u32>(floor(cc));
    let i1 = min(i0 + 1u, n - 1u);
    let f = cc - vec2<f32>(i0);
    let lo = mix(textureLoad(t, vec2<u32>(i0.x, i0.y), 0), textureLoad(t, vec2<u32>(i1.x, i0.y), 0), f.x);
    let hi = mix(textureLoad(t, vec2<u32>(i0.x, i1.y), 0), textureLoad(t, vec2<u32>(i1.x, i1.y), 0), f.x);
    return mix(lo, hi, f.y);
}

// Coarse index coordinates of fine pixel p: (p + 0.5) / 2 - 0.5.
fn up(p: vec2<u32>) -> vec4<f32> {
    return bilinear(coarse, (vec2<f32>(p) + 0.5) * 0.5 - 0.5, prm.coarse_size);
}

@compute @workgroup_size(8, 8)
fn down(@builtin(global_invocation_id) g: vec3<u32>) {
    if (g.x >= prm.dst_size.x || g.y >= prm.dst_size.y) {
        return;
    }
    let base = 2.0 * vec2<f32>(g.xy);
    let lo = base - 0.25;
    let hi = base + 1.25;
    let sum = bilinear(src, vec2<f32>(lo.x, lo.y), prm.src_size)
        + bilinear(src, vec2<f32>(hi.x, lo.y), prm.src_size)
        + bilinear(src, vec2<f32>(lo.x, hi.y), prm.src_size)
        + bilinear(src, vec2<f32>(hi.x, hi.y), prm.src_size);
    textureStore(dst, g.xy, 0.25 * sum);
}

@compute @workgroup_size(8, 8)
fn compose(@builtin(global_invocation_id) g: vec3<u32>) {
    if (g.x >= prm.dst_size.x || g.y >= prm.dst_size.y) {
        return;
    }
    textureStore(dst, g.xy, prm.a * textureLoad(src, g.xy, 0) + prm.b * up(g.xy));
}
