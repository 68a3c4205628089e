// What both shading passes (deferred.wgsl, lightfield.wgsl) do alike for the
// four horizontally adjacent pixels one invocation shades (vec4 lanes, pixel
// k in component k): the G-buffer and output bindings, the interleaved rows,
// reading the G-buffer, which pixels hit before the water surface, their
// materials, the band loop over the material table and the write of linear
// RGB or (DISPLAY) display RGBA8.
//
// The including shader defines N_BANDS, DISPLAY, TONEMAP,
// PER_PIXEL_MATERIALS, the uniform struct of {{ display_struct_name }}, and
// for the band loop a struct BandPixels (what a band needs of the four
// pixels) and
//   fn shade_band(i: u32, rho_m: vec4<f32>, p: BandPixels, acc: ptr<function, Rgb4>)
// which adds band i (material reflectance rho_m, 0 where none) to acc, and
//   fn band_group_start(q: u32)
// called before bands 4q .. 4q + 3 (per-group data of the four pixels,
// such as the light-field pass's occlusion factors; may do nothing).
// The per-band loop reads the band table (a uniform array) and the material
// table by index inside shade_band: no array goes into a function by value
// (on lavapipe an array argument in the band loop made 32 bands 20x slower).

#include "common.wgsl"
#include "tonemap.wgsl"
#include "materials.wgsl"

// G-buffer: the geometry pass's render targets (aquaspec.gpu.gbuffer):
// surface (S bits, n_y bits, octahedral normal, material index) and sigmoid
// (c0, c1, c2, unused).
@group(0) @binding(1) var gb_surface: texture_2d<u32>;
@group(0) @binding(2) var gb_sigmoid: texture_2d<f32>;
// The outputs (aquaspec.gpu.shading_output): linear RGB; status[0] pixels
// with a material index out of range, with DISPLAY status[2] pixels with a
// non-finite value (written black) and status[3] the smallest such pixel
// index; the display transform's uniform and the packed RGBA8 image.
@group(0) @binding(6) var<storage, read_write> rgb_out: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
@group(0) @binding(9) var<uniform> disp: {{ display_struct_name }};
@group(0) @binding(10) var<storage, read_write> rgba_out: array<u32>;

// Material index meaning "use this pixel's sigmoid coefficients" (gbuffer.PER_PIXEL).
const PER_PIXEL: u32 = 0xffffffffu;

// The row of local row lid_y in workgroup row wg_y of nwg_y: rows of
// workgroups are interleaved, top half / bottom half. lavapipe gives each
// CPU thread a contiguous part of the dispatch, and the two halves of a
// typical frame (water above, seabed below) cost differently.
fn interleaved_row(wg_y: u32, lid_y: u32, nwg_y: u32) -> u32 {
    let half = (nwg_y + 1u) / 2u;
    let block = select(half + wg_y / 2u, wg_y / 2u, wg_y % 2u == 0u);
    return block * {{ workgroup_y }}u + lid_y;
}

// The G-buffer at four pixels (columns px, rows py): the hit distance S
// (negative: none), n_y, the octahedral normal's word (gbuffer_normal.wgsl's
// decode_normal), the material index and (PER_PIXEL_MATERIALS) the sigmoid
// coefficients.
struct GbufferPixels {
    s: vec4<f32>,
    n_y: vec4<f32>,
    oct: vec4<u32>,
    material: vec4<u32>,
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
}

fn load_gbuffer(px: vec4<u32>, py: vec4<u32>) -> GbufferPixels {
    var g: GbufferPixels;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let xy = vec2<u32>(px[k], py[k]);
        let surf = textureLoad(gb_surface, xy, 0);
        g.s[k] = bitcast<f32>(surf.x);
        g.n_y[k] = bitcast<f32>(surf.y);
        g.oct[k] = surf.z;
        g.material[k] = surf.w;
        if (PER_PIXEL_MATERIALS) {
            let c = textureLoad(gb_sigmoid, xy, 0).xyz;
            g.c0[k] = c.x;
            g.c1[k] = c.y;
            g.c2[k] = c.z;
        }
    }
    return g;
}

// Whether each ray hits its G-buffer surface (S >= 0) before the water
// surface (rays going up reach it at depth_o / v_y).
fn hit_before_surface(s: vec4<f32>, v_y: vec4<f32>, depth_o: f32) -> vec4<bool> {
    let up = v_y > vec4<f32>(0.0);
    return (s >= vec4<f32>(0.0)) & (!up | (s <= depth_o / select(vec4<f32>(1.0), v_y, up)));
}

// Where the four pixels' reflectances come from: per-pixel sigmoid
// coefficients (c0, c1, c2, zero elsewhere), a row of the material table
// (mrow: each pixel's first vec4, 0 where unused: it exists, and
// material_group zeroes it), or nothing.
struct PixelMaterials {
    use_sigmoid: vec4<bool>,
    use_material: vec4<bool>,
    mrow: vec4<u32>,
    c0: vec4<f32>,
    c1: vec4<f32>,
    c2: vec4<f32>,
}

// The materials of the hits among the four pixels; hits with an
// out-of-range material index (or PER_PIXEL in a G-buffer declared without
// per-pixel materials) among the counted lanes are reported in status[0]
// (the host raises; those pixels get rho = 0).
fn pixel_materials(g: GbufferPixels, hit: vec4<bool>, n_materials: u32,
                   counted: vec4<bool>) -> PixelMaterials {
    let use_sigmoid = hit & (g.material == vec4<u32>(PER_PIXEL)) & vec4<bool>(PER_PIXEL_MATERIALS);
    let use_material = hit & !use_sigmoid & (g.material < vec4<u32>(n_materials));
    let zero = vec4<f32>(0.0);
    let bad = counted & hit & !use_sigmoid & !use_material;
    let ones = select(vec4<u32>(0u), vec4<u32>(1u), bad);
    let n_bad = ones.x + ones.y + ones.z + ones.w;
    if (n_bad > 0u) {
        atomicAdd(&status[0], n_bad);
    }
    return PixelMaterials(use_sigmoid, use_material,
                          select(vec4<u32>(0u), g.material * MATERIAL_GROUPS, use_material),
                          select(zero, g.c0, use_sigmoid), select(zero, g.c1, use_sigmoid),
                          select(zero, g.c2, use_sigmoid));
}

// The N_BANDS bands of the four pixels added to acc by shade_band (none
// unless run), one material vec4 per pixel for four bands
// (aquaspec.gpu.materials): below GROUPED_MIN_BANDS nested loops, from it
// four band bodies per iteration, then N_BANDS % 4. run sets trip counts
// (lavapipe leaves a loop when no SIMD lane has iterations left, which a
// branch around it would not do).
fn band_loop(m: PixelMaterials, run: bool, p: BandPixels, acc: ptr<function, Rgb4>) {
    if (!GROUPED_BANDS) {
        // A material vec4 per outer iteration, a band per inner one (trip
        // counts per invocation: the loops stay loops, as materials.wgsl says).
        if (N_BANDS < 4u) {
            // (One vec4, read outside any loop: with 3 bands the outer loop's
            // single iteration cost 1.1-1.3 ms per 1280x720 frame.)
            let g = material_group(m.mrow, 0u, m.use_material);
            band_group_start(0u);
            let n_in = select(0u, N_BANDS, run);
            for (var j = 0u; j < n_in; j = j + 1u) {
                shade_band(j, group_band(g, j), p, acc);
            }
        } else {
            let n_outer = select(0u, MATERIAL_GROUPS, run);
            for (var q = 0u; q < n_outer; q = q + 1u) {
                let g = material_group(m.mrow, q, m.use_material);
                band_group_start(q);
                let n_in = min(4u, N_BANDS - 4u * q);
                for (var j = 0u; j < n_in; j = j + 1u) {
                    shade_band(4u * q + j, group_band(g, j), p, acc);
                }
            }
        }
    }
    let n_groups = select(0u, select(0u, FULL_GROUPS, run), GROUPED_BANDS);
    for (var q = 0u; q < n_groups; q = q + 1u) {
        let g = material_group(m.mrow, q, m.use_material);
        band_group_start(q);
        shade_band(4u * q, group_band(g, 0u), p, acc);
        shade_band(4u * q + 1u, group_band(g, 1u), p, acc);
        shade_band(4u * q + 2u, group_band(g, 2u), p, acc);
        shade_band(4u * q + 3u, group_band(g, 3u), p, acc);
    }
    let n_rest = select(0u, select(0u, 1u, GROUPED_BANDS && REST_BANDS > 0u), run);
    for (var t = 0u; t < n_rest; t = t + 1u) {
        let g = material_group(m.mrow, FULL_GROUPS, m.use_material);
        band_group_start(FULL_GROUPS);
        let i = 4u * FULL_GROUPS;
        shade_band(i, group_band(g, 0u), p, acc);
        if (REST_BANDS > 1u) {
            shade_band(i + 1u, group_band(g, 1u), p, acc);
        }
        if (REST_BANDS > 2u) {
            shade_band(i + 2u, group_band(g, 2u), p, acc);
        }
    }
}

// The four pixels' camera RGB (channels r, g, b) written at row, columns
// j0 .. j0 + 3 of an image width pixels wide (those inside it): linear RGB,
// or with DISPLAY display.wgsl's main for each, non-finite ones (or ones
// that overflow after exposure) written black and reported once per
// invocation (atomics in a per-pixel branch cost a millisecond per 1280x720
// frame on lavapipe, masked for every lane).
fn write_pixels(row: u32, j0: u32, width: u32, r: vec4<f32>, g: vec4<f32>, b: vec4<f32>) {
    let row_start = row * width;
    if (DISPLAY) {
        var n_bad = 0u;
        var first_bad = 0xffffffffu;
        for (var k = 0u; k < 4u; k = k + 1u) {
            if (j0 + k < width) {
                let p = row_start + j0 + k;
                let lin = vec3<f32>(r[k], g[k], b[k]);
                let c = max(lin, vec3<f32>(0.0));
                let x = vec3<f32>(dot(disp.m0, c), dot(disp.m1, c), dot(disp.m2, c));
                let bad = any_non_finite(lin) || any_non_finite(x);
                n_bad = n_bad + select(0u, 1u, bad);
                first_bad = select(first_bad, min(first_bad, p), bad);
                rgba_out[p] = select(display_rgba8(x), 0xff000000u, bad);
            }
        }
        if (n_bad > 0u) {
            atomicAdd(&status[2], n_bad);
            atomicMin(&status[3], first_bad);
        }
    } else {
        for (var k = 0u; k < 4u; k = k + 1u) {
            if (j0 + k < width) {
                rgb_out[row_start + j0 + k] = vec4<f32>(r[k], g[k], b[k], 1.0);
            }
        }
    }
}
