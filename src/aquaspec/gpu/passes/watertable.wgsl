// The light field's water table for the camera's depth, built on the GPU:
// twin of aquaspec.transport.lightfield.compiled (water_table, float64 NumPy; its
// module docstring has the axes and the formula). One invocation per texel
// (distance column k, direction row j); per band group (four bands as vec4)
//   R(d, v)  = F(d, v) b E0 / (4 pi) ms_path_integral(c, kappa_1, d, v, l(d))
//   L_bg(d)  = R(d, v) + exp(-c l(d)) L_end
//   base     = L_bg(d_o) - T L_bg(d_S),  cone = -(T' - T) L_bg(d_S)
// where the line of sight from depth d ends on the water surface (up rays:
// l = d / v, L_end = L_top(v), the surface seen from below), on the seabed at depth
// H (SEABED, down rays: l = (H - d) / -v, L_end = L_bed) or nowhere (l = inf).
// With SEABED a down ray's finite hit distance S is cut at the seabed (a
// black target beyond it is taken at it) and d_S clamped to [0, H];
// T' = exp(-c' S), T = T' (not SPLIT) or exp(-c S) (SPLIT), summed over
// bands in camera RGB. Layer 0 holds base + alpha cone (SPLIT) or base,
// layer 1 (SPLIT) the cone's share; column DISTANCES - 1 is open water
// (L_bg(d_o)). Output: a storage buffer copied into the table texture.
// Two entry points, in this order: open_column (one invocation per row:
// the open-water column), then main (the hit columns), which reads a row's
// open water in camera RGB instead of evaluating L_bg(d_o) per texel
// (sum_i w_i (L_bg,i(d_o) - T_i L_bg,i(d_S)) = W_open - sum_i w_i T_i L_bg,i(d_S)).
// NODES > 0 (the multiple-scattering spread, lightfield_compiled.water_table
// with alpha_nodes): a band's cone term C_i at z_i = log3(1 + 2 f_i b_i S)
// is kept with alpha(z_i) in layer 0, and layers 1 .. NODES hold it split
// between the nodes by the hat weights max(0, 1 - |z_i - k|); layer 0's
// fourth channel holds the share a pixel keeps of its target's cone,
// alpha at log3(1 + 2 mean(f b) S) (lightfield_compiled.node_alpha).

#include "common.wgsl"
#include "lftables.wgsl"

{{ params_struct }}

const N_GROUPS: u32 = {{ n_groups }}u;
const N_DEPTH: u32 = {{ n_depth }}u;
const N_MU: u32 = {{ n_mu }}u;
const DISTANCES: u32 = {{ distances }}u;
const LENGTH_SCALE: f32 = {{ length_scale }};
const SPLIT: bool = {{ split }};
const NODES: u32 = {{ nodes }}u;
const SEABED: bool = {{ seabed }};

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
// Per band group g, field f at [f N_GROUPS + g] (watertable.water_band_fields):
// 0 c, 1 kappa_1, 2 c' = c - f b, 3 b E0 / (4 pi), 4 w_r, 5 w_g, 6 w_b,
// 7 L_bed (the seabed's radiance; 0 without a seabed).
@group(0) @binding(1) var<uniform> bands: array<vec4<f32>, {{ band_len }}>;
// ln F: layer g, texel (direction j, depth i) holds bands 4g .. 4g + 3.
@group(0) @binding(2) var log_prefactor: texture_2d_array<f32>;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;
// L_top at direction node j for band group g at [j N_GROUPS + g]
// (watertable.top_fields: the sky through the surface and what it mirrors).
@group(0) @binding(4) var<storage, read> top: array<vec4<f32>>;

fn field(f: u32, g: u32) -> vec4<f32> {
    return bands[f * N_GROUPS + g];
}

// lightfield.bilinear of ln F for bands 4g .. 4g + 3 at depth d, direction v.
fn log_f(d: f32, v: f32, g: u32) -> vec4<f32> {
    let y = table_cos_coord(vec4<f32>(v), N_MU).x;
    let x = table_depth_coord(vec4<f32>(d), prm.max_depth, N_DEPTH).x;
    let j = min(u32(max(y, 0.0)), N_MU - 2u);
    let i = min(u32(max(x, 0.0)), N_DEPTH - 2u);
    let fy = y - f32(j);
    let fx = x - f32(i);
    let lo = mix(textureLoad(log_prefactor, vec2<u32>(j, i), g, 0),
                 textureLoad(log_prefactor, vec2<u32>(j + 1u, i), g, 0), fy);
    let hi = mix(textureLoad(log_prefactor, vec2<u32>(j, i + 1u), g, 0),
                 textureLoad(log_prefactor, vec2<u32>(j + 1u, i + 1u), g, 0), fy);
    return mix(lo, hi, fx);
}

// Whether the line of sight along v ends (on the surface or the seabed).
fn ends(v: f32) -> bool {
    return v > 0.0 || (SEABED && v < 0.0);
}

// Length l(d) of the line of sight from depth d to its end (ends(v) only).
fn to_end(d: f32, v: f32) -> f32 {
    return select((prm.seabed_depth - d) / -v, d / v, v > 0.0);
}

// R(d, v) of four bands: F b E0 / (4 pi) times the seeds' path integral to
// the line of sight's end (length l, at depth d_end: 0 or H; else to
// infinity), written with exponents <= 0 whatever the sign of k = c -
// kappa_1 v (exp(-kappa_1 d - k l) = exp(-kappa_1 d_end - c l)), and its
// series where |k l| < 0.1 would cancel in f32 (model.ms_path_integral).
fn r_at(d: f32, v: f32, g: u32) -> vec4<f32> {
    let c = field(0u, g);
    let k1 = field(1u, g);
    let k = c - k1 * v;
    let e1 = exp(-k1 * d);
    var path: vec4<f32>;
    if (ends(v)) {
        let len = to_end(d, v);
        let d_end = select(prm.seabed_depth, 0.0, v > 0.0);
        let x = k * len;
        let series = e1 * len * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0
                     - x * (1.0 / 120.0)))));
        let k_safe = select(vec4<f32>(1.0), k, k != vec4<f32>(0.0));
        path = select((e1 - exp(-k1 * d_end - c * len)) / k_safe, series,
                      abs(x) < vec4<f32>(0.1));
    } else {
        path = e1 / k;
    }
    return exp(log_f(d, v, g)) * field(3u, g) * path;
}

// The line of sight's end seen from depth d along direction node j (v):
// exp(-c l(d)) L_end (four bands).
fn end_light(d: f32, v: f32, j: u32, g: u32) -> vec4<f32> {
    if (!ends(v)) {
        return vec4<f32>(0.0);
    }
    let l_end = select(field(7u, g), top[j * N_GROUPS + g], v > 0.0);
    return exp(-field(0u, g) * to_end(d, v)) * l_end;
}

// Direction node j (lightfield_compiled.direction_nodes): (v, inside the window).
fn node_direction(j: u32) -> vec2<f32> {
    let w = prm.window_cos;
    let q_w = sign(w) * sqrt(abs(w));
    let inside = j >= prm.n_out;
    let q = -1.0 + f32(min(j, prm.n_out - 1u)) * (q_w + 1.0) / f32(prm.n_out - 1u);
    let u = f32(max(j, prm.n_out) - prm.n_out) / f32(prm.n_in - 1u);
    let v = select(sign(q) * q * q, select(w + (1.0 - w) * u * u, w, j == prm.n_out), inside);
    return vec2<f32>(v, select(0.0, 1.0, inside));
}

fn rgb_of(l: vec4<f32>, g: u32) -> vec3<f32> {
    return vec3<f32>(dot(l, field(4u, g)), dot(l, field(5u, g)), dot(l, field(6u, g)));
}

@compute @workgroup_size(64)
fn open_column(@builtin(global_invocation_id) gid: vec3<u32>) {
    let j = gid.x;
    let rows = prm.n_out + prm.n_in;
    if (j >= rows) {
        return;
    }
    let node = node_direction(j);
    let v = node.x;
    var open = vec3<f32>(0.0);
    for (var g = 0u; g < N_GROUPS; g = g + 1u) {
        open = open + rgb_of(r_at(prm.depth_o, v, g)
                             + end_light(prm.depth_o, v, j, g), g);
    }
    let texel = j * DISTANCES + DISTANCES - 1u;
    out[texel] = vec4<f32>(open, 0.0);
    if (SPLIT) {
        for (var k = 1u; k <= max(NODES, 1u); k++) {
            out[k * rows * DISTANCES + texel] = vec4<f32>(0.0);
        }
    }
}

// The kept share alpha_k of node k (prm.alpha_lo / alpha_hi).
fn node_alpha(k: u32) -> f32 {
    return select(prm.alpha_hi[k % 4u], prm.alpha_lo[k % 4u], k < 4u);
}

// Hat weight of node k at lambda coordinates z (clamped to the nodes).
fn hat(z: vec4<f32>, k: u32) -> vec4<f32> {
    let zc = clamp(z, vec4<f32>(0.0), vec4<f32>(f32(max(NODES, 1u) - 1u)));
    return max(vec4<f32>(0.0), 1.0 - abs(zc - f32(k)));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let k = gid.x;
    let j = gid.y;
    let rows = prm.n_out + prm.n_in;
    if (k >= DISTANCES - 1u || j >= rows) {
        return;
    }
    let node = node_direction(j);
    let v = node.x;
    let up = v > 0.0;
    let d_o = prm.depth_o;
    // Distance node (distance_nodes): S = length x / (1 - x), x = k / (DISTANCES - 2).
    let inf_node = k == DISTANCES - 2u;
    let xn = f32(k) / f32(DISTANCES - 2u);
    let to_surface = select(0.0, d_o / v, up);
    var s = LENGTH_SCALE * xn / max(1.0 - xn, 1e-30);
    if (up) {
        s = select(min(s, to_surface), to_surface, inf_node);
    }
    var d_s = max(d_o - s * v, 0.0);
    if (SEABED && v < 0.0 && !inf_node) {
        s = min(s, (prm.seabed_depth - d_o) / -v);
        d_s = clamp(d_o - s * v, 0.0, prm.seabed_depth);
    }

    // Open water seen past the hit, T L_bg(d_S), and the cone's share.
    var behind = vec3<f32>(0.0);
    var cone = vec3<f32>(0.0);
    var kept = vec3<f32>(0.0);
    var node_rgb: array<vec3<f32>, {{ node_array }}>;
    if (up || !inf_node) {
        for (var g = 0u; g < N_GROUPS; g = g + 1u) {
            let c = field(0u, g);
            let blocked = r_at(d_s, v, g) + end_light(d_s, v, j, g);
            let t_beam = exp(-field(2u, g) * s);
            let t = select(t_beam, exp(-c * s), SPLIT);
            behind = behind + rgb_of(t * blocked, g);
            cone = cone - rgb_of((t_beam - t) * blocked, g);
            if (NODES > 0u) {
                let cb = -(t_beam - t) * blocked;
                // lambda = f b S, f b = c - c'.
                let z = log(1.0 + 2.0 * (c - field(2u, g)) * s) / log(3.0);
                for (var k = 0u; k < NODES; k++) {
                    let h = hat(z, k);
                    kept = kept + rgb_of(node_alpha(k) * h * cb, g);
                    node_rgb[k] = node_rgb[k] + rgb_of(h * cb, g);
                }
            }
        }
    }
    let base = out[j * DISTANCES + DISTANCES - 1u].xyz - behind;
    let texel = j * DISTANCES + k;
    if (NODES > 0u) {
        let zm = log(1.0 + 2.0 * prm.fb_mean * s) / log(3.0);
        var alpha_s = 0.0;
        for (var k = 0u; k < NODES; k++) {
            alpha_s = alpha_s + node_alpha(k) * hat(vec4<f32>(zm), k).x;
        }
        out[texel] = vec4<f32>(base + kept, alpha_s);
        for (var k = 0u; k < NODES; k++) {
            out[(k + 1u) * rows * DISTANCES + texel] = vec4<f32>(node_rgb[k], 0.0);
        }
    } else if (SPLIT) {
        out[texel] = vec4<f32>(base + prm.alpha * cone, 0.0);
        out[rows * DISTANCES + texel] = vec4<f32>(cone, 0.0);
    } else {
        out[texel] = vec4<f32>(base, 0.0);
    }
}
