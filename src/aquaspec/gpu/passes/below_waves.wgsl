// The wind sea seen from below: twin of
// aquaspec.shading.below_waves.window_correction, in camera RGB. One
// invocation per pixel: its ray v going up through open water (the
// G-buffer's distance negative, or beyond the surface at S = d_o / v_y)
// meets the wave tile's facet n at the mean plane, and the pixel gains
//   sum_i w_i exp(-c_i S) (L_i(v, n) - L_i(v, up)),
//   L_i(v, n) = T_out(v.n) n^2 sky_i + (1 - T_out(v.n)) water_i(r_y),
// r the ray mirrored about the facet, water_i the table of the water's light
// just below the surface over r_y in [-1, -t_top] (above_water.water_below_table)
// (waves_on = 1; else the facet is up and that change is zero), and with a
// sun (sun_on = 1) its disc seen through the facet: where the ray refracted
// into the air is within the disc, sum_i w_i exp(-c_i S) T_out n^2 E_i / omega
// (below_waves.sun_through_surface); under waves with unresolved slopes
// (s2 > 0) the sun's glitter instead (below_waves.glitter_below). With a sun
// the sky through the surface is the CIE clear sky about it (above_water.
// sky_shape) against the uniform sky of the frame, for a flat sea too.

#include "fresnel.wgsl"
#include "clear_sky.wgsl"

{{ params_struct }}

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
// Per band two vec4: (c, sky, E_sun in air, 0), (w_r, w_g, w_b, 0).
@group(0) @binding(2) var<storage, read> bands: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> water: array<f32>;
@group(0) @binding(4) var<storage, read> slopes: array<vec2<f32>>;
@group(0) @binding(5) var<storage, read_write> rgb_out: array<vec4<f32>>;

#include "wave_facets.wgsl"
#include "camera_ray.wgsl"

// Where r_y falls in the water table: (node, fraction).
fn table_at(r_y: f32) -> vec2<f32> {
    let last = f32(prm.nodes - 1u);
    let x = clamp((min(r_y, -prm.t_top) + 1.0) / (1.0 - prm.t_top) * last, 0.0, last);
    let k = min(floor(x), last - 1.0);
    return vec2<f32>(k, x - k);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.width || gid.y >= prm.height) {
        return;
    }
    let v = camera_ray(f32(gid.x), f32(gid.y));
    var rgb = vec3<f32>(0.0);
    let s_hit = bitcast<f32>(textureLoad(gb_surface, vec2<i32>(gid.xy), 0).x);
    if (v.y > 0.0) {
        let s = -prm.position.y / v.y;
        if (s_hit < 0.0 || s_hit > s) {
            var n = vec3<f32>(0.0, 1.0, 0.0);
            if (prm.waves_on == 1u) {
                n = wave_facet(prm.position.x + s * v.x, prm.position.z + s * v.z);
            }
            var cos_i = dot(v, n);
            if (cos_i <= 0.0) {
                n = vec3<f32>(0.0, 1.0, 0.0);
                cos_i = v.y;
            }
            let tw = fresnel_transmittance_out(cos_i, prm.n_water);
            let nn = prm.n_water * prm.n_water;
            let sin2_t = nn * (1.0 - cos_i * cos_i);
            // The ray refracted into the air (grazing the facet beyond the critical angle).
            let t = normalize(prm.n_water * v + (sqrt(max(1.0 - sin2_t, 0.0)) - prm.n_water * cos_i) * n);
            var sky_gain = 1.0;
            if (prm.sun_on == 1u) {
                sky_gain = clear_sky(t, prm.sun_air, prm.sky_norm);
            }
            if (prm.waves_on == 1u) {
                let tf = fresnel_transmittance_out(v.y, prm.n_water);
                let aw = table_at(v.y - 2.0 * cos_i * n.y);
                let af = table_at(-v.y);
                let kw = u32(aw.x);
                let kf = u32(af.x);
                for (var i = 0u; i < prm.n_bands; i = i + 1u) {
                    let cs = bands[2u * i];
                    let w = bands[2u * i + 1u].xyz;
                    let ww = mix(water[kw * prm.n_bands + i], water[(kw + 1u) * prm.n_bands + i], aw.y);
                    let wf = mix(water[kf * prm.n_bands + i], water[(kf + 1u) * prm.n_bands + i], af.y);
                    let wavy = tw * nn * cs.y * sky_gain + (1.0 - tw) * ww;
                    let flat = tf * nn * cs.y + (1.0 - tf) * wf;
                    rgb = rgb + w * (exp(-cs.x * s) * (wavy - flat));
                }
            } else if (prm.sun_on == 1u) {
                // A flat sea: only the clear sky's shape against the uniform sky.
                for (var i = 0u; i < prm.n_bands; i = i + 1u) {
                    let cs = bands[2u * i];
                    rgb = rgb + bands[2u * i + 1u].xyz
                        * (exp(-cs.x * s) * tw * nn * cs.y * (sky_gain - 1.0));
                }
            }
            if (prm.sun_on == 1u && prm.s2 > 0.0) {
                // The sun's glitter over the unresolved slopes (below_waves.glitter_below).
                let hv = prm.n_water * v - prm.sun_air;
                let len2 = dot(hv, hv);
                let h = hv / sqrt(len2);
                let cos_v = dot(v, h);
                let cos_t = dot(h, prm.sun_air);
                let cos_b = dot(h, n);
                if (cos_v > 0.0 && cos_t > 0.0 && cos_b > 0.0 && cos_i > 0.0) {
                    let cb2 = cos_b * cos_b;
                    let p = exp(-(1.0 - cb2) / cb2 / prm.s2) / (3.14159265 * prm.s2);
                    let gain = fresnel_transmittance_out(cos_v, prm.n_water) * nn * cos_t * cos_v
                        * p / (cos_i * len2 * cb2 * cb2);
                    for (var i = 0u; i < prm.n_bands; i = i + 1u) {
                        let cs = bands[2u * i];
                        rgb = rgb + bands[2u * i + 1u].xyz * (exp(-cs.x * s) * gain * cs.z);
                    }
                }
            } else if (prm.sun_on == 1u) {
                if (sin2_t < 1.0 && dot(t, prm.sun_air) >= prm.sun_cos_radius) {
                    let gain = tw * nn / prm.omega;
                    for (var i = 0u; i < prm.n_bands; i = i + 1u) {
                        let cs = bands[2u * i];
                        rgb = rgb + bands[2u * i + 1u].xyz * (exp(-cs.x * s) * gain * cs.z);
                    }
                }
            }
        }
    }
    rgb_out[gid.y * prm.width + gid.x] = vec4<f32>(rgb, 0.0);
}
