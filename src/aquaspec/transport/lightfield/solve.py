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
(:func:`aquaspec.medium.phase_bands.redistribution_matrix`). With ``L+-`` the radiance at
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
outside; both normalised so that ``E_d(0) = E0`` on the quadrature, and
upwelling light leaves through the surface (no internal reflection).
``surface="fresnel"`` is the real flat interface
(:func:`aquaspec.medium.interface.below_surface`): the sky enters the window
with the Fresnel transmittance ``T`` and the surface mirrors the light going
up with ``R = 1 - T`` inside the window and totally outside it, so the top
condition couples the streams, ``L(0, mu) - R(mu) L(0, -mu) = sky(mu)``, as
the seabed's couples them at the bottom; the sky's part of the solution is
then scaled so that ``E_d(0) = E0`` again, the mirrored light included. Bottom: infinitely
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

*Any direction and camera rays*: :class:`aquaspec.transport.lightfield.field.LightField`,
the solution this module returns, evaluates the modes anywhere.

*Tables for the renderer*: :mod:`aquaspec.transport.lightfield.tables` (what
they hold and how they are read) and :mod:`aquaspec.transport.lightfield.bake`
(how they are made from this solution).

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
.. [Jin1994] Z. Jin, K. Stamnes, "Radiative transfer in nonuniformly refracting
   layered media: atmosphere-ocean system", Applied Optics 33 (1994) 431-442.
.. [Mobley1994] C. D. Mobley, "Light and Water", Academic Press (1994),
   Sec. 9.3 (asymptotic radiance distribution and K_inf).
"""

from __future__ import annotations


import numpy as np
from numpy.polynomial.legendre import leggauss

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import N_WATER, SURFACES, below_surface
from aquaspec.medium.phase_bands import band_moments, redistribution_matrix
from aquaspec.transport.lightfield.field import LightField, beam_scattering

#: Surface boundary conditions (the radiance looking up just below y = 0).

#: Resonance guard of the sun's particular solution: when ``c*/mu0`` lies
#: within this relative distance of a mode's ``kappa_m``, that band's ``mu0``
#: is moved so that it lies exactly this far away (see :func:`solve_lightfield`).
SUN_RESONANCE_GAP = 1e-6

#: Single-scattering albedo cap: the conservative mode (kappa = 0) of a = 0 is
#: replaced by kappa ~ 5e-4 c (eigh resolves it), so every mode decays.
_MAX_ALBEDO = 1.0 - 1e-7


def _band(name, value, n):
    arr = np.broadcast_to(np.asarray(value, dtype=float), (n,)).astype(float)
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise AquaspecError(f"{name} must be finite and >= 0 per band; got {arr.tolist()}")
    return arr


def solve_lightfield(a, b, *, phase="petzold", wavelength_nm=None, e0=1.0,
                     n_streams: int = 32, seabed_depth_m=None, seabed_albedo=0.0,
                     surface: str = "null", n_water: float = N_WATER,
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
    surface : {"null", "refracted", "fresnel"}
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
    mu_up, w_up = hemisphere_nodes(n, below_surface(np.ones(1), surface, n_water)[2])
    mu = np.concatenate([mu_up, -mu_up])
    w = np.concatenate([w_up, w_up])
    shape, mirror, window = below_surface(mu_up, surface, n_water)

    chi = band_moments(phase, 2 * n, b=b_arr, wavelength_nm=wavelength_nm, **phase_params)
    # The delta-M truncation: the mass of p above order 2N. Moments computed by
    # quadrature can come out a few 1e-14 below 0 where p has no such mass
    # (Henyey-Greenstein g <= 0.5): a negative f would make exp(-f b s) grow.
    f = np.maximum(chi[:, 2 * n], 0.0)
    chi_star = (chi[:, : 2 * n] - f[:, None]) / (1.0 - f[:, None])
    c = a_arr + b_arr
    c_star = c - f * b_arr
    # A tiny absorption a* = c* - b* keeps every mode decaying when a = 0.
    b_star = np.minimum((1.0 - f) * b_arr, _MAX_ALBEDO * c_star)

    p_sym = redistribution_matrix(chi_star, mu, mu, np.ones_like(mu))   # 2 pi pbar
    if window > 0:
        # The split nodes integrate P_l P_m exactly only to a lower order than
        # Gauss's: rows renormalised so that scattering conserves energy.
        p_sym = p_sym / (p_sym @ w)[..., None]
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

    top = e0_arr / (2.0 * np.pi * np.sum(w_up * mu_up * shape))
    l_top = top[:, None] * shape
    phi_up, phi_lo = phi[:, :n], phi[:, n:]
    # Looking up at d = 0 the surface shows the sky and mirrors the light going
    # up: L(0, mu) - R(mu) L(0, -mu) = sky(mu), with R = mirror.
    r_col = mirror[None, :, None]
    # The sun's particular solution X exp(-c* d/mu0) leaves the homogeneous
    # part to answer what it does not meet at the boundaries.
    sun_top, sun_bed, sun = np.zeros_like(l_top), np.zeros_like(l_top), {}
    if sun_mu0 is not None:
        x, mu0_b, rate = _sun_particular(mu0, beam, c_star, b_star, chi_star, kappa, mu, w,
                                         phi)
        sun_top = -(x[:, :n] - mirror * x[:, n:])
    if np.isfinite(depth_h):
        decay = np.exp(-kappa * depth_h)[:, None, :]
        refl = 2.0 * albedo[:, None, None] * (w_up * mu_up)[None, None, :]
        # Rows: top (looking up at d = 0), bottom (looking down at d = H).
        top_rows = np.concatenate([phi_up - r_col * phi_lo, (phi_lo - r_col * phi_up) * decay],
                                  axis=2)
        bot_rows = np.concatenate([(phi_lo - refl @ phi_up) * decay, phi_up - refl @ phi_lo],
                                  axis=2)
        system = np.concatenate([top_rows, bot_rows], axis=1)
        if sun_mu0 is not None:
            # Lambertian under the diffuse E_d and the beam's mu0 F0 exp(-c* H/mu0).
            sun_bed = np.exp(-rate * depth_h)[:, None] * (
                (albedo * mu0_b * beam / np.pi)[:, None]
                - (x[:, n:] - (refl @ x[:, :n, None])[..., 0]))
        # Two right-hand sides: the sky's light and the sun's.
        rhs = np.stack([np.concatenate([l_top, np.zeros_like(l_top)], axis=1),
                        np.concatenate([sun_top, sun_bed], axis=1)], axis=2)
        amps = np.linalg.solve(system, rhs)
        sky_dec, sky_grow = amps[:, :n, 0], amps[:, n:, 0]
        sun_dec, sun_grow = amps[:, :n, 1], amps[:, n:, 1]
        sky_down = phi_up @ sky_dec[..., None] + (phi_lo * decay) @ sky_grow[..., None]
    else:
        amps = np.linalg.solve(phi_up - r_col * phi_lo, np.stack([l_top, sun_top], axis=2))
        sky_dec, sun_dec = amps[..., 0], amps[..., 1]
        sky_grow = sun_grow = np.zeros_like(sky_dec)
        sky_down = phi_up @ sky_dec[..., None]
    if np.any(mirror > 0):
        # The light the surface mirrors down adds to E_d(0): the sky's part
        # (linear in it) is scaled so that its E_d(0) is E0 again.
        e_d0 = 2.0 * np.pi * np.sum(w_up * mu_up * sky_down[..., 0], axis=1)
        scale = e0_arr / np.where(e_d0 > 0, e_d0, 1.0)
        sky_dec, sky_grow, top = (sky_dec * scale[:, None], sky_grow * scale[:, None],
                                  top * scale)
    amp_dec, amp_grow = sky_dec + sun_dec, sky_grow + sun_grow
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


def hemisphere_nodes(n: int, window_cos: float = 0.0):
    """Discrete-ordinates nodes and weights on one hemisphere, zenith first:
    ``(mu, w)``, ``n`` of each, weights summing to 1.

    Without a window (``window_cos`` 0) the double-Gauss rule: Gauss-Legendre
    on [0, 1]. Under a refracting surface the light looking up jumps at
    Snell's window's edge (the sky inside, the mirrored water outside), which
    a Gauss rule across it integrates to a few per cent only (E_d(0) and the
    radiance at 5 m looking up moved by 2-4 % between 16, 32 and 64 nodes);
    so the hemisphere is split there, Gauss on [0, window_cos] and on
    [window_cos, 1], as coupled atmosphere-ocean discrete-ordinates codes place
    extra nodes in the ocean's total-reflection region ([Jin1994]). The nodes
    are shared in proportion to the angles (the window's 48.8 degrees get 17
    of 32), not to the cosines' lengths (11 of 32): with forward-peaked water
    (Petzold) the coarser nodes near the zenith gave the radiance looking up a
    spurious 7 % bump between the top node and the zenith.
    """
    if window_cos <= 0.0:
        x, wg = leggauss(n)
        return 0.5 * (x[::-1] + 1.0), 0.5 * wg[::-1]
    n_in = int(np.clip(round(n * np.arccos(window_cos) / (0.5 * np.pi)), 2, n - 2))
    parts = []
    for lo, hi, k in ((window_cos, 1.0, n_in), (0.0, window_cos, n - n_in)):
        x, wg = leggauss(k)
        parts.append((lo + 0.5 * (hi - lo) * (x[::-1] + 1.0), 0.5 * (hi - lo) * wg[::-1]))
    return np.concatenate([parts[0][0], parts[1][0]]), np.concatenate([parts[0][1],
                                                                       parts[1][1]])


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


def _sun_particular(mu0, beam, c_star, b_star, chi_star, kappa, mu, w, phi):
    """The sun's particular solution at the nodes, ``X`` (n_bands, 2N), per unit
    ``exp(-c* d / mu0)``; also the ``mu0`` used per band (moved off
    resonances) and the rate ``c*/mu0`` (see the module docstring)."""
    n = kappa.shape[1]
    mu0_b = _resonance_free_mu0(mu0, c_star, kappa)                  # (n,)
    # Beam source per unit exp(-c* d/mu0): b* F0 pbar*(mu_i, mu0) at the nodes.
    rhs = beam_scattering(chi_star, b_star, beam, mu0_b, mu)          # (n, 2N)
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
