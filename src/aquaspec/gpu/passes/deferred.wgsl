// Deferred spectral shading: G-buffer -> linear camera RGB, or with DISPLAY
// straight to display RGBA8 (one invocation per four pixels).
//
// Twin of aquaspec.shading.shade (shade_gbuffer, float64 NumPy reference): same
// per-pixel cases (hit before the water surface / open water), same model
// functions (common.wgsl <-> aquaspec.transport.monzon2022). Buffer layouts are
// documented in aquaspec.gpu.passes.deferred and aquaspec.gpu.gbuffer.
//
// Written for lavapipe (SIMD over 8 pixels on the CPU), measured there:
// - everything that does not depend on the pixel is computed per band on the
//   host in float64 (band_table: exp(-Kd d_o), b E0 / (4 pi), E0 / pi, ...)
//   and everything that does not depend on the band once per pixel, outside
//   the band loop;
// - the band table is a uniform array of vec4 and the band count a
//   compile-time constant: per-band scalar loads from a storage buffer were
//   half of the pass's time;
// - the cases are selects, not branches, where both sides are cheap: SIMD
//   lanes run both sides of a divergent branch anyway;
// - one invocation shades four adjacent pixels (vec4 lanes), so each band's
//   table entries are loaded once per four pixels;
// - the material table is read one vec4 (four bands) per pixel at a time;
//   from GROUPED_MIN_BANDS bands (materials.wgsl) the band loop does four
//   bands per iteration (1280x720 frames with 16 / 32 bands 2-3 / 7-8 ms
//   faster than a band per iteration), below it a loop over each vec4's
//   bands sits in a loop over the vec4s (1-1.4 ms faster with 3 or 8).

#include "common.wgsl"
#include "tonemap.wgsl"
#include "materials.wgsl"

{{ camera_struct }}

{{ display_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
const WRITE_RADIANCE: bool = {{ write_radiance }};
// DISPLAY: also apply the display transform (display.wgsl) and write packed
// RGBA8 instead of linear RGB, saving the display pass and the linear
// image's round trip through memory; TONEMAP is its tone map id.
const DISPLAY: bool = {{ display }};
const TONEMAP: u32 = {{ tonemap_id }}u;
// Whether the G-buffer has per-pixel (sigmoid) materials: when false the
// sigmoid texture is not read and no sigmoid is evaluated.
const PER_PIXEL_MATERIALS: bool = {{ per_pixel }};

// Material index meaning "use this pixel's sigmoid coefficients" (gbuffer.PER_PIXEL).
const PER_PIXEL: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> cam: {{ camera_struct_name }};
// G-buffer: the geometry pass's render targets (aquaspec.gpu.gbuffer):
// surface (S bits, n_y bits, octahedral normal, material index) and sigmoid
// (c0, c1, c2, unused).
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
// Three vec4 per band i (aquaspec.gpu.passes.deferred.BAND_FIELDS):
//   [3i]     c, kd, t, ms_scale = b E0 / (4 pi) exp(-Kd d_o)
//   [3i + 1] w_r, w_g, w_b, e0_over_pi = E0 / pi
//   [3i + 2] be0 = b E0 / (4 pi), base = -Kd d_o, e0_window = E0 n^2 / pi, 0
@group(0) @binding(4) var<uniform> band_table: array<vec4<f32>, {{ band_table_len }}>;
// (Bindings 3 and 5: the material table, materials.wgsl.)
@group(0) @binding(6) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> radiance_out: array<f32>;
// status[0]: pixels with a material index out of range; with DISPLAY,
// status[2]: pixels with a non-finite value (written black) and status[3]
// the smallest such pixel index.
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(9) var<uniform> disp: {{ display_struct_name }};
@group(0) @binding(10) var<storage, read_write> rgba_out: array<u32>;
// Open-water table (aquaspec.gpu.passes.deferred.open_water_table): camera RGB of a
// ray that hits nothing, two vec4 per sample of v_y over [-1, 1]: [2j] the
// scattering term, [2j + 1] the sky through Snell's window (added inside it).
@group(0) @binding(11) var<storage, read> open_table: array<vec4<f32>>;
const OPEN_TABLE_SIZE: u32 = {{ open_table_size }}u;

// Camera.ray_directions: the up component of the unit ray through the pixel
// centres (j + 0.5, i + 0.5) of four pixels j = j0 .. j0 + 3 in row i.
fn ray_direction_y(j0: u32, i: u32) -> vec4<f32> {
    let x = (vec4<f32>(f32(j0)) + vec4<f32>(0.5, 1.5, 2.5, 3.5) - cam.cx) / cam.fx;
    let y = (f32(i) + 0.5 - cam.cy) / cam.fy;
    let dx = cam.right.x * x + (cam.forward.x - cam.up.x * y);
    let dy = cam.right.y * x + (cam.forward.y - cam.up.y * y);
    let dz = cam.right.z * x + (cam.forward.z - cam.up.z * y);
    return dy * inverseSqrt(dx * dx + dy * dy + dz * dz);
}

// What the band loop needs of the four pixels (vec4 lanes).
struct SeedsPixels {
    s: vec4<f32>,
    s_finite: vec4<bool>,
    v_y: vec4<f32>,
    end_depth: vec4<f32>,
    g: vec4<f32>,
    hit: vec4<bool>,
    in_window: vec4<bool>,
    use_sigmoid: vec4<bool>,
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
    // The first pixel's index and how many of the four are in the image.
    first: u32,
    n_valid: u32,
}

// Band i of the four pixels (material reflectance rho_m, 0 where none) added
// to acc, and with WRITE_RADIANCE written out.
fn shade_band(i: u32, rho_m: vec4<f32>, p: SeedsPixels, acc: ptr<function, Rgb4>) {
    let q0 = band_table[3u * i];
    let q1 = band_table[3u * i + 1u];
    let q2 = band_table[3u * i + 2u];
    let c = q0.x;
    let kd = q0.y;
    // The two exponentials of the band: transmittance exp(-c S) and the
    // downwelling attenuation exp(-Kd d_end) where the ray ends; the
    // seeds' term and the ambient light are written with them.
    let tr = transmittance(c, p.s, p.s_finite);
    let e_end = exp(-kd * p.end_depth);
    let l_ms = l_ms_seeds_shared(c - kd * p.v_y, p.s, p.s_finite, q0.w, q2.x, tr * e_end);
    var rho = rho_m;
    if (PER_PIXEL_MATERIALS) {
        rho = select(rho, sigmoid_reflectance(p.c0, p.c1, p.c2, q0.z), p.use_sigmoid);
    }
    let l_surf = select(surface_from_below(q2.z, p.in_window),
                        lambertian_radiance(rho, q1.w * e_end * p.g), p.hit);
    let l = select(l_ms, tr * l_surf + l_ms, tr > vec4<f32>(0.0));
    (*acc).r = (*acc).r + l * q1.x;
    (*acc).g = (*acc).g + l * q1.y;
    (*acc).b = (*acc).b + l * q1.z;
    if (WRITE_RADIANCE) {
        for (var k = 0u; k < p.n_valid; k = k + 1u) {
            radiance_out[(p.first + k) * N_BANDS + i] = l[k];
        }
    }
}

// Each invocation shades four horizontally adjacent pixels, as vec4 lanes:
// the per-band loads are shared by four pixels, and they were the larger
// part of the band loop's cost.
@compute @workgroup_size({{ workgroup_x }}, {{ workgroup_y }})
fn main(@builtin(workgroup_id) wg: vec3<u32>, @builtin(local_invocation_id) lid: vec3<u32>,
        @builtin(num_workgroups) nwg: vec3<u32>) {
    // Rows of workgroups are interleaved, top half / bottom half: lavapipe
    // gives each CPU thread a contiguous part of the dispatch, and the two
    // halves of a typical frame (water above, seabed below) cost differently
    // once open water takes the table path below.
    let half = (nwg.y + 1u) / 2u;
    let block = select(half + wg.y / 2u, wg.y / 2u, wg.y % 2u == 0u);
    let row = block * {{ workgroup_y }}u + lid.y;
    let j0 = 4u * (wg.x * {{ workgroup_x }}u + lid.x);
    if (j0 >= cam.width || row >= cam.height) {
        return;
    }
    let row_start = row * cam.width;
    let v_y = ray_direction_y(j0, row);
    let depth_o = -cam.position.y;

    var s_gb: vec4<f32>;
    var n_y: vec4<f32>;
    var material: vec4<u32>;
    var sig: array<vec3<f32>, 4>;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let xy = vec2<u32>(min(j0 + k, cam.width - 1u), row);
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
    let hit = (s_gb >= vec4<f32>(0.0))
        & (!up | (s_gb <= depth_o / select(vec4<f32>(1.0), v_y, up)));
    let rl = ray_length(s_gb, hit, depth_o, v_y);
    let s = rl.s;
    let s_finite = rl.finite;

    // Per pixel, outside the band loop: the surface's depth and ambient
    // factor g(n_y), its reflectance source, and Snell's window.
    // Depth where the ray ends (the surface point, or 0 at the water surface).
    let end_depth = max(depth_o - s * v_y, vec4<f32>(0.0));
    let g = select(vec4<f32>(0.0), ambient_factor(cam.ambient_model, n_y), hit);
    let use_sigmoid = hit & (material == vec4<u32>(PER_PIXEL)) & vec4<bool>(PER_PIXEL_MATERIALS);
    let use_material = hit & !use_sigmoid & (material < vec4<u32>(cam.n_materials));
    var c0 = vec4<f32>(0.0);
    var c1 = vec4<f32>(0.0);
    var c2 = vec4<f32>(0.0);
    var bad = 0u;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let valid = j0 + k < cam.width;
        if (valid && use_sigmoid[k]) {
            let c = sig[k];
            c0[k] = c.x;
            c1[k] = c.y;
            c2[k] = c.z;
        }
        if (valid && hit[k] && !use_sigmoid[k] && !use_material[k]) {
            // Out-of-range material index (or PER_PIXEL in a G-buffer declared
            // without per-pixel materials).
            bad = bad + 1u;
        }
    }
    if (bad > 0u) {
        // Reported to the host, which raises; those pixels get rho = 0.
        atomicAdd(&status[0], bad);
    }
    let in_window = !hit & s_finite & (v_y > vec4<f32>(cam.snell_cos));
    // Each pixel's first vec4 in the material table (0 where unused: it
    // exists, and material_group zeroes it).
    let mrow = select(vec4<u32>(0u), material * MATERIAL_GROUPS, use_material);

    var r = vec4<f32>(0.0);
    var gr = vec4<f32>(0.0);
    var b = vec4<f32>(0.0);
    // Where all four pixels see open water their colour depends on v_y alone:
    // it comes from the open-water table and the band loop is skipped (a
    // per-invocation trip count: lavapipe leaves a loop when no SIMD lane
    // has iterations left, which a branch around it would not do).
    let from_table = !any(hit) && cam.open_table != 0u && !WRITE_RADIANCE;
    // (A loop rather than a branch for the same reason: lavapipe runs a
    // branch's body for every lane, masked.)
    let n_table = select(0u, 4u, from_table);
    {
        for (var k = 0u; k < n_table; k = k + 1u) {
            let x = (clamp(v_y[k], -1.0, 1.0) + 1.0) * (0.5 * f32(OPEN_TABLE_SIZE - 1u));
            let j = min(u32(x), OPEN_TABLE_SIZE - 2u);
            let f = x - f32(j);
            var rgb = mix(open_table[2u * j], open_table[2u * j + 2u], f);
            if (in_window[k]) {
                rgb = rgb + mix(open_table[2u * j + 1u], open_table[2u * j + 3u], f);
            }
            r[k] = rgb.x;
            gr[k] = rgb.y;
            b[k] = rgb.z;
        }
    }
    // (The table's loop indexes r, gr, b per pixel: the band loop's sums
    // start from them in a variable of their own, which stays in registers.)
    var acc = Rgb4(r, gr, b);
    let px = SeedsPixels(s, s_finite, v_y, end_depth, g, hit, in_window, use_sigmoid, c0, c1, c2,
                         row_start + j0, min(cam.width - j0, 4u));
    // One material vec4 per pixel for four bands (aquaspec.gpu.materials):
    // below GROUPED_MIN_BANDS nested loops, from it four band bodies per
    // iteration, then N_BANDS % 4.
    if (!GROUPED_BANDS) {
        // A material vec4 per outer iteration, a band per inner one (trip
        // counts per invocation: the loops stay loops, as materials.wgsl says).
        if (N_BANDS < 4u) {
            // (One vec4, read outside any loop: with 3 bands the outer loop's
            // single iteration cost 1.1-1.3 ms per 1280x720 frame.)
            let m = material_group(mrow, 0u, use_material);
            let n_in = select(N_BANDS, 0u, from_table);
            for (var j = 0u; j < n_in; j = j + 1u) {
                shade_band(j, group_band(m, j), px, &acc);
            }
        } else {
            let n_outer = select(MATERIAL_GROUPS, 0u, from_table);
            for (var q = 0u; q < n_outer; q = q + 1u) {
                let m = material_group(mrow, q, use_material);
                let n_in = min(4u, N_BANDS - 4u * q);
                for (var j = 0u; j < n_in; j = j + 1u) {
                    shade_band(4u * q + j, group_band(m, j), px, &acc);
                }
            }
        }
    }
    let n_groups = select(0u, select(FULL_GROUPS, 0u, from_table), GROUPED_BANDS);
    for (var q = 0u; q < n_groups; q = q + 1u) {
        let m = material_group(mrow, q, use_material);
        shade_band(4u * q, group_band(m, 0u), px, &acc);
        shade_band(4u * q + 1u, group_band(m, 1u), px, &acc);
        shade_band(4u * q + 2u, group_band(m, 2u), px, &acc);
        shade_band(4u * q + 3u, group_band(m, 3u), px, &acc);
    }
    let n_rest = select(select(0u, 1u, GROUPED_BANDS && REST_BANDS > 0u), 0u, from_table);
    for (var t = 0u; t < n_rest; t = t + 1u) {
        let m = material_group(mrow, FULL_GROUPS, use_material);
        let i = 4u * FULL_GROUPS;
        shade_band(i, group_band(m, 0u), px, &acc);
        if (REST_BANDS > 1u) {
            shade_band(i + 1u, group_band(m, 1u), px, &acc);
        }
        if (REST_BANDS > 2u) {
            shade_band(i + 2u, group_band(m, 2u), px, &acc);
        }
    }
    r = acc.r;
    gr = acc.g;
    b = acc.b;
    if (DISPLAY) {
        // display.wgsl's main for the four pixels; non-finite ones (or ones
        // that overflow after exposure) are written black and reported once
        // per invocation (atomics in a per-pixel branch cost a millisecond
        // per 1280x720 frame on lavapipe, masked for every lane).
        var n_bad = 0u;
        var first_bad = 0xffffffffu;
        for (var k = 0u; k < 4u; k = k + 1u) {
            if (j0 + k < cam.width) {
                let p = row_start + j0 + k;
                let lin = vec3<f32>(r[k], gr[k], b[k]);
                let c = max(lin, vec3<f32>(0.0));
                let x = vec3<f32>(dot(disp.m0, c), dot(disp.m1, c), dot(disp.m2, c));
                let bad = any_non_finite(lin) || any_non_finite(x);
                n_bad = n_bad + select(0u, 1u, bad);
                first_bad = select(first_bad, min(first_bad, p), bad);
                rgba_out[p] = select(display_rgba8(x), 0xff000000u, bad);
            }
        }
        if (n_bad > 0u) {
            atomicAdd(&status[2], n_bad);
            atomicMin(&status[3], first_bad);
        }
    } else {
        for (var k = 0u; k < 4u; k = k + 1u) {
            if (j0 + k < cam.width) {
                rgb_out[row_start + j0 + k] = vec4<f32>(r[k], gr[k], b[k], 1.0);
            }
        }
    }
}
