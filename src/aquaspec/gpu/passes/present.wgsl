// Present: the display pass's packed RGBA8 image -> a render target (the
// window's surface texture, or any texture of the same format), one
// fullscreen triangle, no readback.
//
// The image is `width * height` u32, pixel p = row * width + column, packed
// r | g << 8 | b << 16 | a << 24 and already sRGB-encoded (display.wgsl,
// tonemap.wgsl). A target of another size samples it nearest-neighbour
// (fragment centre scaled into the image), so equal sizes copy every pixel
// exactly. On a unorm target the encoded bytes are written as they are; an
// -srgb target would encode them a second time, so for one the shader
// decodes them first (DECODE_SRGB, a compile-time constant).
//
// An overlay (text, RGBA8 with straight alpha, sRGB-encoded like the image)
// covers the target's top-left overlay_size pixels one to one, mixed over the
// image by its alpha before any decoding; outside it, or with overlay_size 0,
// the image passes unchanged.

{{ present_struct }}

const DECODE_SRGB: bool = {{ decode_srgb }};

@group(0) @binding(0) var<uniform> params: {{ present_struct_name }};
@group(0) @binding(1) var<storage, read> rgba8: array<u32>;
@group(0) @binding(2) var overlay: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // Vertices (-1, -1), (3, -1), (-1, 3): one triangle over the whole target.
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

fn srgb_decode(c: vec3<f32>) -> vec3<f32> {
    let lo = c / 12.92;
    let hi = pow((c + 0.055) / 1.055, vec3<f32>(2.4));
    return select(hi, lo, c <= vec3<f32>(0.04045));
}

@fragment
fn fs_main(@builtin(position) frag: vec4<f32>) -> @location(0) vec4<f32> {
    // frag.xy is the target pixel's centre (x right, y down, in pixels).
    let image = vec2<f32>(params.image_size);
    let scaled = floor(frag.xy * image / vec2<f32>(params.target_size));
    let src = vec2<u32>(clamp(scaled, vec2<f32>(0.0), image - 1.0));
    var c = unpack4x8unorm(rgba8[src.y * params.image_size.x + src.x]).rgb;
    let px = vec2<u32>(frag.xy);
    if (all(px < params.overlay_size)) {
        let o = textureLoad(overlay, px, 0);
        c = mix(c, o.rgb, o.a);
    }
    if (DECODE_SRGB) {
        return vec4<f32>(srgb_decode(c), 1.0);
    }
    return vec4<f32>(c, 1.0);
}
