// Deferred spectral shading with the light-field multiple-scattering model
// (ms_model = "lightfield"): G-buffer -> linear camera RGB, one pixel per
// invocation.
//
// Twin of aquaspec/lightfield.py (lightfield_pixel_radiance, lightfield_l_ms,
// bilinear; float64 NumPy reference) as used by aquaspec/shading.py
// (shade_gbuffer with light-field tables). Deep water only (no seabed
// boundary in the tables). G-buffer layout: aquaspec/gpu/deferred.py.

const PI: f32 = 3.14159265358979;
const PER_PIXEL: u32 = 0xffffffffu;
const SIGMOID_X_MAX: f32 = 1.0e6;

{{ params_struct }}

@group(0) @binding(0) var<uniform> prm: LightfieldParams;
@group(0) @binding(1) var<storage, read> gb_distance: array<f32>;
@group(0) @binding(2) var<storage, read> gb_surface: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> gb_sigmoid: array<vec4<f32>>;
// Per band i: [3i] = (c, b, kappa_1, E0), [3i+1] = (w_r, w_g, w_b, t),
// [3i+2] = (sky radiance per E0, f b, 0, 0) with f the forward-cone fraction.
@group(0) @binding(4) var<storage, read> bands: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> material_bands: array<f32>;
@group(0) @binding(6) var<storage, read> log_prefactor: array<f32>;
@group(0) @binding(7) var<storage, read> irradiance: array<f32>;
@group(0) @binding(8) var<storage, read_write> rgb_out: array<vec4<f32>>;

// lightfield.bilinear: texel x = sqrt(d / D) (n_depth - 1), y = (1 - acos(v) / pi) (n_mu - 1).
struct Texel { i: u32, j: u32, fx: f32, fy: f32 };

fn texel(depth: f32, v: f32) -> Texel {
    let nd = f32(prm.n_depth);
    let nm = f32(prm.n_mu);
    let x = sqrt(clamp(depth, 0.0, prm.max_depth) / prm.max_depth) * (nd - 1.0);
    let y = (1.0 - acos(clamp(v, -1.0, 1.0)) / PI) * (nm - 1.0);
    let i = min(u32(floor(x)), prm.n_depth - 2u);
    let j = min(u32(floor(y)), prm.n_mu - 2u);
    return Texel(i, j, x - f32(i), y - f32(j));
}

fn lookup_prefactor(band: u32, t: Texel) -> f32 {
    let base = (band * prm.n_depth + t.i) * prm.n_mu + t.j;
    let n = prm.n_mu;
    return (1.0 - t.fx) * ((1.0 - t.fy) * log_prefactor[base] + t.fy * log_prefactor[base + 1u])
         + t.fx * ((1.0 - t.fy) * log_prefactor[base + n] + t.fy * log_prefactor[base + n + 1u]);
}

fn lookup_irradiance(band: u32, t: Texel) -> f32 {
    let base = (band * prm.n_depth + t.i) * prm.n_mu + t.j;
    let n = prm.n_mu;
    return (1.0 - t.fx) * ((1.0 - t.fy) * irradiance[base] + t.fy * irradiance[base + 1u])
         + t.fx * ((1.0 - t.fy) * irradiance[base + n] + t.fy * irradiance[base + n + 1u]);
}

// (1 - exp(-x)) / x, x >= 0, as in model.ms_path_integral (series below 0.1, as common.wgsl).
fn phi(x: f32) -> f32 {
    if (x < 0.1) {
        return 1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0))));
    }
    return (1.0 - exp(-x)) / x;
}

// model.ms_path_integral(c, kappa_1, d, v, inf): the ray to infinity, or to
// the surface for up rays. For k < 0, exp(-K d) S (e^y - 1) / y is written
// exp(-K d + y) S phi(y), y = -k S, whose exponent stays <= 0 under water.
fn ms_integral_inf(c: f32, k1: f32, d: f32, v: f32) -> f32 {
    let k = c - k1 * v;
    if (v > 0.0) {
        let s = d / v;
        let x = k * s;
        if (x >= 0.0) {
            return exp(-k1 * d) * s * phi(x);
        }
        return exp(-k1 * d - x) * s * phi(-x);
    }
    return exp(-k1 * d) / k;
}

fn sigmoid_reflectance(co: vec3<f32>, t: f32) -> f32 {
    let x = clamp((co.x * t + co.y) * t + co.z, -SIGMOID_X_MAX, SIGMOID_X_MAX);
    return 0.5 + 0.5 * x / sqrt(1.0 + x * x);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.width || gid.y >= prm.height) {
        return;
    }
    let p = gid.y * prm.width + gid.x;
    let xn = (f32(gid.x) + 0.5 - prm.cx) / prm.fx;
    let yn = (f32(gid.y) + 0.5 - prm.cy) / prm.fy;
    let v = normalize(prm.right * xn - prm.up * yn + prm.forward).y;
    let d_o = prm.depth_o;

    let s_gb = gb_distance[p];
    var hit = s_gb >= 0.0;
    if (hit && v > 0.0) {
        hit = s_gb <= d_o / v;
    }
    var s = 0.0;
    var finite = false;
    if (hit) {
        s = s_gb;
        finite = true;
    } else if (v > 0.0) {
        s = d_o / v;
        finite = true;
    }
    let surf = gb_surface[p];
    let n_y = bitcast<f32>(surf.y);
    let material = surf.w;
    let sig = gb_sigmoid[p].xyz;
    let surface_depth = d_o - s * v;
    let t_o = texel(d_o, v);
    let t_s = texel(max(d_o - s * v, 0.0), v);
    let t_n = texel(surface_depth, n_y);

    var rgb = vec3<f32>(0.0);
    for (var i = 0u; i < prm.n_bands; i = i + 1u) {
        let cbke = bands[3u * i];
        let wt = bands[3u * i + 1u];
        let sky_fb = bands[3u * i + 2u];
        let c = cbke.x;
        let b = cbke.y;
        let k1 = cbke.z;
        let e0 = cbke.w;
        let scale = e0 * b / (4.0 * PI);
        let r_o = exp(lookup_prefactor(i, t_o)) * scale * ms_integral_inf(c, k1, d_o, v);
        // lightfield_pixel_radiance: with the open-water field
        // L_bg(d) = R(d) + exp(-c d / v) L_top (up rays), the radiance is
        // L_bg(d_o) + T' (L_surf - L_bg(d_S)), T' = exp(-(c - f b) S).
        var l_top = 0.0;
        var u_o = 0.0;
        if (v > prm.window_cos) {
            l_top = sky_fb.x * e0;
        }
        if (v > 0.0) {
            u_o = exp(-c * d_o / v);
        }
        var l = r_o + u_o * l_top;
        if (finite) {
            let d_s = max(d_o - s * v, 0.0);
            let r_s = exp(lookup_prefactor(i, t_s)) * scale * ms_integral_inf(c, k1, d_s, v);
            var u_s = 0.0;
            if (v > 0.0) {
                u_s = exp(-c * d_s / v);
            }
            let tr = exp(-(c - sky_fb.y) * s);
            var l_surf = l_top;
            if (hit) {
                var rho = 0.0;
                if (material == PER_PIXEL) {
                    rho = sigmoid_reflectance(sig, wt.w);
                } else if (material < prm.n_materials) {
                    rho = material_bands[material * prm.n_bands + i];
                }
                l_surf = rho * lookup_irradiance(i, t_n) * e0 / PI;
            }
            l = l + tr * (l_surf - r_s - u_s * l_top);
        }
        rgb = rgb + l * wt.xyz;
    }
    rgb_out[p] = vec4<f32>(rgb, 1.0);
}
