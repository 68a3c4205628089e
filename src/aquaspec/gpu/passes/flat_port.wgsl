// The flat port's image on the GPU: each sensor pixel reads each channel of
// the pinhole render in water where that channel's water ray meets the
// surface (one invocation per sensor pixel).
//
// Twin of aquaspec.optics.remap.port_image with port_coordinates (float64
// NumPy): Snell's law at both faces of the window per channel wavelength
// (indices given per channel), the ray's lateral offset delta, the surface's
// axial depth read at the nearest pixel and the position refined ITERATIONS
// times, then a bilinear read clamped to the image's edge. The depth comes
// from the render's G-buffer (aquaspec.gpu.gbuffer: the surface texture's x,
// the ray distance S as f32 bits, negative for open water, where the port is
// central), made axial as optics.remap.axial_depth does. Each channel is then
// scaled to the radiance in air, FlatPort.radiance_factor: T / n_w^2, the two
// faces' unpolarised Fresnel transmittance over the water's index squared.

#include "fresnel.wgsl"

{{ port_struct }}

const ITERATIONS: u32 = {{ iterations }}u;

@group(0) @binding(0) var<uniform> params: {{ port_struct_name }};
@group(0) @binding(1) var<storage, read> rgb_in: array<vec4<f32>>;
@group(0) @binding(2) var gb_surface: texture_2d<u32>;
@group(0) @binding(3) var<storage, read_write> rgb_out: array<vec4<f32>>;

fn tan_of_sin(s: f32) -> f32 {
    return s / sqrt(1.0 - s * s);
}

fn clamp_index(x: f32, n: u32) -> u32 {
    return u32(clamp(round(x), 0.0, f32(n - 1u)));
}

// Bilinear read of channel c at array coordinates (row, col), pixel centres
// at integers, the edge value beyond the edge.
fn bilinear(row: f32, col: f32, c: u32) -> f32 {
    let r = clamp(row, 0.0, f32(params.water_height - 1u));
    let q = clamp(col, 0.0, f32(params.water_width - 1u));
    let r0 = u32(floor(r));
    let q0 = u32(floor(q));
    let r1 = min(r0 + 1u, params.water_height - 1u);
    let q1 = min(q0 + 1u, params.water_width - 1u);
    let fr = r - f32(r0);
    let fq = q - f32(q0);
    let w = params.water_width;
    let top = mix(rgb_in[r0 * w + q0][c], rgb_in[r0 * w + q1][c], fq);
    let bottom = mix(rgb_in[r1 * w + q0][c], rgb_in[r1 * w + q1][c], fq);
    return mix(top, bottom, fr);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= params.width || gid.y >= params.height) {
        return;
    }
    let tx = (f32(gid.x) + 0.5 - params.cx) / params.fx;
    let ty = (f32(gid.y) + 0.5 - params.cy) / params.fy;
    let rho = sqrt(tx * tx + ty * ty);
    var ux = 0.0;
    var uy = 0.0;
    if (rho > 0.0) {
        ux = tx / rho;
        uy = ty / rho;
    }
    let cos_a = 1.0 / sqrt(1.0 + rho * rho);
    let sin_a = rho * cos_a;
    var out = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    for (var c = 0u; c < 3u; c = c + 1u) {
        let tan_g = tan_of_sin(sin_a / params.n_glass[c]);
        let tan_w = tan_of_sin(sin_a / params.n_water[c]);
        let delta = params.gap_m * (rho - tan_w) + params.thickness_m * (tan_g - tan_w);
        var t = tan_w;
        var row = params.water_cy + params.water_fy * t * uy - 0.5;
        var col = params.water_cx + params.water_fx * t * ux - 0.5;
        if (params.use_depth != 0u) {
            for (var i = 0u; i < ITERATIONS; i = i + 1u) {
                let r = clamp_index(row, params.water_height);
                let q = clamp_index(col, params.water_width);
                let s = bitcast<f32>(textureLoad(gb_surface, vec2<u32>(q, r), 0).x);
                let wx = (f32(q) + 0.5 - params.water_cx) / params.water_fx;
                let wy = (f32(r) + 0.5 - params.water_cy) / params.water_fy;
                let z = s / sqrt(1.0 + wx * wx + wy * wy);
                t = tan_w;
                if (z > 0.0) {
                    t = tan_w + delta / z;
                }
                row = params.water_cy + params.water_fy * t * uy - 0.5;
                col = params.water_cx + params.water_fx * t * ux - 0.5;
            }
        }
        let n_w = params.n_water[c];
        let n_g = params.n_glass[c];
        let cos_w = sqrt(1.0 - (sin_a / n_w) * (sin_a / n_w));
        let t_port = fresnel_transmittance(cos_a, n_g) * fresnel_transmittance(cos_w, n_g / n_w);
        out[c] = bilinear(row, col, c) * t_port / (n_w * n_w);
    }
    rgb_out[gid.y * params.width + gid.x] = out;
}
