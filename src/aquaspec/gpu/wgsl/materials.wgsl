// Material band reflectances, four bands to a vec4 (aquaspec.gpu.materials):
// row m of the table is material m, MATERIAL_GROUPS vec4 long, band i in
// component i % 4 of vec4 i / 4 (zeros past the last band). In a uniform
// array when the table fits in 64 KiB (MATERIALS_IN_UNIFORM), else in a
// storage buffer. Needs the including shader's N_BANDS.
//
// Measured on lavapipe, 1280x720, four pixels per invocation: in a
// micro-benchmark (8 bands, one exponential each) the reflectance reads cost
// 4.3-4.5 ms a frame from a storage buffer and 1.0-1.1 ms from a uniform
// array. Both shading passes read one vec4 per pixel for four bands. From
// GROUPED_MIN_BANDS bands their loops take four bands per iteration (the
// band body written out four times); below it a loop over the vec4s holds a
// loop over their bands, both with trip counts that differ between
// invocations, so that they stay loops. Against a band per iteration
// (reading a vec4 per band), alternating in one run (2026-11-24): 1-1.4 ms
// faster at 3 and 8 bands for both passes; at 16 and 32 bands the
// written-out bodies were 0.3-0.6 and 1-4 ms faster than the nested loops.

const MATERIAL_GROUPS: u32 = (N_BANDS + 3u) / 4u;
// Bands in whole vec4s, and the bands of the last, partial one.
const FULL_GROUPS: u32 = N_BANDS / 4u;
const REST_BANDS: u32 = N_BANDS % 4u;
// Whether the band loops write out four band bodies per iteration or nest
// a loop over each vec4's bands in a loop over the vec4s.
const GROUPED_BANDS: bool = N_BANDS >= {{ grouped_min_bands }}u;
const MATERIALS_IN_UNIFORM: bool = {{ materials_in_uniform }};
const MATERIAL_UNIFORM_VEC4: u32 = {{ material_uniform_vec4 }}u;

@group(0) @binding(3) var<storage, read> material_storage: array<vec4<f32>>;
@group(0) @binding(5) var<uniform> material_uniform: array<vec4<f32>, MATERIAL_UNIFORM_VEC4>;

fn material_vec4(index: u32) -> vec4<f32> {
    if (MATERIALS_IN_UNIFORM) {
        return material_uniform[index];
    }
    return material_storage[index];
}

// Four bands (group g) of four pixels' reflectances: pixel k's in p[k].
// row: each pixel's first vec4 (material * MATERIAL_GROUPS).
struct MaterialGroup {
    p0: vec4<f32>,
    p1: vec4<f32>,
    p2: vec4<f32>,
    p3: vec4<f32>,
}

fn material_vec4s(row: vec4<u32>, g: u32) -> MaterialGroup {
    return MaterialGroup(material_vec4(row.x + g), material_vec4(row.y + g),
                         material_vec4(row.z + g), material_vec4(row.w + g));
}

// Band j (0-3) of a group: the four pixels' values.
fn group_band(m: MaterialGroup, j: u32) -> vec4<f32> {
    return vec4<f32>(m.p0[j], m.p1[j], m.p2[j], m.p3[j]);
}

// The group with pixel k's values zeroed where use_material[k] is false.
fn material_group(row: vec4<u32>, g: u32, use_material: vec4<bool>) -> MaterialGroup {
    let m = material_vec4s(row, g);
    let zero = vec4<f32>(0.0);
    return MaterialGroup(select(zero, m.p0, use_material.x), select(zero, m.p1, use_material.y),
                         select(zero, m.p2, use_material.z), select(zero, m.p3, use_material.w));
}
