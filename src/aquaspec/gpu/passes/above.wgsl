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
// With a sun (SUN_ON) the water's light gains the beam scattered once
// along t, read bilinearly from a table over (t_y, cos theta = to_sun . t)
// (above_water.sun_scattering_table), and the mirrored ray inside the sun's
// disc (cos >= sun_cos_radius about sun_air) adds R(mu_i) glint_rgb.
// With waves (WAVES_ON) every ray is mirrored and refracted by the wave
// tile's facet where it meets the mean plane (facet_normal), and the sun's
// glint is Cox & Munk's glitter over the unresolved slopes (glitter; s2 > 0).
// edge_cos is the table's top: t_y runs over [-1, -edge_cos].

#include "fresnel.wgsl"

{{ params_struct }}

// Which terms this pipeline draws, fixed when it is compiled (a branch not
// taken still cost lavapipe a third of the frame when it was a uniform's).
const SUN_ON: bool = {{ sun_on }};
const WAVES_ON: bool = {{ waves_on }};

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var<storage, read> water: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> sun_table: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> slopes: array<vec2<f32>>;

#include "wave_facets.wgsl"
#include "camera_ray.wgsl"
#include "clear_sky.wgsl"

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

// The wave tile's facet normal where the ray meets the mean plane
// (light.wave_facets.SurfaceFacets.normals: slopes bilinear, periodic), or
// up for a flat sea or a facet (nearly) facing away from the ray.
fn facet_normal(v: vec3<f32>) -> vec3<f32> {
    let up = vec3<f32>(0.0, 1.0, 0.0);
    if (!WAVES_ON) {
        return up;
    }
    let s = prm.position.y / -v.y;
    let n = wave_facet(prm.position.x + s * v.x, prm.position.z + s * v.z);
    if (-dot(v, n) > prm.min_facet_cos) {
        return n;
    }
    return up;
}

// Cox & Munk's glitter over the unresolved slopes about the facet n
// (light.wave_facets.glitter), per unit of the sun's irradiance.
fn glitter(v: vec3<f32>, n: vec3<f32>) -> f32 {
    let h = normalize(prm.sun_air - v);
    let cos_w = -dot(v, h);
    let cos_b = dot(h, n);
    let mu_v = -dot(v, n);
    if (cos_w <= 0.0 || cos_b <= 0.0 || mu_v <= 0.0) {
        return 0.0;
    }
    let tan2 = (1.0 - cos_b * cos_b) / (cos_b * cos_b);
    let p = exp(-tan2 / prm.s2) / (3.14159265358979 * prm.s2);
    let r = 1.0 - fresnel_transmittance(cos_w, prm.n_water);
    return r * p / (4.0 * mu_v * cos_b * cos_b * cos_b * cos_b);
}

// The sky in air along d: uniform (overcast), or the CIE clear sky about
// the sun (aquaspec.shading.above_water.sky_shape).
fn sky_along(d: vec3<f32>) -> vec3<f32> {
    if (SUN_ON) {
        return prm.sky_rgb * clear_sky(d, prm.sun_air, prm.sky_norm);
    }
    return prm.sky_rgb;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.width || gid.y >= prm.height) {
        return;
    }
    let v = camera_ray(f32(gid.x), f32(gid.y));
    var rgb = sky_along(v);
    if (v.y < 0.0) {
        let n = prm.n_water;
        let nf = facet_normal(v);
        let cos_i = -dot(v, nf);
        let t = fresnel_transmittance(cos_i, n);
        // Snell through the facet: t = v / n + (cos_i / n - cos_t) nf.
        let cos_t = sqrt(max(1.0 - (1.0 - cos_i * cos_i) / (n * n), 0.0));
        let tv = v / n + (cos_i / n - cos_t) * nf;
        let t_y = min(tv.y, -prm.edge_cos);
        let last = prm.nodes - 1u;
        let x = clamp((t_y + 1.0) / (1.0 - prm.edge_cos) * f32(last), 0.0, f32(last));
        let k = min(u32(x), last - 1u);
        var w = mix(water[k], water[k + 1u], x - f32(k)).xyz;
        if (SUN_ON) {
            w = w + sun_scattering(t_y, dot(prm.to_sun, vec3<f32>(tv.x, t_y, tv.z)));
        }
        rgb = (1.0 - t) * sky_along(v + 2.0 * cos_i * nf) + t / (n * n) * w;
        if (SUN_ON) {
            if (WAVES_ON && prm.s2 > 0.0) {
                rgb = rgb + glitter(v, nf) * prm.sun_rgb;
            } else if (dot(v + 2.0 * cos_i * nf, prm.sun_air) >= prm.sun_cos_radius) {
                rgb = rgb + (1.0 - t) * prm.glint_rgb;
            }
        }
    }
    rgb_out[gid.y * prm.width + gid.x] = vec4<f32>(rgb, 1.0);
}
