// Marine snow's splat of one disc (aquaspec.gpu.passes.particles: cs_splat,
// and snow_field.wgsl): the pixels its anti-aliased disc reaches get the
// weight clamp(R + 0.5 - rho, 0, 1) / (pi (R^2 + 1/12)) at their centres,
// dropped where the G-buffer's surface is nearer, and (a w L, a w) is
// added into four f32 per pixel (held as u32 for the atomics): rows of the width rounded up to 16 pixels (256 bytes, as the copy
// into the rgba32uint texture snow_accum.wgsl reads needs). The including
// shader declares surface_tex (the G-buffer's surface), snow_prm (the
// particle pass's params) and accum (array<atomic<u32>>).

const PI: f32 = 3.14159265358979;

// Index of channel 0 of pixel (col, row) in the buffer.
fn snow_index(col: u32, row: u32) -> u32 {
    let stride = 16u * ((u32(snow_prm.width) + 15u) / 16u);
    return 4u * (row * stride + col);
}

// x added to the f32 whose bits accum[i] holds (WGSL has no float atomics:
// a compare-exchange loop, repeated only when another invocation wrote the
// pixel in between).
fn add_f32(i: u32, x: f32) {
    if (x == 0.0) {
        return;
    }
    var old = atomicLoad(&accum[i]);
    loop {
        let r = atomicCompareExchangeWeak(&accum[i], old, bitcast<u32>(bitcast<f32>(old) + x));
        if (r.exchanged) {
            break;
        }
        old = r.old_value;
    }
}

// disc: (col, row, radius px, distance m); light: (camera RGB, coverage a).
fn splat_disc(disc: vec4<f32>, light: vec4<f32>) {
    let r = disc.z;
    let reach = r + 0.5;
    let norm = 1.0 / (PI * (r * r + 1.0 / 12.0));
    let w = i32(snow_prm.width);
    let h = i32(snow_prm.height);
    let j0 = max(i32(floor(disc.x - reach)), 0);
    let j1 = min(i32(floor(disc.x + reach)), w - 1);
    let i0 = max(i32(floor(disc.y - reach)), 0);
    let i1 = min(i32(floor(disc.y + reach)), h - 1);
    for (var i = i0; i <= i1; i++) {
        for (var j = j0; j <= j1; j++) {
            let rho = distance(vec2<f32>(f32(j) + 0.5, f32(i) + 0.5), disc.xy);
            let weight = clamp(reach - rho, 0.0, 1.0) * norm;
            let s = bitcast<f32>(textureLoad(surface_tex, vec2<i32>(j, i), 0).x);
            if (weight > 0.0 && (s < 0.0 || disc.w < s)) {
                let alpha = weight * light.w;
                let p = snow_index(u32(j), u32(i));
                add_f32(p, alpha * light.x);
                add_f32(p + 1u, alpha * light.y);
                add_f32(p + 2u, alpha * light.z);
                add_f32(p + 3u, alpha);
            }
        }
    }
}
