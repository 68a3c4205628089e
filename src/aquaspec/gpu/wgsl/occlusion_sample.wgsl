// The occlusion factors' grid read by the light-field pass
// (aquaspec.gpu.passes.lightfield, OCCLUSION; written by
// aquaspec.gpu.passes.occlusion): binding 26 (lightfield.B_OCCLUSION), layer
// g holding bands 4g .. 4g + 3. Cell c stands for pixel OCC_SCALE c +
// OCC_SCALE / 2, so pixel p sits at cell coordinate (p - OCC_SCALE / 2) /
// OCC_SCALE; one bilinear sample per layer and pixel, into occ_band (band i,
// the four lanes) for shade_band.
@group(0) @binding(26) var occ_tex: texture_2d_array<f32>;

fn fill_occlusion(px: vec4<u32>, py: vec4<u32>) {
    let dims = vec2<f32>(textureDimensions(occ_tex));
    let half = f32(OCC_SCALE / 2u);
    for (var k = 0u; k < 4u; k = k + 1u) {
        let cell = (vec2<f32>(f32(px[k]), f32(py[k])) - half) / f32(OCC_SCALE);
        let uv = (cell + 0.5) / dims;
        for (var g = 0u; g < OCC_LAYERS; g = g + 1u) {
            let o = textureSampleLevel(occ_tex, table_sampler, uv, g, 0.0);
            for (var j = 0u; j < 4u; j = j + 1u) {
                let i = 4u * g + j;
                if (i < N_BANDS) {
                    occ_band[i][k] = o[j];
                }
            }
        }
    }
}
