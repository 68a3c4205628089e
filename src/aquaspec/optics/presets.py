"""Camera models: a port, a lens and a sensor, and the presets of ``--camera-model``.

A :class:`CameraModel` is what stands between the water and the image file
in a real underwater camera: the port (:mod:`aquaspec.optics.flat_port`,
:mod:`aquaspec.optics.dome_port`, or none), the lens
(:mod:`aquaspec.optics.lens`) and the sensor
(:mod:`aquaspec.optics.sensor`), with the exposure settings. None of it is
on unless asked for (``render(camera_model=...)``, ``aquaspec render
--camera-model``); ``aquaspec validate`` never uses it.

The presets' sensor numbers are *typical* of their class of camera, chosen
within the range that EMVA 1288 data sheets and photon-transfer
measurements of such sensors report; they are not the data sheet of one
product:

- ``dslr-flat-port``: an APS-C CMOS DSLR of the Nikon D5100's generation
  (4.78 um photosites: 23.6 mm over 4928 pixels; pair it with
  ``--sensor nikon5100-npl``, that camera's measured response curves) with
  an 18 mm lens at f/8 focused at 2 m, behind a 10 mm N-BK7 flat port 40 mm
  in front of the entrance pupil; 14-bit raw, ISO 100-6400, auto exposure
  up to 1/60 s (hand-held).
- ``machine-vision-dome``: a global-shutter machine-vision camera of the
  Sony IMX174 class (5.86 um photosites, 12-bit, gain 0-24 dB) with a 6 mm
  lens at f/2.8 focused at 1 m, behind a 100 mm (50 mm radius) N-BK7 dome
  6 mm thick; auto exposure up to 1/30 s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from aquaspec.errors import AquaspecError
from aquaspec.optics.dome_port import DomePort
from aquaspec.optics.flat_port import DEFAULT_MIN_DISTANCE_M, FlatPort
from aquaspec.optics.lens import ThinLens
from aquaspec.optics.sensor import Emva1288Sensor


@dataclass(frozen=True)
class CameraModel:
    """A real camera: port, lens, sensor and exposure settings.

    Parameters
    ----------
    name : str
    port : FlatPort, DomePort or None
    lens : ThinLens
    sensor : Emva1288Sensor
    exposure_s : "auto" or float
        Exposure time, s; ``"auto"`` meters (:func:`aquaspec.optics.exposure.auto_exposure`).
    iso : "auto" or float
        ``"auto"`` goes with auto exposure (the gain rises once the time is at
        ``max_exposure_s``); a number fixes the gain.
    min_exposure_s, max_exposure_s : float
        Auto exposure's range.
    seed : int
        Seed of the sensor noise.
    min_distance_m : float
        The nearest surface a flat port's image is made wide enough for
        (:func:`aquaspec.optics.remap.water_intrinsics`).
    depth_of_field : bool
        Blur by the lens's depth of field (off: everything sharp).
    """

    name: str
    port: FlatPort | DomePort | None
    lens: ThinLens
    sensor: Emva1288Sensor
    exposure_s: float | str = "auto"
    iso: float | str = "auto"
    min_exposure_s: float = 1.0 / 8000.0
    max_exposure_s: float = 1.0 / 60.0
    seed: int = 0
    min_distance_m: float = DEFAULT_MIN_DISTANCE_M
    depth_of_field: bool = True

    def __post_init__(self):
        if self.exposure_s != "auto" and not (isinstance(self.exposure_s, (int, float))
                                              and 1e-6 <= self.exposure_s <= 60.0):
            raise AquaspecError(f"exposure_s={self.exposure_s!r}; accepted: 'auto' or "
                                "1e-6 to 60 seconds")
        if self.iso != "auto":
            self.sensor.gain(self.iso)
        if not 1e-6 <= self.min_exposure_s <= self.max_exposure_s <= 60.0:
            raise AquaspecError(f"exposure range {self.min_exposure_s!r}-"
                                f"{self.max_exposure_s!r} s; accepted: 1e-6 <= min <= max <= 60")
        if not 0.05 <= self.min_distance_m <= 100.0:
            raise AquaspecError(f"min_distance_m={self.min_distance_m!r}; accepted: 0.05 to 100")

    def describe(self) -> dict:
        return {"name": self.name,
                "port": None if self.port is None else self.port.describe(),
                "lens": self.lens.describe(), "sensor": self.sensor.describe(),
                "exposure_s": self.exposure_s, "iso": self.iso,
                "exposure_range_s": [self.min_exposure_s, self.max_exposure_s],
                "seed": self.seed, "min_distance_m": self.min_distance_m,
                "depth_of_field": self.depth_of_field}


_APSC_DSLR = Emva1288Sensor(
    name="aps-c-cmos-dslr", quantum_efficiency=0.45, pixel_pitch_um=4.78, full_well_e=40000.0,
    dark_noise_e=3.0, dark_current_e_per_s=0.2, adc_bits=14, gain_dn_per_e=(16383.0 - 600.0) / 40000.0,
    base_iso=100.0, max_iso=6400.0, black_level_dn=600.0,
    source="typical of a 2011 APS-C CMOS DSLR (Nikon D5100 generation); not one data sheet")
_MACHINE_VISION = Emva1288Sensor(
    name="imx174-class-global-shutter", quantum_efficiency=0.70, pixel_pitch_um=5.86,
    full_well_e=30000.0, dark_noise_e=7.0, dark_current_e_per_s=10.0, adc_bits=12,
    gain_dn_per_e=(4095.0 - 64.0) / 30000.0, base_iso=100.0, max_iso=1600.0, black_level_dn=64.0,
    source="typical of a Sony IMX174-class machine-vision camera (gain 0-24 dB as ISO "
           "100-1600); not one data sheet")

#: ``--camera-model`` presets by name.
CAMERA_MODELS = {
    "dslr-flat-port": CameraModel(
        "dslr-flat-port", FlatPort(thickness_m=0.01, gap_m=0.04, glass="bk7"),
        ThinLens(focal_length_mm=18.0, f_number=8.0, focus_distance_m=2.0), _APSC_DSLR,
        max_exposure_s=1.0 / 60.0),
    "machine-vision-dome": CameraModel(
        "machine-vision-dome", DomePort(radius_m=0.05, thickness_m=0.006, glass="bk7"),
        ThinLens(focal_length_mm=6.0, f_number=2.8, focus_distance_m=1.0), _MACHINE_VISION,
        min_exposure_s=1e-5, max_exposure_s=1.0 / 30.0),
}


def get_camera_model(spec) -> CameraModel | None:
    """``spec``: None, a :class:`CameraModel`, or a preset name of
    :data:`CAMERA_MODELS`, optionally with settings, e.g.
    ``"dslr-flat-port:iso=3200,exposure=0.01,seed=4,dof=off"``."""
    if spec is None or isinstance(spec, CameraModel):
        return spec
    name, _, settings = str(spec).partition(":")
    try:
        model = CAMERA_MODELS[name.strip().lower()]
    except KeyError:
        raise AquaspecError(f"camera model {spec!r} is unknown; accepted: "
                            f"{', '.join(CAMERA_MODELS)} (optionally ':iso=...,exposure=..."
                            ",seed=...,dof=on|off')") from None
    changes = {}
    for item in filter(None, (s.strip() for s in settings.split(","))):
        key, _, value = item.partition("=")
        key, value = key.strip().lower(), value.strip().lower()
        try:
            if key in ("iso", "exposure"):
                changes["iso" if key == "iso" else "exposure_s"] = (
                    "auto" if value == "auto" else float(value))
            elif key == "seed":
                changes["seed"] = int(value)
            elif key == "dof" and value in ("on", "off"):
                changes["depth_of_field"] = value == "on"
            else:
                raise ValueError
        except ValueError:
            raise AquaspecError(f"camera model setting {item!r}; accepted: iso=auto|NUMBER, "
                                "exposure=auto|SECONDS, seed=INT, dof=on|off") from None
    return dataclasses.replace(model, **changes)
