// The forward cone's light spread over the image with a pyramid: the GPU twin
// of aquaspec.transport.lightfield.conespread (spread, float64 NumPy reference; its module
// docstring has the maths), run on the spread's start level written by the
// light-field pass's COARSE pipeline (aquaspec.transport.lightfield.compiled).
//
// One entry point, dispatched as ONE workgroup that computes every level in
// order, all invocations looping over a level's work (grid-stride) with a
// storage barrier between levels:
//   down     P_l = halving of P_{l-1}, weights [1, 3, 3, 1] / 8 per axis over
//            the fine texels 2i - 1 .. 2i + 2 (indices clamped), l = 1 .. L;
//   compose  U_l = a_l P_l + b up(C) for l = L - 1 .. 0, C = P_L with
//            b = a_L for the coarsest (U_L = a_L P_L is never stored), else
//            U_{l+1} with b = 1; up = bilinear at (x + 0.5) / 2 - 0.5,
//            clamped to the edge. With L = 0, U_0 = a_0 P_0.
// Level 0 (P_0) is read from the cone texture; P_1 .. P_L live in one storage
// buffer (a storage texture written in a dispatch cannot be read back in it)
// and U_l overwrites P_l in place (a texel of U_l needs only its own P_l);
// U_0 is stored into the result texture, which the full-resolution
// light-field pass samples bilinearly. Every read is a textureLoad or a
// buffer load, with the reference's clamping done by hand (no sampler: a
// linear sample cost about two texel fetches, and the shared loads below
// need fewer).
//
// Instead of 2L small dispatches (each 20-40 us of overhead on lavapipe).
// One workgroup runs on one CPU thread there, so the rest is counted in
// memory operations (measured per texel, 8-wide: textureLoad 1.9 ns, buffer
// load 2.8 ns, buffer store 2.1 ns, textureStore about 5 ns): an invocation
// walks a strip two columns wide down ROWS rows, carrying what the next row
// shares, so a halved texel costs 6 fine loads (16 without sharing) and a
// composed texel half a coarse load (4 without). The textureStore of U_0
// and the first halving are most of what is left (160x90, L = 5: 0.36 ms
// for the whole pyramid, 0.60 ms as 10 dispatches; conespread_pass.py).
// Layouts: aquaspec.gpu.passes.conespread.
//
// SLOTS > 1 (the multiple-scattering spread, aquaspec.transport.lightfield.conespread.spread_nodes):
// a texel holds K node images of camera RGB, 3 K values in SLOTS vec4
// (value q = 4 m + j of slot m is node q / 3, channel q % 3); level 0's
// slot m is texel (x + m width, y) of the cone texture, a level's slot m
// element SLOTS (offset + y width + x) + m of pyr. The halving runs once per
// slot; a level's own term sums the nodes with their weights
// (node_mask[3 (SLOTS level + m) + c] . slot m for channel c), the coarsest
// level is summed in place first (U_L = its own term), and U_l is stored in
// slot 0.

const WG: u32 = {{ workgroup }}u;
// Coarse rows walked by one invocation (down and compose).
const ROWS: u32 = {{ rows }}u;
const MAX_LEVELS: u32 = {{ max_levels }}u;
const SLOTS: u32 = {{ slots }}u;

struct Pyramid {
    // x: the levels below level 0, L; y: 1 to add `extra` to level 0.
    count: vec4<u32>,
    // Level k: (width, height, first element in `pyr` (k >= 1), 0).
    level: array<vec4<u32>, MAX_LEVELS + 1>,
    // a_0 .. a_L, four to a vec4.
    weight: array<vec4<f32>, (MAX_LEVELS + 4) / 4>,
    // SLOTS > 1: per level, slot and channel the nodes' weights where that
    // channel's values sit in the slot (0 elsewhere).
    node_mask: array<vec4<f32>, 3u * SLOTS * (MAX_LEVELS + 1u)>,
};

// Sizes and weights in a uniform: one pipeline for every size and level
// count, and new weights need no new pipeline.
@group(0) @binding(0) var<uniform> prm: Pyramid;
// P_0, the cone term written by the light-field pass (COARSE).
@group(0) @binding(1) var cone: texture_2d<f32>;
// P_1 .. P_L (then U_1 .. U_{L-1} in place), row-major per level.
@group(0) @binding(2) var<storage, read_write> pyr: array<vec4<f32>>;
// U_0.
@group(0) @binding(3) var result: texture_storage_2d<rgba32float, write>;
// Added to P_0 when count.y is 1 (one slot): the lamps' lit surfaces' cone
// share at level 0's size, row-major (aquaspec.gpu.passes.lamps, cone_share).
@group(0) @binding(4) var<storage, read> extra: array<vec4<f32>>;

fn weight(k: u32) -> f32 {
    return prm.weight[k / 4u][k % 4u];
}

fn size(k: u32) -> vec2<u32> {
    return prm.level[k].xy;
}

fn offset(k: u32) -> u32 {
    return prm.level[k].z;
}

// Texel (x, y) of level 0 (`tex`: the cone texture) or of the level at `off`
// in pyr, `w` wide. `tex` is a literal at every call: after inlining, one
// side of the branch is left.
fn fetch(tex: bool, off: u32, w: u32, x: u32, y: u32, m: u32) -> vec4<f32> {
    if (tex) {
        let p = textureLoad(cone, vec2<u32>(x + m * w, y), 0);
        if (SLOTS == 1u && prm.count.y != 0u) {
            return p + extra[y * w + x];
        }
        return p;
    }
    return pyr[SLOTS * (off + y * w + x) + m];
}

// Stores into the result texture (`tex`, U_0) or into slot m of pyr.
fn store(tex: bool, off: u32, w: u32, x: u32, y: u32, m: u32, v: vec4<f32>) {
    if (tex) {
        textureStore(result, vec2<u32>(x, y), v);
    } else {
        pyr[SLOTS * (off + y * w + x) + m] = v;
    }
}

// A level's own term at texel (x, y): a_lev P (SLOTS 1), or the nodes' RGB
// summed with their weights.
fn own(tex: bool, off: u32, w: u32, x: u32, y: u32, lev: u32) -> vec4<f32> {
    if (SLOTS == 1u) {
        return weight(lev) * fetch(tex, off, w, x, y, 0u);
    }
    var u = vec4<f32>(0.0);
    for (var m = 0u; m < SLOTS; m++) {
        let p = fetch(tex, off, w, x, y, m);
        let base = 3u * (SLOTS * lev + m);
        u = u + vec4<f32>(dot(prm.node_mask[base], p), dot(prm.node_mask[base + 1u], p),
                          dot(prm.node_mask[base + 2u], p), 0.0);
    }
    return u;
}

// Index i clamped to [0, n).
fn cl(i: i32, n: u32) -> u32 {
    return u32(clamp(i, 0, i32(n) - 1));
}

// [1, 3, 3, 1] / 8 of four values.
fn comb(v0: vec4<f32>, v1: vec4<f32>, v2: vec4<f32>, v3: vec4<f32>) -> vec4<f32> {
    return 0.125 * (v0 + v3) + 0.375 * (v1 + v2);
}

// The two horizontal [1, 3, 3, 1] / 8 combs of fine row y over columns
// x0 .. x2 (fine columns 4u - 1 .. 4u + 1, clamped) and x3 .. x5
// (4u + 2 .. 4u + 4): coarse columns 2u and 2u + 1.
struct Pair {
    a: vec4<f32>,
    b: vec4<f32>,
};

fn hcomb(tex: bool, src: u32, w: u32, xa: vec3<u32>, xb: vec3<u32>, y: u32, m: u32) -> Pair {
    let f2 = fetch(tex, src, w, xa.z, y, m);
    let f3 = fetch(tex, src, w, xb.x, y, m);
    return Pair(comb(fetch(tex, src, w, xa.x, y, m), fetch(tex, src, w, xa.y, y, m), f2, f3),
                comb(f2, f3, fetch(tex, src, w, xb.y, y, m), fetch(tex, src, w, xb.z, y, m)));
}

// P (size d, at `dst`) from the level below (size s, at `src`). An
// invocation walks coarse columns 2u, 2u + 1 down over ROWS coarse rows:
// coarse row y combs fine rows 2y - 1 .. 2y + 2 (clamped), two of them
// carried over from row y - 1, so a coarse texel costs 6 fine loads (16
// without sharing). Every slot, one after the other.
fn down(lid: u32, tex: bool, src: u32, s: vec2<u32>, dst: u32, d: vec2<u32>) {
    let nb = vec2<u32>((d.x + 1u) / 2u, (d.y + ROWS - 1u) / ROWS);
    for (var i = lid; i < SLOTS * nb.x * nb.y; i += WG) {
        let m = i / (nb.x * nb.y);
        let cx = 2u * (i % nb.x);
        let y0 = ROWS * ((i / nb.x) % nb.y);
        let bx = 2 * i32(cx) - 1;
        let xa = vec3<u32>(cl(bx, s.x), cl(bx + 1, s.x), cl(bx + 2, s.x));
        let xb = vec3<u32>(cl(bx + 3, s.x), cl(bx + 4, s.x), cl(bx + 5, s.x));
        var r0 = hcomb(tex, src, s.x, xa, xb, cl(2 * i32(y0) - 1, s.y), m);
        var r1 = hcomb(tex, src, s.x, xa, xb, 2u * y0, m);
        for (var y = y0; y < min(y0 + ROWS, d.y); y++) {
            let r2 = hcomb(tex, src, s.x, xa, xb, min(2u * y + 1u, s.y - 1u), m);
            let r3 = hcomb(tex, src, s.x, xa, xb, min(2u * y + 2u, s.y - 1u), m);
            store(false, dst, d.x, cx, y, m, comb(r0.a, r1.a, r2.a, r3.a));
            if (cx + 1u < d.x) {
                store(false, dst, d.x, cx + 1u, y, m, comb(r0.b, r1.b, r2.b, r3.b));
            }
            r0 = r2;
            r1 = r3;
        }
    }
}

// U = own term + b up at fine texel (x, y) of level `lev` at `dst` (size
// d), if x is inside it.
fn compose1(tex: bool, dst: u32, d: vec2<u32>, x: i32, y: u32, lev: u32, up: vec4<f32>) {
    if (x >= 0 && u32(x) < d.x) {
        store(tex, dst, d.x, u32(x), y, 0u, own(tex, dst, d.x, u32(x), y, lev) + up);
    }
}

// SLOTS > 1: the coarsest level's own term, in place (slot 0).
fn collapse(lid: u32, lev: u32) {
    let d = size(lev);
    for (var i = lid; i < d.x * d.y; i += WG) {
        let x = i % d.x;
        let y = i / d.x;
        store(false, offset(lev), d.x, x, y, 0u, own(false, offset(lev), d.x, x, y, lev));
    }
}

// U = a P + b up(C) in place at `dst` (size d; TEX: P_0 from the cone
// texture, U_0 into the result texture), C at `src` (size s; not read when
// `coarse` is false, L = 0). Fine texels 2u - 1 and 2u (u from 0 to s.x)
// interpolate between coarse columns u - 1 and u (clamped) with weights
// 3/4, 1/4 (odd fine index) or 1/4, 3/4 (even), and the same along y: an
// invocation walks fine columns 2u - 1, 2u down over ROWS coarse rows v,
// fine rows 2v - 1 and 2v from coarse rows v - 1 (carried over) and v, so a
// fine texel costs half a coarse load (4 without sharing).
fn compose(lid: u32, tex: bool, dst: u32, d: vec2<u32>, src: u32, s: vec2<u32>, lev: u32,
           b: f32, coarse: bool) {
    let nb = vec2<u32>(s.x + 1u, (s.y + ROWS) / ROWS);
    for (var i = lid; i < nb.x * nb.y; i += WG) {
        let u = i32(i % nb.x);
        let v0 = ROWS * (i / nb.x);
        let x0 = cl(u - 1, s.x);
        let x1 = cl(u, s.x);
        var t_odd = vec4<f32>(0.0);
        var t_even = vec4<f32>(0.0);
        if (coarse) {
            let y = cl(i32(v0) - 1, s.y);
            let c0 = b * fetch(false, src, s.x, x0, y, 0u);
            let c1 = b * fetch(false, src, s.x, x1, y, 0u);
            t_odd = 0.75 * c0 + 0.25 * c1;
            t_even = 0.25 * c0 + 0.75 * c1;
        }
        for (var v = v0; v < min(v0 + ROWS, s.y + 1u); v++) {
            var b_odd = vec4<f32>(0.0);
            var b_even = vec4<f32>(0.0);
            if (coarse) {
                let y = min(v, s.y - 1u);
                let c0 = b * fetch(false, src, s.x, x0, y, 0u);
                let c1 = b * fetch(false, src, s.x, x1, y, 0u);
                b_odd = 0.75 * c0 + 0.25 * c1;
                b_even = 0.25 * c0 + 0.75 * c1;
            }
            if (v > 0u && 2u * v - 1u < d.y) {
                compose1(tex, dst, d, 2 * u - 1, 2u * v - 1u, lev, 0.75 * t_odd + 0.25 * b_odd);
                compose1(tex, dst, d, 2 * u, 2u * v - 1u, lev, 0.75 * t_even + 0.25 * b_even);
            }
            if (2u * v < d.y) {
                compose1(tex, dst, d, 2 * u - 1, 2u * v, lev, 0.25 * t_odd + 0.75 * b_odd);
                compose1(tex, dst, d, 2 * u, 2u * v, lev, 0.25 * t_even + 0.75 * b_even);
            }
            t_odd = b_odd;
            t_even = b_even;
        }
    }
}

@compute @workgroup_size(WG)
fn main(@builtin(local_invocation_index) lid: u32) {
    let L = prm.count.x;
    // Down: P_1 from the cone texture, then P_2 .. P_L.
    if (L > 0u) {
        down(lid, true, 0u, size(0u), offset(1u), size(1u));
    }
    for (var k = 2u; k <= L; k++) {
        storageBarrier();
        down(lid, false, offset(k - 1u), size(k - 1u), offset(k), size(k));
    }
    // Up: U_{L-1} .. U_1 in place; the coarsest term is P_L weighted with
    // a_L (SLOTS > 1: U_L summed in place first).
    let multi = SLOTS > 1u;
    if (multi && L > 0u) {
        storageBarrier();
        collapse(lid, L);
    }
    for (var m = L; m > 1u; m--) {
        storageBarrier();
        let k = m - 1u;
        let b = select(1.0, weight(L), k == L - 1u && !multi);
        compose(lid, false, offset(k), size(k), offset(k + 1u), size(k + 1u), k, b, true);
    }
    storageBarrier();
    // U_0 into the result texture; with L = 0, U_0 = a_0 P_0 (coarse false;
    // (size_0 + 1) / 2 is level 1's size, or the blocks' layout without it).
    compose(lid, true, 0u, size(0u), offset(1u), (size(0u) + 1u) / 2u, 0u,
            select(1.0, weight(L), L == 1u && !multi), L > 0u);
}
