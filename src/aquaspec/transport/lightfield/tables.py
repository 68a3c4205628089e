"""The light field's tables for the renderer: a typed object and its lookups.

:func:`aquaspec.transport.lightfield.bake.lightfield_tables` tabulates the
solved light field (:mod:`aquaspec.transport.lightfield.solve`) per band, over
depth (uniform in ``sqrt(d)``, :func:`table_depths`) and direction cosine
(uniform in angle, :func:`table_cosines`): the prefactor
``F(d, v_y) = R(d, v_y) / [b E0/(4 pi) ms_path_integral(c, kappa_1, d, v_y, inf)]``
with ``R = L_MS(S = inf)``, and ``E(d, n_y)/E0`` (with a sun: per unit total
``E0 = E_sky + mu0 F0``, diffuse field only). Because the part of a ray
beyond its hit point is the same ray continued, the exact identity
``L_MS(d_o, v, S) = R(d_o, v) - exp(-c S) R(d_S, v)`` (``d_S`` the depth of
the hit) needs only the S = inf table; :meth:`LightfieldTables.pixel_radiance`
uses it (``form="two_point"``) or the one-lookup prefactor form
``F(d_o, v) * seeds-form(S)`` (``form="prefactor"``).
``K = kappa_1`` (not the database Kd) is used in the seeds' form because it
is the decay rate of the light field being tabulated: F then tends to a
constant at depth, so clamping the depth axis beyond its end is accurate.

:class:`LightfieldTables` is what every consumer (the NumPy shading, the GPU
passes, the layers, the appearance) reads: named fields and the lookups as
methods. The forward cone's spread over the image (:class:`ConeTables`) and
the scene's shadow (:class:`aquaspec.transport.lightfield.shadowphase.ShadowTables`)
are optional parts of it. Lookups read the tables as a GPU sampler with
linear filtering would (:func:`table_lookup`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import SURFACES, below_surface, index_of_window
from aquaspec.numerics import bilinear_blend
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.lightfield.shadowphase import ShadowTables
from aquaspec.transport.lightfield.solve import hemisphere_nodes

#: Default table sizes and depth range (depth axis uniform in sqrt(d)).
DEFAULT_N_DEPTH = 64
DEFAULT_N_MU = 65
DEFAULT_MAX_DEPTH_M = 50.0
#: Forms of the table evaluator (see :meth:`LightfieldTables.pixel_radiance`).
TABLE_FORMS = ("two_point", "prefactor")


def table_depths(max_depth_m: float, n_depth: int) -> np.ndarray:
    """Depth axis: ``d_k = D (k / (n - 1))^2``, uniform in ``sqrt(d)`` (fine near the surface)."""
    return max_depth_m * (np.arange(n_depth) / (n_depth - 1.0)) ** 2


def table_cosines(n_mu: int) -> np.ndarray:
    """Direction-cosine axis, uniform in angle: ``v_j = cos(pi (1 - j / (n - 1)))``.

    Uniform in angle rather than in ``v_y`` because the in-scattering of a
    forward-peaked medium is peaked towards the zenith (``v_y -> 1``), where a
    step in ``v_y`` is a large step in angle.
    """
    return np.cos(np.pi * (1.0 - np.arange(n_mu) / (n_mu - 1.0)))


def table_depth_index(depth_m, max_depth_m, n_depth):
    """The depth axis of :func:`table_lookup`: lower texel ``i`` and weight ``f`` of
    ``x = sqrt(clamp(d, 0, D)/D) (n_depth - 1)`` (the texel below the last one
    at the axis' end)."""
    d = np.clip(np.asarray(depth_m, dtype=float), 0.0, max_depth_m)
    x = np.sqrt(d / max_depth_m) * (n_depth - 1)
    i = np.minimum(np.floor(x).astype(int), n_depth - 2)
    return i, x - i


def table_cos_index(cos, n_mu):
    """The direction axis of :func:`table_lookup`: lower texel ``j`` and weight ``f`` of
    ``y = (1 - acos(clamp(v, -1, 1))/pi) (n_mu - 1)``."""
    y = (1.0 - np.arccos(np.clip(np.asarray(cos, dtype=float), -1.0, 1.0)) / np.pi) * (n_mu - 1)
    j = np.minimum(np.floor(y).astype(int), n_mu - 2)
    return j, y - j


def table_lookup(table, depth_m, cos, max_depth_m, *, band_last: bool = False):
    """Bilinear lookup of ``table[band, depth, cos]`` as a GPU sampler would.

    Texel coordinates: ``x = sqrt(clamp(d, 0, D)/D) (n_depth - 1)``,
    ``y = (1 - acos(clamp(v, -1, 1))/pi) (n_mu - 1)``; on a GPU with linear filtering
    the texture coordinate is ``(x + 0.5) / n_depth`` (texel centres). Returns
    shape ``depth.shape + (n_bands,)`` (band axis last). ``band_last``: the
    table is ``[depth, cos, band]`` already (:func:`band_last_table`: many
    lookups in one table read each texel's bands in one piece). The blend is
    :func:`aquaspec.numerics.bilinear_blend`.
    """
    if band_last:
        tt = np.asarray(table)
        nd, nm = tt.shape[:2]
    else:
        t = np.asarray(table, dtype=np.float32)
        nd, nm = t.shape[1:]
        tt = np.moveaxis(t, 0, -1)  # (a view: the texels read are converted, not the table)
    i, fx = table_depth_index(depth_m, max_depth_m, nd)
    j, fy = table_cos_index(cos, nm)
    i, fx, j, fy = np.broadcast_arrays(i, fx, j, fy)
    fx, fy = fx[..., None], fy[..., None]

    if band_last:
        flat = tt.reshape(nd * nm, -1)

        def at(ii, jj):             # (np.take on flat indices: the fastest gather)
            return np.take(flat, ii * nm + jj, axis=0)
    else:
        def at(ii, jj):
            return tt[ii, jj].astype(float)

    return bilinear_blend(at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1), fx, fy)


def band_last_table(table) -> np.ndarray:
    """``table[band, depth, cos]`` as float32 texels laid out ``[depth, cos, band]``
    in float64, for ``table_lookup(..., band_last=True)`` (the same values)."""
    t = np.asarray(table, dtype=np.float32).astype(float)
    return np.ascontiguousarray(np.moveaxis(t, 0, -1))


def seeds_shape(b, c, k, depth, v_y, s):
    """``b/(4 pi) ms_path_integral(c, K, d, v, s)``: the seeds' closed form per unit E0."""
    return b / (4.0 * np.pi) * model.ms_path_integral(c, k, depth, v_y, s)


def cut_at_seabed(s, d_o, v, bed):
    """Ray lengths ``s`` from depth ``d_o`` along up components ``v``, cut where
    a down ray meets the seabed at depth ``bed`` (inf: no seabed)."""
    if not np.isfinite(bed):
        return np.asarray(s, dtype=float)
    down = v < 0
    to_bed = np.where(down, (bed - d_o) / np.where(down, -v, 1.0), np.inf)
    return np.minimum(s, to_bed)


@dataclass(frozen=True, eq=False)
class ConeTables:
    """The forward cone's light spread over the image (``lightfield_tables(cone_spread=True)``).

    ``offset_rad`` (m,) the apparent angular offsets and ``offset_cdf``
    (n, m) per band ``P(alpha <= offset)``
    (:func:`aquaspec.medium.phase_bands.band_cone_offset_cdf`); ``weight`` (n,) the
    cone's share of scattering ``f b`` (1/m). With
    ``spread_scattering="multiple"`` also ``lambda_nodes`` (k,), the mean
    numbers of scatterings in the cone with a kernel of their own, and
    ``offset_cdf_nodes`` (k, m) their CDFs
    (:mod:`aquaspec.transport.lightfield.conespread`).
    """

    offset_rad: np.ndarray
    offset_cdf: np.ndarray
    weight: np.ndarray
    lambda_nodes: np.ndarray | None = None
    offset_cdf_nodes: np.ndarray | None = None

    @property
    def multiple(self) -> bool:
        """Whether the cone's light is taken as scattered a Poisson number of times."""
        return self.offset_cdf_nodes is not None


#: The cache's (npz) key of each field of :class:`ConeTables`.
_CONE_KEYS = {"offset_rad": "cone_offset_rad", "offset_cdf": "cone_offset_cdf",
              "weight": "cone_weight", "lambda_nodes": "cone_lambda_nodes",
              "offset_cdf_nodes": "cone_offset_cdf_nodes"}
#: The fields of :class:`LightfieldTables` stored as (1,) float32 arrays in the cache.
_SCALARS = ("forward_cone_deg", "window_cos", "seabed_depth_m", "max_depth_m", "sun_mu0")
_ARRAYS = ("ms_log_prefactor", "irradiance_per_e0", "k_inf", "sky_radiance_per_e0",
           "seabed_albedo", "depth_m", "cosine", "forward_fraction", "beam_extinction",
           "sun_fraction")


@dataclass(frozen=True, eq=False)
class LightfieldTables:
    """Per-band tables of the light field (made by
    :func:`aquaspec.transport.lightfield.bake.lightfield_tables`; see the module docstring).

    Arrays are float32 (the texels a GPU reads); scalars are float32 values
    held as Python floats. ``n`` bands, ``n_depth`` x ``n_mu`` nodes.

    Attributes
    ----------
    ms_log_prefactor : (n, n_depth, n_mu)
        ``ln F(d, v_y)`` (F spans orders of magnitude over direction, so its
        logarithm is what interpolates well).
    irradiance_per_e0 : (n, n_depth, n_mu)
        ``E(d, n_y)/E0`` on the same axes (second axis read as ``n_y``).
    k_inf : (n,)
        ``kappa_1``, 1/m.
    sky_radiance_per_e0 : (n,)
        The radiance looking up just below the surface, seen for
        ``v_y > window_cos``; with a sun the sky's part only. With the
        ``fresnel`` surface, times the surface's transmission shape
        (:meth:`top_radiance`).
    mirrored_top_per_e0 : (n, n_mu) or None
        ``fresnel`` surface: the light going up that the surface mirrors,
        ``R(v) L(0, -v)`` on the cosine axis (zero for ``v <= 0``); None
        for the others.
    seabed_albedo : (n,)
    depth_m : (n_depth,), cosine : (n_mu,)
        The axes.
    forward_fraction : (n,)
        ``f``, the share of ``b`` within ``forward_cone_deg`` of forward,
        which camera rays ending on a surface count as unscattered.
    beam_extinction : (n,)
        The delta-M ``c* = c - f_2N b`` (1/m) that attenuates the sun's beam,
        ``F(d) = F0 exp(-c* d / mu0)``, consistently with the diffuse field
        (with or without a sun).
    sun_fraction : (n,)
        The sun's share ``mu0 F0 / E0`` of the downwelling irradiance just
        below the surface (zeros without a sun).
    forward_cone_deg, window_cos, max_depth_m : float
    surface : str
        The top boundary's model (:data:`aquaspec.medium.interface.SURFACES`).
    seabed_depth_m : float
        ``inf`` in deep water (then the depth axis ends at ``max_depth_m``).
    sun_mu0 : float
        The refracted beam's zenith cosine under water, NaN without a sun.
    cone : ConeTables or None
        With the cone spread.
    shadow : ShadowTables or None
        With the scene's shadow (``ambient_shadow``).
    """

    ms_log_prefactor: np.ndarray
    irradiance_per_e0: np.ndarray
    k_inf: np.ndarray
    sky_radiance_per_e0: np.ndarray
    seabed_albedo: np.ndarray
    depth_m: np.ndarray
    cosine: np.ndarray
    forward_fraction: np.ndarray
    beam_extinction: np.ndarray
    sun_fraction: np.ndarray
    forward_cone_deg: float
    window_cos: float
    seabed_depth_m: float
    max_depth_m: float
    sun_mu0: float = float("nan")
    cone: ConeTables | None = None
    shadow: ShadowTables | None = None
    surface: str = "null"
    mirrored_top_per_e0: np.ndarray | None = None

    # ---- the cache's form ---------------------------------------------------
    def to_arrays(self) -> dict:
        """The tables as named arrays (the on-disk cache's ``.npz``)."""
        out = {k: getattr(self, k) for k in _ARRAYS}
        out.update({k: np.array([getattr(self, k)], np.float32) for k in _SCALARS})
        if self.cone is not None:
            out.update({key: getattr(self.cone, f) for f, key in _CONE_KEYS.items()
                        if getattr(self.cone, f) is not None})
        if self.shadow is not None:
            out.update(self.shadow.to_arrays())
        if self.surface != "null":
            out["surface_model"] = np.array([SURFACES.index(self.surface)], np.float32)
        if self.mirrored_top_per_e0 is not None:
            out["mirrored_top_per_e0"] = self.mirrored_top_per_e0
        return out

    @classmethod
    def from_arrays(cls, arrays: dict) -> LightfieldTables:
        """The tables from :meth:`to_arrays`' named arrays."""
        cone = None
        if _CONE_KEYS["offset_cdf"] in arrays:
            cone = ConeTables(**{f: arrays.get(key) for f, key in _CONE_KEYS.items()})
        surface = SURFACES[int(arrays["surface_model"][0])] if "surface_model" in arrays \
            else "null"
        return cls(**{k: arrays[k] for k in _ARRAYS},
                   **{k: float(arrays[k][0]) for k in _SCALARS}, cone=cone,
                   shadow=ShadowTables.from_arrays(arrays), surface=surface,
                   mirrored_top_per_e0=arrays.get("mirrored_top_per_e0"))

    # ---- what the tables hold -----------------------------------------------
    @property
    def n_bands(self) -> int:
        return self.k_inf.size

    @property
    def has_seabed(self) -> bool:
        return bool(np.isfinite(self.seabed_depth_m))

    @property
    def has_sun(self) -> bool:
        return bool(np.isfinite(self.sun_mu0))

    def ray_extinction(self, a, b):
        """``c - f b``: extinction of a camera ray's beam when the forward cone
        (:attr:`forward_fraction`) counts as unscattered."""
        f = np.asarray(self.forward_fraction, dtype=float)
        return np.asarray(a, dtype=float) + (1.0 - f) * np.asarray(b, dtype=float)

    def prefactor(self, depth_m, v_y):
        """``F(d, v_y)``: ``exp`` of the bilinearly interpolated :attr:`ms_log_prefactor`
        (band axis last)."""
        return np.exp(table_lookup(self.ms_log_prefactor, depth_m, v_y, self.max_depth_m))

    # ---- lookups --------------------------------------------------------------
    def surface_radiance(self, rho, depth_m, n_y, e0) -> np.ndarray:
        """Lambertian radiance ``rho E(d, n_y) / pi`` of surfaces lit by the light
        field (irradiance table), shape ``depth.shape + (n_bands,)``."""
        e = table_lookup(band_last_table(self.irradiance_per_e0), depth_m, n_y,
                         self.max_depth_m, band_last=True)
        return model.lambertian_radiance(rho, e * np.asarray(e0, dtype=float))

    def _two_point(self, *, a, b, e0, depth_o, v_y, s):
        """``(R(d_o), R(d_S), S finite, S)`` of the two-point form (see :meth:`l_ms`)."""
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        c = a + b
        k1 = np.asarray(self.k_inf, dtype=float)
        bed = self.seabed_depth_m
        d_o = np.asarray(depth_o, dtype=float)
        v = np.asarray(v_y, dtype=float)
        e0 = np.asarray(e0, dtype=float)

        def r_at(d):
            d_b, v_b = np.broadcast_arrays(d, v)
            f = self.prefactor(d_b[..., 0] if d_b.ndim else d_b, v_b[..., 0] if v_b.ndim else v_b)
            return f * e0 * seeds_shape(b, c, k1, d, v, cut_at_seabed(np.inf, d, v, bed))

        s_eff = cut_at_seabed(model.ray_length(s, d_o, v), d_o, v, bed)
        fin = np.isfinite(s_eff)
        s_f = np.where(fin, s_eff, 0.0)
        d_s = np.clip(d_o - s_f * v, 0.0, bed)
        return r_at(d_o), r_at(d_s), fin, s_f

    def l_ms(self, *, a, b, e0, depth_o, v_y, s, form: str = "two_point"):
        """``L_MS`` from the tables (band axis last), the NumPy reference of the GPU lookup.

        F is :meth:`prefactor`. ``form="two_point"``: ``R(d_o, v) - exp(-c S) R(d_S, v)`` with
        ``R(d, v) = F(d, v) E0 b/(4 pi) ms_path_integral(c, kappa_1, d, v, inf)``
        (the ray cut at the surface and at the seabed)
        (two lookups; exact but for the interpolation of F). ``form="prefactor"``:
        ``F(d_o, v) E0 b/(4 pi) ms_path_integral(c, kappa_1, d_o, v, S)`` (one lookup).
        Per-ray inputs need a trailing axis of length 1 to meet band arrays.
        """
        if form not in TABLE_FORMS:
            raise AquaspecError(f"unknown table form {form!r}; known: {', '.join(TABLE_FORMS)}")
        c = np.asarray(a, dtype=float) + np.asarray(b, dtype=float)
        if form == "prefactor":
            d_o = np.asarray(depth_o, dtype=float)
            v = np.asarray(v_y, dtype=float)
            s_eff = cut_at_seabed(model.ray_length(s, d_o, v), d_o, v, self.seabed_depth_m)
            f_o = self.prefactor(d_o[..., 0] if d_o.ndim else d_o, v[..., 0] if v.ndim else v)
            return f_o * np.asarray(e0, dtype=float) * seeds_shape(
                np.asarray(b, dtype=float), c, np.asarray(self.k_inf, dtype=float), d_o, v, s_eff)
        r_o, r_s, fin, s_f = self._two_point(a=a, b=b, e0=e0, depth_o=depth_o, v_y=v_y, s=s)
        return r_o - np.where(fin, np.exp(-c * s_f), 0.0) * r_s

    def seabed_radiance(self, e0):
        """The seabed's own radiance (Lambertian under the downwelling light: the
        diffuse field's and, with a sun, the beam's, as ``LightField``'s boundary)."""
        bed = self.seabed_depth_m
        e_bed = table_lookup(self.irradiance_per_e0, bed, 1.0, self.max_depth_m)
        if self.has_sun:
            e_bed = e_bed + np.asarray(self.sun_fraction, dtype=float) * np.exp(
                -np.asarray(self.beam_extinction, dtype=float) * bed / self.sun_mu0)
        return np.asarray(self.seabed_albedo, dtype=float) * e_bed * e0 / np.pi

    def sky_share(self) -> np.ndarray:
        """The sky's share of ``E_d(0) = E0`` per band, (n,): 1 but for what a
        mirroring surface (``fresnel``) sends back down of the water's own
        light, which is the rest. Under a uniform sky of irradiance ``E_sky``
        in air, ``E0 = diffuse_transmittance() E_sky / sky_share()``
        (:func:`aquaspec.medium.interface.diffuse_transmittance`)."""
        mu, w = hemisphere_nodes(64, self.window_cos if self.surface != "null" else 0.0)
        shape, _, _ = below_surface(mu, self.surface, index_of_window(self.window_cos))
        return (2.0 * np.pi * np.sum(w * mu * shape)
                * np.asarray(self.sky_radiance_per_e0, dtype=float))

    def top_radiance(self, v, e0) -> np.ndarray:
        """The light field's top boundary seen looking up along ``v``: the sky
        through the surface (:func:`aquaspec.medium.interface.below_surface`'s
        shape) and what the surface mirrors (``fresnel``); zero for ``v <= 0``.
        ``v``: (J,) or (..., 1) (a trailing ray axis); returns ``(..., n)``."""
        v = np.asarray(v, dtype=float)
        vv = v[..., 0] if v.ndim and v.shape[-1] == 1 else v
        shape, _, _ = below_surface(vv, self.surface, index_of_window(self.window_cos))
        sky = np.asarray(self.sky_radiance_per_e0, dtype=float) * np.asarray(e0, dtype=float)
        out = np.where((vv > 0)[..., None], shape[..., None] * sky, 0.0)
        if self.mirrored_top_per_e0 is not None:
            table = np.asarray(self.mirrored_top_per_e0, dtype=float).T     # (n_mu, n)
            j, t = table_cos_index(vv, table.shape[0])
            mirrored = (1.0 - t[..., None]) * table[j] + t[..., None] * table[j + 1]
            out = out + np.where((vv > 0)[..., None], mirrored * np.asarray(e0, dtype=float),
                                 0.0)
        return out

    def pixel_radiance(self, *, a, b, e0, depth_o, v_y, s, rho=None, surface_depth=None,
                       n_y=None, form: str = "two_point", split_cone: bool = False,
                       surface_scale=None):
        """Band radiance along camera rays from the light-field tables.

        Same shape of call as :func:`aquaspec.transport.monzon2022.pixel_radiance` (per-ray
        arrays with a trailing axis of length 1, band arrays (n,)):
        ``L = T(S) L_surf + L_MS`` with ``L_MS`` from :meth:`l_ms`.
        Open water (``rho`` None): an up ray ends at the water surface and sees
        the light field's own top boundary (:meth:`top_radiance`); a down ray in water with a seabed sees the seabed
        (``albedo E(H, +1)/pi``). A hit surface of reflectance ``rho`` at
        ``surface_depth`` with normal ``n_y`` gets ``rho E(d, n_y)/pi`` from the
        irradiance table, times ``surface_scale`` (per ray and band, e.g. the
        scene's occlusion of the ambient light,
        :func:`aquaspec.transport.lightfield.occlusion.occlusion_factor`) when given.

        ``split_cone=True`` returns ``(L without the cone, cone term)``: the
        radiance with the beam's full extinction ``c`` and the part the forward
        cone adds, ``(T' - T)(L_surf - L_bg(d_S, v))`` (zero for open water), whose
        sum is the radiance
        (:func:`aquaspec.transport.lightfield.cone.spread_cone_light` moves the second term).
        """
        a = np.asarray(a, dtype=float)
        b = np.asarray(b, dtype=float)
        e0 = np.asarray(e0, dtype=float)
        c = a + b
        d_o = np.asarray(depth_o, dtype=float)
        v = np.asarray(v_y, dtype=float)
        bed = self.seabed_depth_m
        s_eff = cut_at_seabed(model.ray_length(s, d_o, v), d_o, v, bed)
        l_bed = self.seabed_radiance(e0) if np.isfinite(bed) else 0.0
        if rho is None:
            l_surf = np.where(np.isfinite(s_eff) & (v > 0), self.top_radiance(v, e0), 0.0)
            if np.isfinite(bed):
                l_surf = np.where(np.isfinite(s_eff) & (v < 0), l_bed, l_surf)
        else:
            sd = np.asarray(surface_depth, dtype=float)
            ny = np.asarray(n_y, dtype=float)
            sd, ny = np.broadcast_arrays(sd, ny)
            l_surf = self.surface_radiance(rho, sd[..., 0] if sd.ndim else sd,
                                           ny[..., 0] if ny.ndim else ny, e0)
            if surface_scale is not None:
                l_surf = l_surf * np.asarray(surface_scale, dtype=float)
        f = np.asarray(self.forward_fraction, dtype=float)
        if form == "two_point" and np.any(f > 0):
            # The forward cone stays in the beam (extinction c - f b): with the
            # open-water field L_bg(d) = R(d) + exp(-c l(d)) L_end, where the line
            # of sight ends on the sky (up rays, l = d / v) or on the seabed (down
            # rays, l = (H - d) / -v), the radiance is L_bg(d_o) + T' (L_surf -
            # L_bg(d_S)); with f = 0 it is the two-point form above exactly.
            # (The end's term cancels from T'-independent parts; in the cone's
            # share it is the background the target hides, seabed included.)
            r_o, r_s, fin, s_f = self._two_point(a=a, b=b, e0=e0, depth_o=d_o, v_y=v, s=s_eff)
            l_top = self.top_radiance(v, e0)
            up = v > 0
            to_bed = (v < 0) & np.isfinite(bed)
            l_end = np.where(up, l_top, np.where(to_bed, l_bed, 0.0))
            d_s = np.clip(d_o - s_f * v, 0.0, bed)

            def u_end(d):
                """exp(-c l): transmittance from depth d to the line of sight's end."""
                length = np.where(up, d / np.where(up, v, 1.0),
                                  (bed - d) / np.where(to_bed, -v, 1.0))
                return np.where(up | to_bed, np.exp(-c * np.where(up | to_bed, length, 0.0)),
                                0.0)

            u_o, u_s = u_end(d_o), u_end(d_s)
            t_beam = np.where(fin, np.exp(-self.ray_extinction(a, b) * s_f), 0.0)
            blocked = np.where(fin, l_surf - r_s - u_s * l_end, 0.0)
            if split_cone:
                t = np.where(fin, np.exp(-c * s_f), 0.0)
                out = r_o + u_o * l_end + t * blocked
                cone = (t_beam - t) * blocked
                if not (np.all(np.isfinite(out)) and np.all(np.isfinite(cone))):
                    raise AquaspecError("light-field radiance came out non-finite; check the "
                                        "inputs")
                return out, cone
            out = r_o + u_o * l_end + t_beam * blocked
        else:
            l_ms = self.l_ms(a=a, b=b, e0=e0, depth_o=d_o, v_y=v, s=s_eff, form=form)
            t = model.transmittance(c, s_eff)
            out = np.where(t > 0, t * l_surf, 0.0) + l_ms
        if not np.all(np.isfinite(out)):
            raise AquaspecError("light-field radiance came out non-finite; check the inputs")
        if split_cone:
            return out, np.zeros_like(out)
        return out
