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
// Per-texel sigmoid coefficients of a textured mesh (rgba32float is not
// filterable, so the bilinear filter is done here with textureLoad).
@group(1) @binding(1) var coeff_tex: texture_2d<f32>;

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

fn wrap(i: i32, n: i32) -> i32 {
    return ((i % n) + n) % n;
}

// Bilinear, repeat-wrapped; uv origin at the bottom-left, texel row 0 at the top.
fn sample_coeff(uv: vec2<f32>) -> vec3<f32> {
    let size = vec2<i32>(textureDimensions(coeff_tex));
    let p = vec2<f32>(uv.x, 1.0 - uv.y) * vec2<f32>(size) - 0.5;
    let p0 = floor(p);
    let f = p - p0;
    let i0 = vec2<i32>(p0);
    let x0 = wrap(i0.x, size.x);
    let x1 = wrap(i0.x + 1, size.x);
    let y0 = wrap(i0.y, size.y);
    let y1 = wrap(i0.y + 1, size.y);
    let a = textureLoad(coeff_tex, vec2<i32>(x0, y0), 0).xyz;
    let b = textureLoad(coeff_tex, vec2<i32>(x1, y0), 0).xyz;
    let c = textureLoad(coeff_tex, vec2<i32>(x0, y1), 0).xyz;
    let d = textureLoad(coeff_tex, vec2<i32>(x1, y1), 0).xyz;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
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

fn surface_out(rel: vec3<f32>, normal: vec3<f32>, material: u32) -> vec4<u32> {
    let n = facing_normal(rel, normal);
    return vec4<u32>(bitcast<u32>(length(rel)), bitcast<u32>(n.y), pack2x16snorm(oct_encode(n)),
                     material);
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
    return FsOut2(surface_out(in.rel, in.normal, PER_PIXEL), vec4<f32>(sample_coeff(in.uv), 0.0));
}

@fragment
fn fs_vertex(in: VsVertexOut) -> FsOut2 {
    return FsOut2(surface_out(in.rel, in.normal, PER_PIXEL), vec4<f32>(in.coeff, 0.0));
}
