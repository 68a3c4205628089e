// The lamps (aquaspec.gpu.passes.lamps; NumPy twin: aquaspec.shading.lamp.lamp_radiance,
// maths in aquaspec.transport.lamp_scattering and lamp_froxels, shadows in
// aquaspec.scene.lamp_shadow). Three entry points, dispatched in this order:
// - build_veil, one invocation per column of TILE x TILE pixels: each
//   lamp's light scattered once along the column's central ray, cut to the
//   lamp's cone, over the equiangular variable theta (t = t* + D tan theta,
//   dt / r^2 = dtheta / D) in N_SLICES equal steps of u = sqrt(psi / pi),
//   psi = pi/2 + theta the scattering angle (dtheta = 2 pi u du), each sampled
//   at its middle with the lamp's shadow there; the sums up to each slice
//   boundary read at the N_DEPTHS + 1 distances of lamp_froxels.depth_boundaries
//   (linear in u), in camera RGB, summed over the lamps, written to veil_out
//   (then copied to veil_tex);
// - main, one invocation per pixel: the veil sampled from veil_tex (trilinear:
//   the four columns around the pixel, the depths around its distance), and per
//   lamp a lit surface's light
//   rho / pi I0 f(alpha) V max(0, n.l) exp(-c_lamp r) / r^2 exp(-c_view S)
//   and its glow's rho / pi E_glow exp(-c_view S) (unshadowed, lamp_halo),
//   summed over the bands in camera RGB; added to rgb_out. The columns also hold
//   the glow scattered towards the camera (halo_column).
// - with the cone spread (lp.split_cone), cone_share before the light field's
//   pass: the forward cone's share of the lit surfaces' light (pixel_light)
//   at the spread's level 0, into the ConeSpreadPass's extra input; main
//   then takes 1 - lp.alpha of that share off the pixel.
//
// Everything read per pixel or per sample is in uniform buffers or textures:
// storage-buffer reads were most of the pass's time on lavapipe.
// `bands`, eight vec4 per group of four bands 4q ... 4q + 3 (a band a component,
// 0 past the last band): [8q] c_lamp, [8q + 1] c_view, [8q + 2] b, [8q + 3] t (the
// normalised band centre for sigmoid materials), [8q + 4 ... 8q + 6] the camera
// RGB weights w_r, w_g, w_b, [8q + 7] f b (the forward cone's share of b).
// `intensity[k * BAND_GROUPS + i / 4][i % 4]`: lamp k's on-axis I0 in band i.
// profile entry k * PROFILE_SIZE + j: f of lamp k at alpha_j = cone j / (PROFILE_SIZE - 1).
// log_phase entry q * PHASE_SIZE + j: ln p of bands 4q ... 4q + 3 (a vec4, 0 past the
// last band) at psi_j = pi (j / (PHASE_SIZE - 1))^2.
// halo entry 4 (q * N_DEPTHS + m) + c: the glow's table's component c for bands
// 4q ... 4q + 3 at distance m (halo_at).
// `faces`, three vec4 per shadow-map face: right (xyz) and focal length in
// texels (w), up (xyz) and 0, forward (xyz) and the face's size in texels; layer
// f of shadow_maps holds face f's perspective depth (near NEAR, far FAR).
// veil_out texel (x, y, j) at (z * cols_y + y) * veil_row + x (rows of a multiple of 256 bytes).

#include "common.wgsl"
#include "gbuffer_normal.wgsl"
#include "pcf.wgsl"

{{ params_struct }}

struct LampGpu {
    position: vec3<f32>,
    cos_cut: f32,
    direction: vec3<f32>,
    cone: f32,
    first_face: u32,
    n_faces: u32,
    clip: u32,
    iso: f32,
};

const N_BANDS: u32 = {{ n_bands }}u;
const PHASE_SIZE: u32 = {{ phase_size }}u;
const PROFILE_SIZE: u32 = {{ profile_size }}u;
const N_SLICES: u32 = {{ slices }}u;
const N_DEPTHS: u32 = {{ depths }}u;
const DEPTH_M0: f32 = {{ depth_m0 }};
const DEPTH_MAX: f32 = {{ depth_max }};
const DEPTH_STEP: f32 = {{ depth_step }};
const BAND_GROUPS: u32 = (N_BANDS + 3u) / 4u;
const PER_PIXEL: u32 = 0xffffffffu;
const HALF_PI: f32 = 1.57079632679490;
const NEAR: f32 = {{ near }};
const FAR: f32 = {{ far }};
const BIAS_TEXELS: f32 = {{ bias_texels }};
const NORMAL_OFFSET_TEXELS: f32 = {{ normal_offset_texels }};
const MIN_DISTANCE: f32 = {{ min_distance }};
const MIN_RANGE: f32 = {{ min_range }};

@group(0) @binding(0) var<uniform> lp: {{ params_struct_name }};
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
{{ material_binding }}
@group(0) @binding(4) var<uniform> bands: array<vec4<f32>, {{ band_vec4 }}>;
@group(0) @binding(5) {{ phase_binding }};
@group(0) @binding(6) var<uniform> lamps: array<LampGpu, {{ max_lamps }}>;
@group(0) @binding(7) var<uniform> intensity: array<vec4<f32>, {{ intensity_vec4 }}>;
@group(0) @binding(8) var<uniform> profile: array<vec4<f32>, {{ profile_vec4 }}>;
@group(0) @binding(9) var<uniform> faces: array<vec4<f32>, {{ face_vec4 }}>;
@group(0) @binding(10) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(11) var shadow_sampler: sampler_comparison;
@group(0) @binding(12) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(13) var<storage, read_write> veil_out: array<{{ veil_word }}>;
@group(0) @binding(14) var veil_tex: texture_3d<f32>;
@group(0) @binding(15) var veil_sampler: sampler;
@group(0) @binding(16) {{ halo_binding }};

@group(0) @binding(17) var spot_tex: texture_2d_array<f32>;

// DISPLAY: the image's linear RGB plus the lamps goes through the display
// transform (display.wgsl) and out as packed RGBA8, saving the display pass.
{{ display_struct }}
const DISPLAY: bool = {{ display }};
const TONEMAP: u32 = {{ tonemap_id }}u;
@group(0) @binding(18) var<uniform> dparams: {{ display_struct_name }};
@group(0) @binding(19) var<storage, read_write> rgba_out: array<u32>;
@group(0) @binding(20) var<storage, read_write> status: array<atomic<u32>>;
// The lamps' cone share at the cone spread's level 0 (cone_share; the
// ConeSpreadPass's `extra`).
@group(0) @binding(21) var<storage, read_write> cone_out: array<vec4<f32>>;
#include "tonemap.wgsl"

const MIN_HALO_RANGE: f32 = {{ min_halo_range }};
const SPOT_ANGLES: f32 = {{ spot_angles }}.0;

// Where distance r falls in the glow's table and the spot factors (lamp_depths'
// index of r, clamped to the table): (x, m0, fraction).
fn halo_index(r: f32) -> vec3<f32> {
    let x = clamp(log(1.0 + r / DEPTH_M0) / DEPTH_STEP, 0.0, f32(N_DEPTHS - 1u));
    let m0 = min(floor(x), f32(N_DEPTHS - 2u));
    return vec3<f32>(x, m0, x - m0);
}

// Component c of the glow's table (lamp_halo.halo_lookup) at halo_index hi for
// bands 4q ... 4q + 3, linear between the depths of lamp_depths.depth_boundaries,
// per unit intensity: c = 0 r phi / 4, 1 r |F| / 2, 2 r b* phi / 4 pi,
// 3 r 3 b* g* |F| / 4 pi (divide by r).
fn halo_at(q: u32, c: u32, hi: vec3<f32>) -> vec4<f32> {
    let e = 4u * (q * N_DEPTHS + u32(hi.y)) + c;
    return mix(halo[e], halo[e + 4u], hi.z);
}

// Where the spot factors are read at halo_index hi and cos(alpha) from a lamp's axis.
fn spot_uv(hi: vec3<f32>, cos_a: f32) -> vec2<f32> {
    let y = acos(clamp(cos_a, -1.0, 1.0)) / PI * (SPOT_ANGLES - 1.0);
    return vec2<f32>((hi.x + 0.5) / f32(N_DEPTHS), (y + 0.5) / SPOT_ANGLES);
}

// Lamp k's spot factor (lamp_halo.spot_lookup) for bands 4g ... 4g + 3 at spot_uv uv:
// bilinear in the distances' index and the angle.
fn spot_at(k: u32, g: u32, uv: vec2<f32>) -> vec4<f32> {
    return textureSampleLevel(spot_tex, veil_sampler, uv, k * BAND_GROUPS + g, 0.0);
}

// ln p of bands 4q ... 4q + 3 at entry j of the phase table (uniform when it
// fits; else storage; 0 past the last band).
fn phase_at(q: u32, j: u32) -> vec4<f32> {
    return log_phase[q * PHASE_SIZE + j];
}

fn material_entry(k: u32) -> f32 {
    return {{ material_read }};
}

// Camera.ray_directions through pixel coordinates (px, py).
fn pixel_ray(px: f32, py: f32) -> vec3<f32> {
    let xc = (px - lp.cx) / lp.fx;
    let yc = (py - lp.cy) / lp.fy;
    return normalize(lp.right * xc - lp.up * yc + lp.forward);
}

// f(alpha) of lamp k at cos(alpha), linear in the table over alpha.
fn beam(k: u32, cos_a: f32) -> f32 {
    let cone = lamps[k].cone;
    let a = acos(clamp(cos_a, -1.0, 1.0));
    if (a >= cone) {
        return 0.0;
    }
    let x = a / cone * f32(PROFILE_SIZE - 1u);
    let j0 = min(u32(floor(x)), PROFILE_SIZE - 2u);
    let e = k * PROFILE_SIZE + j0;
    let e1 = e + 1u;
    return mix(profile[e / 4u][e % 4u], profile[e1 / 4u][e1 % 4u], x - f32(j0));
}

// WebGPU's perspective depth of view depth z (0 at NEAR, 1 at FAR).
fn ndc_depth(z: f32) -> f32 {
    return FAR * (z - NEAR) / ((FAR - NEAR) * z);
}

// Lamp k's visibility at p (aquaspec.scene.lamp_shadow.lamp_visibility): the face
// p's direction points at most along, four texels compared (percentage-closer),
// texels outside the face lit; with `surface`, p moved off it along n first.
fn lamp_visibility(k: u32, p: vec3<f32>, n: vec3<f32>, surface: bool) -> f32 {
    if (lp.shadowed == 0u) {
        return 1.0;
    }
    var d = p - lamps[k].position;
    let first = lamps[k].first_face;
    var face = first;
    var best = -3.4e38;
    for (var j = 0u; j < lamps[k].n_faces; j = j + 1u) {
        let along = dot(d, faces[3u * (first + j) + 2u].xyz);
        if (along > best) {
            best = along;
            face = first + j;
        }
    }
    let right = faces[3u * face];
    let up = faces[3u * face + 1u].xyz;
    let fwd = faces[3u * face + 2u];
    var z = dot(d, fwd.xyz);
    if (surface) {
        d = d + n * (NORMAL_OFFSET_TEXELS * max(z, 0.0) / right.w);
        z = dot(d, fwd.xyz);
    }
    if (z <= 0.0) {
        return 1.0;
    }
    let size = fwd.w;
    let x = right.w * dot(d, right.xyz) / z + 0.5 * size - 0.5;
    let y = -right.w * dot(d, up) / z + 0.5 * size - 0.5;
    let zb = max(z - BIAS_TEXELS * z / right.w, NEAR);
    let z_ref = min(ndc_depth(zb), 1.0);
    let j0 = floor(x);
    let i0 = floor(y);
    let g = textureGatherCompare(shadow_maps, shadow_sampler,
                                 vec2<f32>(j0 + 1.0, i0 + 1.0) / size, face, z_ref);
    return pcf_blend(g, j0, i0, x - j0, y - i0, size);
}

// Where the ray o + t v is inside lamp k's cone (lamp_scattering.cone_interval):
// (lo, hi), lo > hi where it never is; the whole line for cones of 90 degrees and more.
fn cone_interval(k: u32, v: vec3<f32>) -> vec2<f32> {
    let inf = f32_inf();
    if (lamps[k].clip == 0u) {
        return vec2<f32>(-inf, inf);
    }
    let w = lp.position - lamps[k].position;
    let dir = lamps[k].direction;
    let cc = lamps[k].cos_cut * lamps[k].cos_cut;
    let vd = dot(v, dir);
    let wd = dot(w, dir);
    let a = vd * vd - cc;
    let b = 2.0 * (vd * wd - cc * dot(v, w));
    let c = wd * wd - cc * dot(w, w);
    let disc = b * b - 4.0 * a * c;
    let sq = sqrt(max(disc, 0.0));
    if (a > 1e-6) {
        if (vd > 0.0) {
            return vec2<f32>((-b + sq) / (2.0 * a), inf);
        }
        return vec2<f32>(-inf, (-b - sq) / (2.0 * a));
    }
    if (a < -1e-6) {
        let r1 = (-b + sq) / (2.0 * a);
        let r2 = (-b - sq) / (2.0 * a);
        if (disc < 0.0 || wd + 0.5 * (r1 + r2) * vd < 0.0) {
            return vec2<f32>(inf, -inf);
        }
        return vec2<f32>(r1, r2);
    }
    return vec2<f32>(-inf, inf);
}

fn u_of(theta: f32) -> f32 {
    return sqrt(clamp(theta + HALF_PI, 0.0, PI) / PI);
}

// Open water along v: to the water surface going up, else inf.
fn open_length(v: vec3<f32>) -> f32 {
    return select(f32_inf(), -lp.position.y / v.y, v.y > 0.0);
}

// Distance j of lamp_froxels.depth_boundaries.
fn depth_boundary(j: u32) -> f32 {
    if (j >= N_DEPTHS) {
        return f32_inf();
    }
    return DEPTH_M0 * (exp(f32(j) * DEPTH_STEP) - 1.0);
}

// u at distance t along a ray with closest approach (t_star, dist) and beam [t0, t1]
// (lamp_froxels.u_at): u_a before the beam, u_b after it.
fn u_at(t: f32, t_star: f32, dist: f32, t0: f32, t1: f32, u_a: f32, u_b: f32) -> f32 {
    if (t <= t0) {
        return u_a;
    }
    if (t >= t1) {
        return u_b;
    }
    return clamp(u_of(atan2(t - t_star, dist)), u_a, u_b);
}

// Column (a, b) at depth z: `value` stored (the first lamp) or added (the others).
fn store_veil(a: u32, b: u32, z: u32, value: vec3<f32>, add: bool) {
    let i = (z * lp.cols_y + b) * lp.veil_row + a;
    var sum = value;
    if (add) {
        sum = sum + {{ veil_unpack }};
    }
    veil_out[i] = {{ veil_pack }};
}

// One invocation per column (gid.x, gid.y): every lamp's veil, summed.
@compute @workgroup_size(8, 8, 1)
fn build_veil(@builtin(global_invocation_id) gid: vec3<u32>,
              @builtin(workgroup_id) wg: vec3<u32>,
              @builtin(local_invocation_id) lid: vec3<u32>,
              @builtin(num_workgroups) nwg: vec3<u32>) {
    let a = gid.x;
    let b = interleaved_row(wg.y, lid.y, nwg.y);
    if (a >= lp.cols_x || b >= lp.cols_y) {
        return;
    }
    let tile = f32(lp.tile);
    let v = pixel_ray(tile * f32(a) + 0.5 * tile, tile * f32(b) + 0.5 * tile);
    for (var k = 0u; k < lp.n_lamps; k = k + 1u) {
        lamp_column(k, a, b, v);
    }
}

// Lamp k's veil along column (a, b)'s ray v, added to the column's depths.
fn lamp_column(k: u32, a: u32, b: u32, v: vec3<f32>) {
    let add = k > 0u;
    let q = lamps[k].position;
    let dir = lamps[k].direction;
    let rel = q - lp.position;
    let t_star = dot(v, rel);
    let dist = max(length(rel - t_star * v), MIN_DISTANCE);
    let inside = cone_interval(k, v);
    let t0 = max(0.0, inside.x);
    let t1 = min(open_length(v), inside.y);
    let u_a = u_of(atan2(t0 - t_star, dist));
    var u_b = u_a;
    if (t1 > t0) {
        u_b = max(select(u_of(atan2(t1 - t_star, dist)), 1.0, t1 >= f32_inf()), u_a);
    }
    let step = (u_b - u_a) / f32(N_SLICES);
    var j = 0u;
    if (!(step > 0.0)) {
        for (; j <= N_DEPTHS; j = j + 1u) {
            store_veil(a, b, j, vec3<f32>(0.0), add);
        }
        halo_column(k, a, b, v, open_length(v));
        return;
    }
    let scale = 2.0 * PI * step / dist;
    var uj = u_at(depth_boundary(0u), t_star, dist, t0, t1, u_a, u_b);
    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < N_SLICES; i = i + 1u) {
        let u = u_a + (f32(i) + 0.5) * step;
        let theta = PI * u * u - HALF_PI;
        let cos_t = cos(theta);
        let t = t_star + dist * sin(theta) / cos_t;
        let r = dist / cos_t;
        let x = lp.position + v * t;
        var g = beam(k, dot(x - q, dir) / r);
        var inc = vec3<f32>(0.0);
        if (g > 0.0) {
            g = g * u * scale * lamp_visibility(k, x, vec3<f32>(0.0), false);
        }
        if (g > 0.0) {
            // The phase table is over sqrt(psi / pi): u itself.
            let xp = u * f32(PHASE_SIZE - 1u);
            let p0 = min(u32(floor(xp)), PHASE_SIZE - 2u);
            let fp = xp - f32(p0);
            for (var q = 0u; q < BAND_GROUPS; q = q + 1u) {
                let ln_p = mix(phase_at(q, p0), phase_at(q, p0 + 1u), fp);
                let e = exp(ln_p - band4(q, 0u) * r - band4(q, 1u) * t);
                inc = inc + band_rgb(q, g * e * band4(q, 2u) * intensity[k * BAND_GROUPS + q]);
            }
        }
        // The depths in this slice [u_i, u_i + step]: linear in u between the sums.
        let u_end = u_a + f32(i + 1u) * step;
        loop {
            if (j > N_DEPTHS || (uj > u_end && i + 1u < N_SLICES)) {
                break;
            }
            let w = clamp((uj - (u_end - step)) / step, 0.0, 1.0);
            store_veil(a, b, j, acc + w * inc, add);
            j = j + 1u;
            uj = u_at(depth_boundary(j), t_star, dist, t0, t1, u_a, u_b);
        }
        acc = acc + inc;
    }
    halo_column(k, a, b, v, open_length(v));
}

// Lamp k's glow scattered towards the camera along column (a, b)'s ray v of open
// length len: one midpoint per depth slice up to DEPTH_MAX (cut at len), summed and
// added to the column's depths (lamp_froxels.lamp_froxel_grid, lamp_halo.halo_along_rays).
fn halo_column(k: u32, a: u32, b: u32, v: vec3<f32>, len: f32) {
    let iso = lamps[k].iso;
    if (iso <= 0.0) {
        return;
    }
    let q = lamps[k].position;
    var acc = vec3<f32>(0.0);
    var t_a = 0.0;
    for (var j = 1u; j < N_DEPTHS; j = j + 1u) {
        let t_b = min(depth_boundary(j), len);
        let dt = max(t_b - t_a, 0.0);
        if (dt > 0.0) {
            let tm = 0.5 * (t_a + t_b);
            let rel = lp.position + v * tm - q;
            let r = max(length(rel), MIN_HALO_RANGE);
            let rv = dot(rel, v) / r;
            let hi = halo_index(r);
            let uv = spot_uv(hi, dot(rel, lamps[k].direction) / r);
            for (var q = 0u; q < BAND_GROUPS; q = q + 1u) {
                let sp = spot_at(k, q, uv);
                let hz = halo_at(q, 2u, hi) / r * sp;
                let hw = halo_at(q, 3u, hi) / r * sp;
                let src = max(hz - hw * rv, vec4<f32>(0.0)) * exp(-band4(q, 1u) * tm);
                acc = acc + band_rgb(q, dt * iso * src * intensity[k * BAND_GROUPS + q]);
            }
        }
        t_a = t_b;
        store_veil(a, b, j, acc, true);
    }
    store_veil(a, b, N_DEPTHS, acc, true);
}

// The lamps' veil at pixel (col, row), depth index x (lamp_froxels.lamp_froxel_lookup).
fn veil_sample(col: u32, row: u32, x: f32) -> vec3<f32> {
    let tile = f32(lp.tile);
    let cu = (f32(col) + 0.5 - 0.5 * tile) / tile + 0.5;
    let cv = (f32(row) + 0.5 - 0.5 * tile) / tile + 0.5;
    let uvw = vec3<f32>(cu / f32(lp.cols_x), cv / f32(lp.cols_y),
                        (x + 0.5) / f32(N_DEPTHS + 1u));
    return textureSampleLevel(veil_tex, veil_sampler, uvw, 0.0).xyz;
}

// lamp_froxels.depth_coordinate of distance s (inf allowed).
fn depth_coordinate(s: f32) -> f32 {
    if (s <= DEPTH_MAX) {
        return log(1.0 + max(s, 0.0) / DEPTH_M0) / DEPTH_STEP;
    }
    if (s >= f32_inf()) {
        return f32(N_DEPTHS);
    }
    return f32(N_DEPTHS - 1u) + (1.0 - DEPTH_MAX / s);
}

fn reflectance(material: u32, sig: vec3<f32>, i: u32, t: f32) -> f32 {
    if (material == PER_PIXEL) {
        return sigmoid_reflectance(vec4<f32>(sig.x), vec4<f32>(sig.y), vec4<f32>(sig.z), t).x;
    }
    return material_entry(material * N_BANDS + i);
}

// Band constant c of bands 4q ... 4q + 3 (the `bands` layout above; 0 past the last band).
fn band4(q: u32, c: u32) -> vec4<f32> {
    return bands[8u * q + c];
}

// Camera RGB of bands 4q ... 4q + 3 weighted by t.
fn band_rgb(q: u32, t: vec4<f32>) -> vec3<f32> {
    return vec3<f32>(dot(t, bands[8u * q + 4u]), dot(t, bands[8u * q + 5u]),
                     dot(t, bands[8u * q + 6u]));
}

// The row of local row lid_y in workgroup row wg_y of nwg_y (as shading4.wgsl's):
// rows of workgroups interleaved, top half / bottom half, so that lavapipe's
// threads, each given a contiguous part of the dispatch, get both open water
// and lit surfaces.
fn interleaved_row(wg_y: u32, lid_y: u32, nwg_y: u32) -> u32 {
    let half = (nwg_y + 1u) / 2u;
    let block = select(half + wg_y / 2u, wg_y / 2u, wg_y % 2u == 0u);
    return block * 8u + lid_y;
}

// A pixel's lamps' light: `full` the veil and the lit surface's light,
// `cone` the forward cone's share of the lit surface's light against the
// veil it hides (shading.lamp: (1 - exp(-f b S)) L_s - (1 - exp(-<f b> S))
// (V(inf) - V(S)), zero for open water or without lp.split_cone).
struct PixelLight {
    full: vec3<f32>,
    cone: vec3<f32>,
};

fn pixel_light(col: u32, row: u32) -> PixelLight {
    let word = textureLoad(gb_surface, vec2<i32>(i32(col), i32(row)), 0);
    let s_raw = bitcast<f32>(word.x);
    let v = pixel_ray(f32(col) + 0.5, f32(row) + 0.5);
    let to_surface = open_length(v);
    let hit = s_raw >= 0.0 && s_raw <= to_surface;
    let s = select(to_surface, s_raw, hit);
    let x = depth_coordinate(s);
    let veil = veil_sample(col, row, x);
    var out = PixelLight(veil, vec3<f32>(0.0));
    let split = hit && lp.split_cone != 0u;
    if (split) {
        // The veil behind the surface, which it hides.
        out.cone = (veil - veil_sample(col, row, f32(N_DEPTHS))) * (1.0 - exp(-lp.fb_mean * s));
    }
    if (hit && lp.surfaces != 0u) {
        let n = decode_normal(word.z, word.y);
        var sig = vec3<f32>(0.0);
        if (word.w == PER_PIXEL) {
            sig = textureLoad(gb_sigmoid, vec2<i32>(i32(col), i32(row)), 0).xyz;
        }
        let pos = lp.position + v * s;
        // The pixel's reflectance times exp(-c_view S), four bands a vec4, once
        // for every lamp; the band loops below work on those vec4 (on lavapipe a
        // loop over single bands with dynamically indexed arrays cost more than
        // its exponentials).
        var rho: array<vec4<f32>, BAND_GROUPS>;
        for (var q = 0u; q < BAND_GROUPS; q = q + 1u) {
            let t = band4(q, 3u);
            let i = min(vec4<u32>(4u * q) + vec4<u32>(0u, 1u, 2u, 3u), vec4<u32>(N_BANDS - 1u));
            let r4 = vec4<f32>(reflectance(word.w, sig, i.x, t.x),
                               reflectance(word.w, sig, i.y, t.y),
                               reflectance(word.w, sig, i.z, t.z),
                               reflectance(word.w, sig, i.w, t.w));
            // (Past the last band b is 0, so nothing is added there.)
            rho[q] = r4 * exp(-band4(q, 1u) * s);
        }
        for (var k = 0u; k < lp.n_lamps; k = k + 1u) {
            let to_lamp = lamps[k].position - pos;
            let len = length(to_lamp);
            let r = max(len, MIN_RANGE);
            let cos_n = dot(n, to_lamp) / r;
            // The direct light: beam, shadow, max(0, n . l) / r^2 (and 1 / pi).
            var g = 0.0;
            if (cos_n > 0.0) {
                let f = beam(k, -dot(to_lamp, lamps[k].direction) / max(len, 1e-30));
                if (f > 0.0) {
                    g = f * cos_n * lamp_visibility(k, pos, n, true) / (PI * r * r);
                }
            }
            let iso = lamps[k].iso / PI;
            let rh = max(len, MIN_HALO_RANGE);
            let cos_h = dot(n, to_lamp) / rh;
            if (g <= 0.0 && iso <= 0.0) {
                continue;
            }
            let hi = halo_index(rh);
            let uv = spot_uv(hi, -dot(to_lamp, lamps[k].direction) / rh);
            for (var q = 0u; q < BAND_GROUPS; q = q + 1u) {
                var e = vec4<f32>(0.0);
                if (g > 0.0) {
                    e = g * exp(-band4(q, 0u) * r);
                }
                if (iso > 0.0) {
                    let sp = spot_at(k, q, uv);
                    let h0 = halo_at(q, 0u, hi) / rh;
                    let h1 = halo_at(q, 1u, hi) / rh;
                    e = e + iso * max(h0 * sp + (h1 * sp) * cos_h, vec4<f32>(0.0));
                }
                let t = rho[q] * e * intensity[k * BAND_GROUPS + q];
                out.full = out.full + band_rgb(q, t);
                if (split) {
                    // 1 - exp(-f b S) per band ([8q + 7]: f b).
                    out.cone = out.cone + band_rgb(q, t * (1.0 - exp(-band4(q, 7u) * s)));
                }
            }
        }
    }
    return out;
}

// One invocation per texel of the cone spread's level 0 (coarse_w x
// coarse_h, blocks of `block` pixels): the mean cone share of the block's two
// diagonal pixels (spreadplan.coarse_sample_pixels), into cone_out.
@compute @workgroup_size(8, 8)
fn cone_share(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= lp.coarse_w || gid.y >= lp.coarse_h) {
        return;
    }
    let f = lp.block;
    let o = vec2<u32>(f / 4u, (3u * f) / 4u);
    let x0 = min(f * gid.x + o.x, lp.width - 1u);
    let y0 = min(f * gid.y + o.x, lp.height - 1u);
    let x1 = min(f * gid.x + o.y, lp.width - 1u);
    let y1 = min(f * gid.y + o.y, lp.height - 1u);
    let c = 0.5 * (pixel_light(x0, y0).cone + pixel_light(x1, y1).cone);
    cone_out[gid.y * lp.coarse_w + gid.x] = vec4<f32>(c, 0.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>,
        @builtin(workgroup_id) wg: vec3<u32>,
        @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    let col = gid.x;
    let row = interleaved_row(wg.y, lid.y, nwg.y);
    if (col >= lp.width || row >= lp.height) {
        return;
    }
    // The pixel keeps alpha of its cone share (the spread's finer levels);
    // the rest went to the spread's input (cone_share).
    let light = pixel_light(col, row);
    let acc = light.full - (1.0 - lp.alpha) * light.cone;
    let idx = row * lp.width + col;
    let total = rgb_out[idx].xyz + acc;
    if (!DISPLAY) {
        rgb_out[idx] = vec4<f32>(total, 0.0);
        return;
    }
    // display.wgsl's main.
    let c = max(total, vec3<f32>(0.0));
    let xd = vec3<f32>(dot(dparams.m0, c), dot(dparams.m1, c), dot(dparams.m2, c));
    if (any_non_finite(total) || any_non_finite(xd)) {
        atomicAdd(&status[0], 1u);
        atomicMin(&status[1], idx);
        rgba_out[idx] = 0xff000000u;
        return;
    }
    rgba_out[idx] = display_rgba8(xd);
}
