// Marine snow: each particle's disc added into an accumulation buffer (the
// NumPy reference: aquaspec.shading.particles.splat_image), then composed
// over the shaded image (aquaspec.shading.particles.composite).
//
// Splat (cs_splat): one invocation per particle, looping over the pixels its
// anti-aliased disc reaches: the pixel centre's weight
// clamp(R + 0.5 - rho, 0, 1) / (pi (R^2 + 1/12)), dropped where the
// G-buffer's surface is nearer; adds (a w L scale, a w) in fixed point
// (round(x FIXED)) with atomicAdd into four u32 per pixel (snow_accum.wgsl's layout). Camera RGB is
// multiplied on the host by scale = 1 / max(RGB) of the frame's particles,
// and FIXED chosen there so that no pixel's sum can reach 2^31
// (aquaspec.gpu.passes.particles.ParticlePass.set_splats). On lavapipe a
// render pass of instanced quads cost about 3 us per particle (triangle
// set-up); this costs a few pixels' work per particle.

{{ params_struct }}

const PI: f32 = 3.14159265358979;

@group(0) @binding(0) var surface_tex: texture_2d<u32>;
@group(0) @binding(1) var<uniform> snow_prm: {{ params_name }};
// Two vec4 per particle: (col, row, radius px, distance m), (camera RGB x scale, coverage).
@group(0) @binding(2) var<storage, read> records: array<vec4<f32>>;
// Laid out as snow_accum.wgsl says.
@group(0) @binding(3) var<storage, read_write> accum: array<atomic<u32>>;

#include "snow_accum.wgsl"

fn add_fixed(i: u32, x: f32) {
    let q = u32(x * snow_prm.fixed + 0.5);
    if (q > 0u) {
        atomicAdd(&accum[i], q);
    }
}

@compute @workgroup_size(64)
fn cs_splat(@builtin(global_invocation_id) gid: vec3<u32>) {
    let n = gid.x;
    if (n >= u32(snow_prm.count)) {
        return;
    }
    let disc = records[2u * n];
    let light = records[2u * n + 1u];
    let r = disc.z;
    let reach = r + 0.5;
    let norm = 1.0 / (PI * (r * r + 1.0 / 12.0));
    let w = i32(snow_prm.width);
    let h = i32(snow_prm.height);
    let j0 = max(i32(floor(disc.x - reach)), 0);
    let j1 = min(i32(floor(disc.x + reach)), w - 1);
    let i0 = max(i32(floor(disc.y - reach)), 0);
    let i1 = min(i32(floor(disc.y + reach)), h - 1);
    for (var i = i0; i <= i1; i++) {
        for (var j = j0; j <= j1; j++) {
            let rho = distance(vec2<f32>(f32(j) + 0.5, f32(i) + 0.5), disc.xy);
            let weight = clamp(reach - rho, 0.0, 1.0) * norm;
            let s = bitcast<f32>(textureLoad(surface_tex, vec2<i32>(j, i), 0).x);
            if (weight > 0.0 && (s < 0.0 || disc.w < s)) {
                let alpha = weight * light.w;
                let p = snow_index(u32(j), u32(i));
                add_fixed(p, alpha * light.x);
                add_fixed(p + 1u, alpha * light.y);
                add_fixed(p + 2u, alpha * light.z);
                add_fixed(p + 3u, alpha);
            }
        }
    }
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
