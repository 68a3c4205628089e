// The analytic underwater light model in WGSL (f32), one band at a time for
// four pixels at once: per-pixel quantities are vec4<f32> (pixel k in
// component k), per-band ones f32 (see deferred.wgsl for why).
//
// Twin of aquaspec/model.py (float64 NumPy reference) and of
// aquaspec/shading.py: same formulas and cases, so change them together (the
// cases are mostly selects here, branches there; per-band factors that do not
// depend on the pixel come precomputed from aquaspec.gpu.deferred.band_table).
// Conventions: metres, y up, water surface y = 0, depth d = -p.y; a, b, c, Kd
// in 1/m; the camera ray starts at depth depth_o with unit direction v.
// WGSL has no expm1/log1p: phi below uses a series near 0 where
// 1 - exp(-x) would cancel in f32.

const PI: f32 = 3.14159265358979;
const FOUR_PI: f32 = 12.5663706143592;
// aquaspec.shading.SIGMOID_X_MAX.
const SIGMOID_X_MAX: f32 = 1.0e6;

// +infinity, for the same (impossible for valid input) case where NumPy
// returns inf; the host rejects non-finite output.
fn f32_inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

// (1 - exp(-x)) / x for x >= 0 (model.ms_path_integral), limit 1 at x = 0. Branchless
// (SIMD lanes on lavapipe run both sides of a divergent branch anyway):
// below x = 0.1 the Taylor series of (1 - e^-x) / x (truncation x^5 / 720
// relative, < 2e-8), above it the closed form, whose f32 rounding error is then
// < 1e-5 of the result. max() keeps the unused closed form finite at x = 0.
fn phi(x: vec4<f32>) -> vec4<f32> {
    let series = 1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0))));
    let closed = (1.0 - exp(-x)) / max(x, vec4<f32>(0.1));
    return select(closed, series, x < vec4<f32>(0.1));
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
// already cut by ray_length. Closed form b E0 / (4 pi) exp(-Kd d_o)
// (1 - exp(-k S)) / k, k = c - Kd v_y, stable for k -> 0, k < 0 and S = inf
// (needs k > 0). The factors that do not depend on the pixel come per band
// from the host (aquaspec.gpu.deferred.band_table, float64):
// ms_scale = b E0 / (4 pi) exp(-Kd d_o), be0 = b E0 / (4 pi), base = -Kd d_o.
fn l_ms_seeds(k: vec4<f32>, s: vec4<f32>, s_finite: vec4<bool>, ms_scale: f32, be0: f32,
              base: f32) -> vec4<f32> {
    let x = k * s;
    // x >= 0: ms_scale * S * (1 - e^-x) / x.
    // x < 0 (up-rays with Kd v_y > c): with y = -x, exp(-Kd d_o) S (e^y - 1) / y
    // = exp(-Kd d_o + y) S (1 - e^-y) / y, whose exponent -Kd d_o + y =
    // -Kd d(S) - c S stays <= 0 for rays under water (no overflow); model.py
    // writes it exp(-Kd d_o + log_psi(y)). Both cases are then
    // scale * S * phi(|x|), with a select rather than a branch (a branch
    // around the rare case still cost a third of the pass on lavapipe).
    let neg = x < vec4<f32>(0.0);
    let scale = select(vec4<f32>(ms_scale), be0 * exp(base - x), neg);
    let finite = scale * s * phi(abs(x));
    // S = inf: ms_scale / k (inf if k <= 0).
    let k_pos = k > vec4<f32>(0.0);
    let infinite = select(vec4<f32>(f32_inf()), ms_scale / select(vec4<f32>(1.0), k, k_pos),
                          k_pos);
    return select(infinite, finite, s_finite);
}

// model.AMBIENT_MODELS, by id (aquaspec.gpu.deferred.AMBIENT_MODEL_IDS):
// 0 "uniform": g = 1 (thesis Eq. 4.2); 1 "cosine": g = (1 + n_y) / 2.
fn ambient_factor(model_id: u32, n_y: vec4<f32>) -> vec4<f32> {
    let ny = clamp(n_y, vec4<f32>(-1.0), vec4<f32>(1.0));
    switch model_id {
        case 0u: { return vec4<f32>(1.0); }
        default: { return 0.5 * (1.0 + ny); }
    }
}

// model.ambient_irradiance / pi: E0 exp(-Kd d) g(n_y) / pi, with the factor
// g = ambient_factor(model, n_y) computed once per pixel and e0_over_pi = E0 / pi
// per band from the host (the 1 / pi of lambertian_radiance moved here).
fn ambient_irradiance_over_pi(e0_over_pi: f32, kd: f32, depth: vec4<f32>,
                              g: vec4<f32>) -> vec4<f32> {
    return e0_over_pi * exp(-kd * depth) * g;
}

// model.lambertian_radiance: rho E / pi (E / pi from ambient_irradiance_over_pi).
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
    return 0.5 + 0.5 * x / sqrt(1.0 + x * x);
}
