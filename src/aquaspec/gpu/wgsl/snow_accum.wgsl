// Marine snow's accumulation buffer read back (aquaspec.gpu.passes.particles,
// cs_splat): four u32 per pixel, camera RGB times the frame's scale and the
// coverage alpha, in fixed point. The including shader declares
// snow_in (array<u32>) and snow_prm (the particle pass's params).

// The particles' camera RGB S and coverage alpha at pixel p (the scales taken off).
fn snow_accumulated(p: u32) -> vec4<f32> {
    let q = 4u * p;
    let to_rgb = snow_prm.inv_scale / snow_prm.fixed;
    return vec4<f32>(f32(snow_in[q]) * to_rgb, f32(snow_in[q + 1u]) * to_rgb,
                     f32(snow_in[q + 2u]) * to_rgb, f32(snow_in[q + 3u]) / snow_prm.fixed);
}
