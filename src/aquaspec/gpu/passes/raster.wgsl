// Geometry pass: rasterise meshes into the G-buffer (see aquaspec.gpu.passes.raster).
//
// Targets (aquaspec.gpu.gbuffer, "Layout"):
//   0 surface rgba32uint:  x: distance S in metres from the camera centre as
//                          f32 bits (not z-depth; the clear value is the bits
//                          of OPEN_WATER_DISTANCE < 0 where no surface is
//                          seen); y: the normal's up component n_y as f32
//                          bits (all the shading uses); z: the whole normal,
//                          octahedral, pack2x16snorm; w: the material index
//                          (PER_PIXEL for textured / vertex-coloured meshes)
//   1 sigmoid rgba32float: sigmoid coefficients c0, c1, c2 (only scenes with
//                          textured or vertex-coloured meshes have it)
//
// One 16-byte target instead of two made the pass about 40 % faster on
// lavapipe for the built-in scene, which has no per-pixel materials.

{{ camera_struct }}

const PER_PIXEL: u32 = 0xFFFFFFFFu;

@group(0) @binding(0) var<uniform> cam: RasterCamera;
// Per-texel sigmoid coefficients of a textured mesh (rgba32float where the
// device has float32-filterable, else rgba16float) and its tangent-space
// normal map (rgba8unorm of (n + 1) / 2), each with its mip chain
// (aquaspec.scene.texture), sampled trilinearly by the texture units.
@group(1) @binding(1) var coeff_tex: texture_2d<f32>;
@group(1) @binding(2) var normal_tex: texture_2d<f32>;
@group(1) @binding(3) var tex_sampler: sampler;

// Vertex layouts, one per mode (aquaspec.gpu.passes.raster._vertex_data): position,
// normal, then the mode's own attribute at location 2. Each mode passes on
// only what its fragment shader needs: on lavapipe every varying is
// interpolated for every fragment.
struct VsMaterialIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) material: u32,
};

struct VsTextureIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

// With a normal map: uv at location 3 (texture mode: 2) and the tangent
// (xyz, handedness w) at 4.
struct VsMaterialNmIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) material: u32,
    @location(3) uv: vec2<f32>,
    @location(4) tangent: vec4<f32>,
};

struct VsTextureNmIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(4) tangent: vec4<f32>,
};

struct VsVertexNmIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) coeff: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) tangent: vec4<f32>,
};

struct VsVertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) coeff: vec3<f32>,
};

// Camera-relative position rel: S = length(rel) without cancellation.
struct VsMaterialOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) rel: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) material: u32,
};

struct VsTextureOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) rel: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
};

struct VsVertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) rel: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) coeff: vec3<f32>,
};

struct VsMaterialNmOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) rel: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) @interpolate(flat) material: u32,
    @location(3) uv: vec2<f32>,
    @location(4) tangent: vec4<f32>,
};

struct VsTextureNmOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) rel: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(4) tangent: vec4<f32>,
};

struct VsVertexNmOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) rel: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) coeff: vec3<f32>,
    @location(3) uv: vec2<f32>,
    @location(4) tangent: vec4<f32>,
};

struct FsOut1 {
    @location(0) surface: vec4<u32>,
};

struct FsOut2 {
    @location(0) surface: vec4<u32>,
    @location(1) sigmoid: vec4<f32>,
};

@vertex
fn vs_material(v: VsMaterialIn) -> VsMaterialOut {
    return VsMaterialOut(cam.view_proj * vec4<f32>(v.position, 1.0), v.position - cam.position,
                         v.normal, v.material);
}

@vertex
fn vs_texture(v: VsTextureIn) -> VsTextureOut {
    return VsTextureOut(cam.view_proj * vec4<f32>(v.position, 1.0), v.position - cam.position,
                        v.normal, v.uv);
}

@vertex
fn vs_vertex(v: VsVertexIn) -> VsVertexOut {
    return VsVertexOut(cam.view_proj * vec4<f32>(v.position, 1.0), v.position - cam.position,
                       v.normal, v.coeff);
}

@vertex
fn vs_material_nm(v: VsMaterialNmIn) -> VsMaterialNmOut {
    return VsMaterialNmOut(cam.view_proj * vec4<f32>(v.position, 1.0),
                           v.position - cam.position, v.normal, v.material, v.uv, v.tangent);
}

@vertex
fn vs_texture_nm(v: VsTextureNmIn) -> VsTextureNmOut {
    return VsTextureNmOut(cam.view_proj * vec4<f32>(v.position, 1.0),
                          v.position - cam.position, v.normal, v.uv, v.tangent);
}

@vertex
fn vs_vertex_nm(v: VsVertexNmIn) -> VsVertexNmOut {
    return VsVertexNmOut(cam.view_proj * vec4<f32>(v.position, 1.0),
                         v.position - cam.position, v.normal, v.coeff, v.uv, v.tangent);
}

// Trilinear with the texture units: a repeating sampler with linear
// min/mag/mip filters, the level of detail from the uv's fine screen
// derivatives (aquaspec.scene.texture: the isotropic rule; each GPU
// approximates it in its own way). uv origin at the bottom-left, texel row 0
// at the top, so v is flipped.
fn trilinear(tex: texture_2d<f32>, uv: vec2<f32>, duv_dx: vec2<f32>,
             duv_dy: vec2<f32>) -> vec3<f32> {
    let flip = vec2<f32>(1.0, -1.0);
    return textureSampleGrad(tex, tex_sampler, vec2<f32>(uv.x, 1.0 - uv.y), duv_dx * flip,
                             duv_dy * flip).xyz;
}

// The triangle's own plane, from screen-space derivatives of the
// camera-relative position, oriented towards the camera: the shading normal
// is put on that side, which works whatever the mesh's winding.
fn facing_normal(rel: vec3<f32>, normal: vec3<f32>) -> vec3<f32> {
    var g = cross(dpdx(rel), dpdy(rel));
    if (dot(g, rel) > 0.0) {
        g = -g;
    }
    var n = normalize(normal);
    if (dot(n, g) < 0.0) {
        n = -n;
    }
    return n;
}

// Octahedral map of a unit vector onto [-1, 1]^2 in the (x, z) plane, the
// lower hemisphere (y < 0) folded over the diagonals (Meyer et al. 2010);
// aquaspec.gpu.gbuffer.oct_decode inverts it.
fn oct_encode(n: vec3<f32>) -> vec2<f32> {
    let p = n.xz / (abs(n.x) + abs(n.y) + abs(n.z));
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    return select(p, (1.0 - abs(p.yx)) * s, n.y < 0.0);
}

// The normal perturbed by a normal-map sample m (unnormalised, filtered) in
// the tangent frame, put on the camera's side as the vertex normal is
// (aquaspec.scene.texture.perturb_normals).
fn mapped_normal(rel: vec3<f32>, normal: vec3<f32>, tangent: vec4<f32>,
                 m: vec3<f32>) -> vec3<f32> {
    let n = normalize(normal);
    let t = tangent.xyz - n * dot(n, tangent.xyz);
    let tl = length(t);
    let t3 = select(vec3<f32>(0.0), t / tl, tl > 0.0);
    let b = cross(n, t3) * select(1.0, -1.0, tangent.w < 0.0);
    let p = t3 * m.x + b * m.y + n * m.z;
    let pl = length(p);
    let mapped = select(n, p / pl, pl > 0.0);
    let facing = facing_normal(rel, n);
    return select(-mapped, mapped, dot(facing, n) > 0.0);
}

fn pack_surface(rel: vec3<f32>, n: vec3<f32>, material: u32) -> vec4<u32> {
    return vec4<u32>(bitcast<u32>(length(rel)), bitcast<u32>(n.y), pack2x16snorm(oct_encode(n)),
                     material);
}

fn surface_out(rel: vec3<f32>, normal: vec3<f32>, material: u32) -> vec4<u32> {
    return pack_surface(rel, facing_normal(rel, normal), material);
}

// One fragment entry point per mode (MODE_*) and target set, each its own
// pipeline: on lavapipe a branch on the mode still ran the texture filter
// for every fragment of every mesh (SIMD lanes run both sides), which cost
// 40 % of the geometry pass of the built-in scene, which has no textures.
@fragment
fn fs_material(in: VsMaterialOut) -> FsOut1 {
    return FsOut1(surface_out(in.rel, in.normal, in.material));
}

// The same, in a scene that also has per-pixel materials (two targets).
@fragment
fn fs_material2(in: VsMaterialOut) -> FsOut2 {
    return FsOut2(surface_out(in.rel, in.normal, in.material), vec4<f32>(0.0));
}

@fragment
fn fs_texture(in: VsTextureOut) -> FsOut2 {
    let dx = dpdxFine(in.uv);
    let dy = dpdyFine(in.uv);
    return FsOut2(surface_out(in.rel, in.normal, PER_PIXEL),
                  vec4<f32>(trilinear(coeff_tex, in.uv, dx, dy), 0.0));
}

// With a normal map (the derivatives are taken first, in uniform control flow).
@fragment
fn fs_material_nm(in: VsMaterialNmOut) -> FsOut1 {
    let dx = dpdxFine(in.uv);
    let dy = dpdyFine(in.uv);
    let n = mapped_normal(in.rel, in.normal, in.tangent,
                          trilinear(normal_tex, in.uv, dx, dy) * 2.0 - 1.0);
    return FsOut1(pack_surface(in.rel, n, in.material));
}

@fragment
fn fs_material_nm2(in: VsMaterialNmOut) -> FsOut2 {
    let dx = dpdxFine(in.uv);
    let dy = dpdyFine(in.uv);
    let n = mapped_normal(in.rel, in.normal, in.tangent,
                          trilinear(normal_tex, in.uv, dx, dy) * 2.0 - 1.0);
    return FsOut2(pack_surface(in.rel, n, in.material), vec4<f32>(0.0));
}

@fragment
fn fs_texture_nm(in: VsTextureNmOut) -> FsOut2 {
    let dx = dpdxFine(in.uv);
    let dy = dpdyFine(in.uv);
    let n = mapped_normal(in.rel, in.normal, in.tangent,
                          trilinear(normal_tex, in.uv, dx, dy) * 2.0 - 1.0);
    return FsOut2(pack_surface(in.rel, n, PER_PIXEL),
                  vec4<f32>(trilinear(coeff_tex, in.uv, dx, dy), 0.0));
}

@fragment
fn fs_vertex_nm(in: VsVertexNmOut) -> FsOut2 {
    let dx = dpdxFine(in.uv);
    let dy = dpdyFine(in.uv);
    let n = mapped_normal(in.rel, in.normal, in.tangent,
                          trilinear(normal_tex, in.uv, dx, dy) * 2.0 - 1.0);
    return FsOut2(pack_surface(in.rel, n, PER_PIXEL), vec4<f32>(in.coeff, 0.0));
}

@fragment
fn fs_vertex(in: VsVertexOut) -> FsOut2 {
    return FsOut2(surface_out(in.rel, in.normal, PER_PIXEL), vec4<f32>(in.coeff, 0.0));
}
