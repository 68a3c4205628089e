"""aquaspec's caustic photon map against Mitsuba 3's particle tracer.

Under a wavy surface with no medium (clear water: only the geometry of
refraction and the Fresnel transmittance matter) lit by a directional sun,
the irradiance on a horizontal plane at depth ``d`` over the irradiance under
a flat surface is exactly the caustic factor ``C`` that
:func:`aquaspec.light.caustics.caustic_slices` computes (module docstring of
:mod:`aquaspec.light.caustics`). This module measures that ratio in Mitsuba 3 and
compares it with aquaspec's map read through :func:`aquaspec.light.caustics.sample`
(foot coordinates, half-precision slices, bilinear periodic lookup).

The Mitsuba scene, one per depth:

- the surface: the tile's height field (:func:`aquaspec.light.waves.surface`,
  ``mesh_oversample`` times refined; by default as fine as aquaspec's
  facets) as a triangle mesh over the part of the periodic sea whose refracted
  light can reach the imaged patch (the tile repeated as needed), with
  *smooth* per-vertex normals ``(-h_x, 1, -h_z)`` normalised. At the
  vertices the normals are exactly aquaspec's facet normals; between them
  Mitsuba interpolates. Flat triangles would refract each triangle's light
  into a parallel beam and draw a pattern of tiles with gaps and overlaps
  that the band-limited surface does not have; smooth normals are the closer
  model of the same surface. The BSDF is ``dielectric`` (``int_ior`` =
  aquaspec's ``n_water``, ``ext_ior`` 1), normals up (+y);
- the sun: a ``directional`` emitter travelling along ``-air_to_sun``
  (a point sun, so aquaspec's map is computed with ``sun_radius_deg = 0``);
- the receiver: a white ``diffuse`` rectangle at ``y = -d``;
- the camera: a ``perspective`` camera under the lowest trough looking
  straight down. Its image plane is parallel to the receiver, so pixels map
  affinely to the plane: each pixel is an exact square of the receiver (the
  pixel size is aquaspec's texel ``L / n``, the pixel centres are placed on
  the texel centres in foot coordinates). Mitsuba's ``orthographic`` camera
  cannot be used: the particle tracer needs ``sample_direction``, which it
  does not implement. The pixel -> world mapping is taken from the sensor
  itself (``sample_ray`` through the pixel centres);
- the integrator: ``ptracer`` (light tracing: a delta sun through a specular
  surface is found only from the light), ``max_depth = 3``: emitter ->
  surface -> receiver -> camera. Longer paths (light the receiver sends up
  and the surface reflects back, about half of it by total internal
  reflection)
  would add a nearly uniform glow that is not in ``C``.

The same scene with a flat surface (a dielectric rectangle at ``y = 0``)
gives the normalisation: ``C_mitsuba = wavy / mean(flat)``; its mean is also
checked against ``(rho / pi) cos z T(cos z)`` (Fresnel into flat water).
Each wavy render is made as two independent halves (seeds ``seed`` and
``seed + 1``), so Mitsuba's noise is measured, not assumed: half the rms
difference of the halves is the noise of their mean.

Point-sun caustics are singular along focal lines, so both patterns are
compared box-filtered over ``k x k`` texel blocks (``blocks``). The two
samplings differ: a Mitsuba pixel is the landed flux averaged over a box of
one texel, aquaspec's texel (read at its centre) the flux splatted
bilinearly onto ``f x f`` finer texels (:data:`aquaspec.light.caustics.DEFAULT_SUPERSAMPLE`)
and summed, ``box * box_f`` (``box_f`` a box ``1/f`` texel wide; with
``f = 1`` the two-texel tent ``box * box``). Each block is therefore
compared twice: ``kernel = "raw"`` as sampled, and ``kernel = "matched"``
with aquaspec's image convolved with the texel box and Mitsuba's with
``box * box_f`` (in Fourier space ``sinc`` and ``sinc(x) sinc(x / f)``
per axis, edges reflected), which removes the sampling difference from the
comparison.

The mesh is a discretisation of its own: between vertices Mitsuba's surface
is flat triangles with interpolated normals. ``mesh_oversample`` refines it
independently of aquaspec's facets; the patterns' residual difference
shrinks as it grows (the check's results record how much).
"""

from __future__ import annotations

import time

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.light import caustics
from aquaspec.light.sun import air_to_sun, refracted_to_sun
from aquaspec.light.waves import Waves, surface
from aquaspec.medium.interface import N_WATER, fresnel_transmittance, refract
from aquaspec.validation.reference import mitsuba_variant

#: Mitsuba variants tried in order: monochrome is enough (the dielectric's
#: index is one number) and the LLVM variants are vectorised.
VARIANTS = ("llvm_ad_mono", "llvm_ad_rgb", "scalar_rgb")
#: Receiver reflectance.
ALBEDO = 1.0
#: Path length: sun -> surface -> receiver -> camera.
MAX_DEPTH = 3
#: The camera's clearance below the lowest trough, metres.
CAMERA_CLEARANCE_M = 0.02


def require_mitsuba():
    """Import Mitsuba 3 and choose a variant of :data:`VARIANTS`:
    ``(mi, previous)``, ``previous`` the variant that was set before (``None``
    if none), for the caller to restore."""
    return mitsuba_variant(VARIANTS, "the caustics check")


def heightfield_mesh(mi, h, hx, hz, tile_m, rows, cols, bsdf):
    """A Mitsuba mesh of the periodic height field over grid rows ``rows =
    (i0, i1)`` (z) and columns ``cols = (j0, j1)`` (x), inclusive, indices
    taken modulo the tile (``h[i, j]`` at ``x = j L / M``, ``z = i L / M``),
    with unit vertex normals ``(-h_x, 1, -h_z)``; triangles wound so their
    geometric normals point up."""
    m = h.shape[0]
    step = tile_m / m
    ii = np.arange(rows[0], rows[1] + 1)
    jj = np.arange(cols[0], cols[1] + 1)
    ni, nj = ii.size, jj.size
    wi, wj = np.meshgrid(ii % m, jj % m, indexing="ij")
    xx, zz = np.meshgrid(jj * step, ii * step)
    pos = np.stack([xx, h[wi, wj], zz], axis=-1).reshape(-1, 3)
    nrm = np.stack([-hx[wi, wj], np.ones((ni, nj)), -hz[wi, wj]], axis=-1).reshape(-1, 3)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    v = np.arange(ni * nj).reshape(ni, nj)
    v00, v10, v01, v11 = v[:-1, :-1], v[1:, :-1], v[:-1, 1:], v[1:, 1:]
    faces = np.concatenate([np.stack([v00, v10, v01], -1).reshape(-1, 3),
                            np.stack([v01, v10, v11], -1).reshape(-1, 3)])
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh("water_surface", ni * nj, faces.shape[0], props=props,
                   has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(pos.astype(np.float32).ravel())
    params["vertex_normals"] = mi.Float(nrm.astype(np.float32).ravel())
    params["faces"] = mi.UInt32(faces.astype(np.uint32).ravel())
    params.update()
    return mesh


def _rectangle(mi, lo, hi, y, bsdf):
    """A horizontal rectangle over ``x`` in ``(lo[0], hi[0])``, ``z`` in
    ``(lo[1], hi[1])`` at height ``y``, its normal up."""
    T = mi.ScalarTransform4f
    c = 0.5 * (np.asarray(lo) + np.asarray(hi))
    half = 0.5 * (np.asarray(hi) - np.asarray(lo))
    # Mitsuba's rectangle is [-1, 1]^2 in the xy plane with normal +z;
    # rotating by -90 deg about x takes +z to +y (and y to -z).
    return {"type": "rectangle",
            "to_world": T().translate([float(c[0]), float(y), float(c[1])])
            .rotate([1, 0, 0], -90).scale([float(half[0]), float(half[1]), 1.0]),
            "bsdf": bsdf}


def _pixel_points(mi, sensor, res, depth):
    """World points (res, res, 3) where the sensor's pixel-centre rays meet
    ``y = -depth``; image ``[row, column]``."""
    rows, cols = np.meshgrid(np.arange(res), np.arange(res), indexing="ij")
    fx = ((cols + 0.5) / res).ravel()
    fy = ((rows + 0.5) / res).ravel()
    out = np.empty((fx.size, 3))
    if mi.variant().startswith("scalar"):
        for k in range(fx.size):
            ray, _ = sensor.sample_ray(0.0, 0.5, [fx[k], fy[k]], [0.5, 0.5])
            o, d = np.array(ray.o, float), np.array(ray.d, float)
            out[k] = o + (-depth - o[1]) / d[1] * d
    else:
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(fx, fy), mi.Point2f(0.5, 0.5))
        o = np.stack([np.array(ray.o.x), np.array(ray.o.y), np.array(ray.o.z)], -1)
        d = np.stack([np.array(ray.d.x), np.array(ray.d.y), np.array(ray.d.z)], -1)
        out = o + ((-depth - o[:, 1]) / d[:, 1])[:, None] * d
    out[:, 1] = -depth
    return out.reshape(res, res, 3)


def block_mean(a, k: int):
    """Means of ``k x k`` blocks of a (N, N) image (N divisible by k)."""
    n = a.shape[0] // k
    return a[:n * k, :n * k].reshape(n, k, n, k).mean(axis=(1, 3))


def _shift(a, b):
    """The circular shift (rows, columns) that best aligns ``b`` onto ``a``."""
    fa = np.fft.fft2(a - a.mean())
    fb = np.fft.fft2(b - b.mean())
    xc = np.fft.ifft2(fa * np.conj(fb)).real
    i, j = np.unravel_index(np.argmax(xc), xc.shape)
    n0, n1 = xc.shape
    return (int((i + n0 // 2) % n0 - n0 // 2), int((j + n1 // 2) % n1 - n1 // 2))


def pattern_metrics(c_aqua, c_mits, noise_img):
    """Agreement of two caustic patterns (same grid): Pearson correlation,
    rms difference over the Mitsuba pattern's std (``rms_rel``), Mitsuba's
    noise rms over the same std (``noise_rel``; ``noise_img``: a zero-mean
    image with the noise of ``c_mits``), the part of the difference noise
    does not explain (``excess_rel``), the ratio of means and of stds."""
    a, m = np.asarray(c_aqua, float).ravel(), np.asarray(c_mits, float).ravel()
    sd = m.std()
    rms = np.sqrt(np.mean((a - m) ** 2))
    noise = np.sqrt(np.mean(np.asarray(noise_img, float) ** 2))
    return {"corr": float(np.corrcoef(a, m)[0, 1]), "rms_rel": float(rms / sd),
            "noise_rel": float(noise / sd),
            "excess_rel": float(np.sqrt(max(rms ** 2 - noise ** 2, 0.0)) / sd),
            "mean_aquaspec": float(a.mean()), "mean_mitsuba": float(m.mean()),
            "mean_ratio": float(a.mean() / m.mean()),
            "std_aquaspec": float(a.std()), "std_mitsuba": float(sd),
            "std_ratio": float(a.std() / sd)}


def _render(mi, scene, spp, seed):
    """A render as (rows, columns) float64 (channels averaged) and its seconds."""
    t0 = time.perf_counter()
    img = np.array(mi.render(scene, spp=int(spp), seed=int(seed)), dtype=np.float64)
    return img.reshape(img.shape[0], img.shape[1], -1).mean(axis=-1), time.perf_counter() - t0


def matched_kernels(c_aqua, c_mits, supersample: int = caustics.DEFAULT_SUPERSAMPLE):
    """Both images with the same sampling kernel ``box * box * box_f``: an
    aquaspec texel is ``box * box_f`` (its splat onto ``f x f`` finer texels,
    tents ``1/f`` wide, summed: ``f = supersample``; 1: the two-texel tent),
    a Mitsuba pixel the box; aquaspec's convolved with the box, Mitsuba's with
    ``box * box_f`` (Fourier, edges reflected)."""
    f = float(supersample)

    def filtered(img, transfer):
        pad = 8
        big = np.pad(np.asarray(img, float), pad, mode="reflect")
        t0, t1 = (transfer(np.fft.fftfreq(n)) for n in big.shape)
        out = np.fft.ifft2(np.fft.fft2(big) * t0[:, None] * t1[None, :]).real
        return out[pad:-pad, pad:-pad]

    def both(x):
        return np.sinc(x) * np.sinc(x / f)

    return filtered(c_aqua, np.sinc), filtered(c_mits, both), lambda img: filtered(img, both)


def compare_caustics(waves: Waves, elevation_deg: float, azimuth_deg: float, depths,
                     *, spp: int = 64, oversample: int = 4, mesh_oversample: int | None = None,
                     view_texels: int | None = None, blocks=(1, 2, 4, 8), seed: int = 0,
                     n_water: float = N_WATER) -> dict:
    """aquaspec's caustic factor against Mitsuba's at ``depths`` (m).

    Parameters
    ----------
    waves : aquaspec.light.waves.Waves
        The sea.
    elevation_deg, azimuth_deg : float
        The sun in air (a point sun).
    depths : sequence of float
        Receiver depths, metres, each one Mitsuba scene.
    spp : int
        Mitsuba light paths per pixel per render (two halves of ``spp // 2``
        each for the wavy surface, ``spp`` for the flat one); a render traces
        ``spp * view_texels^2`` photons.
    oversample : int
        aquaspec's facets per texel side (:func:`aquaspec.light.waves.surface`).
    mesh_oversample : int, optional
        The Mitsuba mesh's vertices per texel side (default ``oversample``).
    view_texels : int, optional
        The imaged square in texels (``L / n`` each), from foot coordinate
        ``(0, 0)``; default the whole tile (then both images are periodic).
    blocks : sequence of int
        Box-filter sizes in texels (dividing ``view_texels``).
    seed : int
        Mitsuba's seed (the halves use ``seed`` and ``seed + 1``, the flat
        render ``seed + 2``).
    n_water : float
        Refractive index of the water.

    Returns
    -------
    dict
        ``metrics``: one dict per (depth, block, kernel) (:func:`pattern_metrics`,
        plus ``depth_m``, ``block``, ``filter_m``, ``kernel`` ("raw" or
        "matched", see the module docstring) and at block 1 ``shift``, the
        (rows, columns) offset of the raw cross-correlation peak);
        ``images``: per depth ``aquaspec``, ``mitsuba``, ``halves``,
        ``flat`` (C-normalised), ``points`` (pixel centres, world);
        ``flat``: per depth the flat render's mean over
        ``(rho / pi) cos z T(cos z)``, its per-pixel relative std, and
        ``pixel_foot_error_m``, how far the pixel centres' feet are from the
        texel centres;
        ``timing_s``: per depth the seconds of each render;
        ``info``: the set-up.
    """
    depths = np.atleast_1d(np.asarray(depths, dtype=float))
    if depths.size == 0 or np.any(~np.isfinite(depths)) or np.any(depths <= 0):
        raise AquaspecError(f"caustics check depths {depths.tolist()}; accepted: positive")
    n = waves.grid
    view = n if view_texels is None else int(view_texels)
    if not 1 <= view <= n:
        raise AquaspecError(f"view of {view_texels!r} texels; accepted: 1 to {n}")
    blocks = tuple(int(b) for b in blocks)
    if any(b < 1 or view % b for b in blocks):
        raise AquaspecError(f"blocks {blocks}; accepted: divisors of the view ({view} texels)")
    if int(spp) < 2:
        raise AquaspecError(f"spp {spp!r}; accepted: 2 or more")
    tile = waves.tile_m
    texel = tile / n
    air = air_to_sun(elevation_deg, azimuth_deg)
    s = refracted_to_sun(elevation_deg, azimuth_deg, n_water)
    mu0 = float(s[1])

    t0 = time.perf_counter()
    mesh_os = int(oversample if mesh_oversample is None else mesh_oversample)
    h, hx, hz = surface(waves, mesh_os)
    m = h.shape[0]
    step = tile / m
    # Every facet's refracted direction (for the reach of the light).
    norm = np.stack([-hx, np.ones_like(h), -hz], axis=-1)
    norm /= np.linalg.norm(norm, axis=-1, keepdims=True)
    t_dir, cos_i = refract(np.broadcast_to(-air, norm.shape), norm, n_water)
    slope = t_dir[..., [0, 2]] / np.abs(t_dir[..., 1:2])
    t_surface = time.perf_counter() - t0

    mi, previous = require_mitsuba()
    try:
        T = mi.ScalarTransform4f
        water = {"type": "dielectric", "int_ior": float(n_water), "ext_ior": 1.0}
        white = {"type": "diffuse", "reflectance": ALBEDO}
        sun_dict = {"type": "directional", "direction": [float(v) for v in -air],
                    "irradiance": 1.0}
        flat_expected = ALBEDO / np.pi * air[1] * float(fresnel_transmittance(air[1], n_water))
        y_cam = float(h.min()) - CAMERA_CLEARANCE_M
        out = {"metrics": [], "images": {}, "flat": {}, "timing_s": {}}
        for d in depths:
            if y_cam <= -d + 0.05:
                raise AquaspecError(f"depth {d:g} m is too close to the troughs "
                                    f"(lowest {h.min():.3f} m) for the camera")
            # The imaged patch: foot coordinates [0, view texels]^2.
            foot_lo = np.zeros(2)
            foot_hi = np.full(2, view * texel)
            shift = (d / mu0) * s[[0, 2]]
            view_lo, view_hi = foot_lo - shift, foot_hi - shift
            # Surface that can light it: each facet's light lands at foot
            # x0 + d (slope - flat) + h slope (caustic_slices), so facets
            # within the largest such offset of the patch's feet; and the
            # unrefracted sun's way to the receiver, so that no light goes
            # round the mesh.
            disp = d * (slope + s[[0, 2]] / mu0) + h[..., None] * slope
            reach = float(np.max(np.abs(disp[cos_i > 0]))) + 2.0 * step
            pad = 2.0 * texel
            rec_lo, rec_hi = view_lo - pad, view_hi + pad
            direct = d * air[[0, 2]] / air[1]
            lo = np.minimum(foot_lo - reach, rec_lo + direct - pad)
            hi = np.maximum(foot_hi + reach, rec_hi + direct + pad)
            cols = (int(np.floor(lo[0] / step)), int(np.ceil(hi[0] / step)))
            rows = (int(np.floor(lo[1] / step)), int(np.ceil(hi[1] / step)))
            centre = 0.5 * (view_lo + view_hi)
            dist = y_cam + d
            fov = float(np.degrees(2.0 * np.arctan(0.5 * view * texel / dist)))
            sensor = {"type": "perspective", "fov": fov, "fov_axis": "x",
                      "near_clip": 1e-3, "far_clip": 1e3,
                      "to_world": T().look_at(origin=[float(centre[0]), y_cam, float(centre[1])],
                                              target=[float(centre[0]), -float(d),
                                                      float(centre[1])],
                                              up=[0.0, 0.0, -1.0]),
                      "film": {"type": "hdrfilm", "width": view, "height": view,
                               "rfilter": {"type": "box"}, "pixel_format": "luminance"},
                      "sampler": {"type": "independent", "sample_count": int(spp)}}
            base = {"type": "scene",
                    "integrator": {"type": "ptracer", "max_depth": MAX_DEPTH},
                    "sensor": sensor, "sun": sun_dict,
                    "receiver": _rectangle(mi, rec_lo, rec_hi, -d, white)}
            wavy = dict(base, surface=heightfield_mesh(mi, h, hx, hz, tile, rows, cols,
                                                       mi.load_dict(water)))
            flat = dict(base, surface=_rectangle(mi, (cols[0] * step, rows[0] * step),
                                                 (cols[1] * step, rows[1] * step), 0.0, water))
            half = max(int(spp) // 2, 1)
            scene = mi.load_dict(wavy)
            img1, dt1 = _render(mi, scene, half, seed)
            img2, dt2 = _render(mi, scene, half, seed + 1)
            img_flat, dtf = _render(mi, mi.load_dict(flat), spp, seed + 2)
            norm_flat = img_flat.mean()
            if not norm_flat > 0:
                raise AquaspecError("the flat-surface render is black: no light reached the "
                                    "receiver")
            c1, c2 = img1 / norm_flat, img2 / norm_flat
            c_m = 0.5 * (c1 + c2)
            points = _pixel_points(mi, scene.sensors()[0], view, d)
            # The pixel centres should be the texel centres in foot coordinates.
            u = caustics.foot(points, s)
            grid = (np.arange(view) + 0.5) * texel
            expect = np.stack(np.meshgrid(grid, grid), -1)
            # aquaspec: its map for a point sun with slices at 0 and exactly d,
            # without the unresolved short waves' blur (the mesh holds only the
            # tile's waves), read as the renderer reads it (half-precision
            # slices, foot coordinates, bilinear).
            t1 = time.perf_counter()
            cmap = caustics.caustic_map(waves, elevation_deg, azimuth_deg, n_water=n_water,
                                        oversample=oversample, slices=2, max_depth_m=float(d),
                                        sun_radius_deg=0.0, unresolved_slopes=False)
            c_a = caustics.sample(cmap, points, 0.0)
            t_aqua = time.perf_counter() - t1
            out["images"][float(d)] = {"aquaspec": c_a, "mitsuba": c_m, "halves": (c1, c2),
                                       "flat": img_flat / norm_flat, "points": points}
            out["flat"][float(d)] = {"mean_over_expected": float(norm_flat / flat_expected),
                                     "pixel_rel_std": float(img_flat.std() / norm_flat),
                                     "pixel_foot_error_m": float(np.max(np.abs(u - expect)))}
            out["timing_s"][float(d)] = {"wavy_halves": [dt1, dt2], "flat": dtf,
                                         "aquaspec_map": t_aqua}
            a_k, m_k, tent = matched_kernels(c_a, c_m)
            for kernel, (a_img, m_img, n_img) in (
                    ("raw", (c_a, c_m, 0.5 * (c1 - c2))),     # noise of the mean of halves
                    ("matched", (a_k, m_k, 0.5 * tent(c1 - c2)))):
                for b in blocks:
                    a_b, m_b = block_mean(a_img, b), block_mean(m_img, b)
                    row = {"depth_m": float(d), "block": b, "filter_m": b * texel,
                           "kernel": kernel,
                           **pattern_metrics(a_b, m_b, block_mean(n_img, b))}
                    if b == 1 and kernel == "raw":
                        row["shift"] = _shift(m_b, a_b)
                    out["metrics"].append(row)
        out["info"] = {"variant": mi.variant(), "elevation_deg": float(elevation_deg),
                       "azimuth_deg": float(azimuth_deg), "n_water": float(n_water),
                       "spp": int(spp), "photons_per_render": int(spp) * view * view,
                       "view_texels": view, "texel_m": texel, "oversample": int(oversample),
                       "mesh_oversample": mesh_os, "mesh_step_m": step, "camera_y_m": y_cam,
                       "max_depth": MAX_DEPTH,
                       "surface_s": t_surface, "waves": waves.describe()}
        return out
    finally:
        if previous is not None and previous != mi.variant():
            mi.set_variant(previous)
