// Marine snow lit and splatted on the GPU: one invocation per particle of the
// field's periodic cube (aquaspec.gpu.passes.snow_field; NumPy twin:
// aquaspec.rendering.marine_snow.frame_splats, i.e. SnowField.at,
// ParticleLight.rgb lit by the light field alone, splats; then
// snow_splat.wgsl's disc, as aquaspec.shading.particles.splat_image).
//
// One invocation per particle of the cells that may be in view (the host's
// cull by cells, SnowField.indices_in_view). Per particle: its position at
// the frame's instant, origin + shift wrapped
// into the cube around the camera (pos = mod(origin + shift, side) + cam -
// side / 2, with shift = current t - cam + side / 2 made on the host); kept
// below the surface and beyond NEAR along the axis; projected; its disc's
// radius clamp(max(D_img, blur) / 2, 0.5, MAX_RADIUS) with D_img = D fy / z;
// dropped unless the disc reaches the image; lit: per band
// L_i = V_i(d, w_y) rho E0_i / pi exp(-c_i r) (V bilinear in the
// light-field tables' axes, table_lookup's texel coordinates), camera RGB
// sum_i L_i w_i; coverage pi D_img^2 / 4.

{{ params_struct }}

{{ field_struct }}

const N_BANDS: u32 = {{ n_bands }}u;
const GROUPS: u32 = {{ groups }}u;

@group(0) @binding(0) var surface_tex: texture_2d<u32>;
@group(0) @binding(1) var<uniform> snow_prm: {{ params_name }};
// Laid out as snow_splat.wgsl says.
@group(0) @binding(3) var<storage, read_write> accum: array<atomic<u32>>;
@group(0) @binding(4) var<uniform> field: FieldParams;
// (x, y, z, diameter) per particle, metres.
@group(0) @binding(5) var<storage, read> origins: array<vec4<f32>>;
// V: layer g, texel (j, i) (direction, depth) holds bands 4g .. 4g + 3
// (aquaspec.gpu.passes.lightfield.band_group_texture; on lavapipe a texel
// load costs a fraction of a storage buffer's).
@group(0) @binding(6) var visible: texture_2d_array<f32>;
// Per band: (rho E0 / pi, c_view, w_r, w_g), (w_b, 0, 0, 0).
@group(0) @binding(7) var<uniform> bands: array<vec4<f32>, {{ band_vec4 }}>;
// [0]: the particles drawn.
@group(0) @binding(8) var<storage, read_write> drawn: array<atomic<u32>>;
// The particles of the cells that may be in view (SnowField.indices_in_view).
@group(0) @binding(9) var<storage, read> index: array<u32>;

#include "snow_splat.wgsl"

@compute @workgroup_size(64)
fn cs_field(@builtin(global_invocation_id) gid: vec3<u32>) {
    let n = gid.x;
    if (n >= field.count) {
        return;
    }
    let o = origins[index[n]];
    let q = o.xyz + field.shift;
    let p = q - field.side * floor(q / field.side) + field.cam - 0.5 * field.side;
    let rel = p - field.cam;
    let z = dot(rel, field.forward);
    if (p.y >= 0.0 || z <= field.near) {
        return;
    }
    let col = field.cx + field.fx * dot(rel, field.right) / z;
    let row = field.cy - field.fy * dot(rel, field.up) / z;
    let d_img = o.w * field.fy / z;
    let radius = clamp(0.5 * max(d_img, field.blur_px), 0.5, field.max_radius);
    let reach = radius + 1.0;
    let w = snow_prm.width;
    let h = snow_prm.height;
    if (col + reach <= 0.0 || col - reach >= w || row + reach <= 0.0 || row - reach >= h) {
        return;
    }
    atomicAdd(&drawn[0], 1u);
    // The light field's light (table_lookup's texel coordinates).
    let r = length(rel);
    let w_y = -rel.y / max(r, 1e-30);
    let depth = clamp(-p.y, 0.0, field.max_depth);
    let x = sqrt(depth / field.max_depth) * f32(field.n_depth - 1u);
    let i = min(u32(floor(x)), field.n_depth - 2u);
    let fx = x - f32(i);
    let y = (1.0 - acos(clamp(w_y, -1.0, 1.0)) / PI) * f32(field.n_mu - 1u);
    let j = min(u32(floor(y)), field.n_mu - 2u);
    let fy = y - f32(j);
    var rgb = vec3<f32>(0.0);
    for (var g = 0u; g < GROUPS; g++) {
        let v = (textureLoad(visible, vec2<u32>(j, i), g, 0) * (1.0 - fy)
                 + textureLoad(visible, vec2<u32>(j + 1u, i), g, 0) * fy) * (1.0 - fx)
                + (textureLoad(visible, vec2<u32>(j, i + 1u), g, 0) * (1.0 - fy)
                   + textureLoad(visible, vec2<u32>(j + 1u, i + 1u), g, 0) * fy) * fx;
        for (var c = 0u; c < 4u; c++) {
            let b = 4u * g + c;
            if (b < N_BANDS) {
                let k = bands[2u * b];
                let l = v[c] * k.x * exp(-k.y * r);
                rgb += l * vec3<f32>(k.z, k.w, bands[2u * b + 1u].x);
            }
        }
    }
    splat_disc(vec4<f32>(col, row, radius, r),
               vec4<f32>(rgb, 0.25 * PI * d_img * d_img));
}
