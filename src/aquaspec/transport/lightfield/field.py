"""The solved light field of :mod:`aquaspec.transport.lightfield.solve`, evaluated anywhere.

:func:`aquaspec.transport.lightfield.solve.solve_lightfield` returns a
:class:`LightField`: the discrete-ordinates modes per band and their
amplitudes. Its methods give the radiance ``L(d, mu)`` at any depth and
direction, the irradiance on a surface of any orientation ``E(d, n_y)``, the
in-scattering source ``j(d, v_y)`` and its integral along a camera ray, in
the conventions of :mod:`aquaspec.transport.lightfield.solve` (depth ``d`` in m
below the surface, a direction given by its up component, ``L(d, mu)`` the
radiance seen *looking* in direction ``mu``).

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import below_surface, index_of_window
from aquaspec.medium.phase_bands import redistribution_matrix
from aquaspec.numerics import legendre_table
from aquaspec.transport import monzon2022 as model


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


def beam_scattering(chi_star, b_star, beam, mu0_b, v):
    """``b* F0 pbar*(v, mu0)`` per unit ``exp(-c* d/mu0)`` (n, R), ``v`` (R,),
    ``mu0_b`` (n,): the beam's first scattering into the radiance seen looking
    along ``v``, with ``2 pi pbar* = 1/2 sum_l (2l + 1) chi*_l P_l(v) P_l(mu0)``."""
    lmax = chi_star.shape[1] - 1
    coef = chi_star * (2.0 * np.arange(lmax + 1) + 1.0) * 0.5                # (n, L)
    two_pi_p = np.einsum("bl,lb,li->bi", coef, legendre_table(lmax, mu0_b),
                         legendre_table(lmax, v))                            # (n, R)
    return (b_star * beam / (2.0 * np.pi))[:, None] * two_pi_p


@dataclass
class LightField:
    """Discrete-ordinates solution per band (build it with
    :func:`aquaspec.transport.lightfield.solve.solve_lightfield`).

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
    :data:`aquaspec.transport.lightfield.solve.SUN_RESONANCE_GAP` off a resonance)
    and ``sun_beam`` (n,) its normal irradiance ``F0`` just below the surface. Every method then
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
        (:func:`aquaspec.medium.phase_bands.redistribution_matrix` with weight 1).
        """
        return beam_scattering(self.chi_star, self.b_star, self.sun_beam, self.sun_mu0, v)

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

    @property
    def n_water(self) -> float:
        """The refractive index the surface was solved with (from Snell's window)."""
        return index_of_window(self.window_cos)

    def _top(self, v_y):
        """Radiance looking up just below the surface, (n, R): the sky through
        it and, where it mirrors (``fresnel``), the water's light going up
        (:func:`aquaspec.medium.interface.below_surface`)."""
        v = np.atleast_1d(np.asarray(v_y, dtype=float))
        shape, mirror, _ = below_surface(v, self.surface, self.n_water)
        out = self.top_radiance[:, None] * shape
        mirror = np.where(v > 0, mirror, 0.0)        # (rays going down never meet it)
        if np.any(mirror > 0):
            out = out + mirror * self.radiance(0.0, -np.abs(v))
        return out

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

