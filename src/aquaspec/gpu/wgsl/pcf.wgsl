// Percentage-closer filtering of one shadow-map lookup: the 2x2 texels a
// textureGatherCompare returned (g: x = (j0, i0 + 1), y = (j0 + 1, i0 + 1),
// z = (j0 + 1, i0), w = (j0, i0), WebGPU's gather order) blended bilinearly
// at (j0 + fx, i0 + fy); texels outside the size x size map count as lit.
// Shared by the sun's shadow map (sunlight.wgsl) and the lamps' (lamps.wgsl).
fn pcf_blend(g: vec4<f32>, j0: f32, i0: f32, fx: f32, fy: f32, size: f32) -> f32 {
    let out_j0 = j0 < 0.0 || j0 >= size;
    let out_j1 = j0 + 1.0 < 0.0 || j0 + 1.0 >= size;
    let out_i0 = i0 < 0.0 || i0 >= size;
    let out_i1 = i0 + 1.0 < 0.0 || i0 + 1.0 >= size;
    let lit = select(g, vec4<f32>(1.0), vec4<bool>(out_j0 || out_i1, out_j1 || out_i1,
                                                   out_j1 || out_i0, out_j0 || out_i0));
    return mix(mix(lit.w, lit.z, fx), mix(lit.x, lit.y, fx), fy);
}
