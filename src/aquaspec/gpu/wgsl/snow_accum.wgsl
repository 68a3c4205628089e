// Marine snow's accumulation (aquaspec.gpu.passes.particles): camera RGB S
// and the coverage alpha per pixel, f32 held as u32. The splat adds into a
// buffer (atomics, snow_splat.wgsl), which is then copied into an
// rgba32uint texture: the shaders that compose read texels (on lavapipe a
// texel load cost a fifth of a storage buffer's). The including shader
// declares snow_tex (texture_2d<u32>).

// The particles' camera RGB S and coverage alpha at pixel (col, row).
fn snow_accumulated(col: u32, row: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(textureLoad(snow_tex, vec2<u32>(col, row), 0));
}
