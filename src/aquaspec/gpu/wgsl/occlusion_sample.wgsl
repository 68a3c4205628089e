// The occlusion factors' grid read by the light-field pass
// (aquaspec.gpu.passes.lightfield, OCCLUSION; written by
// aquaspec.gpu.passes.occlusion): binding 26 (lightfield.B_OCCLUSION), layer
// g holding bands 4g .. 4g + 3. Cell c stands for pixel OCC_SCALE c +
// OCC_SCALE / 2, so pixel p sits at cell coordinate (p - OCC_SCALE / 2) /
// OCC_SCALE. The four pixels' coordinates are set once
// (occlusion_coords); at the start of each group of four bands the band
// loop samples that group's layer once per pixel (fill_occlusion) into
// occ_band, which shade_band reads with a constant index (a per-pixel array
// over all bands, indexed by band, cost 40 ms more per 1280x720 frame on a
// loaded host). With cells of 4 pixels or more (OCC_GROUP) the four
// adjacent pixels of the full-resolution pass share one sample at their
// centre (within one cell of each other).
@group(0) @binding(26) var occ_tex: texture_2d_array<f32>;

fn occlusion_coords(px: vec4<u32>, py: vec4<u32>) {
    let dims = vec2<f32>(textureDimensions(occ_tex));
    let half = f32(OCC_SCALE / 2u);
    occ_u = ((vec4<f32>(px) - half) / f32(OCC_SCALE) + 0.5) / dims.x;
    occ_v = ((vec4<f32>(py) - half) / f32(OCC_SCALE) + 0.5) / dims.y;
}

const OCC_GROUP: bool = OCC_SCALE >= 4u && !COARSE;

fn fill_occlusion(q: u32) {
    if (OCC_GROUP) {
        let c = textureSampleLevel(occ_tex, table_sampler,
                                   vec2<f32>(0.5 * (occ_u.y + occ_u.z), occ_v.x), q, 0.0);
        occ_band[0] = vec4<f32>(c.x);
        occ_band[1] = vec4<f32>(c.y);
        occ_band[2] = vec4<f32>(c.z);
        occ_band[3] = vec4<f32>(c.w);
        return;
    }
    let o0 = textureSampleLevel(occ_tex, table_sampler, vec2<f32>(occ_u.x, occ_v.x), q, 0.0);
    let o1 = textureSampleLevel(occ_tex, table_sampler, vec2<f32>(occ_u.y, occ_v.y), q, 0.0);
    let o2 = textureSampleLevel(occ_tex, table_sampler, vec2<f32>(occ_u.z, occ_v.z), q, 0.0);
    let o3 = textureSampleLevel(occ_tex, table_sampler, vec2<f32>(occ_u.w, occ_v.w), q, 0.0);
    occ_band[0] = vec4<f32>(o0.x, o1.x, o2.x, o3.x);
    occ_band[1] = vec4<f32>(o0.y, o1.y, o2.y, o3.y);
    occ_band[2] = vec4<f32>(o0.z, o1.z, o2.z, o3.z);
    occ_band[3] = vec4<f32>(o0.w, o1.w, o2.w, o3.w);
}
