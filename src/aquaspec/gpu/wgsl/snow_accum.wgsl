// Marine snow's accumulation (aquaspec.gpu.passes.particles): camera RGB
// times the frame's scale and the coverage alpha, in fixed point, four u32
// per pixel. The splat adds into a buffer (atomics), pixel by pixel in rows
// of SNOW_ROW pixels (the width rounded up to 16, so that the buffer copies
// into an rgba32uint texture), which is then copied into that texture: the
// shaders that compose read texels (on lavapipe a texel load cost a fifth of
// a storage buffer's). The including shader declares snow_prm (the particle
// pass's params) and, to read, snow_tex (texture_2d<u32>).

// Index of channel 0 of pixel (col, row) in the buffer.
fn snow_index(col: u32, row: u32) -> u32 {
    let stride = 16u * ((u32(snow_prm.width) + 15u) / 16u);
    return 4u * (row * stride + col);
}

// The particles' camera RGB S and coverage alpha at pixel (col, row) (the scales taken off).
fn snow_accumulated(col: u32, row: u32) -> vec4<f32> {
    let t = vec4<f32>(textureLoad(snow_tex, vec2<u32>(col, row), 0));
    return vec4<f32>(t.xyz * (snow_prm.inv_scale / snow_prm.fixed), t.w / snow_prm.fixed);
}
