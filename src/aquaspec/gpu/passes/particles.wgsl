// Marine snow: each particle a disc splatted additively into an accumulation
// target (the NumPy reference: aquaspec.shading.particles.splat_image), then
// composed over the shaded image (aquaspec.shading.particles.composite).
//
// Splat: one instance per particle, a quad of six vertices covering its
// disc; the fragment weights the pixel centre by the anti-aliased disc
// clamp(R + 0.5 - rho, 0, 1) / (pi (R^2 + 1/12)) and drops it where the
// G-buffer's surface is nearer. Outputs (a w L scale, a w): camera RGB is
// pre-multiplied by `scale` on the host so that rgba16float keeps it in range.

{{ params_struct }}

@group(0) @binding(0) var surface_tex: texture_2d<u32>;
@group(0) @binding(1) var<uniform> params: {{ params_name }};

struct Instance {
    @location(0) disc: vec4<f32>,     // col, row, radius (px), distance (m)
    @location(1) light: vec4<f32>,    // camera RGB x scale, coverage (pixel areas)
};

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) disc: vec4<f32>,
    @location(1) @interpolate(flat) light: vec4<f32>,
};

const PI: f32 = 3.14159265358979;

@vertex
fn vs_splat(@builtin(vertex_index) vi: u32, inst: Instance) -> Varyings {
    // Two triangles: corners (0,0) (1,0) (0,1) / (0,1) (1,0) (1,1).
    var corner = array<vec2<f32>, 6>(vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0),
                                     vec2<f32>(-1.0, 1.0), vec2<f32>(-1.0, 1.0),
                                     vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0));
    let reach = inst.disc.z + 1.0;
    let px = inst.disc.xy + corner[vi] * reach;
    var out: Varyings;
    out.position = vec4<f32>(2.0 * px.x / params.width - 1.0, 1.0 - 2.0 * px.y / params.height,
                             0.5, 1.0);
    out.disc = inst.disc;
    out.light = inst.light;
    return out;
}

@fragment
fn fs_splat(v: Varyings) -> @location(0) vec4<f32> {
    let rho = distance(v.position.xy, v.disc.xy);
    let r = v.disc.z;
    let weight = clamp(r + 0.5 - rho, 0.0, 1.0) / (PI * (r * r + 1.0 / 12.0));
    if (weight <= 0.0) {
        discard;
    }
    let s = bitcast<f32>(textureLoad(surface_tex, vec2<i32>(v.position.xy), 0).x);
    if (s >= 0.0 && v.disc.w >= s) {
        discard;
    }
    let alpha = weight * v.light.w;
    return vec4<f32>(alpha * v.light.xyz, alpha);
}

// Compose: rgb = L max(1 - alpha, 0) + S / max(alpha, 1), in place.
@group(0) @binding(2) var accum_tex: texture_2d<f32>;
@group(0) @binding(3) var<storage, read_write> rgb: array<vec4<f32>>;
@group(0) @binding(4) var<uniform> cparams: {{ params_name }};

@compute @workgroup_size(8, 8)
fn cs_compose(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = u32(cparams.width);
    let h = u32(cparams.height);
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let acc = textureLoad(accum_tex, vec2<i32>(gid.xy), 0);
    let i = gid.y * w + gid.x;
    let old = rgb[i];
    let s = acc.xyz * cparams.inv_scale;
    rgb[i] = vec4<f32>(old.xyz * max(1.0 - acc.w, 0.0) + s / max(acc.w, 1.0), old.w);
}
