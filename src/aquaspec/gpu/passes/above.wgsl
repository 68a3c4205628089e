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
// With a sun (sun_on = 1) the water's light gains the beam scattered once
// along t, read bilinearly from a table over (t_y, cos theta = to_sun . t)
// (above_water.sun_scattering_table), and the mirrored ray inside the sun's
// disc (cos >= sun_cos_radius about sun_air) adds R(mu_i) glint_rgb.

#include "fresnel.wgsl"

{{ params_struct }}

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var<storage, read> water: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> sun_table: array<vec4<f32>>;

// The sun's single scattering along t (camera RGB), bilinear in (t_y, cos).
fn sun_scattering(t_y: f32, cos_s: f32) -> vec3<f32> {
    let last_y = f32(prm.sun_nodes_y - 1u);
    let last_c = f32(prm.sun_nodes_cos - 1u);
    let x = clamp((t_y + 1.0) / (1.0 - prm.edge_cos) * last_y, 0.0, last_y);
    let y = clamp((cos_s - prm.sun_cos_lo) / (prm.sun_cos_hi - prm.sun_cos_lo) * last_c, 0.0, last_c);
    let i = min(u32(x), prm.sun_nodes_y - 2u);
    let j = min(u32(y), prm.sun_nodes_cos - 2u);
    let fx = x - f32(i);
    let fy = y - f32(j);
    let row0 = i * prm.sun_nodes_cos;
    let row1 = row0 + prm.sun_nodes_cos;
    let a = mix(sun_table[row0 + j], sun_table[row0 + j + 1u], fy);
    let b = mix(sun_table[row1 + j], sun_table[row1 + j + 1u], fy);
    return mix(a, b, fx).xyz;
}

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
        var w = mix(water[k], water[k + 1u], x - f32(k)).xyz;
        if (prm.sun_on == 1u) {
            // The refracted ray: tangential part scaled by 1/n, then t_y.
            let h = vec3<f32>(v.x, 0.0, v.z) / n;
            let tv = vec3<f32>(h.x, t_y, h.z);
            w = w + sun_scattering(t_y, dot(prm.to_sun, tv));
        }
        rgb = (1.0 - t) * prm.sky_rgb + t / (n * n) * w;
        if (prm.sun_on == 1u && dot(vec3<f32>(v.x, -v.y, v.z), prm.sun_air) >= prm.sun_cos_radius) {
            rgb = rgb + (1.0 - t) * prm.glint_rgb;
        }
    }
    rgb_out[gid.y * prm.width + gid.x] = vec4<f32>(rgb, 1.0);
}
