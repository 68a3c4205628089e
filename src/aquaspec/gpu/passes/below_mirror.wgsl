// The scene mirrored in the sea surface seen from below: twin of
// aquaspec.shading.below_mirror.scene_in_mirror, in camera RGB. One
// invocation per pixel: its ray v going up through open water (the frame's
// G-buffer distance negative, or beyond the surface at S = d_o / v_y) is
// mirrored at the surface (by the wave tile's facet with waves_on = 1:
// r = v - 2 (v.n) n); the mirrored camera's G-buffer (its image flipped left
// to right), at its pixel whose ray is along r, gives the hit at S2 beyond
// the surface, and the pixel gains
//   sum_i w_i R(v.n) exp(-c'_i (S + S2)) (L_hit,i - L_bg,i(d_2, r_y)),
// c' = c - f b the beam's extinction,
// L_hit = rho (E(d_2, n_y) + [sun] E_b(d_2) max(0, n . to_sun)) / pi, the
// irradiance and background tables read bilinearly as the NumPy reference's
// (transport.lightfield.tables.table_lookup; below_mirror.mirror_background_table).

#include "fresnel.wgsl"
#include "gbuffer_normal.wgsl"

{{ params_struct }}

const PI: f32 = 3.14159265358979;
const PER_PIXEL: u32 = 0xffffffffu;
const SIGMOID_X_MAX: f32 = 1.0e6;
// Groups of four bands: a constant, so that the band loop unrolls.
const GROUPS: u32 = {{ groups }}u;

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var mirror_surface: texture_2d<u32>;
@group(0) @binding(3) var mirror_sigmoid: texture_2d<f32>;
// Per group of four bands eight vec4: c - f b, t, e0, w_r, w_g, w_b, beam0,
// c_sun (the bands past the last zero).
@group(0) @binding(4) var<uniform> bands: array<vec4<f32>, {{ groups_x8 }}>;
// Material m's group g at [m * groups + g].
@group(0) @binding(5) var<storage, read> materials: array<vec4<f32>>;
// L_bg at [(k * bg_mu + j) * groups + g]; E / e0 at [(k * e_mu + j) * groups + g].
@group(0) @binding(6) var<storage, read> background: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> irradiance: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> rgb_out: array<vec4<f32>>;
// The wave tile's slopes (wave_facets.wgsl; read when waves_on is 1).
@group(0) @binding(9) var<storage, read> slopes: array<vec2<f32>>;

#include "wave_facets.wgsl"
#include "camera_ray.wgsl"

// (lower node, weight) on a table's depth axis: sqrt(d / D) (nodes - 1).
fn depth_axis(d: f32, nodes: u32) -> vec2<f32> {
    let x = sqrt(clamp(d, 0.0, prm.max_depth) / prm.max_depth) * f32(nodes - 1u);
    let k = min(floor(x), f32(nodes - 2u));
    return vec2<f32>(k, x - k);
}

// (lower node, weight) for a table coordinate x in [0, nodes - 1].
fn node_axis(x: f32, nodes: u32) -> vec2<f32> {
    let k = min(floor(x), f32(nodes - 2u));
    return vec2<f32>(k, x - k);
}

fn background_at(d: vec2<f32>, m: vec2<f32>, g: u32) -> vec4<f32> {
    let n = GROUPS;
    let r0 = (u32(d.x) * prm.bg_mu + u32(m.x)) * n + g;
    let r1 = r0 + prm.bg_mu * n;
    return mix(mix(background[r0], background[r0 + n], m.y),
               mix(background[r1], background[r1 + n], m.y), d.y);
}

fn irradiance_at(d: vec2<f32>, m: vec2<f32>, g: u32) -> vec4<f32> {
    let n = GROUPS;
    let r0 = (u32(d.x) * prm.e_mu + u32(m.x)) * n + g;
    let r1 = r0 + prm.e_mu * n;
    return mix(mix(irradiance[r0], irradiance[r0 + n], m.y),
               mix(irradiance[r1], irradiance[r1 + n], m.y), d.y);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.width || gid.y >= prm.height) {
        return;
    }
    let v = camera_ray(f32(gid.x), f32(gid.y));
    var rgb = vec3<f32>(0.0);
    let s_hit = bitcast<f32>(textureLoad(gb_surface, vec2<i32>(gid.xy), 0).x);
    var found = false;
    var mp = vec2<i32>(0);
    var m = vec4<u32>(0u);
    var s = 0.0;
    var s2 = 0.0;
    var depth = 0.0;
    var cos_i = 0.0;
    var r = vec3<f32>(0.0);
    if (v.y > 0.0) {
        s = -prm.position.y / v.y;
        if (s_hit < 0.0 || s_hit > s) {
            let p = prm.position + v * s;
            var n = vec3<f32>(0.0, 1.0, 0.0);
            if (prm.waves_on == 1u) {
                n = wave_facet(p.x, p.z);
            }
            cos_i = dot(v, n);
            if (cos_i <= 0.0) {
                n = vec3<f32>(0.0, 1.0, 0.0);
                cos_i = v.y;
            }
            r = v - 2.0 * cos_i * n;
            // The mirrored camera's pixel whose ray is along r.
            let mr = vec3<f32>(r.x, -r.y, r.z);
            let f = dot(mr, prm.forward);
            if (r.y < 0.0 && f > 0.0) {
                let jf = floor(prm.cx + prm.fx * dot(mr, prm.right) / f);
                let i_f = floor(prm.cy - prm.fy * dot(mr, prm.up) / f);
                if (jf >= 0.0 && jf < f32(prm.width) && i_f >= 0.0 && i_f < f32(prm.height)) {
                    mp = vec2<i32>(i32(prm.width) - 1 - i32(jf), i32(i_f));
                    m = textureLoad(mirror_surface, mp, 0);
                    let dist = bitcast<f32>(m.x);
                    let ray = camera_ray(jf, i_f);
                    let o_m = vec3<f32>(prm.position.x, -prm.position.y, prm.position.z);
                    let hit = o_m + dist * vec3<f32>(ray.x, -ray.y, ray.z);
                    if (dist >= 0.0 && hit.y < 0.0) {
                        found = true;
                        depth = -hit.y;
                        s2 = depth / -r.y;          // along r to the hit's depth
                    }
                }
            }
        }
    }
    if (found) {
        {
            let normal = decode_normal(m.z, m.y);
            let gain = 1.0 - fresnel_transmittance_out(cos_i, prm.n_water);
            let da = depth_axis(depth, prm.e_depth);
            let ea = node_axis((1.0 - acos(clamp(normal.y, -1.0, 1.0)) / PI) * f32(prm.e_mu - 1u),
                               prm.e_mu);
            let db = depth_axis(depth, prm.bg_depth);
            let ba = node_axis(acos(clamp(-r.y, 0.0, 1.0)) * 2.0 / PI * f32(prm.bg_mu - 1u),
                               prm.bg_mu);
            let sun_cos = max(dot(normal, prm.to_sun), 0.0);
            let coeffs = textureLoad(mirror_sigmoid, mp, 0).xyz;
            let scale = vec4<f32>(gain / PI);
            for (var g = 0u; g < GROUPS; g = g + 1u) {
                let b0 = 8u * g;
                let t = bands[b0 + 1u];
                var rho: vec4<f32>;
                if (m.w == PER_PIXEL) {
                    let x = clamp((coeffs.x * t + coeffs.y) * t + coeffs.z,
                                  vec4<f32>(-SIGMOID_X_MAX), vec4<f32>(SIGMOID_X_MAX));
                    rho = 0.5 + 0.5 * x * inverseSqrt(1.0 + x * x);
                } else {
                    rho = materials[m.w * GROUPS + g];
                }
                var e = irradiance_at(da, ea, g) * bands[b0 + 2u];
                if (prm.sun_on == 1u) {
                    e = e + bands[b0 + 6u] * exp(-bands[b0 + 7u] * depth / prm.mu0) * sun_cos;
                }
                let delta = exp(-bands[b0] * (s + s2))
                    * (scale * rho * e - gain * background_at(db, ba, g));
                rgb = rgb + vec3<f32>(dot(bands[b0 + 3u], delta), dot(bands[b0 + 4u], delta),
                                      dot(bands[b0 + 5u], delta));
            }
        }
    }
    rgb_out[gid.y * prm.width + gid.x] = vec4<f32>(rgb, 0.0);
}
