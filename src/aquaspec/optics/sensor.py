"""The image sensor: the EMVA 1288 linear camera model, its noise and its ADC.

EMVA Standard 1288 (Release 3.1, 2016, Sec. 2) [1]_ describes a linear
camera by a few measured numbers. Per pixel and exposure, ``mu_p`` photons
give ``mu_e = eta mu_p`` photoelectrons (``eta``: quantum efficiency), a
Poisson number; the dark signal adds ``mu_I t`` thermal electrons (dark
current ``mu_I`` in e-/s, also Poisson) and a temporal dark noise of
standard deviation ``sigma_d0`` (read noise, Gaussian, e-); the charge
saturates at the full well; the amplifier and ADC multiply by the system
gain ``K`` (DN/e-) and round to integers (``adc_bits``), on top of a black
level. The photon transfer curve that follows (EMVA 1288 Eqs. 6 and 9)::

    mu_y = mu_y.dark + K mu_e,                       mu_y.dark = black + K mu_I t
    sigma_y^2 = K^2 (sigma_d0^2 + mu_I t) + 1/12 + K (mu_y - mu_y.dark)

(the 1/12 DN^2 is the rounding's noise, valid when sigma_y is above about
0.5 DN). Raising the ISO multiplies ``K`` (the analogue gain); the read
noise in electrons is kept at its base-ISO value (real sensors have less at
high gain: a conservative choice). Spatial non-uniformities (DSNU, PRNU)
and defect pixels are not modelled.

Quantum efficiency per channel: the sensor's response curves
(:class:`aquaspec.colour.sensors.Sensor`) are taken as the relative spectral
sensitivity, and ``quantum_efficiency`` is their peak's:
``eta_c(lambda) = eta R_c(lambda) / max R`` (:mod:`aquaspec.optics.exposure`).

References
----------
.. [1] European Machine Vision Association, "EMVA Standard 1288: Standard for
   Characterization of Image Sensors and Cameras", Release 3.1 (2016).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from aquaspec.errors import AquaspecError


@dataclass(frozen=True)
class Emva1288Sensor:
    """A sensor's EMVA 1288 parameters.

    Parameters
    ----------
    name : str
    quantum_efficiency : float
        Peak quantum efficiency ``eta`` (0 to 1).
    pixel_pitch_um : float
        Photosite pitch, um (its area collects the light).
    full_well_e : float
        Saturation capacity, electrons.
    dark_noise_e : float
        Temporal dark noise ``sigma_d0``, electrons (read noise).
    dark_current_e_per_s : float
        Dark current ``mu_I``, electrons per second (at the housing's temperature).
    adc_bits : int
        ADC resolution (8 to 16).
    gain_dn_per_e : float
        System gain ``K`` at ``base_iso``, DN per electron.
    base_iso, max_iso : float
        The gain's range in ISO (``K`` scales with ISO / base_iso).
    black_level_dn : float
        Offset added before the ADC, DN (keeps the read noise off the floor).
    source : str
        Where the numbers come from.
    """

    name: str
    quantum_efficiency: float
    pixel_pitch_um: float
    full_well_e: float
    dark_noise_e: float
    dark_current_e_per_s: float
    adc_bits: int
    gain_dn_per_e: float
    base_iso: float = 100.0
    max_iso: float = 6400.0
    black_level_dn: float = 0.0
    source: str = ""

    def __post_init__(self):
        checks = (("quantum_efficiency", 0.0, 1.0), ("pixel_pitch_um", 0.5, 50.0),
                  ("full_well_e", 100.0, 1e7), ("dark_noise_e", 0.0, 1e3),
                  ("dark_current_e_per_s", 0.0, 1e5), ("adc_bits", 8, 16),
                  ("gain_dn_per_e", 1e-4, 1e3), ("base_iso", 1.0, 1e6),
                  ("max_iso", self.base_iso, 1e7), ("black_level_dn", 0.0, 2.0 ** 15))
        for name, lo, hi in checks:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) \
                    or not lo <= v <= hi:
                raise AquaspecError(f"sensor {self.name!r}: {name}={v!r}; accepted: "
                                    f"{lo:g} to {hi:g}")

    @property
    def max_dn(self) -> int:
        return 2 ** int(self.adc_bits) - 1

    def gain(self, iso: float) -> float:
        """System gain ``K`` (DN/e-) at ``iso``."""
        if not self.base_iso <= iso <= self.max_iso:
            raise AquaspecError(f"ISO {iso!r} for sensor {self.name!r}; accepted: "
                                f"{self.base_iso:g} to {self.max_iso:g}")
        return self.gain_dn_per_e * iso / self.base_iso

    def mean_dn(self, mu_e, exposure_s: float, iso: float) -> np.ndarray:
        """EMVA 1288 mean signal ``mu_y`` (DN) of ``mu_e`` photoelectrons."""
        k = self.gain(iso)
        return self.black_level_dn + k * (np.asarray(mu_e, dtype=float)
                                          + self.dark_current_e_per_s * exposure_s)

    def variance_dn(self, mu_e, exposure_s: float, iso: float) -> np.ndarray:
        """EMVA 1288 temporal variance ``sigma_y^2`` (DN^2), the photon transfer curve."""
        k = self.gain(iso)
        dark = self.dark_noise_e ** 2 + self.dark_current_e_per_s * exposure_s
        return k * k * (dark + np.asarray(mu_e, dtype=float)) + 1.0 / 12.0

    def capture(self, mu_e, exposure_s: float, iso: float, rng) -> np.ndarray:
        """One exposure: digital numbers (float array of integers, black level
        included, clipped to the ADC's range) of mean photoelectrons ``mu_e``.

        ``rng`` is a :class:`numpy.random.Generator` (the seed makes it repeatable)."""
        mu = np.asarray(mu_e, dtype=float)
        if np.any(~np.isfinite(mu)) or np.any(mu < 0):
            raise AquaspecError("mean photoelectrons must be finite and >= 0")
        k = self.gain(iso)
        electrons = rng.poisson(mu + self.dark_current_e_per_s * exposure_s).astype(float)
        electrons = np.minimum(electrons, self.full_well_e)
        electrons += rng.normal(0.0, self.dark_noise_e, size=mu.shape)
        dn = np.floor(self.black_level_dn + k * electrons + 0.5)
        return np.clip(dn, 0.0, self.max_dn)

    def describe(self) -> dict:
        return {**asdict(self), "model": "EMVA 1288 Release 3.1 linear model"}
