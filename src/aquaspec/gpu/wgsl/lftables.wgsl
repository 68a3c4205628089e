// Coordinates on the light-field tables' axes (aquaspec.transport.lightfield.tables.table_lookup,
// table_depths / table_cosines), shared by lightfield.wgsl and
// watertable.wgsl. Texel k of an axis is at coordinate k.

// arcsin of |z| <= 0.5 (Cephes asinf polynomial, about 1 ulp).
fn asin_small(z: vec4<f32>) -> vec4<f32> {
    let q = z * z;
    return z + z * q * ((((4.2163199048e-2 * q + 2.4181311049e-2) * q + 4.5470025998e-2) * q
        + 7.4953002686e-2) * q + 1.6666752422e-1);
}

// Direction coordinate y = (1 - acos(v) / pi) (n_mu - 1).
// Not WGSL's acos: lavapipe's is off by up to 1.6e-4 rad (3e-3 of a table
// cell with 65 directions), visible against the float64 reference.
// acos(v) = pi / 2 - asin(v) for |v| <= 1/2, else 2 asin(sqrt((1 - |v|) / 2))
// (pi minus that for v < 0).
fn table_cos_coord(v: vec4<f32>, n_mu: u32) -> vec4<f32> {
    let a = min(abs(v), vec4<f32>(1.0));
    let far = 2.0 * asin_small(sqrt(0.5 - 0.5 * a));
    let acos_v = select(0.5 * PI - asin_small(v), select(far, PI - far, v < vec4<f32>(0.0)),
                        a > vec4<f32>(0.5));
    return (1.0 - acos_v / PI) * f32(n_mu - 1u);
}

// Depth coordinate x = sqrt(clamp(d, 0, D) / D) (n_depth - 1).
fn table_depth_coord(depth: vec4<f32>, max_depth: f32, n_depth: u32) -> vec4<f32> {
    return sqrt(clamp(depth, vec4<f32>(0.0), vec4<f32>(max_depth)) / max_depth)
        * f32(n_depth - 1u);
}
