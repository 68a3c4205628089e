// The sea seen from above a flat surface: twin of
// aquaspec.shading.above_water.sea_from_above (NumPy), in camera RGB.
// One invocation per pixel: its ray v (Camera.ray_directions); going level
// or up it sees the sky (sky_rgb); going down it meets the surface at
// incidence cosine mu_i = -v_y, where
//   rgb = R(mu_i) sky_rgb + (1 - R(mu_i)) / n^2 water(t_y),
// R the unpolarised Fresnel reflectance, t_y the refracted ray's up
// component, and water(t_y) the light field's radiance just below the
// surface looking along it, in camera RGB, interpolated linearly from a
// table over t_y in [-1, -cos theta_c] (above_water.water_below_table).

#include "fresnel.wgsl"

{{ params_struct }}

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var<storage, read> water: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rgb_out: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.width || gid.y >= prm.height) {
        return;
    }
    let xc = (f32(gid.x) + 0.5 - prm.cx) / prm.fx;
    let yc = (f32(gid.y) + 0.5 - prm.cy) / prm.fy;
    let v = normalize(prm.right * xc - prm.up * yc + prm.forward);
    var rgb = prm.sky_rgb;
    if (v.y < 0.0) {
        let n = prm.n_water;
        let mu_i = -v.y;
        let t = fresnel_transmittance(mu_i, n);
        // Snell: the refracted ray's up component.
        let t_y = -sqrt(max(1.0 - (1.0 - mu_i * mu_i) / (n * n), 0.0));
        let last = prm.nodes - 1u;
        let x = clamp((t_y + 1.0) / (1.0 - prm.edge_cos) * f32(last), 0.0, f32(last));
        let k = min(u32(x), last - 1u);
        let w = mix(water[k], water[k + 1u], x - f32(k)).xyz;
        rgb = (1.0 - t) * prm.sky_rgb + t / (n * n) * w;
    }
    rgb_out[gid.y * prm.width + gid.x] = vec4<f32>(rgb, 1.0);
}
