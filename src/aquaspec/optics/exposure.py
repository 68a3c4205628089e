"""Radiometry of an exposure: from camera RGB radiance to photoelectrons, and auto exposure.

The renderer's linear camera RGB is ``RGB_c = sum_i w_i L_i R_c,i``
(:mod:`aquaspec.colour.sensors`; ``L`` in W m^-2 sr^-1 nm^-1). A lens of
f-number ``N`` and transmittance ``T`` turns a radiance ``L`` far in front
of it into the sensor irradiance ``E = pi T L / (4 N^2)`` on the axis
(camera equation, e.g. EMVA 1288 Release 3.1 Sec. 3.2; the magnification
term ``(1 + m)^2`` is neglected for objects many focal lengths away, and
the off-axis fall-off is the lens's vignetting). A photosite of pitch
``p`` collects ``E p^2 t`` joules in the exposure time ``t``; a photon of
wavelength ``lambda`` carries ``h c / lambda``. With the quantum efficiency
``eta_c(lambda) = eta R_c(lambda) / max R`` (the response curves read as
relative sensitivity, :mod:`aquaspec.optics.sensor`) the mean photoelectrons
per second are::

    rate_c = RGB_c * pi T / (4 N^2) * p^2 * eta / max R * lambda_c / (h c)

with ``lambda_c`` the response-weighted mean wavelength of channel c (the
energy-to-photon factor ``lambda / (h c)`` taken at it: within a channel
the factor varies by about +-10 %, a gain error, not a noise error).

Auto exposure (:func:`auto_exposure`) meters as a camera does: the exposure
time puts the image's mean green signal at :data:`TARGET_FRACTION` of the
full well, up to the longest hand-held time; beyond that the ISO (gain)
rises to its maximum; beyond that the image stays dark (and noisy).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError

PLANCK_J_S = 6.62607015e-34
LIGHT_SPEED_M_S = 299792458.0
#: Mean green signal auto exposure aims at, as a fraction of the full well
#: (about an 18 % grey three stops below saturation's mid-tone headroom).
TARGET_FRACTION = 0.15


def electron_rate(rgb, wavelength_c_nm, response_max: float, *, f_number: float,
                  transmittance: float, pixel_pitch_um: float, quantum_efficiency: float):
    """Mean photoelectrons per second of camera RGB ``rgb`` (..., 3), per channel
    (module docstring); negative RGB (a response with negative lobes) counts 0."""
    lam = np.asarray(wavelength_c_nm, dtype=float).reshape(3) * 1e-9
    if not response_max > 0:
        raise AquaspecError(f"the response curves' maximum is {response_max!r}; a camera "
                            "needs positive responses")
    scale = (np.pi * transmittance / (4.0 * f_number ** 2) * (pixel_pitch_um * 1e-6) ** 2
             * quantum_efficiency / response_max * lam / (PLANCK_J_S * LIGHT_SPEED_M_S))
    return np.clip(np.asarray(rgb, dtype=float), 0.0, None) * scale


def auto_exposure(mean_green_rate: float, *, full_well_e: float, min_s: float, max_s: float,
                  base_iso: float, max_iso: float) -> tuple[float, float]:
    """``(exposure_s, iso)`` a metering camera picks for an image whose mean
    green photoelectron rate is ``mean_green_rate`` (e-/s)."""
    target = TARGET_FRACTION * full_well_e
    if not mean_green_rate > 0:
        return max_s, max_iso
    t = float(np.clip(target / mean_green_rate, min_s, max_s))
    iso = float(np.clip(base_iso * target / (mean_green_rate * t), base_iso, max_iso))
    return t, iso
