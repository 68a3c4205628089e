// Marine snow composed over an invocation's four pixels of a row before the
// fused display transform (lightfield.wgsl with
// aquaspec.gpu.passes.lightfield.LightfieldPass.set_snow): the particle
// pass's accumulated discs (aquaspec.gpu.passes.particles, snow_accum.wgsl:
// camera RGB S and coverage alpha, one texel per pixel) over the linear image,
// L' = L max(1 - alpha, 0) + S / max(alpha, 1)
// (aquaspec.shading.particles.composite).

{{ snow_struct }}

@group(0) @binding(27) var snow_tex: texture_2d<u32>;
@group(0) @binding(28) var<uniform> snow_prm: {{ snow_params }};

#include "snow_accum.wgsl"

// The four pixels of a row from column j0.
fn snow_compose(j0: u32, row: u32, c: Rgb4) -> Rgb4 {
    var a: vec4<f32>;
    var sr: vec4<f32>;
    var sg: vec4<f32>;
    var sb: vec4<f32>;
    let last = u32(snow_prm.width) - 1u;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let t = snow_accumulated(min(j0 + k, last), row);
        sr[k] = t.x;
        sg[k] = t.y;
        sb[k] = t.z;
        a[k] = t.w;
    }
    let keep = max(1.0 - a, vec4<f32>(0.0));
    let f = 1.0 / max(a, vec4<f32>(1.0));
    return Rgb4(c.r * keep + sr * f, c.g * keep + sg * f, c.b * keep + sb * f);
}
