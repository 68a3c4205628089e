// Adds one camera-RGB image to another in place: rgb[p] += change[p] for the
// width x height pixels, p = row * width + column (vec4 per pixel, w kept).
// A live frame adds what a later pass computes (the surface seen from
// below) to the shading's linear image before its display transform.

{{ params_struct }}

@group(0) @binding(0) var<uniform> prm: {{ params_struct_name }};
@group(0) @binding(1) var<storage, read> change: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> rgb: array<vec4<f32>>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= prm.width || gid.y >= prm.height) {
        return;
    }
    let p = gid.y * prm.width + gid.x;
    rgb[p] = vec4<f32>(rgb[p].xyz + change[p].xyz, rgb[p].w);
}
