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

#include "gbuffer_normal.wgsl"

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
// ln L per unit E0: (n_depth, K, LAYERS_OUT) vec4s, bands 4g .. 4g + 3 in layer g.
@group(0) @binding(3) var<storage, read> log_radiance: array<vec4<f32>>;
// Per layer of four bands: c* (index 2g) and k_inf (2g + 1).
@group(0) @binding(4) var<storage, read> band_data: array<vec4<f32>>;
@group(0) @binding(5) var maps: texture_depth_2d_array;
@group(0) @binding(6) var occ_out: texture_storage_2d_array<rgba16float, write>;
// Nearest, clamp to edge: the four texels of a gather.
@group(0) @binding(7) var map_sampler: sampler;

#include "camera_ray.wgsl"


// Lower depth node and weight (tables.table_depth_index).
fn depth_index(d: f32) -> vec2<f32> {
    let x = sqrt(clamp(d, 0.0, prm.max_depth) / prm.max_depth) * f32(N_DEPTH - 1u);
    let i = min(floor(x), f32(N_DEPTH - 2u));
    return vec2<f32>(i, x - i);
}

// L of bands 4g .. 4g + 3 on direction k at depth d (its index di).
fn radiance4(g: u32, k: u32, di: vec2<f32>, d: f32) -> vec4<f32> {
    let row = u32(di.x);
    let lo = log_radiance[(row * N_DIRS + k) * LAYERS_OUT + g];
    let hi = log_radiance[((row + 1u) * N_DIRS + k) * LAYERS_OUT + g];
    let deep = select(vec4<f32>(0.0), band_data[2u * g + 1u] * max(d - prm.max_depth, 0.0),
                      prm.deep != 0u);
    return exp(mix(lo, hi, di.y) - deep);
}

// What occludes direction k seen from q: (hidden weight, occluder height
// weighted by it) of the four texels around q, weights as the NumPy maps'
// bilinear ones; texels outside the map hide nothing. One gather of the four
// depths ((j0, i0) in w, (j0 + 1, i0) in z, (j0, i0 + 1) in x, (j0 + 1, i0 + 1)
// in y); points off the map read nothing.
fn occluded(dk: Direction, q: vec3<f32>) -> vec2<f32> {
    let texel = dk.map.x;
    let tx = (dot(q, dk.e1.xyz) - dk.e1.w) / texel - 0.5;
    let ty = (dot(q, dk.e2.xyz) - dk.e2.w) / texel - 0.5;
    if (tx < -1.0 || ty < -1.0 || tx >= prm.map_size || ty >= prm.map_size) {
        return vec2<f32>(0.0);
    }
    let h = dot(q, dk.w.xyz);
    let j0 = floor(tx);
    let i0 = floor(ty);
    let fx = tx - j0;
    let fy = ty - i0;
    let z = textureGather(maps, map_sampler, vec2<f32>(j0 + 1.0, i0 + 1.0) / prm.map_size,
                          i32(dk.map.w));
    let out_j0 = j0 < 0.0;
    let out_j1 = j0 + 1.0 >= prm.map_size;
    let out_i0 = i0 < 0.0;
    let out_i1 = i0 + 1.0 >= prm.map_size;
    let inside = !vec4<bool>(out_j0 || out_i1, out_j1 || out_i1, out_j1 || out_i0,
                             out_j0 || out_i0);
    let wt = vec4<f32>((1.0 - fx) * fy, fx * fy, fx * (1.0 - fy), (1.0 - fx) * (1.0 - fy));
    let hm = dk.map.z - z * (dk.map.z - dk.map.y);
    let hides = inside & (z < vec4<f32>(1.0)) & (vec4<f32>(h) < hm - prm.bias_texels * texel);
    let w_hid = select(vec4<f32>(0.0), wt, hides);
    return vec2<f32>(dot(w_hid, vec4<f32>(1.0)), dot(w_hid, hm));
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
    let v = camera_ray(f32(px), f32(py));
    let d_o = -prm.position.y;
    let up_ray = v.y > 0.0;
    let hit = s_hit >= 0.0 && (!up_ray || s_hit <= d_o / select(1.0, v.y, up_ray));
    let p = prm.position + v * max(s_hit, 0.0);
    let n = decode_normal(surf.z, surf.y);
    let d = max(-p.y, 0.0);
    let di_here = depth_index(d);
    // Per layer of four bands: the total and the lost weighted radiance.
    var total: array<vec4<f32>, LAYERS_OUT>;
    var lost: array<vec4<f32>, LAYERS_OUT>;
    var any_lost = false;
    // The light the occluders take (directions they hide) ...
    let n_dirs = select(0u, N_DIRS, hit);
    for (var k = 0u; k < n_dirs; k = k + 1u) {
        let dk = dirs[k];
        let w = dk.w.xyz;
        let g = max(dot(n, w), 0.0) * dk.w.w;
        if (g <= 0.0 || dk.map.w < 0.0) {
            continue;
        }
        let occ = occluded(dk, p + n * (prm.normal_offset_texels * dk.map.x));
        if (occ.x <= 0.0) {
            continue;
        }
        // The distance from the point itself, cut at the water surface.
        var s = max(occ.y / occ.x - dot(p, w), 0.0);
        if (w.y > 0.0) {
            s = min(s, d / w.y);
        }
        let d_occ = clamp(d - s * w.y, 0.0, prm.seabed_depth);
        let di_occ = depth_index(d_occ);
        let lw = min(occ.x, 1.0) * g;
        for (var l = 0u; l < LAYERS_OUT; l = l + 1u) {
            lost[l] = lost[l] + lw * radiance4(l, k, di_occ, d_occ)
                * exp(-band_data[2u * l] * s);
        }
        any_lost = true;
    }
    // ... over all the light (only where some is taken).
    let n_total = select(0u, N_DIRS, any_lost);
    for (var k = 0u; k < n_total; k = k + 1u) {
        let dk = dirs[k];
        let g = max(dot(n, dk.w.xyz), 0.0) * dk.w.w;
        if (g <= 0.0) {
            continue;
        }
        for (var l = 0u; l < LAYERS_OUT; l = l + 1u) {
            total[l] = total[l] + g * radiance4(l, k, di_here, d);
        }
    }
    for (var l = 0u; l < LAYERS_OUT; l = l + 1u) {
        let t = total[l];
        let ratio = select(vec4<f32>(0.0), lost[l] / select(vec4<f32>(1.0), t, t > vec4<f32>(0.0)),
                           t > vec4<f32>(0.0));
        let o = select(vec4<f32>(1.0), clamp(1.0 - ratio, vec4<f32>(0.0), vec4<f32>(1.0)),
                       any_lost);
        textureStore(occ_out, vec2<u32>(gid.x, gid.y), l, o);
    }
}
