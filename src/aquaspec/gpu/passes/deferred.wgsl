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

#include "shading4.wgsl"

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

@group(0) @binding(0) var<uniform> cam: {{ camera_struct_name }};
// (Bindings 1 and 2, the G-buffer, and 6, 8, 9, 10, the outputs: shading4.wgsl.)
// Three vec4 per band i (aquaspec.gpu.passes.deferred.BAND_FIELDS):
//   [3i]     c, kd, t, ms_scale = b E0 / (4 pi) exp(-Kd d_o)
//   [3i + 1] w_r, w_g, w_b, e0_over_pi = E0 / pi
//   [3i + 2] be0 = b E0 / (4 pi), base = -Kd d_o, e0_window = E0 n^2 / pi, 0
@group(0) @binding(4) var<uniform> band_table: array<vec4<f32>, {{ band_table_len }}>;
// (Bindings 3 and 5: the material table, materials.wgsl.)
@group(0) @binding(7) var<storage, read_write> radiance_out: array<f32>;
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

// What the band loop (shading4.wgsl) needs of the four pixels (vec4 lanes).
struct BandPixels {
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
// (No per-group data: shading4.wgsl's band_loop hook does nothing.)
fn band_group_start(q: u32) {
}

fn shade_band(i: u32, rho_m: vec4<f32>, p: BandPixels, acc: ptr<function, Rgb4>) {
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
    // Rows of workgroups interleaved, top half / bottom half (shading4.wgsl).
    let row = interleaved_row(wg.y, lid.y, nwg.y);
    let j0 = 4u * (wg.x * {{ workgroup_x }}u + lid.x);
    if (j0 >= cam.width || row >= cam.height) {
        return;
    }
    let row_start = row * cam.width;
    let v_y = ray_direction_y(j0, row);
    let depth_o = -cam.position.y;

    let cols = vec4<u32>(j0) + vec4<u32>(0u, 1u, 2u, 3u);
    let px = min(cols, vec4<u32>(cam.width - 1u));
    let gb = load_gbuffer(px, vec4<u32>(row));
    // A hit counts only if the ray reaches it before the water surface.
    let hit = hit_before_surface(gb.s, v_y, depth_o);
    let rl = ray_length(gb.s, hit, depth_o, v_y);
    let s = rl.s;
    let s_finite = rl.finite;

    // Per pixel, outside the band loop: the surface's depth and ambient
    // factor g(n_y), its reflectance source, and Snell's window.
    // Depth where the ray ends (the surface point, or 0 at the water surface).
    let end_depth = max(depth_o - s * v_y, vec4<f32>(0.0));
    let g = select(vec4<f32>(0.0), ambient_factor(cam.ambient_model, gb.n_y), hit);
    let mat = pixel_materials(gb, hit, cam.n_materials, cols < vec4<u32>(cam.width));
    let in_window = !hit & s_finite & (v_y > vec4<f32>(cam.snell_cos));

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
    let pix = BandPixels(s, s_finite, v_y, end_depth, g, hit, in_window, mat.use_sigmoid, mat.c0,
                         mat.c1, mat.c2, row_start + j0, min(cam.width - j0, 4u));
    band_loop(mat, !from_table, pix, &acc);
    // (display.wgsl's main with DISPLAY.)
    write_pixels(row, j0, cam.width, acc.r, acc.g, acc.b);
}
