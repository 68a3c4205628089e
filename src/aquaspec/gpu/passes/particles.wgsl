// Marine snow: each particle's disc added into an accumulation buffer (the
// NumPy reference: aquaspec.shading.particles.splat_image), then composed
// over the shaded image (aquaspec.shading.particles.composite).
//
// Splat (cs_splat): one invocation per particle, looping over the pixels its
// anti-aliased disc reaches (snow_splat.wgsl). On lavapipe a render pass of
// instanced quads cost about 3 us per particle (triangle set-up); this
// costs a few pixels' work per particle.

{{ params_struct }}

@group(0) @binding(0) var surface_tex: texture_2d<u32>;
@group(0) @binding(1) var<uniform> snow_prm: {{ params_name }};
// Two vec4 per particle: (col, row, radius px, distance m), (camera RGB, coverage).
@group(0) @binding(2) var<storage, read> records: array<vec4<f32>>;
// Laid out as snow_splat.wgsl says.
@group(0) @binding(3) var<storage, read_write> accum: array<atomic<u32>>;

#include "snow_splat.wgsl"
#include "snow_accum.wgsl"

@compute @workgroup_size(64)
fn cs_splat(@builtin(global_invocation_id) gid: vec3<u32>) {
    let n = gid.x;
    if (n >= u32(snow_prm.count)) {
        return;
    }
    splat_disc(records[2u * n], records[2u * n + 1u]);
}

// Compose: rgb = L max(1 - alpha, 0) + S / max(alpha, 1), in place (the
// params at binding 1 as in the splat).
@group(0) @binding(4) var snow_tex: texture_2d<u32>;
@group(0) @binding(5) var<storage, read_write> rgb: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn cs_compose(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = u32(snow_prm.width);
    let h = u32(snow_prm.height);
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let i = gid.y * w + gid.x;
    let acc = snow_accumulated(gid.x, gid.y);
    let old = rgb[i];
    rgb[i] = vec4<f32>(old.xyz * max(1.0 - acc.w, 0.0) + acc.xyz / max(acc.w, 1.0), old.w);
}
