// The camera sensor on the GPU: natural vignetting and EMVA 1288 noise, one
// invocation per pixel, in camera RGB before white balance.
//
// Twin of a port's transmission per channel (given), then
// aquaspec.optics.lens.ThinLens.vignetting_factor (cos^4 of the chief ray's
// angle) and aquaspec.optics.sensor.Emva1288Sensor.capture (float64
// NumPy). Per channel: mean photoelectrons mu_e = rgb * electrons_per_unit;
// a Poisson number of mu_e + dark_e electrons (Knuth's product of uniforms
// below POISSON_GAUSS, a rounded normal of the same mean and variance above),
// clipped at the full well; Gaussian read noise; gain, black level, rounding,
// clipping to the ADC's range. Writes the digital numbers and the noisy frame
// as camera RGB: (DN - black - K dark_e) / (K electrons_per_unit).
//
// Random numbers: the PCG hash of Jarzynski & Olano, "Hash Functions for GPU
// Rendering", JCGT 9(3), 2020, chained from (seed, frame, pixel, channel); so
// a frame is repeatable, and its noise differs from the NumPy twin's
// (the tests compare statistics, not pixels).

{{ sensor_struct }}

const POISSON_GAUSS: f32 = 64.0;
const TWO_PI: f32 = 6.283185307179586;

@group(0) @binding(0) var<uniform> params: {{ sensor_struct_name }};
@group(0) @binding(1) var<storage, read> rgb_in: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> linear_out: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> raw_out: array<vec4<u32>>;

fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A uniform number in (0, 1) from the state, which it advances.
fn uniform01(state: ptr<function, u32>) -> f32 {
    *state = pcg(*state);
    return (f32(*state >> 8u) + 0.5) / 16777216.0;
}

// Two independent standard normals (Box-Muller: both of its outputs).
fn normals(state: ptr<function, u32>) -> vec2<f32> {
    let r = sqrt(-2.0 * log(uniform01(state)));
    let a = TWO_PI * uniform01(state);
    return r * vec2<f32>(cos(a), sin(a));
}

// A Poisson number of mean ``mean``; ``z`` a standard normal for large means.
fn poisson(mean: f32, z: f32, state: ptr<function, u32>) -> f32 {
    if (mean >= POISSON_GAUSS) {
        return max(floor(mean + sqrt(mean) * z + 0.5), 0.0);
    }
    let limit = exp(-mean);
    var k = 0.0;
    var prod = uniform01(state);
    // exp(-64) is a normal f32; the loop ends after about mean + 1 steps
    // (and at 4 * POISSON_GAUSS at the very most).
    for (var i = 0u; i < 256u; i = i + 1u) {
        if (prod <= limit) {
            break;
        }
        k = k + 1.0;
        prod = prod * uniform01(state);
    }
    return k;
}

// Channel c of pixel p: (digital number, noisy camera RGB) of camera RGB
// ``value`` with ``per_unit`` photoelectrons per unit over the exposure.
fn expose(value: f32, per_unit: f32, p: u32, c: u32) -> vec2<f32> {
    var state = pcg(params.seed ^ pcg(params.frame * 3u + c) ^ pcg(p + 0x9e3779b9u));
    var e = min(value * per_unit + params.dark_e, params.full_well_e);
    if (params.noise != 0u) {
        let z = normals(&state);
        e = min(poisson(value * per_unit + params.dark_e, z.x, &state), params.full_well_e)
            + params.read_noise_e * z.y;
    }
    let dn = clamp(floor(params.black_dn + params.gain * e + 0.5), 0.0, params.max_dn);
    return vec2<f32>(dn, (dn - params.black_dn - params.gain * params.dark_e)
                         / (params.gain * per_unit));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.width || gid.y >= params.height) {
        return;
    }
    let p = gid.y * params.width + gid.x;
    let tx = (f32(gid.x) + 0.5 - params.cx) / params.fx;
    let ty = (f32(gid.y) + 0.5 - params.cy) / params.fy;
    let q = 1.0 + tx * tx + ty * ty;
    let vignette = select(1.0, 1.0 / (q * q), params.vignetting != 0u);
    let rgb = max(rgb_in[p].xyz, vec3<f32>(0.0)) * params.transmission.xyz * vignette;
    let r = expose(rgb.x, params.electrons_per_unit.x, p, 0u);
    let g = expose(rgb.y, params.electrons_per_unit.y, p, 1u);
    let b = expose(rgb.z, params.electrons_per_unit.z, p, 2u);
    let raw = vec4<u32>(u32(r.x), u32(g.x), u32(b.x), 0u);
    let lin = vec4<f32>(r.y, g.y, b.y, 1.0);
    raw_out[p] = raw;
    linear_out[p] = lin;
}
