// The direct sun (aquaspec.gpu.passes.sun, NumPy twin: aquaspec.shading.sun.sun_radiance,
// method "froxel"), two entry points; the per-point and per-pixel terms are
// sunlight.wgsl's (shared with lightfield.wgsl, which adds the sun in its
// own band loop instead of `main`):
// - build_froxels: one invocation per froxel column (TILE x TILE pixels):
//   the beam's single scattering integrated front to back along the
//   column's ray over SLICES slices (boundaries t_k = L (k / SLICES)^2),
//   the shadow map read at each slice's middle, summed over the bands in
//   camera RGB with the phase function divided by the bands' mean at the
//   column's angle (aquaspec.transport.froxels.froxel_grid);
// - main: per pixel, the light of a sun-lit surface carried to the camera
//   plus the single scattering read from the froxels at the pixel's own
//   distance (one trilinear sample: bilinear between columns, linear
//   between slices at the pixel's own sqrt(S / L)) times the
//   mean phase function at the pixel's own angle (froxel_lookup); added in
//   camera RGB to the shading pass's linear image (rgb_out).
//
// Layout of `bands`, two vec4 per band i, then two more per band:
//   [2i]     c_view, c_sun / mu0, b * beam0, beam0 / pi
//   [2i + 1] w_r, w_g, w_b, t (normalised band centre for sigmoid materials)
//   [2 N_BANDS + 2i], [.. + 1] the caustics' contrast scale's polynomial (sunlight.wgsl)
// `log_phase[i * PHASE_SIZE + k]`: ln p of band i at theta_k = pi (k / (PHASE_SIZE - 1))^2.
// Under waves each froxel slice's caustic factor is the mean of CAUSTIC_SUB
// reads along it (aquaspec.transport.froxels.froxel_caustics), each band's at
// the slice's middle depth; surfaces read it over their pixel's footprint s / fx.
// Band reflectance of material m, band i at flat index m * N_BANDS + i: in a
// uniform array of vec4 when it fits in 64 KiB (MATERIALS_IN_UNIFORM; storage
// reads per band were most of the pass's time on lavapipe), else in storage.

#include "sunlight.wgsl"

const N_BANDS: u32 = {{ n_bands }}u;
const PER_PIXEL: u32 = 0xffffffffu;
const CAUSTIC_SUB: u32 = {{ caustic_sub }}u;

@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
{{ material_binding }}
@group(0) @binding(4) var<uniform> bands: array<vec4<f32>, {{ band_vec4 }}>;
@group(0) @binding(5) var<storage, read> log_phase: array<f32>;
@group(0) @binding(7) var<storage, read_write> rgb_out: array<vec4<f32>>;
// The froxels as build_froxels writes them, laid out as the 3-D texture
// sunlight.wgsl's froxel_tex is copied from (a buffer: storage-texture
// writes made the pass a quarter slower on lavapipe): texel (x, y, k) at
// (k * cols_y + y) * FROXEL_ROW + x, FROXEL_ROW texels a row (a multiple of
// 256 bytes); FROXEL_HALF: rgba16float texels as two u32 each.
const FROXEL_ROW: u32 = {{ froxel_row }}u;
const FROXEL_HALF: bool = {{ froxel_half }};
@group(0) @binding(13) var<storage, read_write> froxel_out: array<{{ froxel_word }}>;

fn store_froxel(cx: u32, cy: u32, k: u32, value: vec3<f32>) {
    let i = (k * sp.cols_y + cy) * FROXEL_ROW + cx;
    froxel_out[i] = {{ froxel_pack }};
}

// The mean caustic factor over the slice [ta, tb] of the ray o + t v
// (`speed`: how fast the ray moves in foot coordinates).
fn froxel_caustic(v: vec3<f32>, ta: f32, tb: f32, speed: f32) -> f32 {
    let dt = tb - ta;
    var acc = 0.0;
    for (var j = 0u; j < CAUSTIC_SUB; j = j + 1u) {
        let t = ta + (f32(j) + 0.5) / f32(CAUSTIC_SUB) * dt;
        let fp = max(f32(TILE) * t / sp.fx, speed * dt / f32(CAUSTIC_SUB));
        acc = acc + caustic(sp.position + v * t, fp);
    }
    return acc / f32(CAUSTIC_SUB);
}

fn reflectance(material: u32, sig: vec3<f32>, i: u32, t: f32) -> f32 {
    if (material == PER_PIXEL) {
        return sigmoid_reflectance(vec4<f32>(sig.x), vec4<f32>(sig.y), vec4<f32>(sig.z), t).x;
    }
    let k = material * N_BANDS + i;
    return {{ material_read }};
}

@compute @workgroup_size(64)
fn build_froxels(@builtin(global_invocation_id) gid: vec3<u32>) {
    let column = gid.x;
    if (column >= sp.cols_x * sp.cols_y) {
        return;
    }
    let cx = column % sp.cols_x;
    let cy = column / sp.cols_x;
    let half = 0.5 * f32(TILE);
    let v = ray_through(f32(TILE * cx) + half, f32(TILE * cy) + half);
    let d_o = -sp.position.y;
    let length = march_length(v);

    let at = phase_at(dot(v, sp.to_sun));
    let p_ref = ref_phase_value(at);
    // Per band: the column's constant factor b beam0 (p / p_ref) exp(-c_sun d_o / mu0)
    // and the exponent's rate k along the column.
    var start: array<f32, N_BANDS>;
    var rate: array<f32, N_BANDS>;
    // exp(-k t) at the current slice's start, carried from slice to slice:
    // one exponential per band and slice, exp(-k dt).
    var decay: array<f32, N_BANDS>;
    for (var i = 0u; i < N_BANDS; i = i + 1u) {
        let q0 = bands[2u * i];
        let row = i * PHASE_SIZE + at.k0;
        let p = exp(mix(log_phase[row], log_phase[row + 1u], at.f));
        start[i] = q0.z * p / p_ref * exp(-q0.y * d_o);
        rate[i] = q0.x - q0.y * v.y;
        decay[i] = 1.0;
    }
    let drift = v.xz - v.y / sp.to_sun.y * sp.to_sun.xz;
    let speed = sqrt(dot(drift, drift));
    store_froxel(cx, cy, 0u, vec3<f32>(0.0));
    var acc = vec3<f32>(0.0);
    let step = length / f32(SLICES * SLICES);
    for (var k = 1u; k <= SLICES; k = k + 1u) {
        let ta = step * f32((k - 1u) * (k - 1u));
        let tb = step * f32(k * k);
        let dt = tb - ta;
        let vis = visibility(sp.position + v * (0.5 * (ta + tb)));
        var fc = 1.0;
        if (vis > 0.0 && sp.caustic != 0u) {
            fc = froxel_caustic(v, ta, tb, speed);
        }
        // Each band's factor at the slice's middle depth.
        let c_at = caustic_x(-(sp.position.y + v.y * (0.5 * (ta + tb))));
        for (var i = 0u; i < N_BANDS; i = i + 1u) {
            let kk = rate[i];
            let y = kk * dt;
            let q = exp(-y);
            // int_ta^tb exp(-k t) dt = exp(-k ta) (1 - exp(-y)) / k, y = k dt
            // (its series near y = 0).
            let seg = decay[i] * select((1.0 - q) / kk, dt * (1.0 - y * (0.5 - y / 6.0)),
                                        abs(y) < 1e-2);
            decay[i] = decay[i] * q;
            acc = acc + (vis * caustic_band(i, fc, c_at) * start[i] * seg)
                * bands[2u * i + 1u].xyz;
        }
        store_froxel(cx, cy, k, acc);
    }
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let col = gid.x;
    let row = gid.y;
    if (col >= sp.width || row >= sp.height) {
        return;
    }
    let word = textureLoad(gb_surface, vec2<i32>(i32(col), i32(row)), 0);
    let s_raw = bitcast<f32>(word.x);
    let v = ray_through(f32(col) + 0.5, f32(row) + 0.5);
    let d_o = -sp.position.y;
    let inf = f32_inf();
    let to_surface = select(inf, d_o / v.y, v.y > 0.0);
    let hit = s_raw >= 0.0 && s_raw <= to_surface;
    let s = select(inf, s_raw, hit);

    var acc = sun_veil(col, row, v, s);
    if (hit) {
        let pos = sp.position + v * s;
        let n = decode_normal(word.z, word.y);
        let cos_n = max(dot(n, sp.to_sun), 0.0);
        if (cos_n > 0.0) {
            let lit = sun_lit(v, s, n);
            var sig = vec3<f32>(0.0);
            if (word.w == PER_PIXEL) {
                sig = textureLoad(gb_sigmoid, vec2<i32>(i32(col), i32(row)), 0).xyz;
            }
            let depth_s = -pos.y;
            let c_at = caustic_x(depth_s);
            for (var i = 0u; i < N_BANDS; i = i + 1u) {
                let q0 = bands[2u * i];
                let q1 = bands[2u * i + 1u];
                let rho = reflectance(word.w, sig, i, q1.w);
                let l = rho * q0.w * exp(-q0.y * depth_s - q0.x * s)
                    * lit.x * caustic_band(i, lit.y, c_at);
                acc = acc + l * q1.xyz;
            }
        }
    }
    let idx = row * sp.width + col;
    rgb_out[idx] = rgb_out[idx] + vec4<f32>(acc, 0.0);
}
