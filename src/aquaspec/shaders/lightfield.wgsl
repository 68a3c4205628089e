// Deferred spectral shading with the light-field multiple-scattering model
// (ms_model = "lightfield"): G-buffer -> linear camera RGB, or with DISPLAY
// straight to display RGBA8; one invocation per four horizontally adjacent
// pixels (vec4 lanes, pixel k in component k).
//
// Twin of aquaspec/lightfield.py (lightfield_pixel_radiance, _two_point,
// bilinear; float64 NumPy reference) as used by aquaspec/shading.py
// (shade_gbuffer with light-field tables). Deep water only (no seabed
// boundary in the tables). Layouts: aquaspec/gpu/lightfield_pass.py (its
// module docstring); G-buffer textures: aquaspec/gpu/deferred.py.
//
// The radiance of a pixel (lightfield_pixel_radiance) is, per band,
//   L = L_bg(d_o, v) + T' (L_surf - R(d_S, v) - u_S L_top)   (ray ends at S)
//   L = L_bg(d_o, v)                                          (open water down)
// with the open-water field L_bg(d, v) = R(d, v) + u(d) L_top,
// R(d, v) = F(d, v) b E0 / (4 pi) ms_path_integral(c, kappa_1, d, v, inf),
// u(d) = exp(-c d / v) (up rays; 0 down), L_top = sky E0 inside Snell's
// window (0 outside), T' = exp(-(c - f b) S) (f: forward-cone fraction).
// - The first term depends on the pixel only through v (the camera depth
//   d_o is fixed): its sum over bands in camera RGB comes from the host's
//   float64 open-water table (lightfield_pass.open_water_table), sampled
//   along the table's own direction axis. Open-water pixels (up rays end at
//   the surface, where R(0, v) = 0 and u = 1, so their second term is 0) need
//   nothing else: four-pixel groups without a hit skip the band loop.
// - Hits: u_S T' = exp(-c d_o / v) exp(f b S), so without a forward cone
//   (CONE false) the window terms cancel exactly and are left out.
// - T' R(d_S) is written with the exponentials of the whole product,
//   scale (exp(lnF - c' S - kappa_1 d_S) - exp(lnF - c' S - c d_S / v)) / k,
//   k = c - kappa_1 v, c' = c - f b (the second term for up rays only; both
//   exponents stay small, whatever the sign of k), and the series of
//   (1 - e^-x) / x where |x| = |k d_S / v| < 0.1 would cancel in f32.
//
// Written for lavapipe (SIMD over 8 invocations on the CPU), as
// deferred.wgsl (see its header): per-band constants in a uniform array
// with a compile-time band count (and table sizes), per-pixel work (table
// coordinates: one arccosine per direction, one sqrt per depth) outside the
// band loop, four bands per table sample, selects instead of branches, and
// a per-invocation trip count to skip the band loop. Measured there
// (1280x720, per pixel and frame): a texel fetch about 0.9 ms, a filtered
// sample 1.5 ms, a storage load 0.4 ms, an exp 0.06 ms.

#include "common.wgsl"
#include "tonemap.wgsl"

{{ params_struct }}

{{ display_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
// Table axes (aquaspec.lightfield.table_depths / table_cosines).
const N_DEPTH: u32 = {{ n_depth }}u;
const N_MU: u32 = {{ n_mu }}u;
// Whether any band has a forward-cone fraction f > 0.
const CONE: bool = {{ cone }};
// DISPLAY: apply the display transform (display.wgsl) and write packed
// RGBA8 instead of linear RGB; TONEMAP is its tone map id (tonemap.wgsl).
const DISPLAY: bool = {{ display }};
const TONEMAP: u32 = {{ tonemap_id }}u;
// Whether the G-buffer has per-pixel (sigmoid) materials: when false the
// sigmoid texture is not read and no sigmoid is evaluated.
const PER_PIXEL_MATERIALS: bool = {{ per_pixel }};
// Material index meaning "use this pixel's sigmoid coefficients" (gbuffer.PER_PIXEL).
const PER_PIXEL: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
// G-buffer: surface (S bits, n_y bits, octahedral normal, material index)
// and sigmoid (c0, c1, c2, unused), aquaspec.gpu.deferred.
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
// Three vec4 per band i (lightfield_pass.BAND_FIELDS, float64 on the host):
//   [3i]     c, kappa_1, c' = c - f b, scale = b E0 / (4 pi)
//   [3i + 1] w_r, w_g, w_b, E0 / pi
//   [3i + 2] t (sigmoid band centre), L_top = sky radiance per E0 * E0,
//            f b (the forward cone's share of b), 0
@group(0) @binding(4) var<uniform> band_table: array<vec4<f32>, {{ band_table_len }}>;
// Material band reflectances, row-major (material, band), as deferred.wgsl
// (a storage load per band costs half a texel fetch on lavapipe).
@group(0) @binding(5) var<storage, read> material_bands: array<f32>;
@group(0) @binding(6) var<storage, read_write> rgb_out: array<vec4<f32>>;
// status[0]: pixels with a material index out of range; with DISPLAY,
// status[2]: pixels with a non-finite value (written black) and status[3]
// the smallest such pixel index.
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(9) var<uniform> disp: {{ display_struct_name }};
@group(0) @binding(10) var<storage, read_write> rgba_out: array<u32>;
// Open-water table, sample m of the direction coordinate y = m / table_sub
// in texels (2 (m % OPEN_ROW) + h, m / OPEN_ROW): h = 0 camera RGB of
// R(d_o, v), h = 1 of u(d_o) L_top (added inside Snell's window). A texture
// for the same reason as the tables below.
@group(0) @binding(11) var open_table: texture_2d<f32>;
const OPEN_ROW: u32 = {{ open_row }}u;

fn open_texel(m: u32, h: u32) -> vec4<f32> {
    return textureLoad(open_table, vec2<u32>(2u * (m % OPEN_ROW) + h, m / OPEN_ROW), 0);
}
// ln F and E / E0 on the tables' nodes, four bands per texel: layer g,
// texel (direction j, depth i) holds bands 4g .. 4g + 3 (padded with 0).
// With FILTER one filtered sample (the sampler's bilinear interpolation)
// gives four bands; lavapipe takes about as long for it as for 1.7 texel
// fetches, and a fetch per band and pixel was most of the pass. Without
// FILTER (no float32-filterable on the device) the same bilinear
// interpolation from four fetches.
@group(0) @binding(12) var log_prefactor: texture_2d_array<f32>;
@group(0) @binding(13) var irradiance: texture_2d_array<f32>;
@group(0) @binding(14) var table_sampler: sampler;
const FILTER: bool = {{ filter }};
// SPREAD: the forward cone's term goes to cone_out (camera RGB), the rest to
// rgb_out, for the pyramid that spreads it over the image
// (aquaspec/gpu/conespread_pass.py); DISPLAY is then false here.
const SPREAD: bool = {{ spread }};
@group(0) @binding(15) var cone_out: texture_storage_2d<rgba32float, write>;
const N_GROUPS: u32 = (N_BANDS + 3u) / 4u;

// Camera.ray_directions: the up component of the unit ray through the pixel
// centres (j + 0.5, i + 0.5) of four pixels j = j0 .. j0 + 3 in row i.
fn ray_direction_y(j0: u32, i: u32) -> vec4<f32> {
    let x = (vec4<f32>(f32(j0)) + vec4<f32>(0.5, 1.5, 2.5, 3.5) - prm.cx) / prm.fx;
    let y = (f32(i) + 0.5 - prm.cy) / prm.fy;
    let dx = prm.right.x * x + (prm.forward.x - prm.up.x * y);
    let dy = prm.right.y * x + (prm.forward.y - prm.up.y * y);
    let dz = prm.right.z * x + (prm.forward.z - prm.up.z * y);
    return dy * inverseSqrt(dx * dx + dy * dy + dz * dz);
}

// arcsin of |z| <= 0.5 (Cephes asinf polynomial, about 1 ulp).
fn asin_small(z: vec4<f32>) -> vec4<f32> {
    let q = z * z;
    return z + z * q * ((((4.2163199048e-2 * q + 2.4181311049e-2) * q + 4.5470025998e-2) * q
        + 7.4953002686e-2) * q + 1.6666752422e-1);
}

// lightfield.bilinear's direction coordinate y = (1 - acos(v) / pi) (N_MU - 1).
// Not WGSL's acos: lavapipe's is off by up to 1.6e-4 rad (3e-3 of a table
// cell with 65 directions), visible against the float64 reference.
// acos(v) = pi / 2 - asin(v) for |v| <= 1/2, else 2 asin(sqrt((1 - |v|) / 2))
// (pi minus that for v < 0).
fn cos_coord(v: vec4<f32>) -> vec4<f32> {
    let a = min(abs(v), vec4<f32>(1.0));
    let far = 2.0 * asin_small(sqrt(0.5 - 0.5 * a));
    let acos_v = select(0.5 * PI - asin_small(v), select(far, PI - far, v < vec4<f32>(0.0)),
                        a > vec4<f32>(0.5));
    return (1.0 - acos_v / PI) * f32(N_MU - 1u);
}

// lightfield.bilinear's depth coordinate x = sqrt(d / D) (N_DEPTH - 1).
fn depth_coord(depth: vec4<f32>) -> vec4<f32> {
    return sqrt(clamp(depth, vec4<f32>(0.0), vec4<f32>(prm.max_depth)) / prm.max_depth)
        * f32(N_DEPTH - 1u);
}

// lightfield.bilinear of four bands (layer g) at table coordinates (y, x):
// direction y in [0, N_MU - 1], depth x in [0, N_DEPTH - 1] (texel centres
// at (k + 0.5) / N in the sampler's coordinates).
fn bilinear4(table: texture_2d_array<f32>, y: f32, x: f32, g: u32) -> vec4<f32> {
    if (FILTER) {
        let uv = vec2<f32>((y + 0.5) / f32(N_MU), (x + 0.5) / f32(N_DEPTH));
        return textureSampleLevel(table, table_sampler, uv, g, 0.0);
    }
    let j = min(u32(max(y, 0.0)), N_MU - 2u);
    let i = min(u32(max(x, 0.0)), N_DEPTH - 2u);
    let fy = y - f32(j);
    let fx = x - f32(i);
    let lo = mix(textureLoad(table, vec2<u32>(j, i), g, 0),
                 textureLoad(table, vec2<u32>(j + 1u, i), g, 0), fy);
    let hi = mix(textureLoad(table, vec2<u32>(j, i + 1u), g, 0),
                 textureLoad(table, vec2<u32>(j + 1u, i + 1u), g, 0), fy);
    return mix(lo, hi, fx);
}

@compute @workgroup_size({{ workgroup_x }}, {{ workgroup_y }})
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    // Rows of workgroups interleaved, top half / bottom half, as in
    // deferred.wgsl: the two lavapipe threads each get open water and hits.
    let half = (nwg.y + 1u) / 2u;
    let block = select(half + wg.y / 2u, wg.y / 2u, wg.y % 2u == 0u);
    let row = block * {{ workgroup_y }}u + lid.y;
    let j0 = 4u * (wg.x * {{ workgroup_x }}u + lid.x);
    if (j0 >= prm.width || row >= prm.height) {
        return;
    }
    let row_start = row * prm.width;
    let v_y = ray_direction_y(j0, row);
    let d_o = prm.depth_o;

    var s_gb: vec4<f32>;
    var n_y: vec4<f32>;
    var material: vec4<u32>;
    var sig: array<vec3<f32>, 4>;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let xy = vec2<u32>(min(j0 + k, prm.width - 1u), row);
        let surf = textureLoad(gb_surface, xy, 0);
        s_gb[k] = bitcast<f32>(surf.x);
        n_y[k] = bitcast<f32>(surf.y);
        material[k] = surf.w;
        if (PER_PIXEL_MATERIALS) {
            sig[k] = textureLoad(gb_sigmoid, xy, 0).xyz;
        }
    }
    // A hit counts only if the ray reaches it before the water surface.
    let up = v_y > vec4<f32>(0.0);
    let v_safe = select(vec4<f32>(1.0), v_y, up);
    let hit = (s_gb >= vec4<f32>(0.0)) & (!up | (s_gb <= d_o / v_safe));
    let s = select(vec4<f32>(0.0), s_gb, hit);
    // Depth of the hit (the camera's depth for open water: unused there).
    let d_s = max(d_o - s * v_y, vec4<f32>(0.0));
    let y = cos_coord(v_y);
    let in_window = v_y > vec4<f32>(prm.window_cos);

    // Open-water field at the camera, L_bg(d_o, v), from the table.
    var r: vec4<f32>;
    var gr: vec4<f32>;
    var b: vec4<f32>;
    let add_window = in_window & (!hit | vec4<bool>(CONE));
    let x_table = y * f32(prm.table_sub);
    let m_table = min(vec4<u32>(x_table), vec4<u32>(prm.table_last - 1u));
    let f_table = x_table - vec4<f32>(m_table);
    for (var k = 0u; k < 4u; k = k + 1u) {
        let m = m_table[k];
        let rgb = mix(open_texel(m, 0u), open_texel(m + 1u, 0u), f_table[k]);
        r[k] = rgb.x;
        gr[k] = rgb.y;
        b[k] = rgb.z;
    }
    // The window term (a per-invocation trip count: most groups skip it).
    let n_window = select(0u, 1u, any(add_window));
    for (var q = 0u; q < n_window; q = q + 1u) {
        for (var k = 0u; k < 4u; k = k + 1u) {
            let m = m_table[k];
            let rgb = select(vec4<f32>(0.0), mix(open_texel(m, 1u), open_texel(m + 1u, 1u),
                             f_table[k]), add_window[k]);
            r[k] = r[k] + rgb.x;
            gr[k] = gr[k] + rgb.y;
            b[k] = b[k] + rgb.z;
        }
    }

    // Materials, as deferred.wgsl.
    let use_sigmoid = hit & (material == vec4<u32>(PER_PIXEL)) & vec4<bool>(PER_PIXEL_MATERIALS);
    let use_material = hit & !use_sigmoid & (material < vec4<u32>(prm.n_materials));
    var c0 = vec4<f32>(0.0);
    var c1 = vec4<f32>(0.0);
    var c2 = vec4<f32>(0.0);
    var bad = 0u;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let valid = j0 + k < prm.width;
        if (valid && use_sigmoid[k]) {
            let c = sig[k];
            c0[k] = c.x;
            c1[k] = c.y;
            c2[k] = c.z;
        }
        if (valid && hit[k] && !use_sigmoid[k] && !use_material[k]) {
            // Out-of-range material index (or PER_PIXEL in a G-buffer
            // declared without per-pixel materials): reported, rho = 0.
            bad = bad + 1u;
        }
    }
    if (bad > 0u) {
        atomicAdd(&status[0], bad);
    }
    let mrow = select(vec4<u32>(0u), material * N_BANDS, use_material);

    // Per pixel, outside the band loop: the table coordinates of R(d_S, v)
    // and of E(d_S, n_y), and the ray's length from the hit to the surface (up).
    let x_s = depth_coord(d_s);
    let y_n = cos_coord(n_y);
    let len_up = d_s / v_safe;
    let cone_window = hit & in_window & vec4<bool>(CONE);

    // Only hits have a band loop (a per-invocation trip count: lavapipe
    // leaves a loop when no SIMD lane has iterations left), four bands per
    // step: one table sample per pixel and table gives all four.
    var cr = vec4<f32>(0.0);
    var cg = vec4<f32>(0.0);
    var cb = vec4<f32>(0.0);
    let n_iter = select(0u, N_GROUPS, any(hit));
    for (var g = 0u; g < n_iter; g = g + 1u) {
        let f0 = bilinear4(log_prefactor, y[0], x_s[0], g);
        let f1 = bilinear4(log_prefactor, y[1], x_s[1], g);
        let f2 = bilinear4(log_prefactor, y[2], x_s[2], g);
        let f3 = bilinear4(log_prefactor, y[3], x_s[3], g);
        let h0 = bilinear4(irradiance, y_n[0], x_s[0], g);
        let h1 = bilinear4(irradiance, y_n[1], x_s[1], g);
        let h2 = bilinear4(irradiance, y_n[2], x_s[2], g);
        let h3 = bilinear4(irradiance, y_n[3], x_s[3], g);
        // Bands 4g .. 4g + 3 (lightfield_pass.band_steps: the same step four
        // times, written out, for the components x, y, z, w; a function
        // taking the pixel group's values as a struct cost 2-3 ms more at
        // 1280x720, n = 8).
{{ band_steps }}
    }
    if (DISPLAY) {
        // display.wgsl's main for the four pixels, as in deferred.wgsl.
        var n_bad = 0u;
        var first_bad = 0xffffffffu;
        for (var k = 0u; k < 4u; k = k + 1u) {
            if (j0 + k < prm.width) {
                let p = row_start + j0 + k;
                let lin = vec3<f32>(r[k], gr[k], b[k]);
                let c = max(lin, vec3<f32>(0.0));
                let x = vec3<f32>(dot(disp.m0, c), dot(disp.m1, c), dot(disp.m2, c));
                let bad_px = any_non_finite(lin) || any_non_finite(x);
                n_bad = n_bad + select(0u, 1u, bad_px);
                first_bad = select(first_bad, min(first_bad, p), bad_px);
                rgba_out[p] = select(display_rgba8(x), 0xff000000u, bad_px);
            }
        }
        if (n_bad > 0u) {
            atomicAdd(&status[2], n_bad);
            atomicMin(&status[3], first_bad);
        }
    } else {
        for (var k = 0u; k < 4u; k = k + 1u) {
            if (j0 + k < prm.width) {
                rgb_out[row_start + j0 + k] = vec4<f32>(r[k], gr[k], b[k], 1.0);
                if (SPREAD) {
                    textureStore(cone_out, vec2<u32>(j0 + k, row),
                                 vec4<f32>(cr[k], cg[k], cb[k], 0.0));
                }
            }
        }
    }
}
