// The CIE standard clear sky's radiance relative to a uniform sky of the same
// irradiance (twin of aquaspec.light.sky.clear_sky_shape: ISO 15469 sky type
// 12, gradation 1 - exp(-0.32 / cos Z), indicatrix 1 + 10 (exp(-3 chi) -
// exp(-3 pi / 2)) + 0.45 cos^2 chi), times norm (light.sky.clear_sky_norm).
// Directions at or below the horizon take the horizon's value.
fn clear_sky(d: vec3<f32>, to_sun: vec3<f32>, norm: f32) -> f32 {
    let mu = max(d.y, 0.0);
    var gradation = 1.0;
    if (mu > 0.0) {
        gradation = 1.0 - exp(-0.32 / mu);
    }
    let cos_chi = clamp(dot(d, to_sun), -1.0, 1.0);
    // atan2, not acos: float32's acos loses the angle near the sun.
    let chi = atan2(length(cross(d, to_sun)), dot(d, to_sun));
    let indicatrix = 1.0 + 10.0 * (exp(-3.0 * chi) - exp(-3.0 * 1.5707963267948966))
        + 0.45 * cos_chi * cos_chi;
    return norm * gradation * indicatrix;
}
