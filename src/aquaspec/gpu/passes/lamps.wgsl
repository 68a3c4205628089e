// The lamps (aquaspec.gpu.passes.lamps; NumPy twin: aquaspec.shading.lamp.lamp_radiance,
// maths in aquaspec.transport.lamp_scattering, shadows in aquaspec.scene.lamp_shadow).
// One invocation per pixel; per lamp:
// - the light scattered once along the pixel's ray up to its surface (or the
//   water surface going up, or infinity), over the equiangular variable theta
//   (t = t* + D tan theta, dt / r^2 = dtheta / D) by the midpoint rule on
//   N_SAMPLES equal steps of u = sqrt(psi / pi), psi = pi/2 + theta the
//   scattering angle (dtheta = 2 pi u du), the ray first cut to the lamp's cone;
// - a lit surface's light rho / pi I0 f(alpha) V max(0, n.l) exp(-c_lamp r) / r^2
//   exp(-c_view S).
// Summed over the bands in camera RGB and added to rgb_out (vec4 per pixel).
//
// `bands`, two vec4 per band i: [2i] c_lamp, c_view, b, t (the normalised band
// centre for sigmoid materials); [2i + 1] w_r, w_g, w_b, 0.
// `intensity[k * BAND_GROUPS + i / 4][i % 4]`: lamp k's on-axis I0 in band i.
// Both in uniform arrays: storage reads in the band loops were most of the
// pass's time on lavapipe.
// `profile[k * PROFILE_SIZE + j]`: f of lamp k at alpha_j = cone j / (PROFILE_SIZE - 1).
// `log_phase[i * PHASE_SIZE + j]`: ln p of band i at theta_j = pi (j / (PHASE_SIZE - 1))^2.
// `faces`, three vec4 per shadow-map face: right (xyz) and focal length in
// texels (w), up (xyz) and 0, forward (xyz) and the face's size in texels; layer
// f of shadow_maps holds face f's perspective depth (near NEAR, far FAR).
// The bands' loops read the storage buffers by index (arrays passed by value
// into functions are slow on lavapipe).

#include "common.wgsl"
#include "gbuffer_normal.wgsl"
#include "pcf.wgsl"

{{ params_struct }}

struct LampGpu {
    position: vec3<f32>,
    cos_cut: f32,
    direction: vec3<f32>,
    cone: f32,
    first_face: u32,
    n_faces: u32,
    clip: u32,
    pad: u32,
};

const N_BANDS: u32 = {{ n_bands }}u;
const PHASE_SIZE: u32 = {{ phase_size }}u;
const PROFILE_SIZE: u32 = {{ profile_size }}u;
const N_SAMPLES: u32 = {{ n_samples }}u;
const BAND_GROUPS: u32 = (N_BANDS + 3u) / 4u;
const PER_PIXEL: u32 = 0xffffffffu;
const HALF_PI: f32 = 1.57079632679490;
const NEAR: f32 = {{ near }};
const FAR: f32 = {{ far }};
const BIAS_TEXELS: f32 = {{ bias_texels }};
const NORMAL_OFFSET_TEXELS: f32 = {{ normal_offset_texels }};
const MIN_DISTANCE: f32 = {{ min_distance }};
const MIN_RANGE: f32 = {{ min_range }};

@group(0) @binding(0) var<uniform> lp: {{ params_struct_name }};
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> materials: array<f32>;
@group(0) @binding(4) var<uniform> bands: array<vec4<f32>, {{ band_vec4 }}>;
@group(0) @binding(5) {{ phase_binding }};

// Entry k of the phase table (uniform, four to a vec4, when it fits; else storage).
fn phase_entry(k: u32) -> f32 {
    return {{ phase_read }};
}
@group(0) @binding(6) var<storage, read> lamps: array<LampGpu>;
@group(0) @binding(7) var<uniform> intensity: array<vec4<f32>, {{ intensity_vec4 }}>;
@group(0) @binding(8) var<storage, read> profile: array<f32>;
@group(0) @binding(9) var<storage, read> faces: array<vec4<f32>>;
@group(0) @binding(10) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(11) var shadow_sampler: sampler_comparison;
@group(0) @binding(12) var<storage, read_write> rgb_out: array<vec4<f32>>;

// Camera.ray_directions through pixel coordinates (px, py).
fn pixel_ray(px: f32, py: f32) -> vec3<f32> {
    let xc = (px - lp.cx) / lp.fx;
    let yc = (py - lp.cy) / lp.fy;
    return normalize(lp.right * xc - lp.up * yc + lp.forward);
}

// f(alpha) of lamp k at cos(alpha), linear in the table over alpha.
fn beam(k: u32, cos_a: f32) -> f32 {
    let cone = lamps[k].cone;
    let a = acos(clamp(cos_a, -1.0, 1.0));
    if (a >= cone) {
        return 0.0;
    }
    let x = a / cone * f32(PROFILE_SIZE - 1u);
    let j0 = min(u32(floor(x)), PROFILE_SIZE - 2u);
    let base = k * PROFILE_SIZE + j0;
    return mix(profile[base], profile[base + 1u], x - f32(j0));
}

// WebGPU's perspective depth of view depth z (0 at NEAR, 1 at FAR).
fn ndc_depth(z: f32) -> f32 {
    return FAR * (z - NEAR) / ((FAR - NEAR) * z);
}

// Lamp k's visibility at p (aquaspec.scene.lamp_shadow.lamp_visibility): the face
// p's direction points at most along, four texels compared (percentage-closer),
// texels outside the face lit; with `surface`, p moved off it along n first.
fn lamp_visibility(k: u32, p: vec3<f32>, n: vec3<f32>, surface: bool) -> f32 {
    if (lp.shadowed == 0u) {
        return 1.0;
    }
    let lamp = lamps[k];
    var d = p - lamp.position;
    var face = lamp.first_face;
    var best = -3.4e38;
    for (var j = 0u; j < lamp.n_faces; j = j + 1u) {
        let along = dot(d, faces[3u * (lamp.first_face + j) + 2u].xyz);
        if (along > best) {
            best = along;
            face = lamp.first_face + j;
        }
    }
    let right = faces[3u * face];
    let up = faces[3u * face + 1u].xyz;
    let fwd = faces[3u * face + 2u];
    var z = dot(d, fwd.xyz);
    if (surface) {
        d = d + n * (NORMAL_OFFSET_TEXELS * max(z, 0.0) / right.w);
        z = dot(d, fwd.xyz);
    }
    if (z <= 0.0) {
        return 1.0;
    }
    let size = fwd.w;
    let x = right.w * dot(d, right.xyz) / z + 0.5 * size - 0.5;
    let y = -right.w * dot(d, up) / z + 0.5 * size - 0.5;
    let zb = max(z - BIAS_TEXELS * z / right.w, NEAR);
    let z_ref = min(ndc_depth(zb), 1.0);
    let j0 = floor(x);
    let i0 = floor(y);
    let fx = x - j0;
    let fy = y - i0;
    let g = textureGatherCompare(shadow_maps, shadow_sampler,
                                 vec2<f32>(j0 + 1.0, i0 + 1.0) / size, face, z_ref);
    return pcf_blend(g, j0, i0, fx, fy, size);
}

// Where the ray o + t v is inside lamp k's cone (lamp_scattering.cone_interval):
// (lo, hi), lo > hi where it never is; the whole line for cones of 90 degrees and more.
fn cone_interval(k: u32, v: vec3<f32>) -> vec2<f32> {
    let inf = f32_inf();
    let lamp = lamps[k];
    if (lamp.clip == 0u) {
        return vec2<f32>(-inf, inf);
    }
    let w = lp.position - lamp.position;
    let cc = lamp.cos_cut * lamp.cos_cut;
    let vd = dot(v, lamp.direction);
    let wd = dot(w, lamp.direction);
    let a = vd * vd - cc;
    let b = 2.0 * (vd * wd - cc * dot(v, w));
    let c = wd * wd - cc * dot(w, w);
    let disc = b * b - 4.0 * a * c;
    let sq = sqrt(max(disc, 0.0));
    if (a > 1e-6) {
        if (vd > 0.0) {
            return vec2<f32>((-b + sq) / (2.0 * a), inf);
        }
        return vec2<f32>(-inf, (-b - sq) / (2.0 * a));
    }
    if (a < -1e-6) {
        let r1 = (-b + sq) / (2.0 * a);
        let r2 = (-b - sq) / (2.0 * a);
        if (disc < 0.0 || wd + 0.5 * (r1 + r2) * vd < 0.0) {
            return vec2<f32>(inf, -inf);
        }
        return vec2<f32>(r1, r2);
    }
    return vec2<f32>(-inf, inf);
}

// Lamp k's light scattered once along ray v up to s_ray (inf: open water), camera RGB.
fn lamp_veil(k: u32, v: vec3<f32>, s_ray: f32) -> vec3<f32> {
    let lamp = lamps[k];
    let rel = lamp.position - lp.position;
    let t_star = dot(v, rel);
    let dist = max(length(rel - t_star * v), MIN_DISTANCE);
    let inside = cone_interval(k, v);
    let t0 = max(0.0, inside.x);
    let t1 = min(s_ray, inside.y);
    if (!(t1 > t0)) {
        return vec3<f32>(0.0);
    }
    let theta_a = atan2(t0 - t_star, dist);
    let theta_b = select(atan2(t1 - t_star, dist), HALF_PI, t1 >= f32_inf());
    let u_a = sqrt(clamp(theta_a + HALF_PI, 0.0, PI) / PI);
    let step = max(sqrt(clamp(theta_b + HALF_PI, 0.0, PI) / PI) - u_a, 0.0) / f32(N_SAMPLES);
    var acc = vec3<f32>(0.0);
    for (var j = 0u; j < N_SAMPLES; j = j + 1u) {
        let u = u_a + (f32(j) + 0.5) * step;
        let theta = PI * u * u - HALF_PI;
        let cos_t = cos(theta);
        let sin_t = sin(theta);
        let t = t_star + dist * sin_t / cos_t;
        let r = dist / cos_t;
        let x = lp.position + v * t;
        let f = beam(k, dot(x - lamp.position, lamp.direction) / r);
        if (f <= 0.0) {
            continue;
        }
        let g = f * u * lamp_visibility(k, x, vec3<f32>(0.0), false);
        if (g <= 0.0) {
            continue;
        }
        // The phase table is over sqrt(psi / pi): u itself.
        let xp = u * f32(PHASE_SIZE - 1u);
        let j0 = min(u32(floor(xp)), PHASE_SIZE - 2u);
        let fp = xp - f32(j0);
        for (var i = 0u; i < N_BANDS; i = i + 1u) {
            let q0 = bands[2u * i];
            let row = i * PHASE_SIZE + j0;
            let ln_p = mix(phase_entry(row), phase_entry(row + 1u), fp);
            let e = exp(ln_p - q0.x * r - q0.y * t);
            acc = acc + (g * e * q0.z * intensity[k * BAND_GROUPS + i / 4u][i % 4u]) * bands[2u * i + 1u].xyz;
        }
    }
    return acc * (2.0 * PI * step / dist);
}

fn reflectance(material: u32, sig: vec3<f32>, i: u32, t: f32) -> f32 {
    if (material == PER_PIXEL) {
        return sigmoid_reflectance(vec4<f32>(sig.x), vec4<f32>(sig.y), vec4<f32>(sig.z), t).x;
    }
    return materials[material * N_BANDS + i];
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let col = gid.x;
    let row = gid.y;
    if (col >= lp.width || row >= lp.height) {
        return;
    }
    let word = textureLoad(gb_surface, vec2<i32>(i32(col), i32(row)), 0);
    let s_raw = bitcast<f32>(word.x);
    let v = pixel_ray(f32(col) + 0.5, f32(row) + 0.5);
    let inf = f32_inf();
    let to_surface = select(inf, -lp.position.y / v.y, v.y > 0.0);
    let hit = s_raw >= 0.0 && s_raw <= to_surface;
    let s = select(to_surface, s_raw, hit);

    var acc = vec3<f32>(0.0);
    var n = vec3<f32>(0.0);
    var sig = vec3<f32>(0.0);
    if (hit) {
        n = decode_normal(word.z, word.y);
        if (word.w == PER_PIXEL) {
            sig = textureLoad(gb_sigmoid, vec2<i32>(i32(col), i32(row)), 0).xyz;
        }
    }
    let pos = lp.position + v * s;
    for (var k = 0u; k < lp.n_lamps; k = k + 1u) {
        acc = acc + lamp_veil(k, v, s);
        if (!hit || lp.surfaces == 0u) {
            continue;
        }
        let lamp = lamps[k];
        let to_lamp = lamp.position - pos;
        let r = max(length(to_lamp), MIN_RANGE);
        let cos_n = max(dot(n, to_lamp) / r, 0.0);
        let f = beam(k, -dot(to_lamp, lamp.direction) / max(length(to_lamp), 1e-30));
        if (cos_n <= 0.0 || f <= 0.0) {
            continue;
        }
        let g = f * cos_n * lamp_visibility(k, pos, n, true) / (PI * r * r);
        if (g <= 0.0) {
            continue;
        }
        for (var i = 0u; i < N_BANDS; i = i + 1u) {
            let q0 = bands[2u * i];
            let rho = reflectance(word.w, sig, i, q0.w);
            let e = exp(-q0.x * r - q0.y * s);
            acc = acc + (g * rho * e * intensity[k * BAND_GROUPS + i / 4u][i % 4u]) * bands[2u * i + 1u].xyz;
        }
    }
    let idx = row * lp.width + col;
    rgb_out[idx] = rgb_out[idx] + vec4<f32>(acc, 0.0);
}
