"""Baking the light field's tables: solve, tabulate, keep in the cache.

:func:`lightfield_tables` solves the light field
(:func:`aquaspec.transport.lightfield.solve.solve_lightfield`) for a water's
bands and tabulates what the renderer reads
(:class:`aquaspec.transport.lightfield.tables.LightfieldTables`), once per
machine for each set of arguments (:mod:`aquaspec.cache`).
"""

from __future__ import annotations

import sys

import numpy as np

from aquaspec import cache, parallel
from aquaspec.errors import AquaspecError
from aquaspec.medium import interface, phase_bands
from aquaspec.medium import phase as phase_functions
from aquaspec.medium.phase_bands import band_cone_fraction, band_cone_offset_cdf
from aquaspec.parallel import in_threads
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.lightfield import cone as cone_module
from aquaspec.transport.lightfield import conespread, field, shadowphase, solve, tables
from aquaspec.transport.lightfield.cone import cone_offsets
from aquaspec.transport.lightfield.conespread import (LAMBDA_NODES, cone_cdf,
                                                      multiple_scattering_cdf)
from aquaspec.transport.lightfield.shadowphase import shadow_tables
from aquaspec.transport.lightfield.solve import solve_lightfield
from aquaspec.transport.lightfield.tables import (DEFAULT_MAX_DEPTH_M, DEFAULT_N_DEPTH,
                                                  DEFAULT_N_MU, ConeTables, LightfieldTables,
                                                  cut_at_seabed, seeds_shape, table_cosines,
                                                  table_depths)

#: How the cone's light may be taken to scatter (``spread_scattering``).
SPREAD_SCATTERING = ("single", "multiple")


def lightfield_tables(band_water, *, phase="petzold", seabed_depth_m=None,
                      seabed_albedo=0.0, n_depth: int = DEFAULT_N_DEPTH,
                      n_mu: int = DEFAULT_N_MU, max_depth_m: float = DEFAULT_MAX_DEPTH_M,
                      n_streams: int = 32, surface: str = "null",
                      forward_cone_deg: float = 0.0, cone_spread: bool = False,
                      spread_scattering: str = "single", ambient_shadow: bool = False,
                      sun_mu0=None, sun_fraction=None, **phase_params) -> LightfieldTables:
    """Per-band tables of the light field for the renderer (float32).

    Computed once per machine for each set of arguments and kept in
    aquaspec's cache (:mod:`aquaspec.cache`), keyed by the arguments, the
    water's coefficients and the code (and data versions) behind them
    (:func:`tables_key`; :func:`bake_tables` computes them).

    Parameters
    ----------
    band_water : BandWater or object with ``a``, ``b`` (n,) in 1/m
        and, for ``phase="petzold"``, ``bands.centers_nm`` (or ``wavelength_nm``).
    phase, phase_params : see :func:`aquaspec.transport.lightfield.solve.solve_lightfield`.
    seabed_depth_m, seabed_albedo : Lambertian seabed (None: deep water).
        With a seabed the depth axis ends at it.
    n_depth, n_mu : table sizes (>= 2).
    max_depth_m : depth axis end for deep water (beyond it F is clamped,
        accurate because F tends to a constant with K = kappa_1).
    forward_cone_deg : float
        Scattering within this angle of forward counts as unscattered along
        camera rays that end on a surface: their transmittance uses
        ``c - f b`` (``f`` = ``forward_fraction``, the share of ``b`` in the
        cone). A target then blocks the light that the 1-D field would have
        scattered forward from behind it (SPEC: 10-20 degrees). 0 = off.
    cone_spread : bool
        The cone's light comes from where the cone points in the image, not
        from the pixel's own surface: :func:`aquaspec.shading.shade.shade_gbuffer`
        spreads it over the image (:mod:`aquaspec.transport.lightfield.conespread`).
        Adds :attr:`LightfieldTables.cone
        <aquaspec.transport.lightfield.tables.LightfieldTables.cone>`:
        the offsets (:func:`aquaspec.transport.lightfield.cone.cone_offsets`),
        the CDFs (:func:`aquaspec.medium.phase_bands.band_cone_offset_cdf`) and the
        weights ``f b``. Needs ``forward_cone_deg > 0``.
    spread_scattering : {"single", "multiple"}
        With ``cone_spread``: the cone's light taken as scattered once
        (``"single"``, the renderer's) or a Poisson number of times with mean
        ``f b S`` (``"multiple"``: the cone's tables then also hold the lambda
        nodes and their CDFs, :mod:`aquaspec.transport.lightfield.conespread`).
    ambient_shadow : bool
        Also the tables of the scene's first-order shadow in the light field
        (:mod:`aquaspec.transport.lightfield.shadow`, integrated in NumPy):
        :attr:`LightfieldTables.shadow
        <aquaspec.transport.lightfield.tables.LightfieldTables.shadow>`
        (:func:`aquaspec.transport.lightfield.shadowphase.shadow_tables`);
        :func:`aquaspec.shading.shade.shade_gbuffer` then subtracts the shadow.
        With a sun, its radiance is the diffuse radiance of sky and sun
        together (the beam's own shadow is the renderer's).
    sun_mu0, sun_fraction : float, array_like (n,)
        A direct sun: the zenith cosine of the refracted beam under water
        (:func:`aquaspec.transport.lightfield.solve.solve_lightfield`) and, per band,
        the sun's share ``mu0 F0 / E0`` (0 ... 1) of the total downwelling
        irradiance just below the surface ``E0 = E_sky + mu0 F0``. Both or
        neither. Every ``*_per_e0`` table stays per unit *total* ``E0`` and
        holds the diffuse field of sky and sun (``sky_radiance_per_e0`` then
        only the sky's part, ``(1 - sun_fraction)`` of the sky-only value); the
        unscattered beam (``sun_fraction E0 / mu0 exp(-c* d/mu0)``, ``c*`` =
        ``beam_extinction``) and its first scattering towards the camera
        are left to the renderer, so ``ms_log_prefactor`` holds the
        in-scattering of the diffuse field only.

    Returns
    -------
    LightfieldTables
    """
    if sun_fraction is not None:
        sun_fraction = np.atleast_1d(np.asarray(sun_fraction, dtype=float))
    if sun_mu0 is not None:
        sun_mu0 = float(sun_mu0)
    args = dict(phase=phase, seabed_depth_m=seabed_depth_m, seabed_albedo=seabed_albedo,
                n_depth=n_depth, n_mu=n_mu, max_depth_m=max_depth_m, n_streams=n_streams,
                surface=surface, forward_cone_deg=forward_cone_deg, cone_spread=cone_spread,
                spread_scattering=spread_scattering, ambient_shadow=ambient_shadow,
                sun_mu0=sun_mu0, sun_fraction=sun_fraction, **phase_params)
    return LightfieldTables.from_arrays(cache.cached_arrays(
        "lightfield-tables", tables_key(band_water, args),
        lambda: bake_tables(band_water, **args).to_arrays()))


def _wavelengths(band_water):
    wl = getattr(band_water, "wavelength_nm", None)
    if wl is None and getattr(band_water, "bands", None) is not None:
        wl = band_water.bands.centers_nm
    return wl


def tables_key(band_water, args: dict) -> str | None:
    """The cache key of :func:`lightfield_tables` (None: do not cache): its
    arguments, the water's a, b and wavelengths, and the code and data
    versions the tables come from."""
    code = cache.code_key(sys.modules[__name__], tables, solve, field, cone_module, conespread,
                          shadowphase, phase_functions, phase_bands, interface, model,
                          parallel)
    if code is None:
        return None
    jerlov = cache.package_version("jerlov")
    wl = _wavelengths(band_water)
    parts = [code, jerlov]
    for x in (band_water.a, band_water.b, wl):
        parts.append(None if x is None else np.asarray(x, dtype=float).tobytes())
    for name in sorted(args):
        value = args[name]
        parts.append(name)
        parts.append(np.asarray(value, dtype=float).tobytes()
                     if isinstance(value, np.ndarray) else value)
    return cache.digest(*parts)


#: Optical depth ``K_inf d`` beyond which the light field's scaled modes
#: underflow float64 (``exp(-745)``): measured on Jerlov IB and 9C, the tables
#: are finite up to about 710 and not beyond 730.
MAX_OPTICAL_DEPTH = 700.0


def _water_label(band_water) -> str:
    water = getattr(band_water, "water", None)
    return f"water {water.name!r}" if getattr(water, "name", None) else "the water"


def _band_label(i, wl) -> str:
    return f"{float(np.asarray(wl)[i]):g} nm" if wl is not None else f"band {i + 1}"


def _check_scattering(band_water, b, wl) -> None:
    """The light field is the diffuse light of scattering: refuse b = 0 up
    front, saying what renders a water that does not scatter."""
    none = np.flatnonzero(~(b > 0))
    if none.size:
        where = ", ".join(_band_label(i, wl) for i in none[:4]) + (", ..." if none.size > 4
                                                                   else "")
        raise AquaspecError(
            f"{_water_label(band_water)} has scattering b = 0 at {where} ({none.size} of "
            f"{b.size} bands): the light-field model tabulates the light that scattering "
            "spreads through the water, and without scattering there is none; accepted: "
            "b > 0 in every band, or the seeds' model (--ms-model seeds, "
            "ms_model='seeds'), which renders a water that does not scatter")


def _not_finite_error(band_water, k_inf, d_max, wl, phase) -> AquaspecError:
    """Why the tables came out non-finite: too deep for float64, else (a bug
    or an extreme input) the water and phase named."""
    k = np.asarray(k_inf, dtype=float)
    tau = k * d_max
    if np.nanmax(tau) > MAX_OPTICAL_DEPTH:
        i = int(np.nanargmax(tau))
        reach = MAX_OPTICAL_DEPTH / float(np.nanmax(k))
        return AquaspecError(
            f"the light field's depth axis reaches {d_max:g} m (the seabed, or the deepest "
            f"point asked for), where {_water_label(band_water)} has dimmed the light by "
            f"exp(-{tau[i]:.0f}) at {_band_label(i, wl)} (K = {k[i]:.3g} /m), beyond what "
            f"float64 holds; accepted: a camera and seabed above about {reach:.0f} m in this "
            "water (deeper, the light is far below anything a camera records)")
    return AquaspecError(
        f"light-field tables came out non-finite for {_water_label(band_water)} (a from "
        f"{np.min(band_water.a):g} to {np.max(band_water.a):g} /m, b from "
        f"{np.min(band_water.b):g} to {np.max(band_water.b):g} /m) with phase {phase!r}; "
        "please report these inputs, or use the seeds' model (--ms-model seeds)")


def _mirrored_top(lf, cos):
    """What the surface mirrors down, ``R(v) L(0, -v)`` on the cosine axis (n, n_mu)
    float32, for a surface that mirrors (``fresnel``); else None."""
    _, mirror, _ = interface.below_surface(cos, lf.surface, lf.n_water)
    mirror = np.where(cos > 0, mirror, 0.0)
    if not np.any(mirror > 0):
        return None
    return (mirror * lf.radiance(0.0, -np.abs(cos))).astype(np.float32)


def bake_tables(band_water, *, phase, seabed_depth_m, seabed_albedo, n_depth, n_mu,
                max_depth_m, n_streams, surface, forward_cone_deg, cone_spread,
                spread_scattering, ambient_shadow, sun_mu0=None, sun_fraction=None,
                **phase_params) -> LightfieldTables:
    """:func:`lightfield_tables` computed (not cached)."""
    if spread_scattering not in SPREAD_SCATTERING:
        raise AquaspecError(f"spread_scattering={spread_scattering!r}; accepted: 'single' "
                            "or 'multiple'")
    if spread_scattering == "multiple" and not cone_spread:
        raise AquaspecError("spread_scattering='multiple' is about the cone spread; it needs "
                            "cone_spread=True")
    a = np.asarray(band_water.a, dtype=float)
    b = np.asarray(band_water.b, dtype=float)
    wl = _wavelengths(band_water)
    for name, val in (("n_depth", n_depth), ("n_mu", n_mu)):
        if not (isinstance(val, (int, np.integer)) and val >= 2):
            raise AquaspecError(f"{name}={val!r}; accepted: an integer >= 2")
    _check_scattering(band_water, b, wl)
    if (sun_mu0 is None) != (sun_fraction is None):
        raise AquaspecError("sun_mu0 and sun_fraction go together: give both (a sun) or "
                            f"neither; got sun_mu0={sun_mu0!r}, sun_fraction={sun_fraction!r}")
    if sun_mu0 is None:
        lf = solve_lightfield(a, b, phase=phase, wavelength_nm=wl, e0=1.0, n_streams=n_streams,
                              seabed_depth_m=seabed_depth_m, seabed_albedo=seabed_albedo,
                              surface=surface, **phase_params)
        share = np.zeros(a.size)
    else:
        share = np.broadcast_to(np.asarray(sun_fraction, dtype=float), a.shape).astype(float)
        if not np.all((share >= 0) & (share <= 1)):
            raise AquaspecError(f"sun_fraction={sun_fraction!r}; accepted: the sun's share of "
                                "E0 per band, 0 ... 1")
        if not 0.0 < float(sun_mu0) <= 1.0:
            raise AquaspecError(f"sun_mu0={sun_mu0!r}; accepted: 0 < mu0 <= 1")
        # Per unit total E0: the sky brings 1 - share, the beam mu0 F0 = share.
        lf = solve_lightfield(a, b, phase=phase, wavelength_nm=wl, e0=1.0 - share,
                              n_streams=n_streams, seabed_depth_m=seabed_depth_m,
                              seabed_albedo=seabed_albedo, surface=surface,
                              sun_mu0=sun_mu0, sun_beam=share / float(sun_mu0), **phase_params)
    d_max = lf.seabed_depth_m if lf.has_seabed else float(max_depth_m)
    if not (np.isfinite(d_max) and d_max > 0):
        raise AquaspecError(f"max_depth_m={max_depth_m!r}; accepted: a finite depth > 0 m")
    depth = table_depths(d_max, n_depth)
    cos = table_cosines(n_mu)
    # At d = 0 an up ray (at the seabed a down ray) has length 0 and F is 0/0;
    # its limit is taken so close to the boundary that the source is constant.
    d_eval = np.clip(depth, 1e-7 * d_max, (1.0 - 1e-7) * d_max)
    dd, vv = np.meshgrid(d_eval, cos, indexing="ij")
    r_inf = lf.l_ms(dd, vv, np.inf)
    k1 = lf.k_inf
    # The reference ray ends where the light field's rays end (surface, seabed),
    # so that F stays smooth near both boundaries.
    ref = seeds_shape(b[:, None, None], lf.c[:, None, None], k1[:, None, None], dd, vv,
                      cut_at_seabed(np.inf, dd, vv, lf.seabed_depth_m))
    # Checked below, where the failure is explained (_not_finite_error).
    with np.errstate(divide="ignore", invalid="ignore", over="ignore", under="ignore"):
        pref = r_inf / ref
        irr = lf.irradiance(depth[:, None], cos[None, :])
    if not (np.all(np.isfinite(pref)) and np.all(pref > 0) and np.all(np.isfinite(irr))):
        raise _not_finite_error(band_water, lf.k_inf, d_max, wl, phase)
    f_cone = band_cone_fraction(phase, forward_cone_deg, b, wl, **phase_params)
    f32 = np.float32
    cone = None
    if cone_spread:
        if not forward_cone_deg > 0:
            raise AquaspecError(f"cone_spread needs a forward cone; forward_cone_deg="
                                f"{forward_cone_deg!r}; accepted: above 0 and below 90")
        offsets = cone_offsets(forward_cone_deg)
        cone = ConeTables(offset_rad=offsets,
                          offset_cdf=band_cone_offset_cdf(phase, forward_cone_deg, offsets, b,
                                                          wl, **phase_params),
                          weight=f_cone * b)
        if spread_scattering == "multiple":
            _, single = cone_cdf(cone)
            cone = ConeTables(offset_rad=cone.offset_rad, offset_cdf=cone.offset_cdf,
                              weight=cone.weight,
                              lambda_nodes=np.asarray(LAMBDA_NODES, dtype=float),
                              offset_cdf_nodes=np.stack(in_threads(
                                  lambda lam: multiple_scattering_cdf(offsets, single, lam),
                                  LAMBDA_NODES)))
    shadow = None
    if ambient_shadow:
        shadow = shadow_tables(lf, depth, cos, phase=phase, b=b, wavelength_nm=wl,
                               **phase_params)

    def scalar(x):
        """A float32 value as a float (the texel value every reader sees)."""
        return float(f32(x))

    return LightfieldTables(
        forward_cone_deg=scalar(forward_cone_deg),
        forward_fraction=f_cone.astype(f32),
        ms_log_prefactor=np.log(pref).astype(f32),
        irradiance_per_e0=irr.astype(f32),
        k_inf=k1.astype(f32),
        sky_radiance_per_e0=lf.top_radiance.astype(f32),
        window_cos=scalar(lf.window_cos),
        seabed_depth_m=scalar(lf.seabed_depth_m),
        seabed_albedo=lf.seabed_albedo.astype(f32),
        depth_m=depth.astype(f32),
        cosine=cos.astype(f32),
        max_depth_m=scalar(d_max),
        beam_extinction=lf.c_star.astype(f32),
        sun_mu0=scalar(np.nan if sun_mu0 is None else float(sun_mu0)),
        sun_fraction=share.astype(f32),
        cone=cone, shadow=shadow, surface=surface,
        mirrored_top_per_e0=_mirrored_top(lf, cos))
