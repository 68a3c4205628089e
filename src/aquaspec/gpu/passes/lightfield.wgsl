// Deferred spectral shading with the light-field multiple-scattering model
// (ms_model = "lightfield"), compiled for the camera's depth: G-buffer ->
// linear camera RGB, or with DISPLAY straight to display RGBA8; one
// invocation per four horizontally adjacent pixels (vec4 lanes, pixel k in
// component k).
//
// Twin of aquaspec.transport.lightfield.compiled (shade_compiled, float64 NumPy),
// whose module docstring gives the formulas; the host side is
// aquaspec.gpu.passes.lightfield. Per pixel:
//   RGB = W(v_y, S)                                   (water table, one sample)
//       + sum_i w'_i rho_i exp(K_i d_S - c'_i S + sum_r G_ir U_r(d_S, n_y))
// where the second term is there only for hits, U comes from one texture
// sample (two with ranks 5-8) and w'_i = w_i E0_i / pi exp(C_i).
// With SPREAD (the forward cone spread over the image) two pipelines:
// - COARSE: one invocation per two pixels of the pyramid's start level
//   (blocks of BLOCK x BLOCK pixels), its four lanes two pixels on each
//   block's diagonal; writes the mean of their cone term (water table layer
//   1 plus the target's light the pixel does not keep, over 1 - alpha) to
//   cone_out, where the pyramid (aquaspec.gpu.passes.conespread) takes over;
// - the full-resolution pass: the water table's layer 0 holds W0 + alpha W1,
//   the target's light is weighted alpha + (1 - alpha) exp(-f b S) (its
//   logarithm linear in f b per pixel: a multiply-add per band, none with
//   PROJECTED, no second exponential), and the pyramid's result is added
//   with one bilinear sample.
//
// With NODES > 0 (the multiple-scattering spread, lightfield_compiled with
// alpha_nodes; K = NODES lambda nodes at z = 0 .. K - 1):
// - the kept share is the single-scattering spread's with a per-pixel alpha
//   instead of prm.alpha: the nodes' shares at z = log3(1 + 2 mean(f b) S),
//   which the water table's layer 0 holds in its fourth channel (the table
//   already keeps the water's own share);
// - COARSE writes K node images of camera RGB: the rest of the target's
//   light split by the hat weights of z_i = log3(1 + 2 f_i b_i S) over
//   1 - alpha(z_i) (lightfield_compiled.surface_rgb),
//   plus the water table's layers 1 .. K, in SLOTS vec4 per block, slot m at
//   column block + m coarse_size.x of cone_out (aquaspec.gpu.passes.conespread).
//
// With the sun (the full-resolution pipeline of a frame with a sun,
// aquaspec.gpu.passes.sun.SunPass.fused_resources; twin aquaspec.shading.sun.sun_radiance):
// the template names SUN_PIXELS and SUN_SURFACE are sun_pixels and
// sun_surface (else no_sun_pixels and no_sun_surface, so that a frame
// without the sun does not use the sun's bindings). Per pixel the sun's veil
// (the froxels) and the share of the beam its surface gets (sunlight.wgsl);
// per band the lit surface's light rho beam0 / pi exp(-c_sun d_S / mu0 - c S)
// times that share, added to the image beside the targets' light, so that
// the display transform stays fused and the G-buffer and the image are read
// once.
//
// With marine snow (the fused display of a live frame,
// aquaspec.gpu.passes.lightfield.LightfieldPass.set_snow) the template name
// SNOW_COMPOSE is snow_compose (snow_compose.wgsl: the particles' discs
// composed over the four pixels before the display transform), else
// no_snow_compose.
//
// Written for lavapipe (SIMD over 8 invocations on the CPU), as
// deferred.wgsl (see its header): per-band constants in a uniform array
// with a compile-time band count, per-pixel work (table coordinates)
// outside the band loop, selects instead of branches, and per-invocation
// trip counts to skip work no lane needs. Measured there (1280x720, per
// pixel and frame): a texel fetch about 0.9 ms, a filtered sample 1.5 ms, a
// storage load 0.4 ms, an exp 0.06 ms; the band loop is one exp and a few
// multiply-adds per band, as the seeds' model's two exps. Measured again
// (2026-11-24, leaving one step out): the two filtered samples 1.6-2.3 ms
// each; a sample in a loop whose trip count differs between invocations
// (the irradiance read skipped on open water) made the frame 1.3 ms slower.

#include "shading4.wgsl"
#include "lftables.wgsl"
#include "sunlight.wgsl"

{{ params_struct }}

{{ display_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
// Axes of the irradiance basis U (aquaspec.transport.lightfield.tables.table_depths /
// table_cosines) and its rank (4 or 8: one or two layers).
const N_DEPTH: u32 = {{ n_depth }}u;
const N_MU: u32 = {{ n_mu }}u;
const RANK: u32 = {{ rank }}u;
// Water table: W_OUT + W_IN rows (v_y outside / inside Snell's window,
// lightfield_compiled.direction_split), W_DIST columns (S, open water last).
const W_OUT: u32 = {{ directions_outside }}u;
const W_IN: u32 = {{ directions_inside }}u;
const W_DIST: u32 = {{ distances }}u;
const LENGTH_SCALE: f32 = {{ length_scale }};
// Vec4 per band in band_table.
const BAND_VEC4: u32 = {{ band_vec4 }}u;
// DISPLAY: apply the display transform (display.wgsl) and write packed
// RGBA8 instead of linear RGB; TONEMAP is its tone map id (tonemap.wgsl).
const DISPLAY: bool = {{ display }};
const TONEMAP: u32 = {{ tonemap_id }}u;
// Whether the G-buffer has per-pixel (sigmoid) materials: when false the
// sigmoid texture is not read and no sigmoid is evaluated.
const PER_PIXEL_MATERIALS: bool = {{ per_pixel }};
// FILTER: the tables are read with the sampler's bilinear filtering (needs
// float32-filterable); else the same bilinear interpolation from four fetches.
const FILTER: bool = {{ filter }};
// SPREAD: the forward cone spread over the image; COARSE: this is the
// pipeline of the spread's start level (see the header); BLOCK = 2^L0.
const SPREAD: bool = {{ spread }};
const COARSE: bool = {{ coarse }};
// Whether the spread's result is read once per four pixels (BLOCK >= 4; a
// constant: with a uniform's value lavapipe ran both sides of the branch).
const GROUP_SPREAD: bool = {{ group_spread }};
// PROJECTED: the kept share's term per band, slope S (f_i b_i - mean f b),
// is a combination of the band's other coefficients
// (lightfield_compiled.kept_projection): the pixel shifts d_S, S and U once
// instead (prm.kept_lam*), and COARSE uses that combination (band_table's
// w'.w) so that it takes the exact complement.
const PROJECTED: bool = {{ projected }};
// The multiple-scattering spread's lambda nodes (0: not used) and the vec4
// a coarse block's node images take.
const NODES: u32 = {{ nodes }}u;
const SLOTS: u32 = {{ slots }}u;
const NODE_ARRAY: u32 = max(NODES, 1u);
// The scene's occlusion of the ambient light (aquaspec.gpu.passes.occlusion):
// each surface's light-field term times O_i, sampled from the factors' grid
// (cells of OCC_SCALE pixels) once per pixel before the band loop.
const OCCLUSION: bool = {{ occlusion }};
const OCC_SCALE: u32 = {{ occlusion_scale }}u;
const OCC_LAYERS: u32 = {{ occlusion_layers }}u;
// occ_band[j]: the four pixels' factor of band 4q + j of the current group
// (band_group_start); occ_u, occ_v: the four pixels' texture coordinates.
var<private> occ_band: array<vec4<f32>, 4>;
var<private> occ_u: vec4<f32>;
var<private> occ_v: vec4<f32>;

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
// (Bindings 1 and 2, the G-buffer, and 6, 8, 9, 10, the outputs: shading4.wgsl.)
// BAND_VEC4 vec4 per band i (lightfield_pass.band_table, float64 on the host):
//   [B i]             K (1/m), c' = c - f b, f b - mean(f b), t (sigmoid band centre)
//   [B i + 1 (+ 2)]   G_i0 .. G_i3 (G_i4 .. G_i7 with RANK 8)
//   [B i + B - 1]     w'_r, w'_g, w'_b, f b - mean(f b) projected (PROJECTED)
@group(0) @binding(4) var<uniform> band_table: array<vec4<f32>, {{ band_table_len }}>;
// (Bindings 3 and 5: the material table, materials.wgsl.)
// Water table: layer 0 the water's camera RGB, layer 1 (SPREAD) the cone's
// share; texel (distance column, direction row).
@group(0) @binding(11) var water_table: texture_2d_array<f32>;
// The sun's per-band constants (sun.wgsl's `bands`: c, c_sun / mu0, b beam0,
// beam0 / pi; w_r, w_g, w_b, t).
@group(0) @binding({{ sun_b_bands }}) var<uniform> sun_bands: array<vec4<f32>, {{ sun_band_vec4 }}>;
// Irradiance basis U: layer g, texel (direction j, depth i) holds U_4g .. U_4g+3.
@group(0) @binding(12) var basis_table: texture_2d_array<f32>;
@group(0) @binding(14) var table_sampler: sampler;
// COARSE: the start level of the spread's pyramid (its level 0).
@group(0) @binding(15) var cone_out: texture_storage_2d<rgba32float, write>;
// SPREAD, full resolution: the pyramid's result at its start level.
@group(0) @binding(16) var spread_in: texture_2d<f32>;

// Camera.ray_directions: the up component of the unit ray through the pixel
// centres (j + 0.5, i + 0.5) of four pixels (columns px, rows py).
fn ray_direction_y(px: vec4<u32>, py: vec4<u32>) -> vec4<f32> {
    let x = (vec4<f32>(px) + 0.5 - prm.cx) / prm.fx;
    let y = (vec4<f32>(py) + 0.5 - prm.cy) / prm.fy;
    let dx = prm.right.x * x + (prm.forward.x - prm.up.x * y);
    let dy = prm.right.y * x + (prm.forward.y - prm.up.y * y);
    let dz = prm.right.z * x + (prm.forward.z - prm.up.z * y);
    return dy * inverseSqrt(dx * dx + dy * dy + dz * dz);
}

// lightfield.bilinear's coordinates on the tables' axes (lftables.wgsl).
fn cos_coord(v: vec4<f32>) -> vec4<f32> {
    return table_cos_coord(v, N_MU);
}

fn depth_coord(depth: vec4<f32>) -> vec4<f32> {
    return table_depth_coord(depth, prm.max_depth, N_DEPTH);
}

// Bilinear interpolation of layer g of a table with cols x rows texels at
// texel coordinates (col, row) (texel k centred at k; clamped at the edges).
fn bilinear4(table: texture_2d_array<f32>, col: f32, row: f32, g: u32, cols: u32,
             rows: u32) -> vec4<f32> {
    if (FILTER) {
        let uv = vec2<f32>((col + 0.5) / f32(cols), (row + 0.5) / f32(rows));
        return textureSampleLevel(table, table_sampler, uv, g, 0.0);
    }
    let j = min(u32(max(col, 0.0)), cols - 2u);
    let i = min(u32(max(row, 0.0)), rows - 2u);
    let fj = clamp(col - f32(j), 0.0, 1.0);
    let fi = clamp(row - f32(i), 0.0, 1.0);
    let lo = mix(textureLoad(table, vec2<u32>(j, i), g, 0),
                 textureLoad(table, vec2<u32>(j + 1u, i), g, 0), fj);
    let hi = mix(textureLoad(table, vec2<u32>(j, i + 1u), g, 0),
                 textureLoad(table, vec2<u32>(j + 1u, i + 1u), g, 0), fj);
    return mix(lo, hi, fi);
}

// Bilinear value of the spread's result at coarse index coordinates (x, y),
// clamped to the edge (a sampler's linear filtering at (c + 0.5) / size).
fn spread_at(x: f32, y: f32) -> vec4<f32> {
    let n = vec2<f32>(prm.coarse_size);
    let c = vec2<f32>(x, y);
    if (FILTER) {
        return textureSampleLevel(spread_in, table_sampler, (c + 0.5) / n, 0.0);
    }
    let cc = clamp(c, vec2<f32>(0.0), n - 1.0);
    let i0 = vec2<u32>(floor(cc));
    let i1 = min(i0 + 1u, prm.coarse_size - 1u);
    let f = cc - vec2<f32>(i0);
    let lo = mix(textureLoad(spread_in, vec2<u32>(i0.x, i0.y), 0),
                 textureLoad(spread_in, vec2<u32>(i1.x, i0.y), 0), f.x);
    let hi = mix(textureLoad(spread_in, vec2<u32>(i0.x, i1.y), 0),
                 textureLoad(spread_in, vec2<u32>(i1.x, i1.y), 0), f.x);
    return mix(lo, hi, f.y);
}

// lightfield_compiled.direction_coordinate: rows 0 .. W_OUT - 1 outside
// Snell's window (uniform in q = sign(v) sqrt(|v|)), W_OUT .. W_OUT + W_IN - 1
// inside (uniform in u = sqrt((v - w) / (1 - w)), w the window's cosine).
fn direction_row(v: vec4<f32>) -> vec4<f32> {
    let vc = clamp(v, vec4<f32>(-1.0), vec4<f32>(1.0));
    let q = sign(vc) * sqrt(abs(vc));
    let w = prm.window_cos;
    let q_w = sign(w) * sqrt(abs(w));
    let outside = (q + 1.0) / (q_w + 1.0) * f32(W_OUT - 1u);
    let u = sqrt(max(vc - w, vec4<f32>(0.0)) / (1.0 - w));
    let inside = f32(W_OUT) + u * f32(W_IN - 1u);
    return select(outside, inside, v > vec4<f32>(w));
}

// What the band loop (shading4.wgsl) needs of the four pixels (vec4 lanes):
// the exponent's variables, the kept share's (SPREAD) and per-pixel materials.
struct BandPixels {
    d_e: vec4<f32>,
    s_e: vec4<f32>,
    u0: vec4<f32>,
    u1: vec4<f32>,
    u2: vec4<f32>,
    u3: vec4<f32>,
    u4: vec4<f32>,
    u5: vec4<f32>,
    u6: vec4<f32>,
    u7: vec4<f32>,
    kept_b: vec4<f32>,
    dk: vec4<f32>,
    // COARSE: 1 / (1 - alpha).
    inv_rest: f32,
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    use_sigmoid: vec4<bool>,
}

// The sun's veil (camera RGB), the share of the beam the four pixels'
// surfaces get (0 where no hit) and their caustic factor (sunlight.wgsl's sun_lit).
struct SunPixels {
    r: vec4<f32>,
    g: vec4<f32>,
    b: vec4<f32>,
    lit: vec4<f32>,
    caustic: vec4<f32>,
}

fn no_sun_pixels(px: vec4<u32>, py: vec4<u32>, gb: GbufferPixels, hit: vec4<bool>) -> SunPixels {
    return SunPixels(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0),
                     vec4<f32>(1.0));
}

// One pixel's lit share along its ray v and its caustic factor (0, 1 where no hit).
fn sun_pixel_lit(v: vec3<f32>, s: f32, hit: bool, oct: u32, n_y: f32) -> vec2<f32> {
    let n = decode_normal(oct, bitcast<u32>(n_y));
    return select(vec2<f32>(0.0, 1.0), sun_lit(v, select(0.0, s, hit), n), hit);
}

// One pixel's veil: the froxels' single scattering along its ray v at its
// distance s (inf: open water) times the bands' mean phase function at its angle.
fn sun_pixel_veil(px: u32, py: u32, v: vec3<f32>, s: f32) -> vec3<f32> {
    let x = f32(px) + 0.5;
    let y = f32(py) + 0.5;
    return froxel_read(x, y, v, s) * ref_phase_value(phase_at(dot(v, sp.to_sun)));
}

// The lit shares and the veils (sunlight.wgsl's sun_veil: one trilinear
// froxel sample each) of the four pixels. (Each lane written out: a loop
// over the lanes indexing them with its counter was several times slower on
// lavapipe.) Each pixel's ray is made once for both (made in each, the
// shading pass with the sun took 1-2 ms more per 1280x720 frame).
fn sun_pixels(px: vec4<u32>, py: vec4<u32>, gb: GbufferPixels, hit: vec4<bool>) -> SunPixels {
    let v0 = ray_through(f32(px.x) + 0.5, f32(py.x) + 0.5);
    let v1 = ray_through(f32(px.y) + 0.5, f32(py.y) + 0.5);
    let v2 = ray_through(f32(px.z) + 0.5, f32(py.z) + 0.5);
    let v3 = ray_through(f32(px.w) + 0.5, f32(py.w) + 0.5);
    // The shadow map and caustics only where a lane hits (a trip count, not a
    // branch: lavapipe leaves the loop when no SIMD lane has an iteration).
    var lit = vec4<f32>(0.0);
    var caustic = vec4<f32>(1.0);
    let n_lit = select(0u, 1u, any(hit));
    for (var t = 0u; t < n_lit; t = t + 1u) {
        let a = sun_pixel_lit(v0, gb.s.x, hit.x, gb.oct.x, gb.n_y.x);
        let b = sun_pixel_lit(v1, gb.s.y, hit.y, gb.oct.y, gb.n_y.y);
        let c = sun_pixel_lit(v2, gb.s.z, hit.z, gb.oct.z, gb.n_y.z);
        let e = sun_pixel_lit(v3, gb.s.w, hit.w, gb.oct.w, gb.n_y.w);
        lit = vec4<f32>(a.x, b.x, c.x, e.x);
        caustic = vec4<f32>(a.y, b.y, c.y, e.y);
    }
    let s = select(vec4<f32>(f32_inf()), gb.s, hit);
    let l0 = sun_pixel_veil(px.x, py.x, v0, s.x);
    let l1 = sun_pixel_veil(px.y, py.y, v1, s.y);
    let l2 = sun_pixel_veil(px.z, py.z, v2, s.z);
    let l3 = sun_pixel_veil(px.w, py.w, v3, s.w);
    return SunPixels(vec4<f32>(l0.x, l1.x, l2.x, l3.x), vec4<f32>(l0.y, l1.y, l2.y, l3.y),
                     vec4<f32>(l0.z, l1.z, l2.z, l3.z), lit, caustic);
}

fn no_sun_surface(m: PixelMaterials, run: bool, d: vec4<f32>, s: vec4<f32>,
                  lit: vec4<f32>, caustic: vec4<f32>) -> Rgb4 {
    return Rgb4(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
}

// The sun-lit surface's light in band i (sun.wgsl's main: rho beam0 / pi
// exp(-c_sun d / mu0 - c S) times the share lit and the band's caustic
// factor), added to acc.
fn sun_surface_band(i: u32, rho_m: vec4<f32>, m: PixelMaterials, d: vec4<f32>, s: vec4<f32>,
                    lit: vec4<f32>, caustic: vec4<f32>, at: vec4<f32>,
                    acc: ptr<function, Rgb4>) {
    let q0 = sun_bands[2u * i];
    let q1 = sun_bands[2u * i + 1u];
    var rho = rho_m;
    if (PER_PIXEL_MATERIALS) {
        rho = select(rho, sigmoid_reflectance(m.c0, m.c1, m.c2, q1.w), m.use_sigmoid);
    }
    let l = rho * q0.w * exp(-q0.y * d - q0.x * s) * lit * caustic_band4(i, caustic, at);
    (*acc).r = (*acc).r + l * q1.x;
    (*acc).g = (*acc).g + l * q1.y;
    (*acc).b = (*acc).b + l * q1.z;
}

// The sun-lit surfaces' light at depths d and distances s, in a band loop of
// its own after the targets' (three more per-pixel values in that loop made
// a 1280x720 frame 45 ms of CPU slower on lavapipe), four band bodies per
// material vec4 (a band index picking a vector component cost as much again).
fn sun_surface(m: PixelMaterials, run: bool, d: vec4<f32>, s: vec4<f32>,
               lit: vec4<f32>, caustic: vec4<f32>) -> Rgb4 {
    var acc = Rgb4(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    let at = caustic_x4(d);
    let n_groups = select(0u, FULL_GROUPS, run);
    for (var q = 0u; q < n_groups; q = q + 1u) {
        let g = material_group(m.mrow, q, m.use_material);
        sun_surface_band(4u * q, group_band(g, 0u), m, d, s, lit, caustic, at, &acc);
        sun_surface_band(4u * q + 1u, group_band(g, 1u), m, d, s, lit, caustic, at, &acc);
        sun_surface_band(4u * q + 2u, group_band(g, 2u), m, d, s, lit, caustic, at, &acc);
        sun_surface_band(4u * q + 3u, group_band(g, 3u), m, d, s, lit, caustic, at, &acc);
    }
    let n_rest = select(0u, select(0u, 1u, REST_BANDS > 0u), run);
    for (var t = 0u; t < n_rest; t = t + 1u) {
        let g = material_group(m.mrow, FULL_GROUPS, m.use_material);
        let i = 4u * FULL_GROUPS;
        sun_surface_band(i, group_band(g, 0u), m, d, s, lit, caustic, at, &acc);
        if (REST_BANDS > 1u) {
            sun_surface_band(i + 1u, group_band(g, 1u), m, d, s, lit, caustic, at, &acc);
        }
        if (REST_BANDS > 2u) {
            sun_surface_band(i + 2u, group_band(g, 2u), m, d, s, lit, caustic, at, &acc);
        }
    }
    return acc;
}

// COARSE with NODES: the node images of the four lanes (camera RGB per node).
var<private> node_acc: array<Rgb4, NODE_ARRAY>;

// The kept share alpha_k of node k (prm.alpha_lo / alpha_hi).
fn node_alpha(k: u32) -> f32 {
    return select(prm.alpha_hi[k % 4u], prm.alpha_lo[k % 4u], k < 4u);
}

// Hat weight of node k at lambda coordinates z (clamped to the nodes).
fn hat(z: vec4<f32>, k: u32) -> vec4<f32> {
    let zc = clamp(z, vec4<f32>(0.0), vec4<f32>(f32(NODE_ARRAY - 1u)));
    return max(vec4<f32>(0.0), 1.0 - abs(zc - f32(k)));
}

// z = log3(1 + 2 x) (aquaspec.transport.lightfield.conespread.lambda_coordinate).
fn lambda_coordinate(x: vec4<f32>) -> vec4<f32> {
    return log(1.0 + 2.0 * x) * (1.0 / log(3.0));
}

// The nodes' kept shares interpolated at z.
fn node_value_alpha(z: vec4<f32>) -> vec4<f32> {
    var alpha = vec4<f32>(0.0);
    for (var k = 0u; k < NODES; k++) {
        alpha = alpha + node_alpha(k) * hat(z, k);
    }
    return alpha;
}

// The targets' own light in band i (material reflectance rho_m, 0 where
// none) added to acc: one exponential (COARSE: two, the share the pixel
// does not keep, over 1 - alpha).
fn shade_band(i: u32, rho_m: vec4<f32>, p: BandPixels, acc: ptr<function, Rgb4>) {
    let q0 = band_table[BAND_VEC4 * i];
    let g0 = band_table[BAND_VEC4 * i + 1u];
    let wt = band_table[BAND_VEC4 * i + BAND_VEC4 - 1u];
    var ln_e = q0.x * p.d_e - q0.y * p.s_e + g0.x * p.u0 + g0.y * p.u1 + g0.z * p.u2
        + g0.w * p.u3;
    if (RANK > 4u) {
        // (Compile-time: a term per function past the fourth.)
        let g1 = band_table[BAND_VEC4 * i + 2u];
        ln_e = ln_e + g1.x * p.u4;
        if (RANK > 5u) {
            ln_e = ln_e + g1.y * p.u5;
        }
        if (RANK > 6u) {
            ln_e = ln_e + g1.z * p.u6;
        }
        if (RANK > 7u) {
            ln_e = ln_e + g1.w * p.u7;
        }
    }
    var rho = rho_m;
    if (PER_PIXEL_MATERIALS) {
        rho = select(rho, sigmoid_reflectance(p.c0, p.c1, p.c2, q0.w), p.use_sigmoid);
    }
    if (SPREAD && !COARSE && !PROJECTED) {
        // q0.z: f_i b_i minus the bands' mean.
        ln_e = ln_e + p.kept_b * q0.z;
    }
    // (rho is 0 where there is no hit, and ln_e finite: no select needed.)
    var l = rho * exp(ln_e);
    if (OCCLUSION) {
        l = l * occ_band[i % 4u];
    }
    if (COARSE && NODES > 0u) {
        // The rest, split between the nodes at this band's coordinate
        // (x_i = f_i b_i S, q0.z + mean f b = f_i b_i).
        let z = lambda_coordinate((q0.z + prm.fb_mean) * p.s_e);
        let rest = l - l * p.dk * exp(p.kept_b * q0.z);
        let share = rest / max(1.0 - node_value_alpha(z), vec4<f32>(1e-12));
        for (var k = 0u; k < NODES; k++) {
            let c = hat(z, k) * share;
            node_acc[k].r = node_acc[k].r + c * wt.x;
            node_acc[k].g = node_acc[k].g + c * wt.y;
            node_acc[k].b = node_acc[k].b + c * wt.z;
        }
        return;
    }
    if (COARSE) {
        var offset = q0.z;
        if (PROJECTED) {
            offset = wt.w;
        }
        l = (l - l * p.dk * exp(p.kept_b * offset)) * p.inv_rest;
    }
    (*acc).r = (*acc).r + l * wt.x;
    (*acc).g = (*acc).g + l * wt.y;
    (*acc).b = (*acc).b + l * wt.z;
}

// Without occlusion.
fn no_occlusion_coords(px: vec4<u32>, py: vec4<u32>) {
}

fn no_occlusion(q: u32) {
}

fn band_group_start(q: u32) {
    {{ occlusion_fill }}(q);
}

{{ occlusion_block }}

// Without marine snow.
fn no_snow_compose(j0: u32, row: u32, c: Rgb4) -> Rgb4 {
    return c;
}

{{ snow_block }}

@compute @workgroup_size({{ workgroup_x }}, {{ workgroup_y }})
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    // Rows of workgroups interleaved, top half / bottom half (shading4.wgsl):
    // the two lavapipe threads each get open water and hits.
    let row = interleaved_row(wg.y, lid.y, nwg.y);
    let col = wg.x * {{ workgroup_x }}u + lid.x;
    // The four pixels (lanes) of this invocation: four adjacent pixels of a
    // row, or (COARSE) two pixels of each of two blocks, at offsets BLOCK / 4
    // and 3 BLOCK / 4 on the diagonal (lightfield_compiled.coarse_sample_pixels).
    var px: vec4<u32>;
    var py: vec4<u32>;
    let j0 = 4u * col;
    // COARSE: blocks 2 col and 2 col + 1 (the last repeated at the edge),
    // lanes 0 and 1 the first's two samples, 2 and 3 the second's.
    let cb0 = 2u * col;
    let cb1 = min(cb0 + 1u, prm.coarse_size.x - 1u);
    if (COARSE) {
        if (cb0 >= prm.coarse_size.x || row >= prm.coarse_size.y) {
            return;
        }
        let lo = prm.block / 4u;
        let hi = (3u * prm.block) / 4u;
        px = min(prm.block * vec4<u32>(cb0, cb0, cb1, cb1) + vec4<u32>(lo, hi, lo, hi),
                 vec4<u32>(prm.width - 1u));
        py = min(prm.block * row + vec4<u32>(lo, hi, lo, hi), vec4<u32>(prm.height - 1u));
    } else {
        if (j0 >= prm.width || row >= prm.height) {
            return;
        }
        px = min(vec4<u32>(j0) + vec4<u32>(0u, 1u, 2u, 3u), vec4<u32>(prm.width - 1u));
        py = vec4<u32>(row);
    }
    let v_y = ray_direction_y(px, py);
    let d_o = prm.depth_o;

    let gb = load_gbuffer(px, py);
    // A hit counts only if the ray reaches it before the water surface.
    let hit = hit_before_surface(gb.s, v_y, d_o);
    let s = select(vec4<f32>(0.0), gb.s, hit);
    // Depth of the hit (unused for open water).
    let d_s = max(d_o - s * v_y, vec4<f32>(0.0));

    // The water: one sample of the water table per pixel (column: the hit's
    // distance, or open water).
    let w_row = direction_row(v_y);
    let w_col = select(vec4<f32>(f32(W_DIST - 1u)), s / (s + LENGTH_SCALE) * f32(W_DIST - 2u),
                       hit);
    let w_rows = W_OUT + W_IN;
    var r: vec4<f32>;
    var gr: vec4<f32>;
    var b: vec4<f32>;
    // (Layer 0: the water, with the spread W0 + alpha W1; COARSE reads
    // layer 1, the cone's share, alone, or with NODES layers 1 .. NODES into
    // the node images.)
    let layer = select(0u, 1u, COARSE && NODES == 0u);
    // NODES: the pixel's kept share (layer 0's fourth channel).
    var node_kept = vec4<f32>(0.0);
    if (COARSE && NODES > 0u) {
        for (var k = 0u; k < 4u; k = k + 1u) {
            node_kept[k] = bilinear4(water_table, w_col[k], w_row[k], 0u, W_DIST, w_rows).w;
        }
        for (var n = 0u; n < NODES; n++) {
            for (var k = 0u; k < 4u; k = k + 1u) {
                let w = bilinear4(water_table, w_col[k], w_row[k], 1u + n, W_DIST, w_rows);
                node_acc[n].r[k] = w.x;
                node_acc[n].g[k] = w.y;
                node_acc[n].b[k] = w.z;
            }
        }
    } else {
        for (var k = 0u; k < 4u; k = k + 1u) {
            let w = bilinear4(water_table, w_col[k], w_row[k], layer, W_DIST, w_rows);
            r[k] = w.x;
            gr[k] = w.y;
            b[k] = w.z;
            node_kept[k] = w.w;
        }
    }

    // Materials (COARSE lanes repeat pixels counted by the full-resolution pass).
    let cols = vec4<u32>(j0) + vec4<u32>(0u, 1u, 2u, 3u);
    let mat = pixel_materials(gb, hit, prm.n_materials,
                              (cols < vec4<u32>(prm.width)) & vec4<bool>(!COARSE));

    // The irradiance basis at (d_S, n_y). Read for every pixel: in control
    // flow that differs between invocations (a trip count of any(hit))
    // lavapipe's texture sampling cost 2 ms more per 1280x720 frame.
    var u0 = vec4<f32>(0.0);
    var u1 = vec4<f32>(0.0);
    var u2 = vec4<f32>(0.0);
    var u3 = vec4<f32>(0.0);
    var u4 = vec4<f32>(0.0);
    var u5 = vec4<f32>(0.0);
    var u6 = vec4<f32>(0.0);
    var u7 = vec4<f32>(0.0);
    let any_hit = any(hit);
    {
        let x_s = depth_coord(d_s);
        // (n_y of open water is whatever the G-buffer holds: made 0, so the
        // band loop's exponent stays finite there.)
        let y_n = cos_coord(select(vec4<f32>(0.0), gb.n_y, hit));
        for (var k = 0u; k < 4u; k = k + 1u) {
            let u = bilinear4(basis_table, y_n[k], x_s[k], 0u, N_MU, N_DEPTH);
            u0[k] = u.x;
            u1[k] = u.y;
            u2[k] = u.z;
            u3[k] = u.w;
            if (RANK > 4u) {
                let v = bilinear4(basis_table, y_n[k], x_s[k], 1u, N_MU, N_DEPTH);
                u4[k] = v.x;
                u5[k] = v.y;
                u6[k] = v.z;
                u7[k] = v.w;
            }
        }
    }

    // The targets' own light, one exponential per band. With SPREAD the
    // pixel keeps T' (alpha + (1 - alpha) exp(-f b S)) of it: the tangent of
    // that share's logarithm in f_i b_i at the bands' mean
    // (lightfield_compiled.kept_share), ln kept_i = ln dk + slope S (f_i b_i -
    // mean f b) with dk the share at the mean: per band one multiply-add in
    // the exponent, and dk multiplies the sum once per pixel (no logarithm);
    // COARSE takes the rest over 1 - alpha.
    var dk = vec4<f32>(1.0);
    var kept_b = vec4<f32>(0.0);
    if (SPREAD) {
        let e = exp(-s * prm.fb_mean);
        let alpha = select(vec4<f32>(prm.alpha), node_kept, NODES > 0u);
        // (Floored: alpha = 0 and exp(-x) underflowing would give 0 / 0.)
        dk = max(alpha + (1.0 - alpha) * e, vec4<f32>(1e-30));
        kept_b = -(1.0 - alpha) * e / dk * s;
    }
    // (With PROJECTED the band's term moves into the pixel's: d_S, S and the
    // basis shifted by lam kb, and exp(mu kb) with dk.)
    var d_e = d_s;
    var s_e = s;
    if (SPREAD && PROJECTED && !COARSE) {
        d_e = d_s + prm.kept_lam.x * kept_b;
        s_e = s - prm.kept_lam.y * kept_b;
        dk = dk * exp(prm.kept_lam.z * kept_b);
        u0 = u0 + prm.kept_lam_g0.x * kept_b;
        u1 = u1 + prm.kept_lam_g0.y * kept_b;
        u2 = u2 + prm.kept_lam_g0.z * kept_b;
        u3 = u3 + prm.kept_lam_g0.w * kept_b;
        if (RANK > 4u) {
            u4 = u4 + prm.kept_lam_g1.x * kept_b;
            u5 = u5 + prm.kept_lam_g1.y * kept_b;
            u6 = u6 + prm.kept_lam_g1.z * kept_b;
            u7 = u7 + prm.kept_lam_g1.w * kept_b;
        }
    }
    // The targets' light summed apart from the water's (dk applies to it
    // alone), by the band loop of shading4.wgsl (none where no pixel hits).
    var acc = Rgb4(vec4<f32>(0.0), vec4<f32>(0.0), vec4<f32>(0.0));
    let pix = BandPixels(d_e, s_e, u0, u1, u2, u3, u4, u5, u6, u7, kept_b, dk,
                         1.0 / max(1.0 - prm.alpha, 1e-12), mat.c0, mat.c1, mat.c2,
                         mat.use_sigmoid);
    {{ occlusion_coords }}(px, py);
    band_loop(mat, any_hit, pix, &acc);
    let sr = acc.r;
    let sg = acc.g;
    let sb = acc.b;
    if (SPREAD && !COARSE) {
        r = r + dk * sr;
        gr = gr + dk * sg;
        b = b + dk * sb;
    } else {
        r = r + sr;
        gr = gr + sg;
        b = b + sb;
    }
    // The sun (after the targets' band loop, so that none of it is live there).
    let sun = {{ sun_pixels }}(px, py, gb, hit);
    let lit = {{ sun_surface }}(mat, any_hit, d_s, s, sun.lit, sun.caustic);
    r = r + sun.r + lit.r;
    gr = gr + sun.g + lit.g;
    b = b + sun.b + lit.b;
    if (COARSE && NODES > 0u) {
        // The blocks' mean node images, value q = 3 n + c in slot q / 4.
        var s0: array<vec4<f32>, SLOTS>;
        var s1: array<vec4<f32>, SLOTS>;
        for (var n = 0u; n < NODES; n++) {
            let a = node_acc[n];
            let v0 = 0.5 * vec3<f32>(a.r.x + a.r.y, a.g.x + a.g.y, a.b.x + a.b.y);
            let v1 = 0.5 * vec3<f32>(a.r.z + a.r.w, a.g.z + a.g.w, a.b.z + a.b.w);
            for (var c = 0u; c < 3u; c++) {
                let q = 3u * n + c;
                s0[q / 4u][q % 4u] = v0[c];
                s1[q / 4u][q % 4u] = v1[c];
            }
        }
        for (var m = 0u; m < SLOTS; m++) {
            let x = m * prm.coarse_size.x;
            textureStore(cone_out, vec2<u32>(x + cb0, row), s0[m]);
            if (cb0 + 1u < prm.coarse_size.x) {
                textureStore(cone_out, vec2<u32>(x + cb0 + 1u, row), s1[m]);
            }
        }
        return;
    }
    if (COARSE) {
        // The blocks' mean cone terms: the pyramid's start level.
        textureStore(cone_out, vec2<u32>(cb0, row),
                     vec4<f32>(0.5 * (r.x + r.y), 0.5 * (gr.x + gr.y), 0.5 * (b.x + b.y), 0.0));
        if (cb0 + 1u < prm.coarse_size.x) {
            textureStore(cone_out, vec2<u32>(cb0 + 1u, row),
                         vec4<f32>(0.5 * (r.z + r.w), 0.5 * (gr.z + gr.w), 0.5 * (b.z + b.w),
                                   0.0));
        }
        return;
    }
    if (SPREAD) {
        // The pyramid's result, one bilinear sample for the four pixels at
        // their centre: coarse index coordinates (x + 0.5) / BLOCK - 0.5 with
        // x = j0 + 1.5 (lightfield_compiled.upsample_groups; a sample per
        // pixel cost 1.5 ms more per 1280x720 frame on lavapipe).
        // With blocks under 4 pixels (small images), a sample per pixel.
        let cy = (f32(row) + 0.5) / f32(prm.block) - 0.5;
        if (GROUP_SPREAD) {
            let sp = spread_at((f32(j0) + 2.0) / f32(prm.block) - 0.5, cy);
            r = r + sp.x;
            gr = gr + sp.y;
            b = b + sp.z;
        } else {
            for (var k = 0u; k < 4u; k = k + 1u) {
                let sp = spread_at((f32(px[k]) + 0.5) / f32(prm.block) - 0.5, cy);
                r[k] = r[k] + sp.x;
                gr[k] = gr[k] + sp.y;
                b[k] = b[k] + sp.z;
            }
        }
    }
    // Marine snow over the pixels (snow_compose.wgsl; with it only in the fused display).
    let out = {{ snow_compose }}(j0, row, Rgb4(r, gr, b));
    // (display.wgsl's main with DISPLAY.)
    write_pixels(row, j0, prm.width, out.r, out.g, out.b);
}
