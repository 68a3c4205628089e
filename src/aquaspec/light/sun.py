"""The sun under water: the refracted beam, its light on surfaces and its single scattering.

Conventions (as everywhere in aquaspec): metres, y up, the water surface is
y = 0, depth ``d = -p.y``; coefficients in 1/m; wavelengths in nm.

Geometry
--------
The sun stands at ``elevation_deg`` above the horizon (in air) and at
``azimuth_deg``, a compass angle measured in the horizontal plane from the
``-z`` axis (the built-in camera's view direction: azimuth 0 puts the sun in
front of that camera, 180 behind it) towards ``+x``. The direction towards
the sun in air is ``(cos e sin az, sin e, -cos e cos az)``. Through a flat
surface (Snell, ``n = 1.33``) the beam's zenith angle under water is
``theta_w`` with ``sin theta_w = cos e / n``; ``mu0 = cos theta_w`` (>= 0.66:
the beam is never flatter than the edge of Snell's window). :attr:`Sun.to_sun`
is the unit vector towards the sun under water, :attr:`Sun.direction` the way
the light travels (``-to_sun``).

Beam
----
``beam_normal(lambda)`` is the beam's irradiance on a plane normal to it just
below the surface, W m^-2 nm^-1: the direct normal irradiance in air times
``cos z`` (the horizontal irradiance), the Fresnel transmittance at ``z``,
divided by ``mu0`` (the refracted beam is narrower). Its horizontal
irradiance just below the surface is ``mu0 * beam_normal``, the share of the
light's ``E0`` that the sun brings.

The model, per band
-------------------
At a point at depth ``d`` the beam's normal irradiance is
``E_b(d) = beam_normal * exp(-c_sun d / mu0)``: the path from the surface is
``d / mu0``. ``c_sun`` is the extinction of the beam; with the light-field
model it is that model's delta-M ``c* = c - f b`` (light scattered into the
phase function's narrowest forward peak stays in the beam, as in the
discrete-ordinates solution whose diffuse field complements it); with the
seeds' model it is ``c``.

- A Lambertian surface of reflectance ``rho`` and normal ``n`` gets
  ``E_b(d) max(0, n . to_sun) V`` and sends ``rho / pi`` of it towards the
  camera (``V`` = 1 where the surface sees the sun, 0 in a shadow).
- Along a camera ray ``x(t) = o + t v`` (depth ``d(t) = d_o - t v_y``) the
  beam scattered once towards the camera is

      L_SS = b p(cos theta) int_0^S V(x(t)) E_b(d(t)) exp(-c_view t) dt,
      cos theta = direction . (-v)

  with ``p`` the band's phase function (for ``petzold`` mixed with pure water
  by band, as the light field does) and ``c_view`` the extinction the
  renderer applies to a surface's light on its way to the camera. Without
  shadows (``V = 1``) it is closed form,
  ``b p E_b(0) ms_path_integral(c_view, c_sun / mu0, d_o, v_y, S)``
  (:func:`aquaspec.transport.monzon2022.ms_path_integral`, stable for every sign of
  ``k = c_view - c_sun v_y / mu0``). With shadows the integral is taken over
  ``N`` equal steps up to ``S`` or a length beyond which the beam adds less
  than :data:`TAIL` of the term, with ``V`` at each step's middle and each
  step's exponential integrated exactly (:func:`march_weights`); the GPU pass
  does the same with ``V`` read from a shadow map.

Under a wind-roughened surface (``SunInputs.caustics``, :mod:`aquaspec.light.caustics`)
``V`` is multiplied by the caustic factor ``C(x)`` (mean about 1): on
surfaces read over the pixel's footprint, in the froxels as the mean of
:data:`CAUSTIC_SUBSAMPLES` reads along each slice (:func:`froxel_caustics`).

The multiple scattering of the sun's light is not here: it is part of the
ambient term (the light field's diffuse field, or the seeds' Kd model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.transport import monzon2022 as model
from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError

#: Steps along a camera ray for the shadowed single scattering.
DEFAULT_STEPS = 48
#: The march stops where the rest of the unshadowed integral is below this share.
TAIL = 1e-3


def check_elevation(elevation_deg) -> float:
    e = float(elevation_deg)
    if not (np.isfinite(e) and 1.0 <= e <= 90.0):
        raise AquaspecError(f"sun elevation {elevation_deg!r} deg; accepted: 1 to 90")
    return e


def check_azimuth(azimuth_deg) -> float:
    az = float(azimuth_deg)
    if not np.isfinite(az):
        raise AquaspecError(f"sun azimuth {azimuth_deg!r} deg; accepted: a finite angle "
                            "(0 = towards -z, 90 = towards +x)")
    return az % 360.0


def air_to_sun(elevation_deg, azimuth_deg) -> np.ndarray:
    """Unit vector towards the sun in air."""
    e, az = np.radians(elevation_deg), np.radians(azimuth_deg)
    return np.array([np.cos(e) * np.sin(az), np.sin(e), -np.cos(e) * np.cos(az)])


def refracted_to_sun(elevation_deg, azimuth_deg, n_water: float = model.N_WATER) -> np.ndarray:
    """Unit vector towards the sun under a flat surface (Snell)."""
    air = air_to_sun(elevation_deg, azimuth_deg)
    h = np.hypot(air[0], air[2])                 # sine of the zenith angle in air
    sin_w = h / n_water
    horiz = air[[0, 2]] / h if h > 0 else np.zeros(2)
    mu0 = np.sqrt(1.0 - sin_w ** 2)
    return np.array([sin_w * horiz[0], mu0, sin_w * horiz[1]])


@dataclass(frozen=True)
class Sun:
    """The sun's beam under a flat water surface.

    Attributes
    ----------
    elevation_deg, azimuth_deg : float
        In air (see the module docstring for the azimuth's convention).
    wavelength_nm, beam_normal : ndarray
        The beam's irradiance normal to it just below the surface,
        W m^-2 nm^-1.
    n_water : float
    """

    elevation_deg: float
    azimuth_deg: float
    wavelength_nm: np.ndarray
    beam_normal: np.ndarray
    n_water: float = model.N_WATER

    def __post_init__(self):
        object.__setattr__(self, "elevation_deg", check_elevation(self.elevation_deg))
        object.__setattr__(self, "azimuth_deg", check_azimuth(self.azimuth_deg))
        wl = np.asarray(self.wavelength_nm, dtype=float)
        val = np.asarray(self.beam_normal, dtype=float)
        if wl.shape != val.shape or wl.ndim != 1 or wl.size < 2 or not np.all(np.diff(wl) > 0):
            raise AquaspecError("the sun's spectrum needs increasing wavelengths and one "
                                "value per wavelength")
        if not np.all(np.isfinite(val)) or np.any(val < 0):
            raise AquaspecError("the sun's beam irradiance must be finite and >= 0")
        object.__setattr__(self, "wavelength_nm", wl)
        object.__setattr__(self, "beam_normal", val)

    @property
    def to_sun(self) -> np.ndarray:
        """Unit vector towards the sun under water (y > 0)."""
        return refracted_to_sun(self.elevation_deg, self.azimuth_deg, self.n_water)

    @property
    def direction(self) -> np.ndarray:
        """The way the beam travels under water (y < 0)."""
        return -self.to_sun

    @property
    def mu0(self) -> float:
        """Cosine of the beam's zenith angle under water."""
        return float(self.to_sun[1])

    def beam_on(self, bands: Bands) -> np.ndarray:
        """The beam's normal irradiance just below the surface, per band."""
        return bands.average(self.wavelength_nm, self.beam_normal, name="sun beam")

    def scaled(self, factor: float) -> "Sun":
        return Sun(self.elevation_deg, self.azimuth_deg, self.wavelength_nm,
                   self.beam_normal * float(factor), self.n_water)

    def describe(self) -> dict:
        return {"elevation_deg": self.elevation_deg, "azimuth_deg": self.azimuth_deg,
                "underwater_zenith_deg": float(np.degrees(np.arccos(self.mu0))),
                "to_sun_underwater": self.to_sun.tolist(),
                "beam_normal_w_m2_400_700": float(
                    Bands(1, 400.0, 700.0).average(self.wavelength_nm, self.beam_normal)[0]
                    * 300.0)}


# ---- the model (NumPy reference) -------------------------------------------

def beam_irradiance(beam0, c_sun, depth_m, mu0):
    """``E_b(d) = beam0 exp(-c_sun d / mu0)``; per-point arrays need a trailing band axis."""
    return np.asarray(beam0) * np.exp(-np.asarray(c_sun) * np.maximum(depth_m, 0.0) / mu0)


def surface_irradiance(beam0, c_sun, depth_m, normal, to_sun, visible=1.0):
    """Sun irradiance on surfaces: ``E_b(d) max(0, n . to_sun) V``, shape ``(..., n_bands)``.

    ``depth_m`` (...), ``normal`` (..., 3), ``visible`` (...) broadcast.
    """
    to_sun = np.asarray(to_sun, dtype=float)
    cos_n = np.maximum(np.asarray(normal, dtype=float) @ to_sun, 0.0)
    d = np.asarray(depth_m, dtype=float)
    return beam_irradiance(beam0, c_sun, d[..., None], to_sun[1]) \
        * (cos_n * np.asarray(visible, dtype=float))[..., None]


def scattering_cosine(direction, v):
    """``cos theta`` between the beam and light leaving towards the camera: ``direction . (-v)``."""
    return -(np.asarray(v, dtype=float) @ np.asarray(direction, dtype=float))


def single_scattering_open(*, b, phase_value, beam0, c_sun, c_view, depth_o, v_y, s, mu0):
    """``L_SS`` without shadows (closed form), shape ``(..., n_bands)``.

    ``phase_value`` (..., n_bands): the band phase function at each ray's
    scattering angle. Per-ray ``depth_o, v_y, s`` (...).
    """
    d = np.asarray(depth_o, dtype=float)[..., None]
    vy = np.asarray(v_y, dtype=float)[..., None]
    ss = np.asarray(s, dtype=float)[..., None]
    path = model.ms_path_integral(np.asarray(c_view), np.asarray(c_sun) / mu0, d, vy, ss)
    return np.asarray(b) * phase_value * np.asarray(beam0) * path


def march_length(c_sun, c_view, depth_o, v_y, s, mu0, tail: float = TAIL):
    """Where the march along a ray stops, m, per ray: ``S`` (cut at the surface),
    or earlier where the unshadowed integral's rest is below ``tail``.

    The slowest band sets it: the integrand is ``exp(-k t)`` with
    ``k = c_view - c_sun v_y / mu0``; for ``k > 0`` the rest beyond ``t`` is
    ``exp(-k t)`` of the whole, so ``t = -ln(tail) / k``.
    """
    s_cut = model.ray_length(np.asarray(s, dtype=float), np.asarray(depth_o, dtype=float),
                             np.asarray(v_y, dtype=float))
    k = np.asarray(c_view) - np.asarray(c_sun) * np.asarray(v_y, dtype=float)[..., None] / mu0
    k_min = np.min(k, axis=-1)
    t_tail = np.where(k_min > 0, -np.log(tail) / np.where(k_min > 0, k_min, 1.0), np.inf)
    out = np.minimum(s_cut, t_tail)
    if not np.all(np.isfinite(out)):
        raise AquaspecError("a camera ray has no end: open water with k <= 0 "
                            "(this cannot happen under water; please report it)")
    return out


def march_weights(k, length, n_steps: int):
    """Weights of the ``n_steps`` equal steps over ``[0, length]``:
    ``w_j = int_{t_j}^{t_j+1} exp(-k t) dt``, shape ``(..., n_steps, n_bands)``.

    ``k`` (..., n_bands), ``length`` (...). Exact per step for any sign of k
    (the exponent's caller guarantees it stays bounded under water).
    """
    k = np.asarray(k, dtype=float)
    dt = np.asarray(length, dtype=float)[..., None] / n_steps           # (..., 1)
    j = np.arange(n_steps)
    t0 = j[None, :] * dt                                               # (..., N)
    kk = k[..., None, :]
    x = kk * dt[..., None]                                             # (..., 1, n)
    # int_0^dt exp(-k u) du = dt * (1 - e^-x)/x, = dt at x = 0.
    small = np.abs(x) < 1e-8
    step = np.where(small, dt[..., None], -np.expm1(-x) / np.where(small, 1.0, kk))
    return np.exp(-kk * t0[..., None]) * step


def single_scattering_marched(*, b, phase_value, beam0, c_sun, c_view, depth_o, v_y, s, mu0,
                              visibility, n_steps: int = DEFAULT_STEPS, tail: float = TAIL):
    """``L_SS`` with shadows, shape ``(..., n_bands)``.

    ``visibility(t_mid)`` gets the steps' middles ``(..., n_steps)`` (m along
    each ray) and returns ``V`` there (same shape, 0 ... 1).
    """
    d = np.asarray(depth_o, dtype=float)
    vy = np.asarray(v_y, dtype=float)
    length = march_length(c_sun, c_view, d, vy, s, mu0, tail)
    k = np.asarray(c_view) - np.asarray(c_sun) * vy[..., None] / mu0
    w = march_weights(k, length, n_steps)
    t_mid = (np.arange(n_steps) + 0.5) * (length[..., None] / n_steps)
    vis = np.asarray(visibility(t_mid), dtype=float)
    integral = np.einsum("...j,...jb->...b", vis, w)
    start = np.exp(-np.asarray(c_sun) * d[..., None] / mu0)
    return np.asarray(b) * phase_value * np.asarray(beam0) * start * integral


def band_phase(phase: str, cos_theta, *, b, wavelength_nm, **params):
    """The band phase function at ``cos_theta`` (...), shape ``(..., n_bands)``.

    For the phase functions mixed with pure water (``petzold``) the mixture
    ``(b_w p_w + b_p p) / b`` per band, as :func:`aquaspec.medium.phase.band_moments`.
    """
    from aquaspec.medium.phase import MIXED_WITH_WATER, PureWaterPhase, get_phase, pure_water_fraction
    ph = get_phase(phase, **params)
    mu = np.clip(np.asarray(cos_theta, dtype=float), -1.0, 1.0)
    b_arr = np.atleast_1d(np.asarray(b, dtype=float))
    base = ph.value(mu)[..., None] * np.ones(b_arr.size)
    if ph.name in MIXED_WITH_WATER:
        fw = pure_water_fraction(ph, b_arr, wavelength_nm)
        base = fw * PureWaterPhase().value(mu)[..., None] + (1.0 - fw) * base
    return base


# ---- the shadow map -----------------------------------------------------------
#
# An orthographic height map seen from the sun: texel (row i, column j) holds
# the largest ``h = p . to_sun`` of the scene over the line through its
# centre parallel to the beam (the first surface the beam meets), or nothing.
# A point is lit where its own ``h`` is at least the map's (less a bias); the
# four texels around it are compared and the results interpolated
# bilinearly (percentage-closer filtering), so shadow edges are soft over one
# texel instead of stair-stepped. The GPU rasterises the same map
# (aquaspec.gpu.passes.sun) and reads it the same way.

#: Shadow-map side in texels.
DEFAULT_MAP_SIZE = 2048
#: Shadows are resolved within this distance of the camera, m (beyond it
#: everything is lit): at 2048 texels, 4 cm texels.
DEFAULT_MAP_RADIUS_M = 40.0
#: Depth bias, in texels (a point counts as lit up to this far below the map).
BIAS_TEXELS = 1.0
#: Surface points are looked up this far along their normal, in texels.
NORMAL_OFFSET_TEXELS = 1.5


def _basis(to_sun):
    w = np.asarray(to_sun, dtype=float)
    ref = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(w, ref)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(w, e1)


@dataclass(frozen=True)
class ShadowMapSpec:
    """Where the shadow map lies: axes ``e1, e2`` across the beam, ``to_sun``
    along it; texel ``(i, j)`` is centred at ``u = u0 + (j + 0.5) texel``,
    ``v = v0 + (i + 0.5) texel`` (``u = p . e1``, ``v = p . e2``); heights
    ``h = p . to_sun`` within ``[h_min, h_max]``."""

    to_sun: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    u0: float
    v0: float
    texel: float
    size: int
    h_min: float
    h_max: float

    def texel_coords(self, points):
        """Continuous texel coordinates ``(x, y, h)`` of points (..., 3); texel
        ``(i, j)``'s centre is at ``x = j``, ``y = i``."""
        p = np.asarray(points, dtype=float)
        x = (p @ self.e1 - self.u0) / self.texel - 0.5
        y = (p @ self.e2 - self.v0) / self.texel - 0.5
        return x, y, p @ self.to_sun

    def clip_matrix(self) -> np.ndarray:
        """4x4 world -> clip matrix of the GPU raster (x right = +u, y up =
        -v so that row 0 is ``v0``; depth 0 at ``h_max``, 1 at ``h_min``)."""
        span = self.size * self.texel
        m = np.zeros((4, 4))
        m[0, :3] = 2.0 * self.e1 / span
        m[0, 3] = -1.0 - 2.0 * self.u0 / span
        m[1, :3] = -2.0 * self.e2 / span
        m[1, 3] = 1.0 + 2.0 * self.v0 / span
        m[2, :3] = -self.to_sun / (self.h_max - self.h_min)
        m[2, 3] = self.h_max / (self.h_max - self.h_min)
        m[3, 3] = 1.0
        return m

    def describe(self) -> dict:
        return {"size": self.size, "texel_m": self.texel,
                "extent_m": self.size * self.texel}


def shadow_map_spec(scene_bounds, camera_position, to_sun, *, size: int = DEFAULT_MAP_SIZE,
                    radius_m: float = DEFAULT_MAP_RADIUS_M) -> ShadowMapSpec | None:
    """The map over the scene's bounds ((2, 3): low and high corners), cut to
    ``radius_m`` around the camera across the beam; None for an empty scene."""
    if not (isinstance(size, (int, np.integer)) and 16 <= size <= 8192):
        raise AquaspecError(f"shadow map size {size!r}; accepted: an integer 16 ... 8192")
    if not (np.isfinite(radius_m) and radius_m > 0):
        raise AquaspecError(f"shadow map radius {radius_m!r} m; accepted: a distance > 0")
    lo, hi = np.asarray(scene_bounds, dtype=float)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        return None
    w = np.asarray(to_sun, dtype=float)
    e1, e2 = _basis(w)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    cam = np.asarray(camera_position, dtype=float)
    u_lo = max((corners @ e1).min(), cam @ e1 - radius_m)
    u_hi = min((corners @ e1).max(), cam @ e1 + radius_m)
    v_lo = max((corners @ e2).min(), cam @ e2 - radius_m)
    v_hi = min((corners @ e2).max(), cam @ e2 + radius_m)
    if u_hi <= u_lo or v_hi <= v_lo:
        return None
    extent = max(u_hi - u_lo, v_hi - v_lo) * (1.0 + 1e-6)
    texel = extent / size
    h = corners @ w
    margin = 1e-3 * (h.max() - h.min()) + 1e-3
    return ShadowMapSpec(w, e1, e2, u_lo, v_lo, texel, int(size),
                         float(h.min() - margin), float(h.max() + margin))


def shadow_map_numpy(scene, spec: ShadowMapSpec, *, block: int = 8) -> np.ndarray:
    """The height map (size, size) in float64 (``-inf``: no surface), by
    testing texel centres against each triangle (inside or on its edges).

    Triangles whose bounding box spans at most ``block`` texels each way are
    done together; larger ones one at a time.
    """
    n = spec.size
    out = np.full((n, n), -np.inf)
    tris = [m.vertices[m.faces] for m in scene.meshes]
    if not tris:
        return out
    tri = np.concatenate(tris)
    x, y, h = spec.texel_coords(tri)                       # (T, 3) each
    j_lo = np.maximum(np.ceil(x.min(axis=1)), 0).astype(int)
    j_hi = np.minimum(np.floor(x.max(axis=1)), n - 1).astype(int)
    i_lo = np.maximum(np.ceil(y.min(axis=1)), 0).astype(int)
    i_hi = np.minimum(np.floor(y.max(axis=1)), n - 1).astype(int)
    keep = (j_hi >= j_lo) & (i_hi >= i_lo)
    # Degenerate (edge-on) triangles cover no texel centre in the raster either.
    area = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    keep &= np.abs(area) > 1e-12

    def cover(ids, jj, ii):
        """Texels (ii, jj) (T, K) tested against triangles ``ids`` (T,)."""
        xa, ya, ha = x[ids], y[ids], h[ids]
        ar = area[ids][:, None]
        px, py = jj.astype(float), ii.astype(float)
        w0 = ((xa[:, 1, None] - px) * (ya[:, 2, None] - py)
              - (xa[:, 2, None] - px) * (ya[:, 1, None] - py)) / ar
        w1 = ((xa[:, 2, None] - px) * (ya[:, 0, None] - py)
              - (xa[:, 0, None] - px) * (ya[:, 2, None] - py)) / ar
        w2 = 1.0 - w0 - w1
        tol = -1e-9
        inside = (w0 >= tol) & (w1 >= tol) & (w2 >= tol) & (jj <= j_hi[ids, None]) \
            & (ii <= i_hi[ids, None]) & (jj < n) & (ii < n)
        hv = w0 * ha[:, 0, None] + w1 * ha[:, 1, None] + w2 * ha[:, 2, None]
        ii, jj, hv = ii[inside], jj[inside], hv[inside]
        np.maximum.at(out, (ii, jj), hv)

    span = np.maximum(j_hi - j_lo, i_hi - i_lo) + 1
    small = np.flatnonzero(keep & (span <= block))
    oj, oi = np.meshgrid(np.arange(block), np.arange(block))
    oj, oi = oj.ravel(), oi.ravel()
    chunk = max(1, 2_000_000 // (block * block))
    for s in range(0, small.size, chunk):
        ids = small[s:s + chunk]
        cover(ids, j_lo[ids, None] + oj[None], i_lo[ids, None] + oi[None])
    for t in np.flatnonzero(keep & (span > block)):
        jj, ii = np.meshgrid(np.arange(j_lo[t], j_hi[t] + 1), np.arange(i_lo[t], i_hi[t] + 1))
        cover(np.array([t]), jj.ravel()[None], ii.ravel()[None])
    return out


def map_visibility(height_map, spec: ShadowMapSpec, points, *, bias_texels=BIAS_TEXELS):
    """``V`` in [0, 1] at points (..., 3): four texels compared, bilinear
    weights; texels outside the map or without a surface are lit."""
    x, y, h = spec.texel_coords(points)
    n = spec.size
    j0, i0 = np.floor(x), np.floor(y)
    fx, fy = x - j0, y - i0
    j0, i0 = j0.astype(np.int64), i0.astype(np.int64)
    bias = bias_texels * spec.texel
    vis = np.zeros(np.shape(x))
    for di, wy in ((0, 1.0 - fy), (1, fy)):
        for dj, wx in ((0, 1.0 - fx), (1, fx)):
            ii, jj = i0 + di, j0 + dj
            inside = (ii >= 0) & (ii < n) & (jj >= 0) & (jj < n)
            hm = np.where(inside, height_map[np.clip(ii, 0, n - 1), np.clip(jj, 0, n - 1)],
                          -np.inf)
            vis = vis + wx * wy * (h >= hm - bias)
    return vis


# ---- the sun's radiance over a G-buffer (NumPy reference) ------------------------

#: Entries of the per-band phase-function table, over ``sqrt(theta / pi)``.
PHASE_TABLE_SIZE = 512


def phase_table(phase, *, b, wavelength_nm, size: int = PHASE_TABLE_SIZE, **params):
    """``ln p`` per band at ``theta_k = pi (k / (size - 1))^2``: (n_bands, size).

    The grid is fine towards forward scattering, where the measured phase
    functions change over orders of magnitude; the GPU interpolates ``ln p``
    linearly in ``sqrt(theta)``.
    """
    theta = np.pi * (np.arange(size) / (size - 1.0)) ** 2
    p = band_phase(phase, np.cos(theta), b=b, wavelength_nm=wavelength_nm, **params)
    return np.log(np.maximum(p, 1e-30)).T


def phase_from_table(table, cos_theta):
    """Linear interpolation of :func:`phase_table` at ``cos_theta`` (...): (..., n_bands)."""
    size = table.shape[1]
    theta = np.arccos(np.clip(np.asarray(cos_theta, dtype=float), -1.0, 1.0))
    x = np.sqrt(theta / np.pi) * (size - 1)
    k0 = np.clip(np.floor(x).astype(np.int64), 0, size - 2)
    f = (x - k0)[..., None]
    t = np.asarray(table, dtype=float).T
    return np.exp((1.0 - f) * t[k0] + f * t[k0 + 1])


@dataclass(frozen=True)
class SunInputs:
    """Everything per band the sun's terms need (see the module docstring).

    ``beam0`` (n,): normal irradiance just below the surface; ``c_sun`` (n,)
    the beam's extinction; ``c_view`` (n,) the extinction on the way to the
    camera; ``b`` (n,); ``log_phase`` (n, K): :func:`phase_table`;
    ``to_sun`` (3,); ``n_steps``: steps of the march; ``caustics``: a
    :class:`aquaspec.light.caustics.CausticMap` modulating the beam (None: a flat surface).
    """

    beam0: np.ndarray
    c_sun: np.ndarray
    c_view: np.ndarray
    b: np.ndarray
    log_phase: np.ndarray
    to_sun: np.ndarray
    n_steps: int = DEFAULT_STEPS
    caustics: object = None

    @property
    def mu0(self) -> float:
        return float(self.to_sun[1])


#: Froxels: columns of ``FROXEL_TILE`` x ``FROXEL_TILE`` pixels, ``FROXEL_SLICES`` slices deep.
FROXEL_TILE = 8
FROXEL_SLICES = 64
#: Caustic reads per froxel slice, spread evenly along it.
CAUSTIC_SUBSAMPLES = 4


def caustic_foot_speed(v, to_sun) -> np.ndarray:
    """How fast a ray ``x(t) = o + t v`` (..., 3) moves in caustic foot
    coordinates (:func:`aquaspec.light.caustics.foot`), m per m along the ray."""
    v = np.asarray(v, dtype=float)
    s = np.asarray(to_sun, dtype=float)
    dx = v[..., 0] - v[..., 1] / s[1] * s[0]
    dz = v[..., 2] - v[..., 1] / s[1] * s[2]
    return np.hypot(dx, dz)


def froxel_caustics(camera, caustics, dirs, t_a, t_b, *, tile: int = FROXEL_TILE,
                    n_sub: int = CAUSTIC_SUBSAMPLES) -> np.ndarray:
    """The mean caustic factor over each froxel slice [t_a, t_b] of the rays
    ``dirs`` (..., 3): :data:`CAUSTIC_SUBSAMPLES` reads at the middles of equal
    parts, each averaged over the larger of the column's width
    (``tile t / fx``) and its part's length in foot coordinates."""
    from aquaspec.light import caustics as cst
    speed = caustic_foot_speed(dirs, caustics.to_sun)[..., None]
    dt = t_b - t_a
    out = np.zeros(np.shape(t_a))
    for j in range(n_sub):
        t = t_a + (j + 0.5) / n_sub * dt
        fp = np.maximum(tile * t / camera.fx, speed * dt / n_sub)
        out += cst.sample(caustics, camera.position + dirs[..., None, :] * t[..., None], fp)
    return out / n_sub


def column_directions(camera, tile: int = FROXEL_TILE) -> np.ndarray:
    """Unit rays through the centres of the froxel columns' tiles, (ch, cw, 3):
    column ``(b, a)`` covers pixels ``tile a ... tile a + tile - 1`` (and rows
    alike); its ray goes through pixel coordinates ``(tile a + tile/2, tile b + tile/2)``."""
    cw, ch = -(-camera.width // tile), -(-camera.height // tile)
    px = tile * np.arange(cw) + tile / 2.0
    py = tile * np.arange(ch) + tile / 2.0
    x = ((px - camera.cx) / camera.fx)[None, :, None]
    y = ((py - camera.cy) / camera.fy)[:, None, None]
    d = camera.right * x - camera.true_up * y + camera.forward
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def reference_phase(log_phase) -> np.ndarray:
    """``ln`` of the bands' mean phase function on the table's grid (K,): the
    froxels store the single scattering divided by it at their column's
    angle, and each pixel multiplies it back at its own angle, so the sharp
    forward peak follows the pixel while only the bands' ratios to the mean
    (which change slowly with angle) come from the column."""
    return np.log(np.mean(np.exp(np.asarray(log_phase, dtype=float)), axis=0))


def froxel_grid(camera, sun: SunInputs, visibility=None, *, tile: int = FROXEL_TILE,
                slices: int = FROXEL_SLICES, tail: float = TAIL) -> dict:
    """The beam's single scattering integrated front to back along each froxel column.

    Column rays ``v`` (:func:`column_directions`); slice boundaries
    ``t_k = L (k / K)^2``, ``k = 0 ... K``, with ``L`` the column's march
    length (:func:`march_length` of an open-water ray); ``V`` at each slice's
    middle (``visibility(points)`` -> (...), or 1). Per band, with the
    phase function divided by the bands' mean at the column's angle:

        cum_k = sum_{m <= k} b beam0 exp(-c_sun d_o / mu0) p / p_ref
                V_m int_{t_{m-1}}^{t_m} exp(-k_band t) dt

    Returns ``{"length": (ch, cw), "cum": (ch, cw, K + 1, n)}`` (``cum[..., 0, :] = 0``).
    """
    from aquaspec.shading.shade import camera_depth
    d_o = camera_depth(camera)
    dirs = column_directions(camera, tile)
    mu0 = sun.mu0
    v_y = dirs[..., 1]
    length = march_length(sun.c_sun, sun.c_view, np.full(v_y.shape, d_o), v_y,
                          np.full(v_y.shape, np.inf), mu0, tail)
    frac = (np.arange(slices + 1) / slices) ** 2
    t = length[..., None] * frac                                        # (ch, cw, K+1)
    t_a, t_b = t[..., :-1], t[..., 1:]
    dt = t_b - t_a
    if visibility is None:
        vis = np.ones(t_a.shape)
    else:
        vis = visibility(camera.position + dirs[..., None, :] * (0.5 * (t_a + t_b))[..., None])
    if sun.caustics is not None:
        vis = vis * froxel_caustics(camera, sun.caustics, dirs, t_a, t_b, tile=tile)
    k = np.asarray(sun.c_view) - np.asarray(sun.c_sun) * v_y[..., None] / mu0   # (ch, cw, n)
    kk = k[..., None, :]
    x = kk * dt[..., None]
    small = np.abs(x) < 1e-8
    ratio = np.where(small, 1.0, -np.expm1(-x) / np.where(small, 1.0, x))
    seg = np.exp(-kk * t_a[..., None]) * dt[..., None] * ratio            # (ch, cw, K, n)
    cos = dirs @ sun.to_sun
    p = phase_from_table(sun.log_phase, cos)                             # (ch, cw, n)
    ref = _ref_phase_at(sun.log_phase, cos)
    start = (np.asarray(sun.b) * np.asarray(sun.beam0) * np.exp(-np.asarray(sun.c_sun) * d_o / mu0)
             * p / ref[..., None])
    inc = start[..., None, :] * vis[..., None] * seg
    cum = np.concatenate([np.zeros(inc.shape[:2] + (1, inc.shape[-1])),
                          np.cumsum(inc, axis=2)], axis=2)
    return {"length": length, "cum": cum}


def _ref_phase_at(log_phase, cos_theta):
    """The bands' mean phase function (:func:`reference_phase`) at ``cos_theta`` (...)."""
    return phase_from_table(reference_phase(log_phase)[None, :], cos_theta)[..., 0]


def froxel_lookup(grid: dict, camera, s, *, tile: int = FROXEL_TILE) -> np.ndarray:
    """Each pixel's single scattering from the froxels, (H, W, n) before the
    pixel's own phase factor: bilinear between the four nearest columns, each
    read at ``min(S, L)`` linearly between slice boundaries (uniform in
    ``sqrt(t / L)``). ``s`` (H, W): the pixel's ray length (inf: open water)."""
    length, cum = grid["length"], grid["cum"]
    ch, cw = length.shape
    slices = cum.shape[2] - 1
    hgt, wid = camera.height, camera.width

    def axis(n_px, n_col):
        u = (np.arange(n_px) + 0.5 - tile / 2.0) / tile
        a0 = np.clip(np.floor(u), 0, n_col - 1).astype(np.int64)
        a1 = np.minimum(a0 + 1, n_col - 1)
        f = np.clip(u - a0, 0.0, 1.0)
        return a0, a1, f

    a0, a1, fu = axis(wid, cw)
    b0, b1, fv = axis(hgt, ch)
    s = np.asarray(s, dtype=float)
    out = np.zeros((hgt, wid, cum.shape[-1]))
    for bi, wv in ((b0, 1.0 - fv), (b1, fv)):
        for ai, wu in ((a0, 1.0 - fu), (a1, fu)):
            ll = length[bi[:, None], ai[None, :]]
            empty = ll <= 0                  # a camera at the surface, looking up
            ll = np.where(empty, 1.0, ll)
            tc = np.minimum(s, ll)
            x = np.where(empty, 0.0, np.sqrt(tc / ll) * slices)
            k0 = np.minimum(np.floor(x), slices - 1).astype(np.int64)
            f = (x - k0)[..., None]
            bb, aa = np.broadcast_arrays(bi[:, None], ai[None, :])
            lo, hi = cum[bb, aa, k0], cum[bb, aa, k0 + 1]                # (H, W, n)
            out += (wv[:, None] * wu[None, :])[..., None] * ((1.0 - f) * lo + f * hi)
    return out


#: How :func:`sun_radiance` integrates the single scattering.
SS_METHODS = ("froxel", "march")


def sun_radiance(gbuffer, sun: SunInputs, *, rho_of_hits, height_map=None,
                 spec: ShadowMapSpec | None = None, tail: float = TAIL,
                 method: str = "froxel") -> np.ndarray:
    """The sun's band radiance per pixel, (H, W, n): the lit surfaces' light
    carried to the camera plus the beam's single scattering along the ray.

    ``rho_of_hits(mask)`` returns the band reflectance (P, n) of the pixels in
    ``mask`` (H, W). Without a map (``height_map`` None) nothing is shadowed.
    ``method="froxel"`` (the renderer's; twin of ``shaders/sun_froxel.wgsl``
    and ``shaders/sun.wgsl``) reads the single scattering from
    :func:`froxel_grid`; ``"march"`` integrates each pixel's own ray in
    ``sun.n_steps`` steps (:func:`single_scattering_marched`), the reference
    the froxels are measured against.
    """
    from aquaspec.shading.shade import _reached, camera_depth
    if method not in SS_METHODS:
        raise AquaspecError(f"single-scattering method {method!r}; accepted: "
                            f"{', '.join(SS_METHODS)}")
    cam = gbuffer.camera
    d_o = camera_depth(cam)
    dirs = cam.ray_directions().astype(float)
    v_y = dirs[..., 1]
    s = gbuffer.distance.astype(float)
    hit = _reached(s, v_y, d_o)
    s = np.where(hit, s, np.inf)
    mu0 = sun.mu0
    n = sun.b.size
    shadowed = height_map is not None and spec is not None

    def vis_points(points):
        return map_visibility(height_map, spec, points) if shadowed \
            else np.ones(np.shape(points)[:-1])

    def march_light(points, t):
        # The march's reference reads the caustics at each step's own pixel footprint.
        out = vis_points(points)
        if sun.caustics is not None:
            from aquaspec.light import caustics as cst
            out = out * cst.sample(sun.caustics, points, np.abs(t) / cam.fx)
        return out

    if method == "froxel":
        grid = froxel_grid(cam, sun, vis_points, tail=tail)
        out = froxel_lookup(grid, cam, s) * _ref_phase_at(sun.log_phase,
                                                          dirs @ sun.to_sun)[..., None]
    else:
        out = np.zeros(s.shape + (n,))
        phase = phase_from_table(sun.log_phase, dirs @ sun.to_sun)      # (H, W, n)
        rows = max(1, 200_000 // max(1, cam.width * sun.n_steps))
        for r0 in range(0, cam.height, rows):
            sel = np.zeros(s.shape, bool)
            sel[r0:r0 + rows] = True
            out[sel] = single_scattering_marched(
                b=sun.b, phase_value=phase[sel], beam0=sun.beam0, c_sun=sun.c_sun,
                c_view=sun.c_view, depth_o=np.full(sel.sum(), d_o), v_y=v_y[sel], s=s[sel],
                mu0=mu0, n_steps=sun.n_steps, tail=tail,
                visibility=lambda t, sel=sel: march_light(
                    cam.position + dirs[sel][:, None, :] * t[..., None], t))
    if np.any(hit):
        pos = cam.position + dirs[hit] * s[hit, None]
        normal = gbuffer.normal[hit].astype(float)
        vis = 1.0
        if shadowed:
            vis = map_visibility(height_map, spec,
                                 pos + normal * (NORMAL_OFFSET_TEXELS * spec.texel))
        vis = vis * surface_caustics(sun.caustics, cam, pos, s[hit])
        e = surface_irradiance(sun.beam0, sun.c_sun, -pos[:, 1], normal, sun.to_sun, vis)
        out[hit] += rho_of_hits(hit) / np.pi * e * np.exp(-sun.c_view * s[hit, None])
    return out


def surface_caustics(caustics, camera, pos, s):
    """The caustic factor at surface points ``pos`` (P, 3) seen at distances
    ``s`` (P,), each averaged over its pixel's footprint ``s / fx`` (1 without caustics)."""
    if caustics is None:
        return 1.0
    from aquaspec.light import caustics as cst
    return cst.sample(caustics, pos, np.asarray(s, dtype=float) / camera.fx)


def surface_visibility(gbuffer, height_map=None, spec: ShadowMapSpec | None = None,
                       caustics=None):
    """The share of the beam each visible surface gets, (H, W): the shadow
    map's visibility (1 without a map; looked up as :func:`sun_radiance` does,
    off the surface along its normal) times the caustic factor."""
    out = np.ones(gbuffer.distance.shape)
    hit = gbuffer.hit
    if (height_map is None or spec is None) and caustics is None:
        return out
    pos = gbuffer.positions()[hit]
    if height_map is not None and spec is not None:
        out[hit] = map_visibility(height_map, spec, pos + gbuffer.normal[hit].astype(float)
                                  * (NORMAL_OFFSET_TEXELS * spec.texel))
    out[hit] = out[hit] * surface_caustics(caustics, gbuffer.camera, pos,
                                           gbuffer.distance[hit])
    return out


def numpy_shadow_map(scene, camera, to_sun, *, size: int = DEFAULT_MAP_SIZE,
                     radius_m: float = DEFAULT_MAP_RADIUS_M):
    """``(height_map, spec)`` of a scene for :func:`sun_radiance`, or None
    (no scene, or nothing near the camera)."""
    if scene is None or not scene.meshes:
        return None
    spec = shadow_map_spec(scene.bounds(), camera.position, to_sun, size=size,
                           radius_m=radius_m)
    if spec is None:
        return None
    return shadow_map_numpy(scene, spec), spec
