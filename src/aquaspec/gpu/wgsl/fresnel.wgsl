// Unpolarised Fresnel transmittance into a medium of n times the incident
// index (n > 1) at incidence cosine cos_i (clamped to [0, 1]): the WGSL twin
// of aquaspec.medium.interface.fresnel_transmittance. Shared by the sea seen
// from above (above.wgsl) and the camera's flat port (flat_port.wgsl).
fn fresnel_transmittance(cos_i: f32, n: f32) -> f32 {
    let c = clamp(cos_i, 0.0, 1.0);
    let sin_t = sqrt(max(1.0 - c * c, 0.0)) / n;
    let cos_t = sqrt(max(1.0 - sin_t * sin_t, 0.0));
    let rs = (c - n * cos_t) / (c + n * cos_t);
    let rp = (cos_t - n * c) / (cos_t + n * c);
    return 1.0 - 0.5 * (rs * rs + rp * rp);
}

// Fresnel transmittance from water (n times the air's index) into air at
// incidence cosine c on the water side, 0 beyond the critical angle: the
// twin of aquaspec.medium.interface.fresnel_transmittance_out (used by
// below_waves.wgsl).
fn fresnel_transmittance_out(c: f32, n: f32) -> f32 {
    let sin2_air = n * n * (1.0 - c * c);
    if (sin2_air >= 1.0) {
        return 0.0;
    }
    return fresnel_transmittance(sqrt(max(1.0 - sin2_air, 0.0)), n);
}
