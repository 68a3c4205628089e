// The direct sun (aquaspec/sun.py, NumPy twin: aquaspec.sun.sun_radiance):
// per pixel, the beam's single scattering along the camera ray, marched in
// N_STEPS equal steps against the sun's shadow map, plus the light of a
// sun-lit surface carried to the camera; added in camera RGB to the shading
// pass's linear image (rgb_out).
//
// The shadow map (aquaspec/gpu/sun_pass.py) is a depth texture rasterised
// orthographically along the beam: depth z = (h_max - h) / (h_max - h_min)
// with h = p . to_sun; a texel left at the clear value 1 has no surface.
// Four texels are compared and their results weighted bilinearly
// (percentage-closer filtering), as aquaspec.sun.map_visibility does.
//
// Layout of `bands`, two vec4 per band i:
//   [2i]     c_view, c_sun / mu0, b * beam0, beam0 / pi
//   [2i + 1] w_r, w_g, w_b, t (normalised band centre for sigmoid materials)
// `log_phase[i * PHASE_SIZE + k]`: ln p of band i at theta_k = pi (k / (PHASE_SIZE - 1))^2.
// `material_bands[m * N_BANDS + i]`: band reflectance of material m.

{{ params_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
const N_STEPS: u32 = {{ n_steps }}u;
const PHASE_SIZE: u32 = {{ phase_size }}u;
const PER_PIXEL: u32 = 0xffffffffu;
const PI: f32 = 3.14159265358979;

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
@group(0) @binding(3) var<storage, read> material_bands: array<f32>;
@group(0) @binding(4) var<storage, read> bands: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> log_phase: array<f32>;
@group(0) @binding(6) var shadow_map: texture_depth_2d;
@group(0) @binding(7) var<storage, read_write> rgb_out: array<vec4<f32>>;

// aquaspec.gpu.deferred.oct_decode, then n_y kept exact (unpack_surface).
fn decode_normal(word: vec4<u32>) -> vec3<f32> {
    let p = unpack2x16snorm(word.z);
    let y = 1.0 - abs(p.x) - abs(p.y);
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    let xz = select(p, (1.0 - abs(p.yx)) * s, y < 0.0);
    let n_y = clamp(bitcast<f32>(word.y), -1.0, 1.0);
    let h = length(xz);
    let scale = select(0.0, sqrt(max(1.0 - n_y * n_y, 0.0)) / h, h > 0.0);
    return vec3<f32>(xz.x * scale, n_y, xz.y * scale);
}

// Share of the sun that reaches point p (1 where no map or outside it).
fn visibility(p: vec3<f32>) -> f32 {
    if (prm.shadowed == 0u) {
        return 1.0;
    }
    let x = (dot(p, prm.e1) - prm.u0) / prm.texel - 0.5;
    let y = (dot(p, prm.e2) - prm.v0) / prm.texel - 0.5;
    let h = dot(p, prm.to_sun);
    let j0 = floor(x);
    let i0 = floor(y);
    let fx = x - j0;
    let fy = y - i0;
    let size = i32(prm.map_size);
    var v = 0.0;
    for (var di = 0; di < 2; di = di + 1) {
        for (var dj = 0; dj < 2; dj = dj + 1) {
            let ii = i32(i0) + di;
            let jj = i32(j0) + dj;
            var lit = 1.0;
            if (ii >= 0 && ii < size && jj >= 0 && jj < size) {
                let z = textureLoad(shadow_map, vec2<i32>(jj, ii), 0);
                let hm = prm.h_max - z * (prm.h_max - prm.h_min);
                lit = select(0.0, 1.0, z >= 1.0 || h >= hm - prm.bias);
            }
            let wx = select(1.0 - fx, fx, dj == 1);
            let wy = select(1.0 - fy, fy, di == 1);
            v = v + wx * wy * lit;
        }
    }
    return v;
}

// (1 - exp(-y)) / y, accurate near y = 0 (1 there).
fn exp_ratio(y: f32) -> f32 {
    return select((1.0 - exp(-y)) / y, 1.0 - y * (0.5 - y / 6.0), abs(y) < 1e-2);
}

fn reflectance(material: u32, sig: vec3<f32>, i: u32, t: f32) -> f32 {
    if (material == PER_PIXEL) {
        let x = clamp((sig.x * t + sig.y) * t + sig.z, -1e4, 1e4);
        return 0.5 + 0.5 * x * inverseSqrt(1.0 + x * x);
    }
    return material_bands[material * N_BANDS + i];
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let col = gid.x;
    let row = gid.y;
    if (col >= prm.width || row >= prm.height) {
        return;
    }
    let word = textureLoad(gb_surface, vec2<i32>(i32(col), i32(row)), 0);
    let s_raw = bitcast<f32>(word.x);
    // Camera.ray_directions through the pixel centre.
    let xc = (f32(col) + 0.5 - prm.cx) / prm.fx;
    let yc = (f32(row) + 0.5 - prm.cy) / prm.fy;
    let v = normalize(prm.right * xc - prm.up * yc + prm.forward);
    let d_o = -prm.position.y;
    let inf = bitcast<f32>(0x7f800000u);
    let to_surface = select(inf, d_o / v.y, v.y > 0.0);
    let hit = s_raw >= 0.0 && s_raw <= to_surface;
    let s = select(to_surface, s_raw, hit);

    // Where the march stops: the ray's end, or where the slowest band's
    // unshadowed integrand has fallen below the tail.
    var k_min = inf;
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        let q0 = bands[2u * i];
        k_min = min(k_min, q0.x - q0.y * v.y);
    }
    let t_tail = select(inf, prm.neg_log_tail / k_min, k_min > 0.0);
    var length = min(s, t_tail);
    length = select(0.0, length, length < inf);
    let dt = length / f32(N_STEPS);

    var vis: array<f32, N_STEPS>;
    var all_lit = true;
    for (var j = 0u; j < N_STEPS; j = j + 1u) {
        let vj = visibility(prm.position + v * ((f32(j) + 0.5) * dt));
        vis[j] = vj;
        all_lit = all_lit && vj >= 1.0;
    }

    let cos_theta = clamp(dot(v, prm.to_sun), -1.0, 1.0);
    let xp = sqrt(acos(cos_theta) / PI) * f32(PHASE_SIZE - 1u);
    let k0 = min(u32(floor(xp)), PHASE_SIZE - 2u);
    let fp = xp - f32(k0);

    var pos = vec3<f32>(0.0);
    var cos_n = 0.0;
    var v_s = 0.0;
    var depth_s = 0.0;
    var sig = vec3<f32>(0.0);
    if (hit) {
        pos = prm.position + v * s;
        let n = decode_normal(word);
        cos_n = max(dot(n, prm.to_sun), 0.0);
        depth_s = -pos.y;
        if (cos_n > 0.0) {
            v_s = visibility(pos + n * prm.normal_offset);
        }
        if (word.w == PER_PIXEL) {
            sig = textureLoad(gb_sigmoid, vec2<i32>(i32(col), i32(row)), 0).xyz;
        }
    }

    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        let q0 = bands[2u * i];
        let q1 = bands[2u * i + 1u];
        let k = q0.x - q0.y * v.y;
        let x = k * dt;
        let g = exp(-x);
        // int_0^dt exp(-k u) du
        let w0 = dt * exp_ratio(x);
        var sum = 0.0;
        if (all_lit) {
            // sum_j g^j = (1 - g^N) / (1 - g)
            sum = f32(N_STEPS) * exp_ratio(x * f32(N_STEPS)) / exp_ratio(x);
        } else {
            var e = 1.0;
            for (var j = 0u; j < N_STEPS; j = j + 1u) {
                sum = sum + vis[j] * e;
                e = e * g;
            }
        }
        let start = exp(-q0.y * d_o);
        let base = i * PHASE_SIZE + k0;
        let phase = exp(mix(log_phase[base], log_phase[base + 1u], fp));
        var l = q0.z * phase * start * w0 * sum;
        if (hit) {
            let rho = reflectance(word.w, sig, i, q1.w);
            l = l + rho * q0.w * exp(-q0.y * depth_s) * cos_n * v_s * exp(-q0.x * s);
        }
        acc = acc + l * q1.xyz;
    }
    let idx = row * prm.width + col;
    rgb_out[idx] = rgb_out[idx] + vec4<f32>(acc, 0.0);
}
