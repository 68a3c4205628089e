// The wave tile's facet at a point (u, w) = (x, z) of the mean plane: its
// slopes read bilinearly and periodically from `slopes` (row i is z, column j
// is x, the tile prm.tile_m wide on prm.tile_grid points a side), the unit
// normal (-dh/dx, 1, -dh/dz) normalised: the WGSL twin of
// aquaspec.light.wave_facets.SurfaceFacets.normals. The including shader
// declares `slopes` (array<vec2<f32>>) and a `prm` with tile_grid and tile_m.
// Shared by the sea seen from above (above.wgsl) and from below
// (below_waves.wgsl).
fn wave_facet(u: f32, w: f32) -> vec3<f32> {
    let m = f32(prm.tile_grid);
    let fu = u / prm.tile_m * m;
    let fw = w / prm.tile_m * m;
    let u0 = floor(fu);
    let w0 = floor(fw);
    let au = fu - u0;
    let aw = fw - w0;
    let g = i32(prm.tile_grid);
    let j0 = ((i32(u0) % g) + g) % g;
    let i0 = ((i32(w0) % g) + g) % g;
    let j1 = (j0 + 1) % g;
    let i1 = (i0 + 1) % g;
    let top = mix(slopes[i0 * g + j0], slopes[i0 * g + j1], au);
    let bottom = mix(slopes[i1 * g + j0], slopes[i1 * g + j1], au);
    let sl = mix(top, bottom, aw);
    return normalize(vec3<f32>(-sl.x, 1.0, -sl.y));
}
