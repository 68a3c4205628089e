// The unit ray through the centre of pixel (x, y) of the pass's camera, x
// and y as floats (any pixel, in or out of the image): twin of
// aquaspec.scene.camera.Camera.ray_directions. The including pass names its
// uniform block `prm` and gives it aquaspec.gpu.camera.CAMERA_FIELDS; include
// this after that declaration.
fn camera_ray(x: f32, y: f32) -> vec3<f32> {
    let xc = (x + 0.5 - prm.cx) / prm.fx;
    let yc = (y + 0.5 - prm.cy) / prm.fy;
    return normalize(prm.right * xc - prm.up * yc + prm.forward);
}
