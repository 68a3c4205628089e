"""The light-field model's radiance distribution against Tyler's measurement (1958).

Tyler measured the radiance distribution in Lake Pend Oreille (Idaho, 1957)
at seven depths down to 66 m, in a band of 430-546 nm (the PyPI package
``jerlov`` carries his tables, :func:`jerlov.tyler1958_radiance`). Deep
down the distribution stops changing shape and decays with one rate
``K_inf`` (the asymptotic radiance distribution, [Mobley1994]_ Sec. 9.3).
That shape depends only on the single-scattering albedo ``omega0 = b / c``
and the phase function, so it checks the discrete-ordinates model
(:mod:`aquaspec.transport.lightfield.solve`) with no free parameter:

1. ``K_inf`` from Tyler's own tables: the decay of the scalar irradiance
   (his azimuthally averaged radiance integrated over the sphere) between
   two deep depths (default 53.7 and 66.1 m).
2. ``c`` = 0.396 1/m, Tyler's beam attenuation (transmittance 67.3 % per
   metre, as ``jerlov`` records it).
3. ``omega0`` such that the model's slowest mode decays at ``K_inf``
   (``kappa_1(omega0) = K_inf``; ``kappa_1 / c`` falls monotonically as
   ``omega0`` grows).
4. The model's radiance at a depth where it is asymptotic, normalised at the
   zenith, against Tyler's azimuthally averaged radiance at the deepest
   depth, normalised the same way.

The comparison is of shape over about three decades (zenith to nadir).
Known limits: Tyler's deepest table is not yet fully asymptotic (his zenith
and nadir radiances still decay at different rates between 53.7 and 66.1 m),
his tubes average over 6.6 degrees, the sun was at 33.4 degrees from the
zenith (the model's sky is overcast: only the shape at depth, which forgets
the sky, is comparable), and his band is wide.

References
----------
.. [Tyler1958] J. E. Tyler, "Radiance distribution as a function of depth in
   the submarine environment", SIO Reference 58-25, Scripps Institution of
   Oceanography (1958), Tables IV-X.
.. [Mobley1994] C. D. Mobley, "Light and Water", Academic Press (1994).
"""

from __future__ import annotations

import warnings

import jerlov
import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.io.png import write_figure
from aquaspec.transport.lightfield.solve import solve_lightfield

#: Tyler's beam attenuation, 1/m (transmittance 67.3 % per metre; ``jerlov``).
TYLER_C = -float(np.log(0.673))
#: Centre of Tyler's band (430-546 nm), nm.
TYLER_WAVELENGTH_NM = 488.0
#: Phase functions compared by default, with their parameters.
DEFAULT_PHASES = (("petzold", {}), ("ff", {"backscatter": 0.0183}), ("hg", {"g": 0.92}),
                  ("isotropic", {}))


def tyler_mean_radiance(depth_m: float):
    """``(tilt_deg, L)``: Tyler's radiance at one depth averaged over azimuth.

    Tilt 0 is looking straight up, 180 straight down (``mu = cos(tilt)`` in
    :mod:`aquaspec.transport.lightfield.solve`'s convention). His tables give one side of
    the sun's vertical plane at 20-degree steps from 0 to 180 degrees; the
    average over the full circle weights the two end columns by half.
    """
    if depth_m not in jerlov.TYLER1958_DEPTHS:
        raise AquaspecError(f"Tyler depth {depth_m!r} m; accepted: "
                            f"{', '.join(f'{d:g}' for d in jerlov.TYLER1958_DEPTHS)}")
    with warnings.catch_warnings():
        # Cells near the sun's direction are flagged as suspect at shallow
        # depths; the deep tables used here are not affected.
        warnings.simplefilter("ignore")
        r = jerlov.tyler1958_radiance(depth_m)
    rad = np.asarray(r.radiance, dtype=float)
    az = np.asarray(r.azimuth_deg, dtype=float)
    if not (az[0] == 0.0 and az[-1] == 180.0):
        raise AquaspecError(f"unexpected azimuths in Tyler's table: {az.tolist()}")
    w = np.ones(az.size)
    w[0] = w[-1] = 0.5
    return np.asarray(r.tilt_deg, dtype=float), (rad * w).sum(axis=1) / w.sum()


def _scalar_irradiance(tilt_deg, radiance):
    th = np.radians(tilt_deg)
    return float(np.trapezoid(2.0 * np.pi * radiance * np.sin(th), th))


def tyler_k_inf(depths_m=(53.7, 66.1)) -> float:
    """Decay rate (1/m) of Tyler's scalar irradiance between two of his depths."""
    d1, d2 = depths_m
    if not d2 > d1:
        raise AquaspecError(f"depths {depths_m!r}: the second must be deeper than the first")
    t, l1 = tyler_mean_radiance(d1)
    _, l2 = tyler_mean_radiance(d2)
    return float(np.log(_scalar_irradiance(t, l1) / _scalar_irradiance(t, l2)) / (d2 - d1))


def _single_band(c, omega0, phase, n_streams, **phase_params):
    return solve_lightfield([c * (1.0 - omega0)], [c * omega0], phase=phase,
                            wavelength_nm=[TYLER_WAVELENGTH_NM], n_streams=n_streams,
                            **phase_params)


def fit_albedo(k_inf: float, c: float, phase, *, n_streams: int = 32, **phase_params) -> float:
    """``omega0`` whose asymptotic diffuse attenuation ``kappa_1`` equals ``k_inf``."""
    # deferred: scipy.optimize takes about 0.4 s to import; only this fit needs it
    from scipy.optimize import brentq
    if not 0.0 < k_inf < c:
        raise AquaspecError(f"K_inf = {k_inf!r} 1/m must lie between 0 and c = {c!r} 1/m")

    def excess(w0):
        return _single_band(c, w0, phase, n_streams, **phase_params).k_inf[0] - k_inf

    lo, hi = 1e-3, 1.0 - 1e-6
    if excess(lo) < 0 or excess(hi) > 0:
        raise AquaspecError(f"no single-scattering albedo gives K_inf = {k_inf:.4g} 1/m with "
                            f"c = {c:.4g} 1/m and phase {phase!r}")
    return float(brentq(excess, lo, hi, xtol=1e-10))


def tyler_check(phases=DEFAULT_PHASES, *, depths_m=(53.7, 66.1), c: float = TYLER_C,
                n_streams: int = 32) -> dict:
    """Compare the model's asymptotic radiance shape with Tyler's, per phase function.

    Returns a JSON-ready dict: ``k_inf`` (from Tyler), ``c``, ``tilt_deg``,
    ``tyler_shape`` (deepest table, azimuthal mean, 1 at the zenith) and per
    phase (``"results"``): ``omega0``, ``model_shape``, ``ratio`` (model /
    Tyler) and ``max_abs_log_ratio``.
    """
    k_inf = tyler_k_inf(depths_m)
    tilt, deep = tyler_mean_radiance(depths_m[-1])
    tyler_shape = deep / deep[0]
    mu = np.cos(np.radians(tilt))
    results = []
    for phase, params in phases:
        w0 = fit_albedo(k_inf, c, phase, n_streams=n_streams, **params)
        lf = _single_band(c, w0, phase, n_streams, **params)
        rad = lf.asymptotic_radiance(mu)[0]
        if not (np.all(np.isfinite(rad)) and np.all(rad > 0)):
            raise AquaspecError(f"the model's asymptotic radiance is not positive and finite "
                                f"for phase {phase!r} (omega0 = {w0:.4g})")
        shape = rad / rad[0]
        ratio = shape / tyler_shape
        results.append({"phase": phase, **params, "omega0": w0,
                        "model_shape": shape.tolist(), "ratio": ratio.tolist(),
                        "max_abs_log_ratio": float(np.max(np.abs(np.log(ratio))))})
    return {"source": "Tyler (1958), Lake Pend Oreille, via jerlov.tyler1958_radiance",
            "depths_m": list(depths_m), "k_inf": k_inf, "c": c,
            "wavelength_nm": TYLER_WAVELENGTH_NM, "tilt_deg": tilt.tolist(),
            "tyler_shape": tyler_shape.tolist(), "results": results}


def format_tyler(res: dict) -> str:
    """A table of the shapes (tilt rows, Tyler and each phase's model / Tyler)."""
    lines = [f"radiance distribution vs Tyler (1958), Lake Pend Oreille: K_inf = "
             f"{res['k_inf']:.4f} 1/m (his scalar irradiance, {res['depths_m'][0]:g}-"
             f"{res['depths_m'][1]:g} m), c = {res['c']:.3f} 1/m; omega0 fitted so that the "
             "model's kappa_1 = K_inf; shapes 1 at the zenith, model / Tyler per phase"]
    names = [r["phase"] for r in res["results"]]
    lines.append("tilt_deg      tyler " + " ".join(f"{n:>10}" for n in names))
    lines.append("omega0            - " + " ".join(f"{r['omega0']:10.3f}" for r in res["results"]))
    for i, t in enumerate(res["tilt_deg"]):
        lines.append(f"{t:8.0f} {res['tyler_shape'][i]:10.4f} "
                     + " ".join(f"{r['ratio'][i]:10.3f}" for r in res["results"]))
    lines.append("max |ln ratio|    - " + " ".join(f"{r['max_abs_log_ratio']:10.3f}"
                                                  for r in res["results"]))
    return "\n".join(lines)


def plot_tyler(res: dict, path):
    """Tyler's shape and each phase's model shape against tilt (log axis); returns the path."""
    # deferred: matplotlib is heavy to import and only the figure needs it
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # deferred: as above

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.semilogy(res["tilt_deg"], res["tyler_shape"], "ko", label="Tyler 1958, "
                f"{res['depths_m'][-1]:g} m (azimuthal mean)")
    for r in res["results"]:
        ax.semilogy(res["tilt_deg"], r["model_shape"],
                    label=f"{r['phase']}, omega0 = {r['omega0']:.3f}")
    ax.set_xlabel("tilt from straight up (degrees)")
    ax.set_ylabel("radiance / zenith radiance")
    ax.set_title(f"asymptotic radiance, K_inf = {res['k_inf']:.3f} 1/m, c = {res['c']:.3f} 1/m",
                 fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return write_figure(path, fig, dpi=100)
