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
//   lanes run both sides of a divergent branch anyway.

#include "common.wgsl"

{{ camera_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
const WRITE_RADIANCE: bool = {{ write_radiance }};

// Material index meaning "use this pixel's sigmoid coefficients" (gbuffer.PER_PIXEL).
const PER_PIXEL: u32 = 0xffffffffu;

@group(0) @binding(0) var<uniform> cam: {{ camera_struct_name }};
@group(0) @binding(1) var<storage, read> gb_distance: array<f32>;
@group(0) @binding(2) var<storage, read> gb_surface: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> gb_sigmoid: array<vec4<f32>>;
// Three vec4 per band i (aquaspec.gpu.deferred.BAND_FIELDS):
//   [3i]     c, kd, t, ms_scale = b E0 / (4 pi) exp(-Kd d_o)
//   [3i + 1] w_r, w_g, w_b, e0_over_pi = E0 / pi
//   [3i + 2] be0 = b E0 / (4 pi), base = -Kd d_o, e0_window = E0 n^2 / pi, 0
@group(0) @binding(4) var<uniform> band_table: array<vec4<f32>, {{ band_table_len }}>;
@group(0) @binding(5) var<storage, read> material_bands: array<f32>;
@group(0) @binding(6) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> radiance_out: array<f32>;
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;

// Camera.ray_directions: through the pixel centre (j + 0.5, i + 0.5).
fn ray_direction(j: u32, i: u32) -> vec3<f32> {
    let x = (f32(j) + 0.5 - cam.cx) / cam.fx;
    let y = (f32(i) + 0.5 - cam.cy) / cam.fy;
    return normalize(cam.right * x - cam.up * y + cam.forward);
}

@compute @workgroup_size({{ workgroup_x }}, {{ workgroup_y }})
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= cam.width || gid.y >= cam.height) {
        return;
    }
    let p = gid.y * cam.width + gid.x;
    let v = ray_direction(gid.x, gid.y);
    let v_y = v.y;
    let depth_o = -cam.position.y;

    let s_gb = gb_distance[p];
    let surf = gb_surface[p];
    // A hit counts only if the ray reaches it before the water surface.
    var hit = s_gb >= 0.0;
    if (hit && v_y > 0.0) {
        hit = s_gb <= depth_o / v_y;
    }
    let rl = ray_length(s_gb, hit, depth_o, v_y);
    let s = rl.x;
    let s_finite = rl.y > 0.0;

    // Per pixel, outside the band loop: the surface's depth and ambient
    // factor g(n_y), its reflectance source, and Snell's window.
    var surface_depth = 0.0;
    var g = 0.0;
    var material = 0u;
    var sig = vec3<f32>(0.0);
    var use_sigmoid = false;
    var use_material = false;
    if (hit) {
        surface_depth = -(cam.position.y + s * v_y);
        g = ambient_factor(cam.ambient_model, bitcast<f32>(surf.y));
        material = surf.w;
        use_sigmoid = material == PER_PIXEL;
        use_material = !use_sigmoid && material < cam.n_materials;
        if (use_sigmoid) {
            sig = gb_sigmoid[p].xyz;
        } else if (!use_material) {
            // Reported to the host, which raises; the pixel gets rho = 0.
            atomicAdd(&status[0], 1u);
        }
    }
    let in_window = !hit && s_finite && v_y > cam.snell_cos;
    let material_row = material * N_BANDS;

    var rgb = vec3<f32>(0.0);
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        let q0 = band_table[3u * i];
        let q1 = band_table[3u * i + 1u];
        let q2 = band_table[3u * i + 2u];
        let c = q0.x;
        let kd = q0.y;
        let l_ms = l_ms_seeds(c - kd * v_y, s, s_finite, q0.w, q2.x, q2.y);
        var rho = 0.0;
        if (use_material) {
            rho = material_bands[material_row + i];
        }
        rho = select(rho, sigmoid_reflectance(sig, q0.z), use_sigmoid);
        let l_surf = select(
            surface_from_below(q2.z, in_window),
            lambertian_radiance(rho, ambient_irradiance_over_pi(q1.w, kd, surface_depth, g)),
            hit);
        let tr = transmittance(c, s, s_finite);
        let l = select(l_ms, tr * l_surf + l_ms, tr > 0.0);
        rgb = rgb + l * q1.xyz;
        if (WRITE_RADIANCE) {
            radiance_out[p * N_BANDS + i] = l;
        }
    }
    rgb_out[p] = vec4<f32>(rgb, 1.0);
}
