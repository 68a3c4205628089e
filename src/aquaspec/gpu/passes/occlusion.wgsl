// The scene's occlusion of the ambient light field on surfaces
// (aquaspec.gpu.passes.occlusion): per pixel of a reduced-resolution grid,
// the factor O_i per band by which a surface's light-field irradiance is
// multiplied. Twin of aquaspec.transport.lightfield.occlusion.occlusion_factor
// (the direct K-direction sum) with aquaspec.scene.occlusion.OcclusionMaps.visibility:
//
//   O_i = 1 - sum_k (1 - V_k) g_k L_i(d'_k, w_k) exp(-c*_i s_k) / sum_k g_k L_i(d, w_k),
//   g_k = max(0, n . w_k) dw_k,
//
// V_k and s_k from the K depth maps (one layer per direction that has
// occluders; the four texels around the point looked up normal_offset
// texels off the surface, as the NumPy maps), s cut at the water surface,
// d'_k = d - s_k w_ky clamped to [0, seabed]. L from the log-radiance
// table over depth (uniform in sqrt(d), as the light-field tables; beyond
// its end in deep water it decays with k_inf). Grid pixel (x, y) stands for
// the full-resolution pixel (SCALE x + SCALE / 2, SCALE y + SCALE / 2); no
// hit (or a hit past the water surface): O = 1.

const N_BANDS: u32 = {{ n_bands }}u;
const N_DIRS: u32 = {{ n_dirs }}u;
const N_DEPTH: u32 = {{ n_depth }}u;
const LAYERS_OUT: u32 = {{ layers_out }}u;
const SCALE: u32 = {{ scale }}u;

{{ params_struct }}

// One direction: w (xyz) and its solid angle (w); the map's axes and
// offsets; layer < 0: no map (nothing occludes along it).
struct Direction {
    w: vec4<f32>,
    e1: vec4<f32>,       // xyz, u0 in w
    e2: vec4<f32>,       // xyz, v0 in w
    map: vec4<f32>,      // texel, h_min, h_max, layer
}

@group(0) @binding(0) var<uniform> prm: OcclusionParams;
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var<storage, read> dirs: array<Direction>;
// ln L (n_depth, K, n) per unit E0.
@group(0) @binding(3) var<storage, read> log_radiance: array<f32>;
// Per band: c* (x), k_inf (y).
@group(0) @binding(4) var<storage, read> band_data: array<vec4<f32>>;
@group(0) @binding(5) var maps: texture_depth_2d_array;
@group(0) @binding(6) var occ_out: texture_storage_2d_array<rgba16float, write>;

fn decode_normal(oct: u32, n_y_bits: u32) -> vec3<f32> {
    let p = unpack2x16snorm(oct);
    let y = 1.0 - abs(p.x) - abs(p.y);
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    let xz = select(p, (1.0 - abs(p.yx)) * s, y < 0.0);
    let n_y = clamp(bitcast<f32>(n_y_bits), -1.0, 1.0);
    let h = length(xz);
    let scale = select(0.0, sqrt(max(1.0 - n_y * n_y, 0.0)) / h, h > 0.0);
    return vec3<f32>(xz.x * scale, n_y, xz.y * scale);
}

// Lower depth node and weight (tables.table_depth_index).
fn depth_index(d: f32) -> vec2<f32> {
    let x = sqrt(clamp(d, 0.0, prm.max_depth) / prm.max_depth) * f32(N_DEPTH - 1u);
    let i = min(floor(x), f32(N_DEPTH - 2u));
    return vec2<f32>(i, x - i);
}

// L_i(d, w_k) from the table at depth index di (node, weight) and depth d.
fn radiance(i: u32, k: u32, di: vec2<f32>, d: f32) -> f32 {
    let row = u32(di.x);
    let lo = log_radiance[(row * N_DIRS + k) * N_BANDS + i];
    let hi = log_radiance[((row + 1u) * N_DIRS + k) * N_BANDS + i];
    let deep = select(0.0, band_data[i].y * max(d - prm.max_depth, 0.0), prm.deep != 0u);
    return exp(mix(lo, hi, di.y) - deep);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.out_width || gid.y >= prm.out_height) {
        return;
    }
    let px = min(gid.x * SCALE + SCALE / 2u, prm.width - 1u);
    let py = min(gid.y * SCALE + SCALE / 2u, prm.height - 1u);
    let surf = textureLoad(gb_surface, vec2<u32>(px, py), 0);
    let s_hit = bitcast<f32>(surf.x);
    let x = (f32(px) + 0.5 - prm.cx) / prm.fx;
    let y = (f32(py) + 0.5 - prm.cy) / prm.fy;
    let v = normalize(prm.right * x - prm.up * y + prm.forward);
    let d_o = -prm.position.y;
    let up_ray = v.y > 0.0;
    let hit = s_hit >= 0.0 && (!up_ray || s_hit <= d_o / select(1.0, v.y, up_ray));

    var lost_w: array<f32, N_DIRS>;
    var g: array<f32, N_DIRS>;
    var s_k: array<f32, N_DIRS>;
    var d_occ: array<f32, N_DIRS>;
    var any_lost = false;
    let p = prm.position + v * s_hit;
    let n = decode_normal(surf.z, surf.y);
    let d = max(-p.y, 0.0);
    if (hit) {
        for (var k = 0u; k < N_DIRS; k = k + 1u) {
            let dk = dirs[k];
            let w = dk.w.xyz;
            g[k] = max(dot(n, w), 0.0) * dk.w.w;
            lost_w[k] = 0.0;
            s_k[k] = 0.0;
            d_occ[k] = d;
            if (g[k] <= 0.0 || dk.map.w < 0.0) {
                continue;
            }
            let texel = dk.map.x;
            let q = p + n * (prm.normal_offset_texels * texel);
            let tx = (dot(q, dk.e1.xyz) - dk.e1.w) / texel - 0.5;
            let ty = (dot(q, dk.e2.xyz) - dk.e2.w) / texel - 0.5;
            let h = dot(q, w);
            let j0 = floor(tx);
            let i0 = floor(ty);
            let fx = tx - j0;
            let fy = ty - i0;
            let bias = prm.bias_texels * texel;
            var occ_wt = 0.0;
            var occ_h = 0.0;
            for (var c = 0u; c < 4u; c = c + 1u) {
                let jj = j0 + f32(c % 2u);
                let ii = i0 + f32(c / 2u);
                let wt = select(1.0 - fx, fx, c % 2u == 1u) * select(1.0 - fy, fy, c / 2u == 1u);
                let inside = jj >= 0.0 && jj < prm.map_size && ii >= 0.0 && ii < prm.map_size;
                let z = textureLoad(maps, vec2<i32>(i32(clamp(jj, 0.0, prm.map_size - 1.0)),
                                                    i32(clamp(ii, 0.0, prm.map_size - 1.0))),
                                    i32(dk.map.w), 0);
                let hm = dk.map.z - z * (dk.map.z - dk.map.y);
                let hides = inside && z < 1.0 && h < hm - bias;
                occ_wt = occ_wt + select(0.0, wt, hides);
                occ_h = occ_h + select(0.0, wt * hm, hides);
            }
            if (occ_wt <= 0.0) {
                continue;
            }
            // The distance from the point itself, cut at the water surface.
            var s = max(occ_h / occ_wt - dot(p, w), 0.0);
            if (w.y > 0.0) {
                s = min(s, d / w.y);
            }
            lost_w[k] = min(occ_wt, 1.0) * g[k];
            s_k[k] = s;
            d_occ[k] = clamp(d - s * w.y, 0.0, prm.seabed_depth);
            any_lost = true;
        }
    }
    let di_here = depth_index(d);
    var out: array<vec4<f32>, LAYERS_OUT>;
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        var o = 1.0;
        if (any_lost) {
            let c = band_data[i].x;
            var total = 0.0;
            var lost = 0.0;
            for (var k = 0u; k < N_DIRS; k = k + 1u) {
                total = total + g[k] * radiance(i, k, di_here, d);
                if (lost_w[k] > 0.0) {
                    lost = lost + lost_w[k] * radiance(i, k, depth_index(d_occ[k]), d_occ[k])
                        * exp(-c * s_k[k]);
                }
            }
            o = clamp(1.0 - select(0.0, lost / total, total > 0.0), 0.0, 1.0);
        }
        out[i / 4u][i % 4u] = o;
    }
    for (var l = 0u; l < LAYERS_OUT; l = l + 1u) {
        textureStore(occ_out, vec2<u32>(gid.x, gid.y), l, out[l]);
    }
}
