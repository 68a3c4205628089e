// Deferred spectral shading: G-buffer -> linear camera RGB (one invocation per pixel).
//
// Twin of aquaspec/shading.py (shade_gbuffer, float64 NumPy reference): same
// per-pixel cases (hit before the water surface / open water), same model
// functions (common.wgsl <-> aquaspec/model.py). Buffer layouts are
// documented in aquaspec/gpu/deferred.py.
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
//   table entries are loaded once per four pixels.

#include "common.wgsl"

{{ camera_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
const WRITE_RADIANCE: bool = {{ write_radiance }};

// Material index meaning "use this pixel's sigmoid coefficients" (gbuffer.PER_PIXEL).
const PER_PIXEL: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> cam: {{ camera_struct_name }};
// G-buffer: the geometry pass's render targets (normal xyz, S) and
// (sigmoid coefficient bits xyz, material index).
@group(0) @binding(1) var gb_geometry: texture_2d<f32>;
@group(0) @binding(2) var gb_material: texture_2d<u32>;
// Three vec4 per band i (aquaspec.gpu.deferred.BAND_FIELDS):
//   [3i]     c, kd, t, ms_scale = b E0 / (4 pi) exp(-Kd d_o)
//   [3i + 1] w_r, w_g, w_b, e0_over_pi = E0 / pi
//   [3i + 2] be0 = b E0 / (4 pi), base = -Kd d_o, e0_window = E0 n^2 / pi, 0
@group(0) @binding(4) var<uniform> band_table: array<vec4<f32>, {{ band_table_len }}>;
@group(0) @binding(5) var<storage, read> material_bands: array<f32>;
@group(0) @binding(6) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> radiance_out: array<f32>;
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;

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

// Each invocation shades four horizontally adjacent pixels, as vec4 lanes:
// the per-band loads are shared by four pixels, and they were the larger
// part of the band loop's cost.
@compute @workgroup_size({{ workgroup_x }}, {{ workgroup_y }})
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let j0 = 4u * gid.x;
    if (j0 >= cam.width || gid.y >= cam.height) {
        return;
    }
    let row_start = gid.y * cam.width;
    let v_y = ray_direction_y(j0, gid.y);
    let depth_o = -cam.position.y;

    var s_gb: vec4<f32>;
    var n_y: vec4<f32>;
    var material: vec4<u32>;
    var sig: array<vec3<u32>, 4>;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let xy = vec2<u32>(min(j0 + k, cam.width - 1u), gid.y);
        let geo = textureLoad(gb_geometry, xy, 0);
        let mat = textureLoad(gb_material, xy, 0);
        s_gb[k] = geo.w;
        n_y[k] = geo.y;
        material[k] = mat.w;
        sig[k] = mat.xyz;
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
    let surface_depth = select(vec4<f32>(0.0), -(cam.position.y + s * v_y), hit);
    let g = select(vec4<f32>(0.0), ambient_factor(cam.ambient_model, n_y), hit);
    let use_sigmoid = hit & (material == vec4<u32>(PER_PIXEL));
    let use_material = hit & !use_sigmoid & (material < vec4<u32>(cam.n_materials));
    var c0 = vec4<f32>(0.0);
    var c1 = vec4<f32>(0.0);
    var c2 = vec4<f32>(0.0);
    var bad = 0u;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let valid = j0 + k < cam.width;
        if (valid && use_sigmoid[k]) {
            let c = bitcast<vec3<f32>>(sig[k]);
            c0[k] = c.x;
            c1[k] = c.y;
            c2[k] = c.z;
        }
        if (valid && hit[k] && !use_sigmoid[k] && !use_material[k]) {
            bad = bad + 1u;
        }
    }
    if (bad > 0u) {
        // Reported to the host, which raises; those pixels get rho = 0.
        atomicAdd(&status[0], bad);
    }
    let in_window = !hit & s_finite & (v_y > vec4<f32>(cam.snell_cos));
    // Row of each pixel's material in material_bands (row 0 where unused:
    // it exists, and the select below drops it).
    let mrow = select(vec4<u32>(0u), material * N_BANDS, use_material);

    var r = vec4<f32>(0.0);
    var gr = vec4<f32>(0.0);
    var b = vec4<f32>(0.0);
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        let q0 = band_table[3u * i];
        let q1 = band_table[3u * i + 1u];
        let q2 = band_table[3u * i + 2u];
        let c = q0.x;
        let kd = q0.y;
        let l_ms = l_ms_seeds(c - kd * v_y, s, s_finite, q0.w, q2.x, q2.y);
        let mrho = vec4<f32>(material_bands[mrow.x + i], material_bands[mrow.y + i],
                             material_bands[mrow.z + i], material_bands[mrow.w + i]);
        let rho = select(select(vec4<f32>(0.0), mrho, use_material),
                         sigmoid_reflectance(c0, c1, c2, q0.z), use_sigmoid);
        let l_surf = select(
            surface_from_below(q2.z, in_window),
            lambertian_radiance(rho, ambient_irradiance_over_pi(q1.w, kd, surface_depth, g)),
            hit);
        let tr = transmittance(c, s, s_finite);
        let l = select(l_ms, tr * l_surf + l_ms, tr > vec4<f32>(0.0));
        r = r + l * q1.x;
        gr = gr + l * q1.y;
        b = b + l * q1.z;
        if (WRITE_RADIANCE) {
            for (var k = 0u; k < 4u; k = k + 1u) {
                if (j0 + k < cam.width) {
                    radiance_out[(row_start + j0 + k) * N_BANDS + i] = l[k];
                }
            }
        }
    }
    for (var k = 0u; k < 4u; k = k + 1u) {
        if (j0 + k < cam.width) {
            rgb_out[row_start + j0 + k] = vec4<f32>(r[k], gr[k], b[k], 1.0);
        }
    }
}
