"""The underwater light field of a homogeneous water layer, per band: discrete ordinates.

The seeds' multiple-scattering term lights the water by the downwelling
irradiance scattered isotropically. This module solves the plane-parallel
radiative transfer equation (RTE) instead, for a horizontally uniform
(overcast) sky and, optionally, a direct sun's refracted beam, and gives
everything the renderer needs from it: the
radiance ``L(d, mu)`` at any depth and direction, the irradiance on a
surface of any orientation ``E(d, n_y)``, the in-scattering source
``j(d, v_y)`` and its integral along a camera ray.

Conventions
-----------
Depth ``d`` in m below the surface (y = 0, y up). A direction is given by its
up component: ``mu`` (or ``v_y``, ``n_y``). ``L(d, mu)`` is the radiance *seen
looking* in direction ``mu`` (``mu > 0``: looking up, the downwelling light),
so ``E_d = 2 pi int_0^1 L mu dmu`` and
``E(d, n) = int L(d, w) max(0, n . w) dw`` (``E(d, +1) = E_d``,
``E(d, -1) = E_u``). Coefficients a, b, c in 1/m. In this convention the
RTE reads ``mu dL/dd = -c L + j`` with
``j(d, v) = b int p(w . v) L(d, w) dw``.

Method
------
*Delta-M* ([Wiscombe1977]): the phase function's forward peak beyond what
``2N`` streams resolve, ``f = chi_2N``, is treated as unscattered light:
``b* = (1 - f) b``, ``c* = c - f b``, ``chi*_l = (chi_l - f)/(1 - f)``. This is an
exact rewriting of the RTE up to the truncation of ``p*`` to ``2N`` Legendre
terms.

*Discrete ordinates* ([Chandrasekhar1960], [Stamnes1988]): double-Gauss
quadrature, ``N`` nodes per hemisphere (weights summing to 1 on each), and
the azimuthally averaged redistribution matrix
(:func:`aquaspec.medium.phase.redistribution_matrix`). With ``L+-`` the radiance at
``+-mu_i``, ``S = L+ + L-`` and ``D = L+ - L-`` obey
``S'' = (alpha + beta)(alpha - beta) S``; that matrix is similar to a
product of two symmetric positive semi-definite matrices, so its eigenvalues
``kappa_m^2`` are computed with ``eigh`` (real, sorted). The homogeneous
solution is ``sum_m A_m phi_m(mu) exp(-kappa_m d) + B_m phi_m(-mu)
exp(-kappa_m (H - d))`` (the growing modes are anchored at the seabed, so no
exponential ever exceeds 1: the "scaled" form). ``kappa_1`` is the asymptotic
diffuse attenuation.

*Boundaries.* Top: ``surface="null"`` (default; the reference path tracer's
non-refracting surface) is a uniform radiance ``E0/pi`` looking up;
``surface="refracted"`` is uniform inside Snell's window (n = 1.33) and 0
outside; both normalised so that ``E_d(0) = E0`` on the quadrature. Upwelling
light leaves through the surface (no internal reflection). Bottom: infinitely
deep (decaying modes only) or a Lambertian seabed of albedo ``rho`` at depth
``H``.

*The sun* (``solve_lightfield(sun_mu0=, sun_beam=)``): a collimated beam of
normal irradiance ``F0`` just below the surface, travelling down at zenith
cosine ``mu0``. In the scaled problem the delta-M forward peak stays in the
beam, so its normal irradiance at depth d is ``F0 exp(-c* d/mu0)``. The beam
is the radiance ``F0 delta(w - w0)`` seen looking *up* at ``+mu0``; its
first scattering is the source ``b* pbar*(mu, mu0) F0 exp(-c* d/mu0)`` of
the diffuse radiance seen looking along ``mu``, with
``2 pi pbar*(mu, mu0) = 1/2 sum_l (2l + 1) chi*_l P_l(mu) P_l(mu0)`` (the
azimuthal average, i.e. the m = 0 Fourier term). Its particular solution is
``X(mu_i) exp(-c* d/mu0)`` with ``(c* (1 - mu_i/mu0) - b* Q) X = b* F0
pbar*(mu_i, mu0)``, computed by expansion on the 2N modes (see
``_sun_particular``); where ``c*/mu0`` comes within
:data:`SUN_RESONANCE_GAP` of a ``kappa_m`` that band's ``mu0`` is moved to
that distance. It becomes one more decaying "mode" (``kappa = c*/mu0``,
``phi = X``, amplitude 1), so every evaluation below is unchanged; its source
off the nodes also carries the beam's own first-scattering term. Boundary
conditions for the diffuse field: at the top the sun adds no diffuse light
looking up (the sky's top radiance stays as it is); a Lambertian seabed
reflects ``rho/pi (E_d,diffuse(H) + mu0 F0 exp(-c* H/mu0))`` (the beam
reflects too). All the field's quantities (radiance, irradiance, source,
``L_MS``) are then the diffuse field: the sky's plus all orders of
scattering of the beam. The unscattered beam itself (on surfaces, shadowed)
and its first scattering towards the camera, with the full phase function
and its azimuth, are the renderer's (:mod:`aquaspec.light.sun`): ``L_MS`` is the
in-scattering of the diffuse field only (the beam's ``b* pbar*`` term is
subtracted in closed form). Left out by the m = 0 averaging: the azimuthal
structure of the sun's diffuse light (brighter towards the sun's azimuth
near the surface); irradiances on horizontal planes and the scalar
irradiance are exact in it, radiances, tilted irradiances and the
in-scattering are their azimuthal means.

*Any direction* (source-function integration): the DO nodes give ``L`` at
``2N`` cosines; at any other ``v`` the source
``j*(d, v) = b* sum_j Q*(v, mu_j) L(d, mu_j)`` is a sum of the same modes, and
``L(d, v)`` is its integral along the line of sight plus the attenuated
boundary radiance, closed form mode by mode
(:func:`aquaspec.transport.monzon2022.ms_path_integral` with ``Kd -> kappa_m``).

*Camera rays.* The full source is ``j = j* + f b L(d, v)``. Along a ray of
direction ``v`` the second part integrates in closed form too (the line of
sight of ``L(d(t), v)`` is the ray itself), giving the exact
``L_MS = int_0^S exp(-c t) j dt = exp(-f b S) I*(S) + (1 - exp(-f b S)) L(d_o, v)``
with ``I*(S) = int_0^S exp(-c* t) j*(d(t), v) dt`` (:meth:`LightField.l_ms`).

*Tables for the GPU* (:func:`lightfield_tables`): per band, over depth
(uniform in ``sqrt(d)``) and direction cosine (uniform in ``v_y``), the
prefactor ``F(d, v_y) = R(d, v_y) / [b E0/(4 pi) ms_path_integral(c, kappa_1,
d, v_y, inf)]`` with ``R = L_MS(S = inf)``, and ``E(d, n_y)/E0`` (with a sun: per
unit total ``E0 = E_sky + mu0 F0``, diffuse field only). Because the
part of a ray beyond its hit point is the same ray continued, the exact
identity ``L_MS(d_o, v, S) = R(d_o, v) - exp(-c S) R(d_S, v)`` (``d_S`` the
depth of the hit) needs only the S = inf table; :func:`lightfield_pixel_radiance`
uses it (``form="two_point"``) or the one-lookup prefactor form
``F(d_o, v) * seeds-form(S)`` (``form="prefactor"``).
``K = kappa_1`` (not the database Kd) is used in the seeds' form because it
is the decay rate of the light field being tabulated: F then tends to a
constant at depth, so clamping the depth axis beyond its end is accurate.

References
----------
.. [Chandrasekhar1960] S. Chandrasekhar, "Radiative Transfer", Dover (1960), Ch. VI.
.. [Stamnes1988] K. Stamnes, S.-C. Tsay, W. Wiscombe, K. Jayaweera, "Numerically
   stable algorithm for discrete-ordinate-method radiative transfer in
   multiple scattering and emitting layered media", Appl. Opt. 27, 2502-2509
   (1988), doi:10.1364/AO.27.002502 (reduction to half size; scaled
   solutions).
.. [Wiscombe1977] W. J. Wiscombe, "The delta-M method: rapid yet accurate
   radiative flux calculations for strongly asymmetric phase functions",
   J. Atmos. Sci. 34, 1408-1422 (1977).
.. [Mobley1994] C. D. Mobley, "Light and Water", Academic Press (1994),
   Sec. 9.3 (asymptotic radiance distribution and K_inf).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
from numpy.polynomial.legendre import leggauss

from aquaspec.transport import monzon2022 as model
from aquaspec.errors import AquaspecError
from aquaspec.medium.phase import band_moments, legendre_table, redistribution_matrix

#: Surface boundary conditions (the radiance looking up just below y = 0).
SURFACES = ("null", "refracted")

#: Resonance guard of the sun's particular solution: when ``c*/mu0`` lies
#: within this relative distance of a mode's ``kappa_m``, that band's ``mu0``
#: is moved so that it lies exactly this far away (see :func:`solve_lightfield`).
SUN_RESONANCE_GAP = 1e-6

#: Single-scattering albedo cap: the conservative mode (kappa = 0) of a = 0 is
#: replaced by kappa ~ 5e-4 c (eigh resolves it), so every mode decays.
_MAX_ALBEDO = 1.0 - 1e-7


def clamped_cosine_azimuth(mu, n_y):
    """``h(mu, n_y) = int_0^{2 pi} max(0, n . w) dphi`` for unit n, w.

    With ``A = n_y mu`` and ``B = sqrt(1 - n_y^2) sqrt(1 - mu^2)``:
    ``2 pi A`` if ``A >= B``, 0 if ``A <= -B``, else
    ``2 (A arccos(-A/B) + sqrt(B^2 - A^2))``. Then
    ``E(d, n_y) = int_{-1}^{1} L(d, mu) h(mu, n_y) dmu``.
    """
    mu = np.asarray(mu, dtype=float)
    n_y = np.asarray(n_y, dtype=float)
    a = n_y * mu
    b = np.sqrt(np.maximum(1.0 - n_y * n_y, 0.0) * np.maximum(1.0 - mu * mu, 0.0))
    safe_b = np.where(b > 0, b, 1.0)
    mid = 2.0 * (a * np.arccos(np.clip(-a / safe_b, -1.0, 1.0))
                 + np.sqrt(np.maximum(b * b - a * a, 0.0)))
    return np.where(a >= b, 2.0 * np.pi * a, np.where(a <= -b, 0.0, mid))


def _band(name, value, n):
    arr = np.broadcast_to(np.asarray(value, dtype=float), (n,)).astype(float)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise AquaspecError(f"{name} must be finite and >= 0 per band; got {arr.tolist()}")
    return arr


@dataclass
class LightField:
    """Discrete-ordinates solution per band (build it with :func:`solve_lightfield`).

    ``f`` is the delta-M forward fraction, ``b_star = (1 - f) b`` and
    ``c_star = c - f b`` the scaled coefficients (b* capped at
    ``(1 - 1e-7) c*``). Arrays have the band axis first: ``kappa`` (n, N) ascending, ``phi``
    (n, 2N, N) the decaying modes at the nodes ``mu`` (2N: N looking up, then
    the same cosines negated), ``amp_dec``/``amp_grow`` (n, N) mode
    amplitudes for ``E0 = e0``.

    With a sun (``has_sun``) the sun's particular solution is one more,
    last, decaying "mode": ``kappa[:, N] = c*/mu0`` (not in ascending order:
    ``kappa[:, 0]`` stays ``kappa_1``), ``phi[:, :, N] = X`` (not normalised),
    ``amp_dec[:, N] = 1``, ``amp_grow[:, N] = 0``; ``sun_mu0`` (n,) is the
    beam's zenith cosine per band (the given one, or moved by at most
    :data:`SUN_RESONANCE_GAP` off a resonance) and ``sun_beam`` (n,) its
    normal irradiance ``F0`` just below the surface. Every method then
    gives the *diffuse* field (sky + all orders of scattering of the beam);
    the unscattered beam is :meth:`beam_irradiance`.
    """

    a: np.ndarray
    b: np.ndarray
    e0: np.ndarray
    f: np.ndarray
    b_star: np.ndarray
    c_star: np.ndarray
    chi_star: np.ndarray
    mu: np.ndarray
    w: np.ndarray
    kappa: np.ndarray
    phi: np.ndarray
    amp_dec: np.ndarray
    amp_grow: np.ndarray
    top_radiance: np.ndarray
    window_cos: float
    seabed_depth_m: float
    seabed_albedo: np.ndarray
    surface: str
    sun_mu0: np.ndarray | None = None
    sun_beam: np.ndarray | None = None

    @property
    def c(self):
        return self.a + self.b

    @property
    def n_streams(self) -> int:
        return self.mu.size // 2

    @property
    def k_inf(self) -> np.ndarray:
        """Asymptotic diffuse attenuation ``kappa_1`` (1/m), per band."""
        return self.kappa[:, 0]

    @property
    def has_seabed(self) -> bool:
        return np.isfinite(self.seabed_depth_m)

    @property
    def has_sun(self) -> bool:
        return self.sun_mu0 is not None

    def beam_irradiance(self, depth_m):
        """The unscattered beam's normal irradiance ``F0 exp(-c* d / mu0)``; (n_bands, ...).

        Zero without a sun. Its horizontal irradiance is ``mu0`` times this;
        its scalar irradiance is this.
        """
        d = np.asarray(depth_m, dtype=float)
        if not self.has_sun:
            return np.zeros((self.a.size,) + d.shape)
        ex = (-self.c_star / self.sun_mu0).reshape((-1,) + (1,) * d.ndim)
        return self.sun_beam.reshape((-1,) + (1,) * d.ndim) * np.exp(ex * d)

    def _beam_source(self, v):
        """``b* F0 pbar*(v, mu0)`` per unit ``exp(-c* d/mu0)``: the beam's first
        scattering into the radiance seen looking along ``v`` (n, R), ``v`` 1-D.

        The beam is the radiance ``F0 delta(w - w0)`` seen looking *up* at
        ``+mu0``; ``2 pi pbar*(v, mu0) = 1/2 sum_l (2l + 1) chi*_l P_l(v) P_l(mu0)``
        (:func:`aquaspec.medium.phase.redistribution_matrix` with weight 1).
        """
        return _beam_scattering(self.chi_star, self.b_star, self.sun_beam, self.sun_mu0, v)

    # ---- radiance at the quadrature nodes -------------------------------
    def _phi_grow(self):
        n = self.n_streams
        return np.concatenate([self.phi[:, n:], self.phi[:, :n]], axis=1)

    def node_radiance(self, depth_m):
        """``L(d, mu_i)`` at the nodes: shape ``(n_bands,) + depth.shape + (2N,)``."""
        d = np.asarray(depth_m, dtype=float)
        dd = d[..., None]
        k = self.kappa[:, *([None] * d.ndim), :]
        dec = np.exp(-k * dd) * self.amp_dec[:, *([None] * d.ndim), :]
        out = np.einsum("b...m,bim->b...i", dec, self.phi)
        if self.has_seabed:
            grow = np.exp(-k * (self.seabed_depth_m - dd)) \
                * self.amp_grow[:, *([None] * d.ndim), :]
            out = out + np.einsum("b...m,bim->b...i", grow, self._phi_grow())
        return out

    def irradiance(self, depth_m, n_y):
        """``E(d, n_y) = int L max(0, n . w) dw`` on the quadrature; (n_bands, ...).

        ``depth_m`` and ``n_y`` broadcast; ``n_y = +1`` gives ``E_d``, ``-1`` ``E_u``.
        """
        d, ny = np.broadcast_arrays(np.asarray(depth_m, dtype=float),
                                    np.asarray(n_y, dtype=float))
        lrad = self.node_radiance(d)
        h = clamped_cosine_azimuth(self.mu, ny[..., None]) * self.w
        return np.sum(lrad * h, axis=-1)

    def e_d(self, depth_m):
        """Downwelling irradiance ``E_d(d)`` (band axis first)."""
        return self.irradiance(depth_m, 1.0)

    def e_u(self, depth_m):
        """Upwelling irradiance ``E_u(d)``."""
        return self.irradiance(depth_m, -1.0)

    def e_scalar(self, depth_m):
        """Scalar irradiance ``E_0(d) = int L dw``."""
        return 2.0 * np.pi * np.sum(self.node_radiance(depth_m) * self.w, axis=-1)

    def kd_local(self, depth_m):
        """``-d ln E_d / dd`` at ``depth_m`` (analytic derivative of the modes)."""
        d = np.asarray(depth_m, dtype=float)
        dd = d[..., None]
        k = self.kappa[:, *([None] * d.ndim), :]
        up = self.phi[:, : self.n_streams]
        wmu = 2.0 * np.pi * self.w[: self.n_streams] * self.mu[: self.n_streams]
        flux_dec = np.einsum("bim,i->bm", up, wmu)[:, *([None] * d.ndim), :]
        e = np.exp(-k * dd) * self.amp_dec[:, *([None] * d.ndim), :] * flux_dec
        de = -k * e
        if self.has_seabed:
            flux_g = np.einsum("bim,i->bm", self._phi_grow()[:, : self.n_streams],
                               wmu)[:, *([None] * d.ndim), :]
            g = np.exp(-k * (self.seabed_depth_m - dd)) \
                * self.amp_grow[:, *([None] * d.ndim), :] * flux_g
            e, de = e + g, de + k * g
        return -np.sum(de, axis=-1) / np.sum(e, axis=-1)

    # ---- any direction ----------------------------------------------------
    def _mode_sources(self, v_y, beam: bool = True):
        """``psi_dec, psi_grow``: (n_bands, R, modes), b* Q*(v, nodes) phi.

        With a sun and ``beam``, the particular solution's column also holds
        the beam's first scattering (same ``exp(-c* d/mu0)``): then the
        sources are those of the diffuse radiance's transport equation.
        """
        v = np.atleast_1d(np.asarray(v_y, dtype=float)).ravel()
        q = redistribution_matrix(self.chi_star, v, self.mu, self.w)   # (n, R, 2N)
        bs = self.b_star[:, None, None]
        psi_d = bs * (q @ self.phi)
        psi_g = bs * (q @ self._phi_grow()) if self.has_seabed \
            else np.zeros_like(psi_d)
        if self.has_sun and beam:
            psi_d[:, :, -1] += self._beam_source(v)
        return psi_d, psi_g

    def _boundary(self, depth_o, v_y):
        """Distance to the boundary along ``v`` and the radiance seen there (n, R)."""
        s_b = model.ray_length(np.inf, depth_o, v_y)
        down = v_y < 0
        if self.has_seabed:
            with np.errstate(divide="ignore"):
                to_bed = np.where(down, (self.seabed_depth_m - depth_o)
                                  / np.where(down, -v_y, 1.0), np.inf)
            s_b = np.minimum(s_b, to_bed)
        top = np.where(v_y > 0, self._top(v_y), 0.0)
        if self.has_seabed:
            e_bed = self.e_d(self.seabed_depth_m)[:, None]
            if self.has_sun:     # the beam reflects too
                e_bed = e_bed + (self.sun_mu0 * self.beam_irradiance(self.seabed_depth_m))[:, None]
            top = np.where(down, self.seabed_albedo[:, None] * e_bed / np.pi, top)
        return s_b, top

    def _top(self, v_y):
        """Radiance looking up just below the surface, (n, R)."""
        inside = np.asarray(v_y) > self.window_cos
        return self.top_radiance[:, None] * inside

    def _mode_integral(self, ext, depth_o, v_y, s, psi_d, psi_g):
        """``sum_m int_0^s exp(-ext t) (A psi_d e^{-k d(t)} + B psi_g e^{-k (H-d(t))}) dt``."""
        k = self.kappa[:, None, :]
        ex = ext[:, None, None]
        d_o, vy, ss = depth_o[None, :, None], v_y[None, :, None], s[:, :, None]
        out = np.sum(self.amp_dec[:, None, :] * psi_d
                     * model.ms_path_integral(ex, k, d_o, vy, ss), axis=-1)
        if self.has_seabed:
            # Anchored at the seabed: depth below it H - d(t) = (H - d_o) + t v_y.
            out = out + np.sum(self.amp_grow[:, None, :] * psi_g * model.ms_path_integral(
                ex, k, self.seabed_depth_m - d_o, -vy, ss), axis=-1)
        return out

    def _rays(self, depth_o, v_y, s):
        d, v, s = np.broadcast_arrays(np.asarray(depth_o, dtype=float),
                                      np.asarray(v_y, dtype=float),
                                      np.asarray(s, dtype=float))
        if np.any(d < 0) or (self.has_seabed and np.any(d > self.seabed_depth_m)):
            raise AquaspecError("depth_o must lie in the water: 0 <= d <= seabed depth "
                                f"({self.seabed_depth_m:g} m)")
        return d.shape, d.ravel(), np.clip(v.ravel(), -1.0, 1.0), s.ravel()

    def radiance(self, depth_m, v_y):
        """``L(d, v_y)`` looking in direction ``v_y`` (any cosine); (n_bands, ...)."""
        shape, d, v, _ = self._rays(depth_m, v_y, 0.0)
        s_b, l_b = self._boundary(d, v)
        psi_d, psi_g = self._mode_sources(v)
        cs = self.c_star
        s_b = np.broadcast_to(s_b, (cs.size, d.size))
        out = self._mode_integral(cs, d, v, s_b, psi_d, psi_g)
        att = np.where(np.isfinite(s_b), np.exp(-cs[:, None] * np.where(
            np.isfinite(s_b), s_b, 0.0)), 0.0)
        return (out + att * l_b).reshape((cs.size,) + shape)

    def source(self, depth_m, v_y, beam: bool = False):
        """In-scattering ``j(d, v) = b int p(w . v) L(d, w) dw``; (n_bands, ...).

        ``j* + f b L(d, v)``: the delta-M truncated part on the nodes plus the
        forward peak, which scatters the radiance seen along ``v`` itself.
        ``L`` is the diffuse field: the sun's beam is not in it (the renderer
        scatters the beam once itself); ``beam=True`` adds the beam's first
        scattering in the model's form, ``b* pbar*(v, mu0) F0 exp(-c* d/mu0)``
        (azimuthally averaged, delta-M truncated phase function).
        """
        shape, d, v, _ = self._rays(depth_m, v_y, 0.0)
        psi_d, psi_g = self._mode_sources(v, beam=beam)
        k = self.kappa[:, None, :]
        j = np.sum(self.amp_dec[:, None, :] * psi_d * np.exp(-k * d[None, :, None]), axis=-1)
        if self.has_seabed:
            j = j + np.sum(self.amp_grow[:, None, :] * psi_g * np.exp(
                -k * (self.seabed_depth_m - d[None, :, None])), axis=-1)
        j = j.reshape((self.a.size,) + shape)
        return j + (self.f * self.b).reshape((-1,) + (1,) * len(shape)) \
            * self.radiance(depth_m, v_y)

    def asymptotic_radiance(self, mu):
        """Shape of the slowest mode at any cosines ``mu``; (n_bands, ...), arbitrary scale.

        Deep down ``L(d, mu) = exp(-kappa_1 d) Lambda(mu)``; in the delta-M
        scaled RTE (``mu dL/dd = -c* L + j*``) that gives ``Lambda(mu) =
        j*_1(mu) / (c* - kappa_1 mu)``, with ``j*_1`` the mode's source from
        its values at the nodes. ``c* > kappa_1``, so the denominator never
        vanishes. Per band the eigenvector's sign is chosen so that the
        largest value is positive (the slowest mode is then positive).
        """
        mu = np.asarray(mu, dtype=float)
        psi_dec, _ = self._mode_sources(mu)
        lam = psi_dec[:, :, 0] / (self.c_star[:, None] - self.kappa[:, :1] * mu.ravel()[None, :])
        big = np.take_along_axis(lam, np.argmax(np.abs(lam), axis=1)[:, None], axis=1)
        return (lam * np.sign(big)).reshape((lam.shape[0],) + mu.shape)

    def l_ms(self, depth_o, v_y, s):
        """Exact ``L_MS = int_0^S exp(-c t) j(d_o - t v_y, v) dt``; (n_bands, ...).

        Rays are cut at the water surface (up) and at the seabed (down).
        ``j`` is :meth:`source` (the diffuse field's in-scattering): with a
        sun, the beam's own first scattering towards the camera is left to
        the renderer (computed here with the beam and subtracted in closed form).
        """
        shape, d, v, s = self._rays(depth_o, v_y, s)
        s_b, l_b = self._boundary(d, v)
        s_eff = np.minimum(s, s_b)
        psi_d, psi_g = self._mode_sources(v)
        cs = self.c_star
        nb = cs.size
        s_eff = np.broadcast_to(s_eff, (nb, d.size))
        s_b = np.broadcast_to(s_b, (nb, d.size))
        i_s = self._mode_integral(cs, d, v, s_eff, psi_d, psi_g)
        same = s_eff >= s_b
        i_b = i_s if np.all(same) else np.where(
            same, i_s, self._mode_integral(cs, d, v, s_b, psi_d, psi_g))
        fin = np.isfinite(s_b)
        l_full = i_b + np.where(fin, np.exp(-cs[:, None] * np.where(fin, s_b, 0.0)), 0.0) * l_b
        fb = (self.f * self.b)[:, None]
        fin_s = np.isfinite(s_eff)
        keep = np.where(fin_s, np.exp(-fb * np.where(fin_s, s_eff, 0.0)), 0.0)
        out = keep * i_s + (1.0 - keep) * l_full
        if self.has_sun:
            # The beam's first scattering, int_0^S exp(-c t) j*_beam(d(t), v) dt.
            out = out - self._beam_source(v) * model.ms_path_integral(
                self.c[:, None], (self.c_star / self.sun_mu0)[:, None], d[None, :],
                v[None, :], s_eff)
        return out.reshape((nb,) + shape)


def _top_radiance(e0, mu_up, w_up, surface, n_water):
    if surface == "null":
        window = 0.0
    elif surface == "refracted":
        window = model.snell_window_cos(n_water)
    else:
        raise AquaspecError(f"unknown surface {surface!r}; known: {', '.join(SURFACES)}")
    inside = mu_up > window
    flux = 2.0 * np.pi * np.sum(w_up * mu_up * inside)
    return e0 / flux, inside, window


def solve_lightfield(a, b, *, phase="petzold", wavelength_nm=None, e0=1.0,
                     n_streams: int = 32, seabed_depth_m=None, seabed_albedo=0.0,
                     surface: str = "null", n_water: float = model.N_WATER,
                     sun_mu0=None, sun_beam=0.0, **phase_params) -> LightField:
    """Solve the RTE by discrete ordinates for every band at once.

    Parameters
    ----------
    a, b : array_like, shape (n,)
        Absorption and scattering in 1/m (``a + b > 0``).
    phase : str or PhaseFunction
        A key of :data:`aquaspec.medium.phase.PHASE_FUNCTIONS` (``phase_params`` go
        to it) or an instance. ``"petzold"`` needs ``wavelength_nm`` (band
        centres) for the pure-water share of b.
    e0 : float or array_like (n,)
        Downwelling irradiance just below the surface.
    n_streams : int
        Gauss nodes per hemisphere, 4 ... 64 (16-48 usual).
    seabed_depth_m, seabed_albedo :
        Lambertian seabed at depth H (> 0) with albedo in [0, 1] (per band or
        scalar); None: infinitely deep water.
    surface : {"null", "refracted"}
        Top boundary (see the module docstring).
    sun_mu0 : float or None
        A direct sun: the zenith cosine of the refracted beam under water,
        ``0 < mu0 <= 1`` (through a flat surface ``mu0 >= 0.66``). None: no
        sun (the solution is then exactly the sky's).
    sun_beam : float or array_like (n,)
        The beam's irradiance on a plane normal to it just below the
        surface, ``F0`` (same units as ``e0``; its horizontal irradiance is
        ``mu0 F0``). The field returned is then the diffuse field of the sky
        (``e0``) plus that of the sun (all orders of scattering of the beam,
        azimuthally averaged); the unscattered beam,
        ``F0 exp(-c* d / mu0)`` with ``c* = LightField.c_star``, is not in
        it (:meth:`LightField.beam_irradiance`). If ``c*/mu0`` comes within
        :data:`SUN_RESONANCE_GAP` (relative) of a mode's ``kappa_m`` in a
        band, that band's ``mu0`` is moved to exactly that distance
        (``LightField.sun_mu0`` holds the value used).
    """
    a_arr = np.atleast_1d(np.asarray(a, dtype=float))
    nb = a_arr.size
    a_arr = _band("a", a_arr, nb)
    b_arr = _band("b", b, nb)
    if np.any(a_arr + b_arr <= 0):
        raise AquaspecError("extinction a + b must be > 0 1/m in every band")
    e0_arr = _band("e0", e0, nb)
    if not (isinstance(n_streams, (int, np.integer)) and 4 <= n_streams <= 64):
        raise AquaspecError(f"n_streams={n_streams!r}; accepted: an integer 4 ... 64 "
                            "(nodes per hemisphere)")
    if seabed_depth_m is None:
        depth_h = np.inf
    else:
        depth_h = float(seabed_depth_m)
        if not (np.isfinite(depth_h) and depth_h > 0):
            raise AquaspecError(f"seabed_depth_m={seabed_depth_m!r}; accepted: None (deep) "
                                "or a finite depth > 0 m")
    albedo = np.broadcast_to(np.asarray(seabed_albedo, dtype=float), (nb,)).astype(float)
    if not np.all((albedo >= 0) & (albedo <= 1)):
        raise AquaspecError(f"seabed_albedo={seabed_albedo!r}; accepted: 0 ... 1")
    if surface not in SURFACES:
        raise AquaspecError(f"unknown surface {surface!r}; known: {', '.join(SURFACES)}")
    if sun_mu0 is not None:
        mu0 = float(sun_mu0)
        if not 0.0 < mu0 <= 1.0:
            raise AquaspecError(f"sun_mu0={sun_mu0!r}; accepted: None (no sun) or a zenith "
                                "cosine 0 < mu0 <= 1 of the beam under water")
        beam = _band("sun_beam", sun_beam, nb)
    elif np.any(np.asarray(sun_beam, dtype=float) != 0):
        raise AquaspecError("sun_beam needs sun_mu0 (the beam's zenith cosine under water)")

    n = int(n_streams)
    x, wg = leggauss(n)
    mu_up = 0.5 * (x[::-1] + 1.0)          # descending: zenith first
    w_up = 0.5 * wg[::-1]
    mu = np.concatenate([mu_up, -mu_up])
    w = np.concatenate([w_up, w_up])

    chi = band_moments(phase, 2 * n, b=b_arr, wavelength_nm=wavelength_nm, **phase_params)
    f = chi[:, 2 * n]
    chi_star = (chi[:, : 2 * n] - f[:, None]) / (1.0 - f[:, None])
    c = a_arr + b_arr
    c_star = c - f * b_arr
    # A tiny absorption a* = c* - b* keeps every mode decaying when a = 0.
    b_star = np.minimum((1.0 - f) * b_arr, _MAX_ALBEDO * c_star)

    p_sym = redistribution_matrix(chi_star, mu, mu, np.ones_like(mu))   # 2 pi pbar
    p_pp, p_pm = p_sym[:, :n, :n], p_sym[:, :n, n:]
    winv = np.diag(1.0 / w_up)
    # alpha +- beta = M^-1 G+- W with G+- symmetric.
    g_plus = c_star[:, None, None] * winv - b_star[:, None, None] * (p_pp - p_pm)
    g_minus = c_star[:, None, None] * winv - b_star[:, None, None] * (p_pp + p_pm)
    u = np.sqrt(w_up / mu_up)
    a_plus = u[:, None] * g_plus * u
    a_minus = u[:, None] * g_minus * u
    lam, vec = np.linalg.eigh(a_minus)
    root = np.einsum("bik,bk,bjk->bij", vec, np.sqrt(np.maximum(lam, 0.0)), vec)
    kap2, y = np.linalg.eigh(root @ a_plus @ root)
    kappa = np.sqrt(np.maximum(kap2, 0.0))
    xvec = a_plus @ root @ y
    s_vec = xvec / np.sqrt(w_up * mu_up)[:, None]
    alpha_minus_beta = g_minus * w_up / mu_up[:, None]
    d_vec = (alpha_minus_beta @ s_vec) / kappa[:, None, :]
    phi = np.concatenate([0.5 * (s_vec + d_vec), 0.5 * (s_vec - d_vec)], axis=1)
    phi /= np.max(np.abs(phi), axis=1, keepdims=True)

    top, inside, window = _top_radiance(e0_arr, mu_up, w_up, surface, n_water)
    l_top = top[:, None] * inside
    phi_up, phi_lo = phi[:, :n], phi[:, n:]
    # The sun's particular solution X exp(-c* d/mu0) leaves the homogeneous
    # part to answer what it does not meet at the boundaries.
    top_rhs, bed_rhs, sun = l_top, None, {}
    if sun_mu0 is not None:
        x, mu0_b, rate = _sun_particular(mu0, beam, c_star, b_star, chi_star, kappa, mu, w,
                                         phi)
        top_rhs = l_top - x[:, :n]
    if np.isfinite(depth_h):
        decay = np.exp(-kappa * depth_h)[:, None, :]
        refl = 2.0 * albedo[:, None, None] * (w_up * mu_up)[None, None, :]
        # Rows: top (looking up at d = 0), bottom (looking down at d = H).
        top_rows = np.concatenate([phi_up, phi_lo * decay], axis=2)
        bot_rows = np.concatenate([(phi_lo - refl @ phi_up) * decay, phi_up - refl @ phi_lo],
                                  axis=2)
        system = np.concatenate([top_rows, bot_rows], axis=1)
        if sun_mu0 is None:
            bed_rhs = np.zeros_like(l_top)
        else:
            # Lambertian under the diffuse E_d and the beam's mu0 F0 exp(-c* H/mu0).
            bed_rhs = np.exp(-rate * depth_h)[:, None] * (
                (albedo * mu0_b * beam / np.pi)[:, None]
                - (x[:, n:] - (refl @ x[:, :n, None])[..., 0]))
        rhs = np.concatenate([top_rhs, bed_rhs], axis=1)
        amps = np.linalg.solve(system, rhs[..., None])[..., 0]
        amp_dec, amp_grow = amps[:, :n], amps[:, n:]
    else:
        amp_dec = np.linalg.solve(phi_up, top_rhs[..., None])[..., 0]
        amp_grow = np.zeros_like(amp_dec)
    if sun_mu0 is not None:
        # X appended as one more decaying mode (kappa = c*/mu0, amplitude 1).
        one = np.ones((nb, 1))
        kappa = np.concatenate([kappa, rate[:, None]], axis=1)
        phi = np.concatenate([phi, x[..., None]], axis=2)
        amp_dec = np.concatenate([amp_dec, one], axis=1)
        amp_grow = np.concatenate([amp_grow, 0.0 * one], axis=1)
        sun = {"sun_mu0": mu0_b, "sun_beam": beam}
    return LightField(a=a_arr, b=b_arr, e0=e0_arr, f=f, b_star=b_star, c_star=c_star,
                      chi_star=chi_star, mu=mu, w=w,
                      kappa=kappa, phi=phi, amp_dec=amp_dec, amp_grow=amp_grow,
                      top_radiance=top, window_cos=window, seabed_depth_m=depth_h,
                      seabed_albedo=albedo, surface=surface, **sun)


def _resonance_free_mu0(mu0, c_star, kappa):
    """Per band ``mu0``, moved where ``c*/mu0`` is within :data:`SUN_RESONANCE_GAP`
    (relative) of a ``kappa_m``, to exactly that distance (staying <= 1)."""
    rate = c_star / mu0                                               # (n,)
    m = np.argmin(np.abs(kappa - rate[:, None]), axis=1)
    k_near = kappa[np.arange(kappa.shape[0]), m]
    close = np.abs(rate - k_near) < SUN_RESONANCE_GAP * rate
    if not np.any(close):
        return np.full(c_star.shape, mu0)
    gap = SUN_RESONANCE_GAP * k_near
    # Move away on the side where c*/mu0 already is; above kappa_m if mu0 would pass 1.
    target = np.where(rate >= k_near, k_near + gap, k_near - gap)
    target = np.where(c_star / target > 1.0, k_near + gap, target)
    return np.where(close, c_star / target, mu0)


def _beam_scattering(chi_star, b_star, beam, mu0_b, v):
    """``b* F0 pbar*(v, mu0)`` per unit ``exp(-c* d/mu0)`` (n, R), ``v`` (R,),
    ``mu0_b`` (n,): the beam's first scattering into the radiance seen looking
    along ``v``, with ``2 pi pbar* = 1/2 sum_l (2l + 1) chi*_l P_l(v) P_l(mu0)``."""
    lmax = chi_star.shape[1] - 1
    coef = chi_star * (2.0 * np.arange(lmax + 1) + 1.0) * 0.5                # (n, L)
    two_pi_p = np.einsum("bl,lb,li->bi", coef, legendre_table(lmax, mu0_b),
                         legendre_table(lmax, v))                            # (n, R)
    return (b_star * beam / (2.0 * np.pi))[:, None] * two_pi_p


def _sun_particular(mu0, beam, c_star, b_star, chi_star, kappa, mu, w, phi):
    """The sun's particular solution at the nodes, ``X`` (n_bands, 2N), per unit
    ``exp(-c* d / mu0)``; also the ``mu0`` used per band (moved off
    resonances) and the rate ``c*/mu0`` (see the module docstring)."""
    n = kappa.shape[1]
    mu0_b = _resonance_free_mu0(mu0, c_star, kappa)                  # (n,)
    # Beam source per unit exp(-c* d/mu0): b* F0 pbar*(mu_i, mu0) at the nodes.
    rhs = _beam_scattering(chi_star, b_star, beam, mu0_b, mu)          # (n, 2N)
    # mu_i (-r) X_i = -c* X_i + b* sum_j Q_ij X_j + rhs_i with r = c*/mu0, i.e.
    # (M - r D) X = rhs, M = c* - b* Q, D = diag(mu). The modes are M phi_k =
    # ev_k D phi_k (ev = +-kappa: decaying, and growing = flipped), and W M, W D
    # are symmetric (W = diag(w)), so phi_j^T W D phi_k = 0 for j != k and
    #     X = sum_k phi_k (phi_k^T W rhs) / ((ev_k - r) phi_k^T W D phi_k).
    # Expanding on the *computed* modes (rather than solving (M - r D) X = rhs)
    # keeps a near-resonant term exactly along its mode, so that the
    # homogeneous amplitudes cancel it without the modes' own ~1e-9 residual
    # being amplified by 1/(kappa_m - r).
    rate = c_star / mu0_b
    modes = np.concatenate([phi, np.concatenate([phi[:, n:], phi[:, :n]], axis=1)], axis=2)
    ev = np.concatenate([kappa, -kappa], axis=1)                     # (n, 2N)
    norm = np.einsum("i,bik,bik->bk", w * mu, modes, modes)
    proj = np.einsum("i,bik,bi->bk", w, modes, rhs)
    x = np.einsum("bik,bk->bi", modes, proj / ((ev - rate[:, None]) * norm))   # (n, 2N)
    return x, mu0_b, rate


# ---- tables for the GPU ------------------------------------------------------

#: Default table sizes and depth range (depth axis uniform in sqrt(d)).
DEFAULT_N_DEPTH = 64
DEFAULT_N_MU = 65
DEFAULT_MAX_DEPTH_M = 50.0
#: Forms of the table evaluator (see :func:`lightfield_pixel_radiance`).
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


def _seeds_shape(b, c, k, depth, v_y, s):
    """``b/(4 pi) ms_path_integral(c, K, d, v, s)``: the seeds' closed form per unit E0."""
    return b / (4.0 * np.pi) * model.ms_path_integral(c, k, depth, v_y, s)


def lightfield_tables(band_water, *, phase="petzold", seabed_depth_m=None,
                      seabed_albedo=0.0, n_depth: int = DEFAULT_N_DEPTH,
                      n_mu: int = DEFAULT_N_MU, max_depth_m: float = DEFAULT_MAX_DEPTH_M,
                      n_streams: int = 32, surface: str = "null",
                      forward_cone_deg: float = 0.0, cone_spread: bool = False,
                      spread_scattering: str = "single", ambient_shadow: bool = False,
                      sun_mu0=None, sun_fraction=None, **phase_params) -> dict:
    """Per-band tables of the light field for the renderer (float32).

    Computed once per machine for each set of arguments and kept in
    aquaspec's cache (:mod:`aquaspec.cache`), keyed by the arguments, the
    water's coefficients and the code (and data versions) behind them.

    Parameters
    ----------
    band_water : BandWater or object with ``a``, ``b`` (n,) in 1/m
        and, for ``phase="petzold"``, ``bands.centers_nm`` (or ``wavelength_nm``).
    phase, phase_params : see :func:`solve_lightfield`.
    seabed_depth_m, seabed_albedo : Lambertian seabed (None: deep water).
        With a seabed the depth axis ends at it.
    n_depth, n_mu : table sizes (>= 2).
    max_depth_m : depth axis end for deep water (beyond it F is clamped,
        accurate because F tends to a constant with K = kappa_1).
    forward_cone_deg : float
        Scattering within this angle of forward counts as unscattered along
        camera rays that end on a surface: their transmittance uses
        ``c - f b`` (``f`` = ``"forward_fraction"``, the share of ``b`` in the
        cone). A target then blocks the light that the 1-D field would have
        scattered forward from behind it (SPEC: 10-20 degrees). 0 = off.
    cone_spread : bool
        The cone's light comes from where the cone points in the image, not
        from the pixel's own surface: :func:`aquaspec.shading.shade.shade_gbuffer`
        spreads it over the image (:mod:`aquaspec.transport.lightfield.conespread`). Adds ``"cone_offset_rad"`` (m,),
        ``"cone_offset_cdf"`` (n, m) (:func:`aquaspec.medium.phase.band_cone_offset_cdf`)
        and ``"cone_weight"`` (n,) = ``f b``.
        Needs ``forward_cone_deg > 0``.
    spread_scattering : {"single", "multiple"}
        With ``cone_spread``: the cone's light taken as scattered once
        (``"single"``, the renderer's) or a Poisson number of times with mean
        ``f b S`` (``"multiple"``: adds ``"cone_lambda_nodes"`` (k,) and
        ``"cone_offset_cdf_nodes"`` (k, m), :mod:`aquaspec.transport.lightfield.conespread`).
    ambient_shadow : bool
        Also the tables of the scene's first-order shadow in the light field
        (:mod:`aquaspec.transport.lightfield.shadow`, integrated in NumPy): ``"radiance_per_e0"``,
        ``"shadow_*"`` (:func:`aquaspec.transport.lightfield.shadow.shadow_tables`);
        :func:`aquaspec.shading.shade.shade_gbuffer` then subtracts the shadow.
        With a sun, ``"radiance_per_e0"`` is the diffuse radiance of sky and
        sun together (the beam's own shadow is the renderer's).
    sun_mu0, sun_fraction : float, array_like (n,)
        A direct sun: the zenith cosine of the refracted beam under water
        (:func:`solve_lightfield`) and, per band, the sun's share
        ``mu0 F0 / E0`` (0 ... 1) of the total downwelling irradiance just
        below the surface ``E0 = E_sky + mu0 F0``. Both or neither. Every
        ``*_per_e0`` table stays per unit *total* ``E0`` and holds the
        diffuse field of sky and sun (``"sky_radiance_per_e0"`` then only the
        sky's part, ``(1 - sun_fraction)`` of the sky-only value); the
        unscattered beam (``sun_fraction E0 / mu0 exp(-c* d/mu0)``, ``c*`` =
        ``"beam_extinction"``) and its first scattering towards the camera
        are left to the renderer, so ``ms_log_prefactor`` holds the
        in-scattering of the diffuse field only.

    Returns
    -------
    dict
        ``"ms_log_prefactor"`` (n, n_depth, n_mu): ``ln F(d, v_y)`` (see the
        module docstring; F spans orders of magnitude over direction, so its
        logarithm is what interpolates well); ``"irradiance_per_e0"`` (n, n_depth, n_mu): ``E(d, n_y)/E0``
        on the same axes (second axis read as ``n_y``); ``"k_inf"`` (n,):
        ``kappa_1`` in 1/m; ``"sky_radiance_per_e0"`` (n,) the radiance looking
        up just below the surface, seen for ``v_y > window_cos``;
        ``"window_cos"`` (1,); ``"seabed"`` (2,) = (depth m or inf, unused);
        ``"seabed_albedo"`` (n,); ``"depth_m"`` (n_depth,) and ``"cosine"``
        (n_mu,): the axes; ``"max_depth_m"`` (1,); ``"forward_cone_deg"`` (1,);
        ``"beam_extinction"`` (n,): the delta-M ``c* = c - f b`` (1/m) that
        attenuates the sun's beam, ``F(d) = F0 exp(-c* d / mu0)``, consistently
        with the diffuse field (in every case, with or without a sun);
        ``"sun_mu0"`` (1,): ``sun_mu0``, NaN without a sun; ``"sun_fraction"``
        (n,): ``sun_fraction``, zeros without a sun.
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
    from aquaspec.cache import cached_arrays
    return cached_arrays("lightfield-tables", _tables_key(band_water, args),
                         lambda: _lightfield_tables(band_water, **args))


def _tables_key(band_water, args: dict) -> str | None:
    """The cache key of :func:`lightfield_tables` (None: do not cache): its
    arguments, the water's a, b and wavelengths, and the code and data
    versions the tables come from."""
    from aquaspec import cache, parallel
    from aquaspec.transport.lightfield import conespread
    from aquaspec.transport import monzon2022 as model
    from aquaspec.medium import phase
    from aquaspec.transport.lightfield import shadow
    code = cache.code_key(sys.modules[__name__], phase, conespread, shadow, model, parallel)
    if code is None:
        return None
    jerlov = cache.package_version("jerlov")
    wl = getattr(band_water, "wavelength_nm", None)
    if wl is None and getattr(band_water, "bands", None) is not None:
        wl = band_water.bands.centers_nm
    parts = [code, jerlov]
    for x in (band_water.a, band_water.b, wl):
        parts.append(None if x is None else np.asarray(x, dtype=float).tobytes())
    for name in sorted(args):
        value = args[name]
        parts.append(name)
        parts.append(np.asarray(value, dtype=float).tobytes()
                     if isinstance(value, np.ndarray) else repr(value))
    return cache.digest(*parts)


def _lightfield_tables(band_water, *, phase, seabed_depth_m, seabed_albedo, n_depth, n_mu,
                       max_depth_m, n_streams, surface, forward_cone_deg, cone_spread,
                       spread_scattering, ambient_shadow, sun_mu0=None, sun_fraction=None,
                       **phase_params) -> dict:
    """:func:`lightfield_tables` computed."""
    if spread_scattering not in ("single", "multiple"):
        raise AquaspecError(f"spread_scattering={spread_scattering!r}; accepted: 'single' "
                            "or 'multiple'")
    if spread_scattering == "multiple" and not cone_spread:
        raise AquaspecError("spread_scattering='multiple' is about the cone spread; it needs "
                            "cone_spread=True")
    a = np.asarray(band_water.a, dtype=float)
    b = np.asarray(band_water.b, dtype=float)
    wl = getattr(band_water, "wavelength_nm", None)
    if wl is None and getattr(band_water, "bands", None) is not None:
        wl = band_water.bands.centers_nm
    for name, val in (("n_depth", n_depth), ("n_mu", n_mu)):
        if not (isinstance(val, (int, np.integer)) and val >= 2):
            raise AquaspecError(f"{name}={val!r}; accepted: an integer >= 2")
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
    ref = _seeds_shape(b[:, None, None], lf.c[:, None, None], k1[:, None, None], dd, vv,
                       _cut_at_seabed(np.inf, dd, vv, lf.seabed_depth_m))
    pref = r_inf / ref
    irr = lf.irradiance(depth[:, None], cos[None, :])
    if not (np.all(np.isfinite(pref)) and np.all(pref > 0) and np.all(np.isfinite(irr))):
        raise AquaspecError("light-field tables came out non-finite; check a, b and the phase")
    from aquaspec.medium.phase import band_cone_fraction, band_cone_offset_cdf
    f_cone = band_cone_fraction(phase, forward_cone_deg, b, wl, **phase_params)
    f32 = np.float32
    extra = {}
    if cone_spread:
        if not forward_cone_deg > 0:
            raise AquaspecError(f"cone_spread needs a forward cone; forward_cone_deg="
                                f"{forward_cone_deg!r}; accepted: above 0 and below 90")
        offsets = np.radians(forward_cone_deg) * np.concatenate(
            [[0.0], np.geomspace(1e-5, 1.0, CONE_OFFSET_SAMPLES - 1)])
        extra = {"cone_offset_rad": offsets,
                 "cone_offset_cdf": band_cone_offset_cdf(phase, forward_cone_deg, offsets, b,
                                                         wl, **phase_params),
                 "cone_weight": f_cone * b}
        if spread_scattering == "multiple":
            from aquaspec.transport.lightfield.conespread import LAMBDA_NODES, cone_cdf, multiple_scattering_cdf
            _, single = cone_cdf(extra)
            extra["cone_lambda_nodes"] = np.asarray(LAMBDA_NODES, dtype=float)
            from aquaspec.parallel import in_threads
            extra["cone_offset_cdf_nodes"] = np.stack(in_threads(
                lambda lam: multiple_scattering_cdf(offsets, single, lam), LAMBDA_NODES))
    if ambient_shadow:
        from aquaspec.transport.lightfield.shadow import shadow_tables
        extra.update(shadow_tables(lf, depth, cos, phase=phase, b=b, wavelength_nm=wl,
                                   **phase_params))
    return {**extra,
        "forward_cone_deg": np.array([forward_cone_deg], f32),
        "forward_fraction": f_cone.astype(f32),
        "ms_log_prefactor": np.log(pref).astype(f32),
        "irradiance_per_e0": irr.astype(f32),
        "k_inf": k1.astype(f32),
        "sky_radiance_per_e0": lf.top_radiance.astype(f32),
        "window_cos": np.array([lf.window_cos], f32),
        "seabed_depth_m": np.array([lf.seabed_depth_m], f32),
        "seabed_albedo": lf.seabed_albedo.astype(f32),
        "depth_m": depth.astype(f32),
        "cosine": cos.astype(f32),
        "max_depth_m": np.array([d_max], f32),
        "beam_extinction": lf.c_star.astype(f32),
        "sun_mu0": np.array([np.nan if sun_mu0 is None else float(sun_mu0)], f32),
        "sun_fraction": share.astype(f32),
    }


#: Forward cone (degrees) used without / with the cone spread over the image:
#: 15 was best for the per-pixel cone (HG 0.92, 10-20 tried); with the spread
#: 40 was best in the Fournier-Forand validation at 4096 samples per pixel
#: (30 and 40 tried: grey +5.8 % and +4.0 %, patches +1.7 % and -0.1 %).
@dataclass(frozen=True)
class Seabed:
    """A flat Lambertian seabed as the light field's lower boundary.

    ``depth_m`` (> 0, m below the surface) and ``reflectance``: an object
    with ``on_bands(bands)`` (:class:`aquaspec.colour.reflectance.Reflectance`, e.g.
    the built-in scene's sand) or a number in [0, 1] (grey). The light field
    then carries the light the seabed reflects up (SPEC: leaving it out made
    targets 9-15 % too dark in Jerlov I); the seabed *mesh* a scene draws is
    separate geometry.
    """

    depth_m: float
    reflectance: object = 0.2

    def __post_init__(self):
        d = self.depth_m
        if isinstance(d, bool) or not isinstance(d, (int, float, np.number)) \
                or not np.isfinite(d) or d <= 0:
            raise AquaspecError(f"seabed depth_m={d!r}; accepted: a finite depth > 0 m")
        r = self.reflectance
        if not hasattr(r, "on_bands"):
            if isinstance(r, bool) or not isinstance(r, (int, float, np.number)) \
                    or not 0.0 <= float(r) <= 1.0:
                raise AquaspecError(f"seabed reflectance={r!r}; accepted: a Reflectance or "
                                    "a number in [0, 1]")

    def albedo_on(self, bands) -> np.ndarray:
        """Band albedo (n,) on ``bands``."""
        r = self.reflectance
        if hasattr(r, "on_bands"):
            return np.asarray(r.on_bands(bands), dtype=float)
        return np.full(bands.n, float(r))

    def describe(self) -> dict:
        r = self.reflectance
        return {"depth_m": float(self.depth_m),
                "reflectance": getattr(r, "name", None) if hasattr(r, "on_bands") else float(r)}


DEFAULT_FORWARD_CONE_DEG = 15.0
SPREAD_FORWARD_CONE_DEG = 40.0


def forward_cone(cone_deg, cone_spread: bool) -> float:
    """``cone_deg``, or the default for the model (None: 15, or 40 with the spread)."""
    if cone_deg is None:
        return SPREAD_FORWARD_CONE_DEG if cone_spread else DEFAULT_FORWARD_CONE_DEG
    return float(cone_deg)


#: Samples of the cone-offset CDF in the tables (geometric towards 0).
CONE_OFFSET_SAMPLES = 256


def cone_spread_kernel(offsets_rad, cdf, pixels_per_radian: float,
                       subsamples: int = 8) -> np.ndarray:
    """The image-space kernel of the forward cone's light, (2r + 1, 2r + 1), summing to 1.

    ``cdf`` is ``P(alpha <= offsets_rad)`` for one band (the apparent angular
    offset, :func:`aquaspec.medium.phase.band_cone_offset_cdf`), radially symmetric,
    turned into pixels with ``pixels_per_radian`` (the camera's ``fy``: the
    small-angle scale at the image centre). Each pixel cell gets the
    density ``F'(r) / (2 pi r)`` integrated on ``subsamples`` x
    ``subsamples`` points; the centre cell gets the rest (the density is
    singular at 0, and most of a forward-peaked cone's light stays in its
    own pixel).
    """
    off = np.asarray(offsets_rad, dtype=float) * float(pixels_per_radian)   # in pixels
    cdf = np.asarray(cdf, dtype=float)
    if not (pixels_per_radian > 0 and np.all(np.diff(off) > 0)):
        raise AquaspecError(f"pixels_per_radian={pixels_per_radian!r}; accepted: > 0")
    r_max = off[-1]
    rad = int(np.ceil(r_max))
    # Density per unit area as a function of radius: dF/dr / (2 pi r), from
    # the CDF's differences (piecewise constant between samples).
    dens = np.diff(cdf) / (np.pi * (off[1:] ** 2 - off[:-1] ** 2))
    sub = (np.arange(subsamples) + 0.5) / subsamples - 0.5
    ax = np.arange(-rad, rad + 1, dtype=float)
    x = (ax[:, None] + sub[None, :]).reshape(-1)
    r = np.hypot(x[:, None], x[None, :])
    k = np.searchsorted(off, r, side="right") - 1
    inside = (k >= 0) & (k < dens.size)
    w = np.where(inside, dens[np.clip(k, 0, dens.size - 1)], 0.0)
    n = ax.size
    kern = w.reshape(n, subsamples, n, subsamples).mean(axis=(1, 3))
    kern[rad, rad] = 0.0
    kern[rad, rad] = max(0.0, 1.0 - kern.sum())
    return kern / kern.sum()


def spread_cone_light(cone_term, tables, pixels_per_radian: float) -> np.ndarray:
    """Convolve the per-pixel forward-cone term (H, W, n) with each band's kernel.

    The image is extended beyond its border with its edge values (the scene
    goes on past the frame) before the convolution.
    """
    from scipy.signal import fftconvolve
    c = np.asarray(cone_term, dtype=float)
    out = np.empty_like(c)
    cdf = np.asarray(tables["cone_offset_cdf"], dtype=float)
    offsets = np.asarray(tables["cone_offset_rad"], dtype=float)
    kernels = {}
    for i in range(c.shape[-1]):
        key = cdf[i].tobytes()
        if key not in kernels:
            kernels[key] = cone_spread_kernel(offsets, cdf[i], pixels_per_radian)
        kern = kernels[key]
        rad = kern.shape[0] // 2
        padded = np.pad(c[..., i], rad, mode="edge")
        out[..., i] = fftconvolve(padded, kern, mode="valid")
    return out


def bilinear(table, depth_m, cos, max_depth_m, *, band_last: bool = False):
    """Bilinear lookup of ``table[band, depth, cos]`` as a GPU sampler would.

    Texel coordinates: ``x = sqrt(clamp(d, 0, D)/D) (n_depth - 1)``,
    ``y = (1 - acos(clamp(v, -1, 1))/pi) (n_mu - 1)``; on a GPU with linear filtering
    the texture coordinate is ``(x + 0.5) / n_depth`` (texel centres). Returns
    shape ``depth.shape + (n_bands,)`` (band axis last). ``band_last``: the
    table is ``[depth, cos, band]`` already (:func:`band_last_table`: many
    lookups in one table read each texel's bands in one piece).
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

    return ((1 - fx) * ((1 - fy) * at(i, j) + fy * at(i, j + 1))
            + fx * ((1 - fy) * at(i + 1, j) + fy * at(i + 1, j + 1)))


def table_depth_index(depth_m, max_depth_m, n_depth):
    """The depth axis of :func:`bilinear`: lower texel ``i`` and weight ``f`` of
    ``x = sqrt(clamp(d, 0, D)/D) (n_depth - 1)`` (the texel below the last one
    at the axis' end)."""
    d = np.clip(np.asarray(depth_m, dtype=float), 0.0, max_depth_m)
    x = np.sqrt(d / max_depth_m) * (n_depth - 1)
    i = np.minimum(np.floor(x).astype(int), n_depth - 2)
    return i, x - i


def table_cos_index(cos, n_mu):
    """The direction axis of :func:`bilinear`: lower texel ``j`` and weight ``f`` of
    ``y = (1 - acos(clamp(v, -1, 1))/pi) (n_mu - 1)``."""
    y = (1.0 - np.arccos(np.clip(np.asarray(cos, dtype=float), -1.0, 1.0)) / np.pi) * (n_mu - 1)
    j = np.minimum(np.floor(y).astype(int), n_mu - 2)
    return j, y - j


def band_last_table(table) -> np.ndarray:
    """``table[band, depth, cos]`` as float32 texels laid out ``[depth, cos, band]``
    in float64, for ``bilinear(..., band_last=True)`` (the same values)."""
    t = np.asarray(table, dtype=np.float32).astype(float)
    return np.ascontiguousarray(np.moveaxis(t, 0, -1))


def _two_point(tables, *, a, b, e0, depth_o, v_y, s):
    """``(R(d_o), R(d_S), S finite, S)`` of the two-point form (see lightfield_l_ms)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = a + b
    k1 = np.asarray(tables["k_inf"], dtype=float)
    d_max = float(tables["max_depth_m"][0])
    bed = float(tables["seabed_depth_m"][0])
    d_o = np.asarray(depth_o, dtype=float)
    v = np.asarray(v_y, dtype=float)
    e0 = np.asarray(e0, dtype=float)

    def r_at(d):
        d_b, v_b = np.broadcast_arrays(d, v)
        f = np.exp(bilinear(tables["ms_log_prefactor"], d_b[..., 0] if d_b.ndim else d_b,
                            v_b[..., 0] if v_b.ndim else v_b, d_max))
        return f * e0 * _seeds_shape(b, c, k1, d, v, _cut_at_seabed(np.inf, d, v, bed))

    s_eff = _cut_at_seabed(model.ray_length(s, d_o, v), d_o, v, bed)
    fin = np.isfinite(s_eff)
    s_f = np.where(fin, s_eff, 0.0)
    d_s = np.clip(d_o - s_f * v, 0.0, bed)
    return r_at(d_o), r_at(d_s), fin, s_f


def lightfield_l_ms(tables, *, a, b, e0, depth_o, v_y, s, form: str = "two_point"):
    """``L_MS`` from the tables (band axis last), the NumPy reference of the GPU lookup.

    F is ``exp`` of the bilinearly interpolated ``ms_log_prefactor``.
    ``form="two_point"``: ``R(d_o, v) - exp(-c S) R(d_S, v)`` with
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
        bed = float(tables["seabed_depth_m"][0])
        s_eff = _cut_at_seabed(model.ray_length(s, d_o, v), d_o, v, bed)
        f_o = np.exp(bilinear(tables["ms_log_prefactor"], d_o[..., 0] if d_o.ndim else d_o,
                              v[..., 0] if v.ndim else v, float(tables["max_depth_m"][0])))
        return f_o * np.asarray(e0, dtype=float) * _seeds_shape(
            np.asarray(b, dtype=float), c, np.asarray(tables["k_inf"], dtype=float), d_o, v, s_eff)
    r_o, r_s, fin, s_f = _two_point(tables, a=a, b=b, e0=e0, depth_o=depth_o, v_y=v_y, s=s)
    return r_o - np.where(fin, np.exp(-c * s_f), 0.0) * r_s


def _beam_extinction(tables, a, b):
    """``c - f b``: extinction of a camera ray's beam when the forward cone
    (``tables["forward_fraction"]``) counts as unscattered."""
    f = np.asarray(tables.get("forward_fraction", 0.0), dtype=float)
    return np.asarray(a, dtype=float) + (1.0 - f) * np.asarray(b, dtype=float)


def _cut_at_seabed(s, d_o, v, bed):
    if not np.isfinite(bed):
        return np.asarray(s, dtype=float)
    down = v < 0
    to_bed = np.where(down, (bed - d_o) / np.where(down, -v, 1.0), np.inf)
    return np.minimum(s, to_bed)


def surface_radiance(tables, rho, depth_m, n_y, e0) -> np.ndarray:
    """Lambertian radiance ``rho E(d, n_y) / pi`` of surfaces lit by the light
    field (irradiance table), shape ``depth.shape + (n_bands,)``."""
    e = bilinear(band_last_table(tables["irradiance_per_e0"]), depth_m, n_y,
                 float(tables["max_depth_m"][0]), band_last=True)
    return model.lambertian_radiance(rho, e * np.asarray(e0, dtype=float))


def lightfield_pixel_radiance(tables, *, a, b, e0, depth_o, v_y, s, rho=None,
                              surface_depth=None, n_y=None, form: str = "two_point",
                              split_cone: bool = False):
    """Band radiance along camera rays from the light-field tables.

    Same shape of call as :func:`aquaspec.transport.monzon2022.pixel_radiance` (per-ray
    arrays with a trailing axis of length 1, band arrays (n,)):
    ``L = T(S) L_surf + L_MS`` with ``L_MS`` from :func:`lightfield_l_ms`.
    Open water (``rho`` None): an up ray ends at the water surface and sees
    the light field's own top boundary (``sky_radiance_per_e0`` E0 for
    ``v_y > window_cos``); a down ray in water with a seabed sees the seabed
    (``albedo E(H, +1)/pi``). A hit surface of reflectance ``rho`` at
    ``surface_depth`` with normal ``n_y`` gets ``rho E(d, n_y)/pi`` from the
    irradiance table.

    ``split_cone=True`` returns ``(L without the cone, cone term)``: the
    radiance with the beam's full extinction ``c`` and the part the forward
    cone adds, ``(T' - T)(L_surf - L_bg(d_S, v))`` (zero for open water), whose
    sum is the radiance (:func:`spread_cone_light` moves the second term).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    e0 = np.asarray(e0, dtype=float)
    c = a + b
    d_o = np.asarray(depth_o, dtype=float)
    v = np.asarray(v_y, dtype=float)
    d_max = float(tables["max_depth_m"][0])
    bed = float(tables["seabed_depth_m"][0])
    s_eff = _cut_at_seabed(model.ray_length(s, d_o, v), d_o, v, bed)
    # The seabed's own radiance (Lambertian under the downwelling light: the
    # diffuse field's and, with a sun, the beam's, as LightField._boundary).
    l_bed = 0.0
    if np.isfinite(bed):
        e_bed = bilinear(tables["irradiance_per_e0"], bed, 1.0, d_max)
        mu0 = float(tables["sun_mu0"][0]) if "sun_mu0" in tables else np.nan
        if np.isfinite(mu0):
            e_bed = e_bed + np.asarray(tables["sun_fraction"], dtype=float) * np.exp(
                -np.asarray(tables["beam_extinction"], dtype=float) * bed / mu0)
        l_bed = np.asarray(tables["seabed_albedo"], dtype=float) * e_bed * e0 / np.pi
    if rho is None:
        sky = np.where(v > float(tables["window_cos"][0]),
                       np.asarray(tables["sky_radiance_per_e0"], dtype=float) * e0, 0.0)
        l_surf = np.where(np.isfinite(s_eff) & (v > 0), sky, 0.0)
        if np.isfinite(bed):
            l_surf = np.where(np.isfinite(s_eff) & (v < 0), l_bed, l_surf)
    else:
        sd = np.asarray(surface_depth, dtype=float)
        ny = np.asarray(n_y, dtype=float)
        sd, ny = np.broadcast_arrays(sd, ny)
        l_surf = surface_radiance(tables, rho, sd[..., 0] if sd.ndim else sd,
                                  ny[..., 0] if ny.ndim else ny, e0)
    f = np.asarray(tables.get("forward_fraction", 0.0), dtype=float)
    if form == "two_point" and np.any(f > 0):
        # The forward cone stays in the beam (extinction c - f b): with the
        # open-water field L_bg(d) = R(d) + exp(-c l(d)) L_end, where the line
        # of sight ends on the sky (up rays, l = d / v) or on the seabed (down
        # rays, l = (H - d) / -v), the radiance is L_bg(d_o) + T' (L_surf -
        # L_bg(d_S)); with f = 0 it is the two-point form above exactly.
        # (The end's term cancels from T'-independent parts; in the cone's
        # share it is the background the target hides, seabed included.)
        r_o, r_s, fin, s_f = _two_point(tables, a=a, b=b, e0=e0, depth_o=d_o, v_y=v, s=s_eff)
        l_top = np.where(v > float(tables["window_cos"][0]),
                         np.asarray(tables["sky_radiance_per_e0"], dtype=float) * e0, 0.0)
        up = v > 0
        to_bed = (v < 0) & np.isfinite(bed)
        l_end = np.where(up, l_top, np.where(to_bed, l_bed, 0.0))
        d_s = np.clip(d_o - s_f * v, 0.0, bed)

        def u_end(d):
            """exp(-c l): transmittance from depth d to the line of sight's end."""
            length = np.where(up, d / np.where(up, v, 1.0),
                              (bed - d) / np.where(to_bed, -v, 1.0))
            return np.where(up | to_bed, np.exp(-c * np.where(up | to_bed, length, 0.0)), 0.0)

        u_o, u_s = u_end(d_o), u_end(d_s)
        t_beam = np.where(fin, np.exp(-_beam_extinction(tables, a, b) * s_f), 0.0)
        blocked = np.where(fin, l_surf - r_s - u_s * l_end, 0.0)
        if split_cone:
            t = np.where(fin, np.exp(-c * s_f), 0.0)
            out = r_o + u_o * l_end + t * blocked
            cone = (t_beam - t) * blocked
            if not (np.all(np.isfinite(out)) and np.all(np.isfinite(cone))):
                raise AquaspecError("light-field radiance came out non-finite; check the inputs")
            return out, cone
        out = r_o + u_o * l_end + t_beam * blocked
    else:
        l_ms = lightfield_l_ms(tables, a=a, b=b, e0=e0, depth_o=d_o, v_y=v, s=s_eff, form=form)
        t = model.transmittance(c, s_eff)
        out = np.where(t > 0, t * l_surf, 0.0) + l_ms
    if not np.all(np.isfinite(out)):
        raise AquaspecError("light-field radiance came out non-finite; check the inputs")
    if split_cone:
        return out, np.zeros_like(out)
    return out
