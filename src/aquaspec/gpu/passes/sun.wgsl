// The direct sun (aquaspec.gpu.passes.sun, NumPy twin: aquaspec.shading.sun.sun_radiance,
// method "froxel"), two entry points:
// - build_froxels: one invocation per froxel column (TILE x TILE pixels):
//   the beam's single scattering integrated front to back along the
//   column's ray over SLICES slices (boundaries t_k = L (k / SLICES)^2),
//   the shadow map read at each slice's middle, summed over the bands in
//   camera RGB with the phase function divided by the bands' mean at the
//   column's angle (aquaspec.transport.froxels.froxel_grid);
// - main: per pixel, the light of a sun-lit surface carried to the camera
//   plus the single scattering read from the froxels at the pixel's own
//   distance (bilinear between columns, linear between slices) times the
//   mean phase function at the pixel's own angle (froxel_lookup); added in
//   camera RGB to the shading pass's linear image (rgb_out).
//
// The shadow map (aquaspec.gpu.passes.sun_shadow) is a depth texture rasterised
// orthographically along the beam: depth z = (h_max - h) / (h_max - h_min)
// with h = p . to_sun; a texel left at the clear value 1 has no surface.
// Four texels are compared and their results weighted bilinearly
// (percentage-closer filtering), as aquaspec.scene.shadowmap.map_visibility does.
//
// Layout of `bands`, two vec4 per band i:
//   [2i]     c_view, c_sun / mu0, b * beam0, beam0 / pi
//   [2i + 1] w_r, w_g, w_b, t (normalised band centre for sigmoid materials)
// `log_phase[i * PHASE_SIZE + k]`: ln p of band i at theta_k = pi (k / (PHASE_SIZE - 1))^2;
// `ref_phase[k]`: ln of the bands' mean p on the same grid.
// `froxels[column * (SLICES + 1) + k]`: (cumulative RGB at t_k, the column's L).
// Caustics (aquaspec.light.caustics, NumPy twin aquaspec.light.caustics.sample): the
// beam's factor per depth slice (array layer) in foot coordinates, a mip
// pyramid of r16float read through a repeating trilinear sampler; layers
// at d_k = D (k / (K - 1))^2, linear between them in sqrt(d / D). Surfaces
// read it over their pixel's footprint s / fx; each froxel slice is the
// mean of CAUSTIC_SUB reads along it (aquaspec.transport.froxels.froxel_caustics).
// Band reflectance of material m, band i at flat index m * N_BANDS + i: in a
// uniform array of vec4 when it fits in 64 KiB (MATERIALS_IN_UNIFORM; storage
// reads per band were most of the pass's time on lavapipe), else in storage.

#include "common.wgsl"

{{ params_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
const TILE: u32 = {{ tile }}u;
const SLICES: u32 = {{ slices }}u;
const PHASE_SIZE: u32 = {{ phase_size }}u;
const PER_PIXEL: u32 = 0xffffffffu;
const CAUSTIC_SUB: u32 = {{ caustic_sub }}u;

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
{{ material_binding }}
@group(0) @binding(4) var<uniform> bands: array<vec4<f32>, {{ band_vec4 }}>;
@group(0) @binding(5) var<storage, read> log_phase: array<f32>;
@group(0) @binding(6) var shadow_map: texture_depth_2d;
@group(0) @binding(7) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> froxels: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> ref_phase: array<f32>;
@group(0) @binding(10) var caustic_tex: texture_2d_array<f32>;
@group(0) @binding(11) var caustic_sampler: sampler;

// aquaspec.gpu.gbuffer.oct_decode, then n_y kept exact (unpack_surface).
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

// The caustic factor at p averaged over about `footprint` metres (1 without caustics).
fn caustic(p: vec3<f32>, footprint: f32) -> f32 {
    if (prm.caustic == 0u) {
        return 1.0;
    }
    let d = -p.y;
    let u = vec2<f32>(p.x + d / prm.to_sun.y * prm.to_sun.x,
                      p.z + d / prm.to_sun.y * prm.to_sun.z) / prm.c_tile;
    let dc = clamp(d, 0.0, prm.c_max_depth);
    let x = sqrt(dc / prm.c_max_depth) * f32(prm.c_slices - 1u);
    let k0 = min(u32(floor(x)), prm.c_slices - 2u);
    let fk = x - f32(k0);
    let lod = clamp(log2(max(footprint / prm.c_texel, 1.0)), 0.0, prm.c_levels - 1.0);
    let a = textureSampleLevel(caustic_tex, caustic_sampler, u, k0, lod).x;
    let b = textureSampleLevel(caustic_tex, caustic_sampler, u, k0 + 1u, lod).x;
    return mix(a, b, fk);
}

// The mean caustic factor over the slice [ta, tb] of the ray o + t v
// (`speed`: how fast the ray moves in foot coordinates).
fn froxel_caustic(v: vec3<f32>, ta: f32, tb: f32, speed: f32) -> f32 {
    let dt = tb - ta;
    var acc = 0.0;
    for (var j = 0u; j < CAUSTIC_SUB; j = j + 1u) {
        let t = ta + (f32(j) + 0.5) / f32(CAUSTIC_SUB) * dt;
        let fp = max(f32(TILE) * t / prm.fx, speed * dt / f32(CAUSTIC_SUB));
        acc = acc + caustic(prm.position + v * t, fp);
    }
    return acc / f32(CAUSTIC_SUB);
}

// (1 - exp(-y)) / y, accurate near y = 0 (1 there).
fn exp_ratio(y: f32) -> f32 {
    return select((1.0 - exp(-y)) / y, 1.0 - y * (0.5 - y / 6.0), abs(y) < 1e-2);
}

fn reflectance(material: u32, sig: vec3<f32>, i: u32, t: f32) -> f32 {
    if (material == PER_PIXEL) {
        return sigmoid_reflectance(vec4<f32>(sig.x), vec4<f32>(sig.y), vec4<f32>(sig.z), t).x;
    }
    let k = material * N_BANDS + i;
    return {{ material_read }};
}

// Camera.ray_directions through pixel coordinates (px, py).
fn ray_through(px: f32, py: f32) -> vec3<f32> {
    let xc = (px - prm.cx) / prm.fx;
    let yc = (py - prm.cy) / prm.fy;
    return normalize(prm.right * xc - prm.up * yc + prm.forward);
}

// Where a phase table is read for cos theta: entry k0 and the fraction to k0 + 1.
struct PhaseAt {
    k0: u32,
    f: f32,
}

fn phase_at(cos_theta: f32) -> PhaseAt {
    let xp = sqrt(acos(clamp(cos_theta, -1.0, 1.0)) / PI) * f32(PHASE_SIZE - 1u);
    let k0 = min(u32(floor(xp)), PHASE_SIZE - 2u);
    return PhaseAt(k0, xp - f32(k0));
}

fn ref_phase_value(at: PhaseAt) -> f32 {
    return exp(mix(ref_phase[at.k0], ref_phase[at.k0 + 1u], at.f));
}

@compute @workgroup_size(64)
fn build_froxels(@builtin(global_invocation_id) gid: vec3<u32>) {
    let column = gid.x;
    if (column >= prm.cols_x * prm.cols_y) {
        return;
    }
    let cx = column % prm.cols_x;
    let cy = column / prm.cols_x;
    let half = 0.5 * f32(TILE);
    let v = ray_through(f32(TILE * cx) + half, f32(TILE * cy) + half);
    let d_o = -prm.position.y;
    let inf = f32_inf();
    // The column's length: the water surface (up rays) or where the slowest
    // band's integrand has fallen below the tail (aquaspec.transport.sun_scattering.march_length).
    var k_min = inf;
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        let q0 = bands[2u * i];
        k_min = min(k_min, q0.x - q0.y * v.y);
    }
    let to_surface = select(inf, d_o / v.y, v.y > 0.0);
    let t_tail = select(inf, prm.neg_log_tail / k_min, k_min > 0.0);
    var length = min(to_surface, t_tail);
    length = select(0.0, length, length < inf);

    let at = phase_at(dot(v, prm.to_sun));
    let p_ref = ref_phase_value(at);
    // Per band: the column's constant factor b beam0 (p / p_ref) exp(-c_sun d_o / mu0)
    // and the exponent's rate k along the column.
    var start: array<f32, N_BANDS>;
    var rate: array<f32, N_BANDS>;
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        let q0 = bands[2u * i];
        let row = i * PHASE_SIZE + at.k0;
        let p = exp(mix(log_phase[row], log_phase[row + 1u], at.f));
        start[i] = q0.z * p / p_ref * exp(-q0.y * d_o);
        rate[i] = q0.x - q0.y * v.y;
    }
    let drift = v.xz - v.y / prm.to_sun.y * prm.to_sun.xz;
    let speed = sqrt(dot(drift, drift));
    let base = column * (SLICES + 1u);
    froxels[base] = vec4<f32>(0.0, 0.0, 0.0, length);
    var acc = vec3<f32>(0.0);
    for (var k = 1u; k <= SLICES; k = k + 1u) {
        let ta = length * pow(f32(k - 1u) / f32(SLICES), 2.0);
        let tb = length * pow(f32(k) / f32(SLICES), 2.0);
        let dt = tb - ta;
        var vis = visibility(prm.position + v * (0.5 * (ta + tb)));
        if (vis > 0.0 && prm.caustic != 0u) {
            vis = vis * froxel_caustic(v, ta, tb, speed);
        }
        if (vis > 0.0) {
            for (var i = 0u; i < N_BANDS; i = i + 1u) {
                let kk = rate[i];
                let seg = exp(-kk * ta) * dt * exp_ratio(kk * dt);
                acc = acc + (vis * start[i] * seg) * bands[2u * i + 1u].xyz;
            }
        }
        froxels[base + k] = vec4<f32>(acc, length);
    }
}

// The single scattering of column (cx, cy) at distance t (before the pixel's phase).
fn froxel_at(cx: u32, cy: u32, t: f32) -> vec3<f32> {
    let base = (cy * prm.cols_x + cx) * (SLICES + 1u);
    let length = froxels[base].w;
    if (length <= 0.0) {
        return vec3<f32>(0.0);
    }
    let x = sqrt(min(t, length) / length) * f32(SLICES);
    let k0 = min(u32(floor(x)), SLICES - 1u);
    let f = x - f32(k0);
    return mix(froxels[base + k0].xyz, froxels[base + k0 + 1u].xyz, f);
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
    let v = ray_through(f32(col) + 0.5, f32(row) + 0.5);
    let d_o = -prm.position.y;
    let inf = f32_inf();
    let to_surface = select(inf, d_o / v.y, v.y > 0.0);
    let hit = s_raw >= 0.0 && s_raw <= to_surface;
    let s = select(inf, s_raw, hit);

    // The single scattering: the four nearest columns, bilinearly.
    let u = (vec2<f32>(f32(col), f32(row)) + 0.5 - 0.5 * f32(TILE)) / f32(TILE);
    let last = vec2<f32>(f32(prm.cols_x - 1u), f32(prm.cols_y - 1u));
    let a0 = clamp(floor(u), vec2<f32>(0.0), last);
    let a1 = min(a0 + 1.0, last);
    let fu = clamp(u - a0, vec2<f32>(0.0), vec2<f32>(1.0));
    let i0 = vec2<u32>(a0);
    let i1 = vec2<u32>(a1);
    let ss = mix(mix(froxel_at(i0.x, i0.y, s), froxel_at(i1.x, i0.y, s), fu.x),
                 mix(froxel_at(i0.x, i1.y, s), froxel_at(i1.x, i1.y, s), fu.x), fu.y);
    var acc = ss * ref_phase_value(phase_at(dot(v, prm.to_sun)));

    if (hit) {
        let pos = prm.position + v * s;
        let n = decode_normal(word);
        let cos_n = max(dot(n, prm.to_sun), 0.0);
        if (cos_n > 0.0) {
            let lit = cos_n * visibility(pos + n * prm.normal_offset) * caustic(pos, s / prm.fx);
            var sig = vec3<f32>(0.0);
            if (word.w == PER_PIXEL) {
                sig = textureLoad(gb_sigmoid, vec2<i32>(i32(col), i32(row)), 0).xyz;
            }
            let depth_s = -pos.y;
            for (var i = 0u; i < N_BANDS; i = i + 1u) {
                let q0 = bands[2u * i];
                let q1 = bands[2u * i + 1u];
                let rho = reflectance(word.w, sig, i, q1.w);
                let l = rho * q0.w * exp(-q0.y * depth_s - q0.x * s) * lit;
                acc = acc + l * q1.xyz;
            }
        }
    }
    let idx = row * prm.width + col;
    rgb_out[idx] = rgb_out[idx] + vec4<f32>(acc, 0.0);
}
