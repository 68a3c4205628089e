"""Caustics: the sun's beam focused and spread by a wind-roughened surface.

Conventions as in :mod:`aquaspec.light.sun` (metres, y up, the mean surface at
``y = 0``, compass azimuths from ``-z`` towards ``+x``). The surface is a
wind sea on a periodic tile (:mod:`aquaspec.light.waves`).

The beam through it
-------------------
Each surface sample is a facet with normal ``n ~ (-h_x, 1, -h_z)``. The sun's
ray (direction ``-s_air``) is refracted there (Snell, ``n_w = 1.33``,
:func:`aquaspec.medium.interface.refract`) into ``t``; the facet passes
``cos_i T(cos_i)`` of the beam per unit of its own area (``T``: unpolarised
Fresnel transmittance, :func:`aquaspec.medium.interface.fresnel_transmittance`),
that is

    w = cos_i T(cos_i) / (n_y cos z T(cos z))

times what a flat surface passes through the same horizontal area. Carried
to depth ``d`` the ray lands at ``x0 + (d + h) t_xz / |t_y|``. The caustic
factor at depth ``d`` is the landed flux per horizontal area over the flat
surface's: a photon map, each facet's ``w`` splatted bilinearly (periodic)
onto texels half as wide as the map's and summed 2 x 2 (each texel the
flux through its own area, smoothed by half a texel, not the two-texel tent
of a splat at its own size; :mod:`aquaspec.light.photon_map`; the landing
points in float32, far below the half floats the map is kept in). The facets are the tile's samples refined ``oversample`` times
by Fourier interpolation (the same band-limited surface, more facets per
texel; against 8, the default 4 differs by up to 0.055 rms per slice, 2 by 0.18).

The factor is stored in *foot coordinates*: a point ``p`` at depth ``d``
looks up ``u = p_xz + (d / mu0) s_xz``, where the flat surface's refracted
beam through ``p`` leaves the surface (``s``: towards the sun under water).
A flat surface gives 1 everywhere; the map tiles with period ``L``.

The sun is not a point: its disc (angular radius 0.2666 deg, the mean
semi-diameter) blurs the pattern at depth ``d`` by an ellipse of radii
``d alpha_perp / mu0`` across the plane of incidence and
``d alpha_par / mu0^2`` along it, with the disc's radius refracted,
``alpha_perp = alpha / n_w`` and ``alpha_par = alpha cos z / (n_w mu0)``:
each slice is convolved with that uniform ellipse (in Fourier space,
``2 J1(q) / q``).

Waves shorter than the tile's samples (down to capillaries) are not in the
tile, yet they tilt the facets further: each ray leaves the surface in a
slightly random direction, which blurs the pattern. Their slope variance is
what Cox & Munk measured beyond what the tile holds and beyond the waves
longer than the tile (Pierson-Moskowitz's share below ``2 pi / L``, closed
form with the exponential integral ``E1``),

    sigma_u^2 = max(0, sigma_CM^2 - sigma_tile^2 - sigma_long^2)

(:func:`aquaspec.light.waves.unresolved_slope_variance`; zero for the default tile up to about
3 m/s, where the tile holds all Cox & Munk's variance). Taken as isotropic
(``sigma_u^2 / 2`` per axis) and small, a facet slope ``g`` moves the ray's
landing point at depth ``d`` by ``d J g``, ``J`` the derivative of the
refracted ray's horizontal run per unit depth with respect to the slope at
the flat surface (:func:`run_jacobian`; ``(1 - 1/n_w) I`` for a sun at the
zenith). Each slice is convolved with the Gaussian of covariance
``d^2 sigma_u^2 / 2 J J^T``.

This is the pattern of the unscattered beam. The light the water scatters
through small angles carries it on, blurred by the angles it has spread
into: with a :class:`aquaspec.light.caustic_scatter.ScatterTransfer` (the
water's ``b``, the beam's extinction and phase function) each slice is
multiplied in Fourier space by the transfer ``G`` of
:mod:`aquaspec.light.caustic_scatter` (``scatter=`` of
:func:`cached_caustic_map` and :func:`caustic_loop`; the map's ``scatter``):
the renderer's beam then carries the fluctuation of the light it and the
diffuse field hold together, and its factor may dip below 0 where the
scattered light is darker than its mean.

Slices are at depths ``d_k = D (k / (K - 1))^2``: caustics change fastest
just below the surface. Lookups between slices are linear in ``sqrt(d / D)``;
below ``D`` the last slice is used. The GPU samples a mip pyramid of each
slice (``2 x 2`` means), trilinearly at a level set by the footprint of what
is being lit; :func:`sample` is the NumPy twin.

Waves in motion
---------------
A map costs about 0.4-0.7 s (about 1 M facets splatted onto 32 slices, the
slices in threads; on lavapipe the same splat with GPU atomics measured
1.1-2.1 s), so a moving sea is a loop (:class:`CausticLoop`): the looping
sea of :mod:`aquaspec.light.waves` (period ``T``) mapped at ``F`` instants
``f T / F``, built once per sea state and sun (each frame kept in the cache
directory). At time ``t`` the factor is linear in time between the two
frames around it (:meth:`CausticLoop.levels_at`; the GPU's
:class:`aquaspec.gpu.passes.caustics.CausticLoopPass` does it per frame):
continuous in ``t``, periodic, and equal to the map of the instant at each
frame.

A live view need not wait (:func:`caustic_loop` with ``background``):
frame 0 is the still map of ``t = 0``, the others are built in a thread in
:func:`build_order` (always spread over the period), and the factor is read
between the ready frames around ``t``: the caustics are there at once, then
cross-fade between the instants built (slowly at first), the motion
sharpening as the gaps close.
"""

from __future__ import annotations

import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace

import numpy as np

from aquaspec.cache import cached_arrays, code_digest
from aquaspec.errors import AquaspecError
from aquaspec.light.caustic_sample import (_bilinear_wrap, band_factor, foot, lod_of,  # noqa: F401
                                            sample)
from aquaspec.light.caustic_scatter import ScatterTransfer, scatter_slices, texture_scales
from aquaspec.light.sun import air_to_sun, check_azimuth, check_elevation, refracted_to_sun
# (splat and disc_blur are this module's too: the photon map's pieces.)
from aquaspec.light.photon_map import (disc_blur, half_wavenumbers, periodic_cell,  # noqa: F401
                                       splat, splat_texels)
from aquaspec.light.waves import (DEFAULT_LOOP_PERIOD_S, Waves, looping,  # noqa: F401
                                  surface, unresolved_slope_variance)
from aquaspec.medium.interface import FLAT_NORMAL, N_WATER, fresnel_transmittance, refract
from aquaspec.parallel import workers

#: The sun's mean angular radius (its semi-diameter), degrees.
SUN_RADIUS_DEG = 0.2666

DEFAULT_OVERSAMPLE = 4
#: The photon map is splatted onto 2 x 2 finer texels and summed per texel.
DEFAULT_SUPERSAMPLE = 2
DEFAULT_SLICES = 32
DEFAULT_MAX_DEPTH_M = 40.0
#: A moving sea's loop: frames per period (:data:`DEFAULT_LOOP_PERIOD_S`;
#: 1/24 s apart: the slices 1 m down decorrelate in about 0.06 s at 5 m/s).
DEFAULT_LOOP_FRAMES = 48


def run_jacobian(air_to_sun, n_water: float = N_WATER, step: float = 1e-6) -> np.ndarray:
    """``J`` (2, 2): how the refracted beam's horizontal run per unit depth,
    ``t_xz / |t_y|``, changes with the facet slope ``(h_x, h_z)`` at the flat
    surface (central differences of :func:`refract`); rows x, z of the run,
    columns the slope's x, z."""
    air = np.asarray(air_to_sun, dtype=float)
    out = np.empty((2, 2))
    for col in range(2):
        runs = []
        for sign in (1.0, -1.0):
            slope = np.zeros(2)
            slope[col] = sign * step
            normal = np.array([-slope[0], 1.0, -slope[1]])
            t, _ = refract(-air, normal / np.linalg.norm(normal), n_water)
            runs.append(t[[0, 2]] / abs(t[1]))
        out[:, col] = (runs[0] - runs[1]) / (2.0 * step)
    return out


def facet_weights(cos_i, normal_y, cos_z, n_water: float = N_WATER):
    """``w``: what a facet passes per horizontal area over what a flat surface passes."""
    ci = np.clip(cos_i, 0.0, 1.0)
    flat = cos_z * fresnel_transmittance(cos_z, n_water)
    return np.where(cos_i > 0, ci * fresnel_transmittance(ci, n_water) / (normal_y * flat), 0.0)


@dataclass(frozen=True)
class CausticGeometry:
    """What a lookup needs besides the texels (the GPU's uniforms): ``slices``
    (K), the tile and the deepest slice (m), level 0's texel (m) and the mip
    levels' count."""

    slices: int
    tile_m: float
    max_depth_m: float
    texel_m: float
    levels: int


@dataclass(frozen=True)
class CausticMap:
    """The caustic factor per depth slice in foot coordinates (see the module docstring).

    ``levels[m]``: (K, n / 2^m, n / 2^m) float32, level 0 the photon map,
    each next level the 2 x 2 means of the one before; ``depths`` (K,) m;
    ``scatter``: the transfer into the scattered light applied (None: the
    unscattered beam's pattern); ``band_scale`` (K, n_bands): each band reads
    ``1 + s (C - 1)`` (:func:`aquaspec.light.caustic_scatter.band_scales`;
    None: every band reads ``C``).
    """

    waves: Waves
    to_sun: np.ndarray
    depths: np.ndarray
    levels: tuple
    mean_weight: float
    info: dict = field(default_factory=dict)
    scatter: ScatterTransfer | None = None
    band_scale: np.ndarray | None = None

    @property
    def max_depth(self) -> float:
        return float(self.depths[-1])

    @property
    def texel(self) -> float:
        return self.waves.tile_m / self.levels[0].shape[-1]

    @property
    def geometry(self) -> CausticGeometry:
        return CausticGeometry(int(self.depths.size), self.waves.tile_m, self.max_depth,
                               self.texel, len(self.levels))

    def describe(self) -> dict:
        return {**self.waves.describe(), "slices": int(self.depths.size),
                "max_depth_m": self.max_depth, "texels": int(self.levels[0].shape[-1]),
                "texel_m": self.texel, "mean_facet_weight": self.mean_weight, **self.info,
                **({} if self.scatter is None else {"scatter": self.scatter.describe()})}


def caustic_slices(h, hx, hz, tile_m: float, n: int, air_to_sun, depths, *,
                   n_water: float = N_WATER, sun_radius_deg: float = SUN_RADIUS_DEG,
                   unresolved_variance: float = 0.0, supersample: int = DEFAULT_SUPERSAMPLE,
                   progress=None):
    """The caustic factor (K, n, n) at ``depths`` (K,) under a periodic surface
    sampled on (M, M) points (height ``h`` and slopes, :func:`surface`'s
    layout), with the sun towards ``air_to_sun`` (unit, in air); and the
    facets' mean weight ``w``. ``unresolved_variance``: the slope variance of
    waves the samples do not hold (:func:`unresolved_slope_variance`), a
    Gaussian blur; ``supersample``: the splat's texels per texel and axis.
    See the module docstring."""
    air = np.asarray(air_to_sun, dtype=float)
    s = -refract(-air, FLAT_NORMAL, n_water)[0]   # towards the sun under water
    mu0 = float(s[1])
    horiz = np.hypot(s[0], s[2])
    dir_h = s[[0, 2]] / horiz if horiz > 1e-12 else np.array([1.0, 0.0])
    m = h.shape[0]
    norm = np.stack([-hx, np.ones_like(h), -hz], axis=-1)
    norm /= np.linalg.norm(norm, axis=-1, keepdims=True)
    t, cos_i = refract(np.broadcast_to(-air, norm.shape), norm, n_water)
    w = facet_weights(cos_i, norm[..., 1], air[1], n_water).reshape(-1)
    mean_w = float(np.sum(w) / (m * m))
    lit = w > 0
    keep = slice(None) if lit.all() else lit           # (a low sun leaves some dark)
    ty = np.abs(t[..., 1]).reshape(-1)[keep]
    # The landing point at depth d in texel units (texel centres at whole
    # numbers), a + d b: x0 + h slope fixed, the run (slope - flat) per metre.
    scale = n / tile_m
    grid = np.arange(m) * (n / float(m)) - 0.5
    rows = np.broadcast_to(grid[:, None], (m, m))          # z of each facet; x: rows.T
    a, b = [], []
    f = int(supersample)
    for axis, x0 in ((0, rows.T), (2, rows)):
        slope = t[..., axis].reshape(-1)[keep] / ty
        # (in the splat's f x f finer texels: the texel's own area, f x f summed)
        a.append(np.asarray(f * (x0.reshape(-1)[keep] + h.reshape(-1)[keep] * slope * scale)
                            + 0.5 * (f - 1), np.float32))
        b.append(np.asarray(f * (slope + s[axis] / mu0) * scale, np.float32))
    w = w[keep] * ((n * n) / float(m * m))
    alpha = np.radians(sun_radius_deg)
    a_perp = alpha / n_water
    a_par = alpha * air[1] / (n_water * mu0)
    jac = run_jacobian(air, n_water)
    spread = 0.5 * float(unresolved_variance) * (jac @ jac.T)     # per unit depth^2
    depths = np.asarray(depths, dtype=float)
    out = np.empty((depths.size, n, n), np.float32)
    k_half = half_wavenumbers(n, tile_m)

    def one(k):
        d = float(depths[k])
        dd = np.float32(d)
        c = splat_texels(b[0] * dd + a[0], b[1] * dd + a[1], w, f * n)
        c = c.reshape(n, f, n, f).sum(axis=(1, 3))
        c = disc_blur(c, (d * a_par / mu0 ** 2, d * a_perp / mu0), dir_h, tile_m,
                      cov=d * d * spread, wavenumbers=k_half)
        out[k] = np.maximum(c, 0.0)

    # The slices in threads (NumPy lets go of the GIL in the splat's loops).
    with ThreadPoolExecutor(max_workers=min(workers(), depths.size)) as pool:
        for done, _ in enumerate(pool.map(one, range(depths.size)), 1):
            if progress is not None:
                progress(done, depths.size)
    return out, mean_w


def slice_depths(max_depth_m: float, slices: int) -> np.ndarray:
    return float(max_depth_m) * (np.arange(slices) / (slices - 1.0)) ** 2


def _check_map_args(elevation_deg, azimuth_deg, slices, max_depth_m, texels=None):
    if texels is not None and (isinstance(texels, bool) or texels != int(texels)
                               or not 16 <= texels <= 4096 or int(texels) & (int(texels) - 1)):
        raise AquaspecError(f"caustic texels {texels!r}; accepted: None (the wave grid) or a "
                            "power of two, 16 to 4096")
    if int(slices) < 2:
        raise AquaspecError(f"caustic slices {slices!r}; accepted: 2 or more")
    if not (np.isfinite(max_depth_m) and max_depth_m > 0):
        raise AquaspecError(f"caustic depth range {max_depth_m!r} m; accepted: > 0")
    return check_elevation(elevation_deg), check_azimuth(azimuth_deg)


def mip_levels(level0) -> tuple:
    """Level 0 (K, n, n) and the mips made from it (``2 x 2`` means), each
    rounded to half precision as the GPU's texture holds them (float32 arrays)."""
    levels = [np.asarray(level0, np.float16).astype(np.float32)]
    while levels[-1].shape[-1] > 1:
        a = levels[-1]
        levels.append(np.asarray(0.25 * (a[:, 0::2, 0::2] + a[:, 1::2, 0::2]
                                         + a[:, 0::2, 1::2] + a[:, 1::2, 1::2]),
                                 np.float16).astype(np.float32))
    return tuple(levels)


def _assemble(waves, elevation_deg, azimuth_deg, level0, mean_weight, *, n_water,
              oversample, slices, max_depth_m, sun_radius_deg,
              unresolved_slopes, texels=None) -> CausticMap:
    """A :class:`CausticMap` from its slices: level 0 and the mips made from
    it, all kept at the GPU texture's half precision (both sides read the
    same numbers)."""
    return CausticMap(waves=waves, to_sun=refracted_to_sun(elevation_deg, azimuth_deg, n_water),
                      depths=slice_depths(max_depth_m, int(slices)), levels=mip_levels(level0),
                      mean_weight=float(mean_weight),
                      info={"sun_elevation_deg": elevation_deg, "sun_azimuth_deg": azimuth_deg,
                            "oversample": int(oversample), "sun_radius_deg": sun_radius_deg,
                            "unresolved_slope_blur": bool(unresolved_slopes)})


def caustic_map(waves: Waves, elevation_deg: float, azimuth_deg: float, *,
                n_water: float = N_WATER, oversample: int = DEFAULT_OVERSAMPLE,
                slices: int = DEFAULT_SLICES, max_depth_m: float = DEFAULT_MAX_DEPTH_M,
                sun_radius_deg: float = SUN_RADIUS_DEG, unresolved_slopes: bool = True,
                texels: int | None = None, progress=None) -> CausticMap:
    """The caustics of ``waves`` under the sun at ``elevation_deg``/``azimuth_deg`` (in air).

    ``unresolved_slopes``: blur by the short waves the tile leaves out
    (:func:`unresolved_slope_variance`). ``texels``: per side of the map
    (None: the wave grid's; finer texels want more facets, ``oversample``).
    ``progress(done, total)`` is called after each slice.
    """
    elevation_deg, azimuth_deg = _check_map_args(elevation_deg, azimuth_deg, slices,
                                                 max_depth_m, texels)
    h, hx, hz = surface(waves, oversample)
    out, mean_w = caustic_slices(h, hx, hz, waves.tile_m,
                                 waves.grid if texels is None else int(texels),
                                 air_to_sun(elevation_deg, azimuth_deg),
                                 slice_depths(max_depth_m, int(slices)), n_water=n_water,
                                 sun_radius_deg=sun_radius_deg,
                                 unresolved_variance=unresolved_slope_variance(waves)
                                 if unresolved_slopes else 0.0, progress=progress)
    return _assemble(waves, elevation_deg, azimuth_deg, out, mean_w, n_water=n_water,
                     oversample=oversample, slices=slices, max_depth_m=max_depth_m,
                     sun_radius_deg=sun_radius_deg, unresolved_slopes=unresolved_slopes,
                     texels=texels)


_CACHE: dict = {}
_CACHE_SIZE = 4
_LOCK = threading.Lock()
#: The modules whose code keys the cached slices (:func:`aquaspec.cache.code_digest`).
_CODE_MODULES = (__name__, "aquaspec.light.photon_map", "aquaspec.light.waves",
                 "aquaspec.light.sun", "aquaspec.medium.interface")


def _map_options(elevation_deg, azimuth_deg, *, n_water=N_WATER,
                 oversample=DEFAULT_OVERSAMPLE, slices=DEFAULT_SLICES,
                 max_depth_m=DEFAULT_MAX_DEPTH_M, sun_radius_deg=SUN_RADIUS_DEG,
                 unresolved_slopes=True, texels=None):
    """The checked sun and :func:`caustic_map`'s options, as a cache key's parts
    (``texels`` only when given: the default's key is as it was)."""
    elevation_deg, azimuth_deg = _check_map_args(elevation_deg, azimuth_deg, slices,
                                                 max_depth_m, texels)
    return elevation_deg, azimuth_deg, dict(
        n_water=float(n_water), oversample=int(oversample), slices=int(slices),
        max_depth_m=float(max_depth_m), sun_radius_deg=float(sun_radius_deg),
        unresolved_slopes=bool(unresolved_slopes),
        **({} if texels is None else {"texels": int(texels)}))


def _stored_slices(waves: Waves, elevation_deg, azimuth_deg, kw):
    """Level 0 (K, n, n) float16 and the mean facet weight of
    :func:`caustic_map`, from the cache directory (computed once). A looping
    sea at ``t = 0`` is the true sea's surface, so both share one entry."""
    if waves.time_s == 0.0 and waves.period_s is not None:
        waves = replace(waves, period_s=None)
    key = (waves, elevation_deg, azimuth_deg, tuple(sorted(kw.items())))

    def compute():
        cm = caustic_map(waves, elevation_deg, azimuth_deg, **kw)
        return {"level0": cm.levels[0].astype(np.float16),
                "mean_weight": np.array(cm.mean_weight)}

    data = cached_arrays("caustics", code_digest([sys.modules[m] for m in _CODE_MODULES],
                                                 repr(key)), compute)
    return data["level0"], float(data["mean_weight"])


def cached_caustic_map(waves: Waves, elevation_deg: float, azimuth_deg: float, *,
                       scatter: ScatterTransfer | None = None, **map_kwargs) -> CausticMap:
    """:func:`caustic_map` (same options), remembered for the last few (waves,
    sun, ``scatter``) in this process and its slices kept in the cache
    directory (:mod:`aquaspec.cache`); ``scatter``: carried into the
    scattered light (:func:`aquaspec.light.caustic_scatter.scatter_slices`)."""
    elevation_deg, azimuth_deg, kw = _map_options(elevation_deg, azimuth_deg, **map_kwargs)
    key = (waves, elevation_deg, azimuth_deg, tuple(sorted(kw.items())), scatter)
    with _LOCK:
        hit = _CACHE.get(key)
    if hit is not None:
        return hit
    level0, mean_w = _stored_slices(waves, elevation_deg, azimuth_deg, kw)
    scale = texture_scales(level0, slice_depths(kw["max_depth_m"], kw["slices"]),
                           waves.tile_m, scatter)
    if scatter is not None:
        level0 = scatter_slices(level0, slice_depths(kw["max_depth_m"], kw["slices"]),
                                waves.tile_m, scatter)
    hit = replace(_assemble(waves, elevation_deg, azimuth_deg, level0, mean_w, **kw),
                  scatter=scatter, band_scale=scale)
    with _LOCK:
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = hit
    return hit


def build_order(frames: int) -> list:
    """The order a loop's frames are built in: frame 0, then each time the
    frame farthest (around the loop) from those built, the first of ties
    (0, 24, 12, 36, 6, ... for 48): the frames built so far always spread
    over the whole period."""
    order, dist = [0], np.array([min(f, frames - f) for f in range(frames)], float)
    while len(order) < frames:
        f = int(np.argmax(dist))
        order.append(f)
        dist = np.minimum(dist, [min((g - f) % frames, (f - g) % frames)
                                 for g in range(frames)])
        dist[order] = -1.0
    return order


@dataclass(frozen=True, eq=False)
class CausticLoop:
    """The caustics of a looping sea (``first.waves.period_s``) at ``F``
    instants ``f T / F`` of one period (see the module docstring).

    ``level0`` (F, K, n, n) float16: each frame's slices; ``first``: frame
    0's :class:`CausticMap` (the geometry, the sun, the description);
    ``ready`` (F,) bool: the frames built so far (all of them unless the loop
    is being built in the background, :func:`caustic_loop`), read between
    the ready ones; ``scatter``: each frame's slices carried into the
    scattered light when its levels are made (:meth:`frame_levels`);
    ``band_scale``: as :class:`CausticMap`'s, frame 0's for every frame.
    """

    first: CausticMap
    level0: np.ndarray
    ready: np.ndarray | None = None
    _run: dict = field(default_factory=dict, repr=False)
    scatter: ScatterTransfer | None = None
    band_scale: np.ndarray | None = None

    def __post_init__(self):
        if self.ready is None:
            object.__setattr__(self, "ready", np.ones(self.level0.shape[0], bool))

    @property
    def period_s(self) -> float:
        return float(self.first.waves.period_s)

    @property
    def frames(self) -> int:
        return int(self.level0.shape[0])

    @property
    def complete(self) -> bool:
        return bool(self.ready.all())

    @property
    def geometry(self) -> CausticGeometry:
        return self.first.geometry

    def frame_levels(self, f: int) -> tuple:
        """Frame ``f``'s mip levels (:func:`mip_levels`; with :attr:`scatter`)."""
        level0 = self.level0[int(f) % self.frames]
        if self.scatter is not None:
            level0 = scatter_slices(level0, self.first.depths, self.first.waves.tile_m,
                                    self.scatter)
        return mip_levels(level0)

    def frame_weights(self, time_s: float, ready=None):
        """``(f0, f1, a)``: the factor at ``time_s`` is ``(1 - a)`` frame ``f0``
        plus ``a`` frame ``f1``, the ready frames (``ready`` (F,) bool, else
        :attr:`ready`) at or before and after the time around the loop
        (``f1 = f0 + 1``, wrapped, once all are)."""
        t = float(time_s)
        if not np.isfinite(t):
            raise AquaspecError(f"wave time {time_s!r} s; accepted: a finite number")
        x = (t / self.period_s) % 1.0 * self.frames
        have = np.flatnonzero(self.ready if ready is None else ready)
        if have.size == self.frames:
            f0 = min(int(np.floor(x)), self.frames - 1)
            return f0, (f0 + 1) % self.frames, float(min(max(x - f0, 0.0), 1.0))
        if have.size == 0:
            raise AquaspecError("the caustic loop has no frame yet")
        i = int(np.searchsorted(have, x, side="right")) - 1      # -1: the last, wrapped
        f0, f1 = int(have[i]), int(have[(i + 1) % have.size])
        if f0 == f1:
            return f0, f1, 0.0
        span = (f1 - f0) % self.frames
        return f0, f1, float(min(max(((x - f0) % self.frames) / span, 0.0), 1.0))

    def levels_at(self, time_s: float, ready=None) -> tuple:
        """The mip levels at ``time_s``: the two frames' levels
        (:meth:`frame_weights`) mixed in float32 and rounded to half
        precision (as the GPU does it)."""
        f0, f1, a = self.frame_weights(time_s, ready)
        return tuple(np.asarray(np.float32(1.0 - a) * p + np.float32(a) * q,
                                np.float16).astype(np.float32)
                     for p, q in zip(self.frame_levels(f0), self.frame_levels(f1)))

    def map_at(self, time_s: float) -> CausticMap:
        """A :class:`CausticMap` of :meth:`levels_at` (for the NumPy shading)."""
        return CausticMap(waves=replace(self.first.waves, time_s=float(time_s)),
                          to_sun=self.first.to_sun, depths=self.first.depths,
                          levels=self.levels_at(time_s), mean_weight=self.first.mean_weight,
                          info={**self.first.info, "loop_frames": self.frames},
                          scatter=self.scatter, band_scale=self.band_scale)

    def wait(self) -> "CausticLoop":
        """Wait for a background build (:func:`caustic_loop`); raises what it raised."""
        thread = self._run.get("thread")
        if thread is not None:
            thread.join()
        if self._run.get("error") is not None:
            raise self._run["error"]
        return self

    def stop(self) -> None:
        """Stop a background build after the frame under way (the frames
        built stay; :func:`caustic_loop` resumes it)."""
        if "stop" in self._run:
            self._run["stop"].set()

    def _fill(self, make_frame, progress, stop) -> None:
        """Build the missing frames in :func:`build_order` (``make_frame(f)``:
        frame f's level 0), calling ``progress(done, total)`` after each."""
        try:
            for f in build_order(self.frames):
                if stop is not None and stop.is_set():
                    return
                if not self.ready[f]:
                    self.level0[f] = make_frame(f)
                    self.ready[f] = True          # (after its texels: readers check this)
                    if progress is not None:
                        progress(int(self.ready.sum()), self.frames)
        except Exception as exc:        # kept for wait(): a background thread has no caller
            self._run["error"] = exc
            if stop is None:
                raise


_LOOPS: dict = {}


def caustic_loop(waves: Waves, elevation_deg: float, azimuth_deg: float, *,
                 frames: int = DEFAULT_LOOP_FRAMES, progress=None, background: bool = False,
                 scatter: ScatterTransfer | None = None, **map_kwargs) -> CausticLoop:
    """The :class:`CausticLoop` of :func:`aquaspec.light.waves.looping`
    ``(waves)`` under the sun, ``frames`` per period, each frame
    :func:`caustic_map` (with ``map_kwargs``) kept in the cache directory; the
    last loop is remembered in this process (a new one stops the last one's
    background build).

    Frame 0 is the sea's map at ``t = 0`` (the still map's cache entry); the
    others are built in :func:`build_order`, one after another (each map's
    slices in threads), calling ``progress(done, total)`` (frames ready)
    after each. ``background``: return once frame 0 is there and build the
    rest in a thread (``progress`` is then called from it;
    :attr:`CausticLoop.ready` says which frames are there,
    :meth:`CausticLoop.wait` waits for all). Either way the frames are the
    same numbers. ``scatter``: the same loop read through that transfer
    (:attr:`CausticLoop.scatter`; one view per transfer, kept with the loop).
    """
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 2:
        raise AquaspecError(f"caustic loop frames {frames!r}; accepted: an integer >= 2")
    elevation_deg, azimuth_deg, kw = _map_options(elevation_deg, azimuth_deg, **map_kwargs)
    sea = replace(looping(waves), time_s=0.0)
    key = (sea, elevation_deg, azimuth_deg, int(frames), tuple(sorted(kw.items())))

    def make_frame(f):
        t = f * sea.period_s / frames
        return _stored_slices(replace(sea, time_s=t), elevation_deg, azimuth_deg, kw)[0]

    loop = _LOOPS.get(key)
    if loop is None:
        level0, mean_w = _stored_slices(sea, elevation_deg, azimuth_deg, kw)
        loop = CausticLoop(first=_assemble(sea, elevation_deg, azimuth_deg, level0, mean_w, **kw),
                           level0=np.empty((int(frames),) + level0.shape, np.float16),
                           ready=np.zeros(int(frames), bool))
        loop.level0[0], loop.ready[0] = level0, True
        with _LOCK:
            for old in _LOOPS.values():
                old.stop()
            _LOOPS.clear()
            _LOOPS[key] = loop
    if progress is not None:
        progress(int(loop.ready.sum()), loop.frames)
    with _LOCK:
        thread = loop._run.get("thread")
        running = thread is not None and thread.is_alive() and not loop._run["stop"].is_set()
        if background and not running and not loop.complete:
            stop = threading.Event()
            thread = threading.Thread(target=loop._fill, args=(make_frame, progress, stop),
                                      daemon=True, name="caustic loop")
            loop._run.update(stop=stop, error=None, thread=thread)
            thread.start()
    if not background:
        if running:
            loop.wait()
        loop._fill(make_frame, progress, None)      # (whatever a stopped build left)
    if scatter is None:
        return loop
    views = loop._run.setdefault("views", {})
    if scatter not in views:          # (frame 0's band scales: the sea's statistics)
        views[scatter] = replace(loop, scatter=scatter, band_scale=texture_scales(
            loop.level0[0], loop.first.depths, sea.tile_m, scatter))
    return views[scatter]
