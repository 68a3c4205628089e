// The analytic underwater light model in WGSL (f32), one band at a time for
// four pixels at once: per-pixel quantities are vec4<f32> (pixel k in
// component k), per-band ones f32 (see deferred.wgsl for why).
//
// Twin of aquaspec.transport.monzon2022 (float64 NumPy reference) and of
// aquaspec.shading.shade: same formulas and cases, so change them together (the
// cases are mostly selects here, branches there; per-band factors that do not
// depend on the pixel come precomputed from aquaspec.gpu.passes.deferred.band_table).
// Conventions: metres, y up, water surface y = 0, depth d = -p.y; a, b, c, Kd
// in 1/m; the camera ray starts at depth depth_o with unit direction v.
// WGSL has no expm1/log1p: l_ms_seeds_shared uses a series near 0 where
// 1 - exp(-x) would cancel in f32.

const PI: f32 = 3.14159265358979;
const FOUR_PI: f32 = 12.5663706143592;
// aquaspec.colour.reflectance.SIGMOID_X_MAX.
const SIGMOID_X_MAX: f32 = 1.0e6;

// +infinity, for the same (impossible for valid input) case where NumPy
// returns inf; the host rejects non-finite output.
fn f32_inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

// model.ray_length: length of the ray under water. `s_finite` false means
// S = inf (open water); rays going up end at the surface, d_o / v_y.
struct RayLength {
    s: vec4<f32>,          // S_eff (0 where it is infinite)
    finite: vec4<bool>,    // S_eff is finite
};

fn ray_length(s: vec4<f32>, s_finite: vec4<bool>, depth_o: f32, v_y: vec4<f32>) -> RayLength {
    let up = v_y > vec4<f32>(0.0);
    let to_surface = depth_o / select(vec4<f32>(1.0), v_y, up);
    let s0 = select(vec4<f32>(0.0), s, s_finite);
    let s_up = select(to_surface, min(s, to_surface), s_finite);
    return RayLength(select(s0, s_up, up), up | s_finite);
}

// model.transmittance: exp(-c S), 0 for S = inf.
fn transmittance(c: f32, s: vec4<f32>, s_finite: vec4<bool>) -> vec4<f32> {
    return select(vec4<f32>(0.0), exp(-c * s), s_finite);
}

// model.l_ms_seeds = b E0 / (4 pi) * model.ms_path_integral (thesis Eq. 4.7):
// b E0 / (4 pi) int_0^S exp(-c t) exp(-Kd d(t)) dt, d(t) = d_o - t v_y, for S
// already cut by ray_length, in closed form b E0 / (4 pi) exp(-Kd d_o)
// (1 - exp(-k S)) / k, k = c - Kd v_y. The factors that do not depend on the
// pixel come per band from the host (aquaspec.gpu.passes.deferred.band_table,
// float64): ms_scale = b E0 / (4 pi) exp(-Kd d_o), be0 = b E0 / (4 pi).
// It is written with exponentials the caller computes anyway, both =
// exp(-c S) exp(-Kd d(S)) = exp(-Kd d_o) exp(-k S) (the transmittance and
// the downwelling attenuation at the ray's end), as (ms_scale - be0 both) / k:
// no exponential of its own, valid for either sign of k (k < 0 happens
// looking up in clear water), and nothing overflows (the two factors of both
// are <= 1 under water). Where |k S| < 0.1 that difference would cancel in
// f32 and the Taylor series of ms_scale S (1 - e^-x) / x, x = k S, is used
// instead (truncation x^5 / 720 relative, < 2e-8). S = inf: ms_scale / k
// (inf if k <= 0; model.py does the same). Selects, not branches: SIMD lanes
// on lavapipe run both sides of a divergent branch anyway, and a branch
// around the rare case cost a third of the pass there.
fn l_ms_seeds_shared(k: vec4<f32>, s: vec4<f32>, s_finite: vec4<bool>, ms_scale: f32,
                     be0: f32, both: vec4<f32>) -> vec4<f32> {
    let x = k * s;
    let inv_k = 1.0 / select(vec4<f32>(1.0), k, k != vec4<f32>(0.0));
    let series = ms_scale * s * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0
                 - x * (1.0 / 120.0)))));
    let closed = (ms_scale - be0 * both) * inv_k;
    let finite = select(closed, series, abs(x) < vec4<f32>(0.1));
    let infinite = select(vec4<f32>(f32_inf()), ms_scale * inv_k, k > vec4<f32>(0.0));
    return select(infinite, finite, s_finite);
}

// model.AMBIENT_MODELS, by id (aquaspec.gpu.passes.deferred.AMBIENT_MODEL_IDS):
// 0 "uniform": g = 1 (thesis Eq. 4.2); 1 "cosine": g = (1 + n_y) / 2.
fn ambient_factor(model_id: u32, n_y: vec4<f32>) -> vec4<f32> {
    let ny = clamp(n_y, vec4<f32>(-1.0), vec4<f32>(1.0));
    switch model_id {
        case 0u: { return vec4<f32>(1.0); }
        default: { return 0.5 * (1.0 + ny); }
    }
}

// model.ambient_irradiance / pi is E0 exp(-Kd d) g(n_y) / pi: deferred.wgsl
// forms it from e0_over_pi = E0 / pi per band (the 1 / pi of
// lambertian_radiance moved there), exp(-Kd d) per band and pixel (shared
// with l_ms_seeds_shared) and g = ambient_factor(...) once per pixel.

// model.lambertian_radiance: rho E / pi (E / pi as above).
fn lambertian_radiance(rho: vec4<f32>, irradiance_over_pi: vec4<f32>) -> vec4<f32> {
    return rho * irradiance_over_pi;
}

// model.surface_from_below: E0 n^2 / pi inside Snell's window (v_y > cos of
// the critical angle), 0 outside. e0_window = E0 n^2 / pi per band from the
// host (model.N_WATER); in_window = v_y > snell_cos per pixel
// (model.snell_window_cos).
fn surface_from_below(e0_window: f32, in_window: vec4<bool>) -> vec4<f32> {
    return select(vec4<f32>(0.0), vec4<f32>(e0_window), in_window);
}

// shading.sigmoid_reflectance: Jakob-Hanika sigmoid 0.5 + x / (2 sqrt(1 + x^2)),
// x = c0 t^2 + c1 t + c2, clamped to +-SIGMOID_X_MAX so x^2 stays finite
// (coefficients c0, c1, c2 of four pixels).
fn sigmoid_reflectance(c0: vec4<f32>, c1: vec4<f32>, c2: vec4<f32>, t: f32) -> vec4<f32> {
    let x = clamp((c0 * t + c1) * t + c2, vec4<f32>(-SIGMOID_X_MAX), vec4<f32>(SIGMOID_X_MAX));
    return 0.5 + 0.5 * x * inverseSqrt(1.0 + x * x);
}

// Camera RGB of four pixels (vec4 lanes), as the band loops accumulate it.
struct Rgb4 {
    r: vec4<f32>,
    g: vec4<f32>,
    b: vec4<f32>,
}
