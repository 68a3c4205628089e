// The direct sun's per-point and per-pixel terms (aquaspec.gpu.passes.sun),
// shared by sun.wgsl (its froxel and per-pixel entry points) and by the
// light-field shading pass (lightfield.wgsl with SUN: the sun's light added
// in its own band loop). The including shader defines nothing of these;
// templates from aquaspec.gpu.passes.sun.SunPass.wgsl_values: the sun's
// uniform struct and binding numbers, the froxel tile, slices and the phase
// table's size. NumPy twins: aquaspec.scene.shadowmap.map_visibility,
// aquaspec.light.caustics.sample, aquaspec.transport.froxels.froxel_lookup.
//
// The shadow map (aquaspec.gpu.passes.sun_shadow) is a depth texture rasterised
// orthographically along the beam: depth z = (h_max - h) / (h_max - h_min)
// with h = p . to_sun; a texel left at the clear value 1 has no surface.
// Four texels are compared and their results weighted bilinearly
// (percentage-closer filtering), as map_visibility does.
// `ref_phase[k]`: ln of the bands' mean p at theta_k = pi (k / (PHASE_SIZE - 1))^2.
// The froxels: a 3-D texture, texel (column x, column y, slice boundary k)
// holding the cumulative RGB at t_k = L (k / SLICES)^2 of the column's own
// length L; a pixel reads it with one trilinear sample at its own
// w = sqrt(min(S, L_px) / L_px) (L_px: its own ray's march length), the
// same w in the four columns around it
// (aquaspec.transport.froxels.froxel_lookup).
// Caustics (aquaspec.light.caustics): the beam's factor per depth slice
// (array layer) in foot coordinates, a mip pyramid read through a repeating
// trilinear sampler; layers at d_k = D (k / (K - 1))^2, linear between them
// in sqrt(d / D). With several bands (sp.c_scaled = 1) band i reads
// 1 + s_i(d) (C - 1), its contrast scale (aquaspec.light.caustic_scatter.
// band_scales) as ln s_i = sum_p c_p x^p, x = sqrt(d / D), p = 1 ... 8, the
// coefficients in the bands' constants after their first two vec4 (NumPy
// twin aquaspec.light.caustic_sample.band_factor).

#include "common.wgsl"
#include "gbuffer_normal.wgsl"
#include "pcf.wgsl"

{{ sun_params_struct }}

const TILE: u32 = {{ tile }}u;
const SLICES: u32 = {{ slices }}u;
const PHASE_SIZE: u32 = {{ phase_size }}u;
const SUN_N_BANDS: u32 = {{ sun_n_bands }}u;

@group(0) @binding({{ sun_b_params }}) var<uniform> sp: {{ sun_params_struct_name }};
@group(0) @binding({{ sun_b_shadow }}) var shadow_map: texture_depth_2d;
@group(0) @binding({{ sun_b_froxels }}) var froxel_tex: texture_3d<f32>;
// Linear, clamped to the edges (the columns' bilinear weights clamped at the
// image's border, linear between slice boundaries).
@group(0) @binding({{ sun_b_froxel_sampler }}) var froxel_sampler: sampler;
@group(0) @binding({{ sun_b_ref_phase }}) var<storage, read> ref_phase: array<f32>;
@group(0) @binding({{ sun_b_caustic }}) var caustic_tex: texture_2d_array<f32>;
@group(0) @binding({{ sun_b_caustic_sampler }}) var caustic_sampler: sampler;
// Comparing depths (less-equal, clamped to the edge): the four texels of a
// shadow-map footprint compared in one gather.
@group(0) @binding({{ sun_b_shadow_sampler }}) var shadow_sampler: sampler_comparison;

// Share of the sun that reaches point p (1 where no map or outside it). A
// texel lets the beam through when h >= h_texel - bias, i.e. when the
// point's depth less the bias, min(z_p, 1), is at most the texel's depth z
// (a texel at the clear value 1 always does): the four texels are compared
// by one gather (texel (j0, i0) in w, (j0 + 1, i0) in z, (j0, i0 + 1) in x,
// (j0 + 1, i0 + 1) in y) and those outside the map count as lit.
fn visibility(p: vec3<f32>) -> f32 {
    if (sp.shadowed == 0u) {
        return 1.0;
    }
    let x = (dot(p, sp.e1) - sp.u0) / sp.texel - 0.5;
    let y = (dot(p, sp.e2) - sp.v0) / sp.texel - 0.5;
    let h = dot(p, sp.to_sun);
    let j0 = floor(x);
    let i0 = floor(y);
    let fx = x - j0;
    let fy = y - i0;
    let size = f32(sp.map_size);
    let z_ref = min((sp.h_max - h - sp.bias) / (sp.h_max - sp.h_min), 1.0);
    let g = textureGatherCompare(shadow_map, shadow_sampler,
                                 vec2<f32>(j0 + 1.0, i0 + 1.0) / size, z_ref);
    return pcf_blend(g, j0, i0, fx, fy, size);
}

// The caustic factor at p averaged over about `footprint` metres (1 without caustics).
fn caustic(p: vec3<f32>, footprint: f32) -> f32 {
    if (sp.caustic == 0u) {
        return 1.0;
    }
    let d = -p.y;
    let u = vec2<f32>(p.x + d / sp.to_sun.y * sp.to_sun.x,
                      p.z + d / sp.to_sun.y * sp.to_sun.z) / sp.c_tile;
    let dc = clamp(d, 0.0, sp.c_max_depth);
    let x = sqrt(dc / sp.c_max_depth) * f32(sp.c_slices - 1u);
    let k0 = min(u32(floor(x)), sp.c_slices - 2u);
    let fk = x - f32(k0);
    let lod = clamp(log2(max(footprint / sp.c_texel, 1.0)), 0.0, sp.c_levels - 1.0);
    let a = textureSampleLevel(caustic_tex, caustic_sampler, u, k0, lod).x;
    let b = textureSampleLevel(caustic_tex, caustic_sampler, u, k0 + 1u, lod).x;
    return mix(a, b, fk);
}

// Where depth d is for the bands' scales: x = sqrt(d / D), clamped to [0, 1]
// (0 for a depth that is not a number).
fn caustic_x(d: f32) -> f32 {
    return sqrt(select(0.0, min(d, sp.c_max_depth), d > 0.0) / sp.c_max_depth);
}

// ln of band i's contrast scale at x: x (c1 + x (c2 + ... + x c8)), Horner.
fn caustic_log_scale(i: u32, x: f32) -> f32 {
    let a = {{ sun_bands_var }}[2u * SUN_N_BANDS + 2u * i];
    let b = {{ sun_bands_var }}[2u * SUN_N_BANDS + 2u * i + 1u];
    return x * (a.x + x * (a.y + x * (a.z + x * (a.w + x * (b.x + x * (b.y + x * (b.z
        + x * b.w)))))));
}

// Band i's caustic factor from the shared one, c, at x (caustic_x).
fn caustic_band(i: u32, c: f32, x: f32) -> f32 {
    if (sp.c_scaled == 0u) {
        return c;
    }
    return 1.0 + exp(caustic_log_scale(i, x)) * (c - 1.0);
}

// The same for four pixels.
fn caustic_x4(d: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(caustic_x(d.x), caustic_x(d.y), caustic_x(d.z), caustic_x(d.w));
}

fn caustic_band4(i: u32, c: vec4<f32>, x: vec4<f32>) -> vec4<f32> {
    if (sp.c_scaled == 0u) {
        return c;
    }
    let a = {{ sun_bands_var }}[2u * SUN_N_BANDS + 2u * i];
    let b = {{ sun_bands_var }}[2u * SUN_N_BANDS + 2u * i + 1u];
    let p = x * (a.x + x * (a.y + x * (a.z + x * (a.w + x * (b.x + x * (b.y + x * (b.z
        + x * b.w)))))));
    return 1.0 + exp(p) * (c - 1.0);
}

// Camera.ray_directions through pixel coordinates (px, py).
fn ray_through(px: f32, py: f32) -> vec3<f32> {
    let xc = (px - sp.cx) / sp.fx;
    let yc = (py - sp.cy) / sp.fy;
    return normalize(sp.right * xc - sp.up * yc + sp.forward);
}

// Where a phase table is read for cos theta: entry k0 and the fraction to k0 + 1.
struct PhaseAt {
    k0: u32,
    f: f32,
}

fn phase_at(cos_theta: f32) -> PhaseAt {
    let xp = sqrt(acos(clamp(cos_theta, -1.0, 1.0)) / PI) * f32(PHASE_SIZE - 1u);
    let k0 = min(u32(floor(xp)), PHASE_SIZE - 2u);
    return PhaseAt(k0, xp - f32(k0));
}

fn ref_phase_value(at: PhaseAt) -> f32 {
    return exp(mix(ref_phase[at.k0], ref_phase[at.k0 + 1u], at.f));
}

// Where the single scattering along ray v is integrated to
// (aquaspec.transport.sun_scattering.march_length of open water): the water
// surface (up rays) or where the slowest band's integrand has fallen below
// the tail; 0 for a camera at the surface looking up. The bands' constants
// `{{ sun_bands_var }}` (c_view, c_sun / mu0 in the first vec4 of each band).
fn march_length(v: vec3<f32>) -> f32 {
    let inf = f32_inf();
    var k_min = inf;
    for (var i = 0u; i < SUN_N_BANDS; i = i + 1u) {
        let q0 = {{ sun_bands_var }}[2u * i];
        k_min = min(k_min, q0.x - q0.y * v.y);
    }
    let to_surface = select(inf, -sp.position.y / v.y, v.y > 0.0);
    let t_tail = select(inf, sp.neg_log_tail / k_min, k_min > 0.0);
    let length = min(to_surface, t_tail);
    return select(0.0, length, length < inf);
}

// The single scattering (before the pixel's phase factor) at pixel
// coordinates (px, py) whose ray v reaches distance s (inf: open water):
// one trilinear sample of the froxels at the columns around the pixel and
// its own w.
fn froxel_read(px: f32, py: f32, v: vec3<f32>, s: f32) -> vec3<f32> {
    let length = march_length(v);
    let w = select(0.0, sqrt(min(s, length) / max(length, 1e-30)), length > 0.0);
    let cols = vec2<f32>(f32(sp.cols_x), f32(sp.cols_y));
    let uv = (vec2<f32>(px, py) / f32(TILE)) / cols;
    let z = (w * f32(SLICES) + 0.5) / f32(SLICES + 1u);
    return textureSampleLevel(froxel_tex, froxel_sampler, vec3<f32>(uv, z), 0.0).xyz;
}

// The sun's light at pixel (col, row) whose ray v reaches distance s (inf:
// open water): the froxels' single scattering times the bands' mean phase
// function at the pixel's angle.
fn sun_veil(col: u32, row: u32, v: vec3<f32>, s: f32) -> vec3<f32> {
    return froxel_read(f32(col) + 0.5, f32(row) + 0.5, v, s)
        * ref_phase_value(phase_at(dot(v, sp.to_sun)));
}

// The share of the beam a surface at distance s along v with normal n gets:
// max(0, n . to_sun) times the shadow map's visibility (read off the surface
// along its normal), and the caustic factor over the pixel's footprint
// (each band's: caustic_band at the surface's depth).
fn sun_lit(v: vec3<f32>, s: f32, n: vec3<f32>) -> vec2<f32> {
    let pos = sp.position + v * s;
    let cos_n = max(dot(n, sp.to_sun), 0.0);
    return vec2<f32>(cos_n * visibility(pos + n * sp.normal_offset), caustic(pos, s / sp.fx));
}
