// The G-buffer's surface normal in WGSL, shared by the passes that need the
// whole normal (sunlight.wgsl, the occlusion factors' occlusion.wgsl).

// aquaspec.gpu.gbuffer.oct_decode of the G-buffer's normal word, then n_y kept exact
// (unpack_surface).
fn decode_normal(oct: u32, n_y_bits: u32) -> vec3<f32> {
    let p = unpack2x16snorm(oct);
    let y = 1.0 - abs(p.x) - abs(p.y);
    let s = select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    let xz = select(p, (1.0 - abs(p.yx)) * s, y < 0.0);
    let n_y = clamp(bitcast<f32>(n_y_bits), -1.0, 1.0);
    let h = length(xz);
    let scale = select(0.0, sqrt(max(1.0 - n_y * n_y, 0.0)) / h, h > 0.0);
    return vec3<f32>(xz.x * scale, n_y, xz.y * scale);
}
