"""Artificial light under water: spot and point lamps (ROV lamps, strobes, dive torches).

Conventions (as everywhere in aquaspec): metres, y up, the water surface is
the plane y = 0 (a lamp must be under water, y < 0), wavelengths in nm.

A :class:`Lamp` is a point source with a position, an axis ``direction``
and a radiant intensity that depends on the angle ``alpha`` from its axis:

    I(lambda, alpha) = I0 * s(lambda) * f(alpha)          (W sr^-1 nm^-1)

- ``f`` is the beam profile, 1 on the axis. A cone (:attr:`Lamp.cone_deg`,
  the cut-off half-angle, and :attr:`Lamp.beam_deg`) is Mitsuba 3's ``spot``
  emitter: ``f = 1`` for ``alpha <= beam``, falling *linearly in the angle*
  to 0 at ``alpha = cone``, 0 beyond. ``cone_deg = 180`` (with the default
  beam) is an isotropic point light. A measured profile
  (:func:`profile_from_csv`, columns ``angle_deg,relative``) is linear
  between its angles, 0 beyond the last, and scaled to 1 at 0 degrees.
- ``s`` is the spectrum's shape, normalised so that
  ``int_400^700 s dlambda = 1`` (1/nm): ``I0`` is the on-axis intensity
  over 400-700 nm, W/sr. Given as a power (radiant flux over 400-700 nm,
  W) it is ``I0 = P / Omega`` with ``Omega = int f dOmega`` the profile's
  solid angle (:meth:`Lamp.solid_angle_sr`).
- The spectra (:data:`SPECTRA`): ``led``, a phosphor-converted white LED
  (CIE 015:2018 illuminant LED-B4, 5111 K); ``halogen``, a tungsten-halogen
  filament as a 3200 K blackbody; ``metal-halide`` (CIE 015:2018 HP5, a
  high-pressure metal-halide lamp, 4050 K; daylight-balanced HMI lamps are
  nearer ``blackbody:5600`` or their maker's CSV); ``blackbody:T`` (Planck
  at T kelvin); ``uniform`` (equal energy, what a path tracer's ``uniform``
  spectrum is); or a CSV ``wavelength_nm,power`` (any scale, >= 0).

Lamps are fixed in the world (``frame="world"``) or to the camera
(``frame="camera"``, the default, as on a vehicle): then ``position`` and
``direction`` are in the camera's frame, x right, y up, -z forward (the
view space of :meth:`aquaspec.scene.camera.Camera.view_matrix`), and
:meth:`Lamp.placed` puts them in the world for a camera.

:func:`parse_lamps` reads the command line's ``--lamp SPEC``
(``pos=0.25,0,0;dir=0,0,-1;cone=30;power=20;spectrum=led``) and the
presets (:data:`PRESETS`, e.g. ``rov-pair``).

Where the light goes: on surfaces and scattered once in the water,
:mod:`aquaspec.transport.lamp_scattering`; its shadows,
:mod:`aquaspec.scene.lamp_shadow`.

References
----------
.. [CIE2018] CIE 015:2018, Colorimetry, 4th ed., Table 11.4 (LED illuminants)
   and 11.3 (high-pressure lamps), via colour-science ``SDS_ILLUMINANTS``.
.. [Mitsuba3] W. Jakob et al., Mitsuba 3, ``spot`` emitter (its fall-off
   measured in aquaspec's SPEC: linear in the angle between beam_width and
   cutoff_angle).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aquaspec.colour import data as colourdata
from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.io.csv import read_csv_columns

#: The range over which a lamp's power and intensity are given, nm.
TOTAL_RANGE_NM = (400.0, 700.0)
#: Built-in spectra (plus ``blackbody:T`` and CSV paths).
SPECTRA = ("led", "halogen", "metal-halide", "uniform")
#: A halogen lamp's filament temperature, K.
HALOGEN_K = 3200.0
FRAMES = ("camera", "world")
#: The beam's full-intensity half-angle as a share of the cone's by default (Mitsuba's).
DEFAULT_BEAM_SHARE = 0.75

_H = 6.62607015e-34
_C = 2.99792458e8
_KB = 1.380649e-23


def planck(wavelength_nm, temperature_k) -> np.ndarray:
    """Blackbody spectral radiance at ``wavelength_nm`` (W m^-2 sr^-1 m^-1), Planck's law."""
    lam = np.asarray(wavelength_nm, dtype=float) * 1e-9
    x = _H * _C / (lam * _KB * float(temperature_k))
    return 2.0 * _H * _C ** 2 / lam ** 5 / np.expm1(x)


@dataclass(frozen=True, eq=False)
class LampSpectrum:
    """A lamp's spectral shape: ``values`` (1/nm) at ``wavelength_nm``, normalised
    so that their integral over 400-700 nm (linear between samples) is 1."""

    name: str
    wavelength_nm: np.ndarray
    values: np.ndarray

    def on_bands(self, bands: Bands) -> np.ndarray:
        """``s`` averaged over each band (1/nm)."""
        return bands.average(self.wavelength_nm, self.values, name=f"lamp spectrum {self.name}")

    def describe(self) -> dict:
        return {"name": self.name}


def _normalised(name, wl, values, source) -> LampSpectrum:
    wl = np.asarray(wl, dtype=float)
    val = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(val)) or np.any(val < 0):
        i = int(np.argmax(~np.isfinite(val) | (val < 0)))
        raise AquaspecError(f"{source}: the lamp's spectrum is {val[i]:g} at {wl[i]:g} nm; "
                            "accepted: finite values >= 0")
    lo, hi = TOTAL_RANGE_NM
    if wl[0] > lo or wl[-1] < hi:
        raise AquaspecError(f"{source}: the lamp's spectrum covers {wl[0]:g}-{wl[-1]:g} nm; "
                            f"accepted: a spectrum covering {lo:g}-{hi:g} nm")
    total = float(Bands(1, lo, hi).average(wl, val)[0] * (hi - lo))
    if not total > 0:
        raise AquaspecError(f"{source}: the lamp's spectrum is 0 over {lo:g}-{hi:g} nm; "
                            "accepted: some power in that range")
    return LampSpectrum(name, wl, val / total)


def lamp_spectrum(kind) -> LampSpectrum:
    """A lamp's spectrum: a name of :data:`SPECTRA`, ``"blackbody:T"`` (T in K),
    a CSV path (columns ``wavelength_nm,power``), or a :class:`LampSpectrum`."""
    if isinstance(kind, LampSpectrum):
        return kind
    text = str(kind)
    if text == "led" or text == "metal-halide":
        wl, val = colourdata.cie_illuminant("LED-B4" if text == "led" else "HP5")
        return _normalised(text, wl, val, f"spectrum {text!r}")
    if text == "uniform":
        return _normalised(text, [300.0, 830.0], [1.0, 1.0], "spectrum 'uniform'")
    if text == "halogen" or text.startswith("blackbody:"):
        t_k = HALOGEN_K
        if text != "halogen":
            try:
                t_k = float(text.split(":", 1)[1])
            except ValueError:
                t_k = float("nan")
            if not (np.isfinite(t_k) and 500.0 <= t_k <= 50000.0):
                raise AquaspecError(f"lamp spectrum {text!r}; accepted: blackbody:T with T "
                                    "from 500 to 50000 K")
        wl = np.arange(300.0, 831.0, 1.0)
        return _normalised(text, wl, planck(wl, t_k), f"spectrum {text!r}")
    if text.lower().endswith(".csv"):
        cols = read_csv_columns(text, ("wavelength_nm", "power"), what="lamp spectrum")
        return _normalised(f"csv:{text}", cols["wavelength_nm"], cols["power"], text)
    raise AquaspecError(f"unknown lamp spectrum {text!r}; accepted: "
                        f"{', '.join(SPECTRA)}, blackbody:T (kelvin) or a .csv file "
                        "(wavelength_nm,power)")


@dataclass(frozen=True, eq=False)
class BeamProfile:
    """A measured angular profile: relative intensity ``relative`` at
    ``angle_deg`` from the axis (ascending from 0), 1 at 0 degrees, linear in
    between, 0 beyond the last angle."""

    angle_deg: np.ndarray
    relative: np.ndarray
    source: str = "table"

    def __post_init__(self):
        a = np.asarray(self.angle_deg, dtype=float)
        r = np.asarray(self.relative, dtype=float)
        if a.ndim != 1 or a.shape != r.shape or a.size < 2:
            raise AquaspecError(f"{self.source}: a beam profile needs two or more angles, one "
                                "value each")
        if a[0] != 0.0 or np.any(np.diff(a) <= 0) or a[-1] > 180.0:
            raise AquaspecError(f"{self.source}: beam profile angles must ascend from 0 to at "
                                f"most 180 degrees; got {a[0]:g} ... {a[-1]:g}")
        if not np.all(np.isfinite(r)) or np.any(r < 0) or not r[0] > 0:
            raise AquaspecError(f"{self.source}: beam profile values must be finite, >= 0, "
                                "and > 0 at 0 degrees")
        object.__setattr__(self, "angle_deg", a)
        object.__setattr__(self, "relative", r / r[0])


def profile_from_csv(path) -> BeamProfile:
    """A measured beam profile from a CSV with columns ``angle_deg,relative``."""
    cols = read_csv_columns(path, ("angle_deg", "relative"), what="beam profile")
    return BeamProfile(cols["angle_deg"], cols["relative"], source=str(path))


def _vector(value, name) -> np.ndarray:
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise AquaspecError(f"lamp {name} {value!r}; accepted: three finite numbers (m)")
    return v


def _positive(value, name, unit) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        x = float("nan")
    if not (np.isfinite(x) and x > 0):
        raise AquaspecError(f"lamp {name} {value!r} {unit}; accepted: a number > 0")
    return x


@dataclass(frozen=True, eq=False)
class Lamp:
    """One spot or point lamp.

    Parameters
    ----------
    position : (3,) m
        In the camera's frame (``frame="camera"``: x right, y up, -z forward)
        or the world's (y < 0: under water).
    direction : (3,)
        The beam's axis (normalised here); ignored by a point light.
    cone_deg : float
        Cut-off half-angle, degrees, 0 < cone <= 180 (180: all around).
    beam_deg : float, optional
        Half-angle of full intensity, 0 <= beam <= cone; default
        ``0.75 cone`` (Mitsuba's), or 180 for ``cone_deg = 180``.
    power_w, intensity_w_sr : float
        Exactly one: the radiant flux (W) or on-axis intensity (W/sr), both
        over 400-700 nm.
    spectrum : str or LampSpectrum
        :func:`lamp_spectrum`'s argument.
    profile : BeamProfile, optional
        A measured profile instead of the cone (``cone_deg`` is then its last angle).
    frame : {"camera", "world"}
    name : str
    """

    position: np.ndarray
    direction: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -1.0]))
    cone_deg: float = 30.0
    beam_deg: float | None = None
    power_w: float | None = None
    intensity_w_sr: float | None = None
    spectrum: object = "led"
    profile: BeamProfile | None = None
    frame: str = "camera"
    name: str = "lamp"

    def __post_init__(self):
        if self.frame not in FRAMES:
            raise AquaspecError(f"lamp frame {self.frame!r}; accepted: {', '.join(FRAMES)}")
        pos = _vector(self.position, "position")
        if self.frame == "world" and pos[1] >= 0:
            raise AquaspecError(f"lamp {self.name!r} at y = {pos[1]:g} m is not under water; "
                                "accepted: y < 0 (the water surface is y = 0)")
        d = _vector(self.direction, "direction")
        norm = float(np.linalg.norm(d))
        if norm == 0:
            raise AquaspecError(f"lamp direction {self.direction!r}; accepted: a non-zero vector")
        object.__setattr__(self, "position", pos)
        object.__setattr__(self, "direction", d / norm)
        if self.profile is not None:
            if not isinstance(self.profile, BeamProfile):
                raise AquaspecError(f"lamp profile {self.profile!r}; accepted: a BeamProfile "
                                    "(profile_from_csv)")
            object.__setattr__(self, "cone_deg", float(self.profile.angle_deg[-1]))
            object.__setattr__(self, "beam_deg", 0.0)
        else:
            cone = float(self.cone_deg) if isinstance(self.cone_deg, (int, float)) else np.nan
            if not (np.isfinite(cone) and 0.0 < cone <= 180.0):
                raise AquaspecError(f"lamp cone {self.cone_deg!r} degrees (the cut-off "
                                    "half-angle); accepted: more than 0, at most 180")
            beam = self.beam_deg
            if beam is None:
                beam = 180.0 if cone == 180.0 else DEFAULT_BEAM_SHARE * cone
            beam = float(beam)
            if not (np.isfinite(beam) and 0.0 <= beam <= cone):
                raise AquaspecError(f"lamp beam {self.beam_deg!r} degrees; accepted: 0 to the "
                                    f"cone's {cone:g}")
            object.__setattr__(self, "cone_deg", cone)
            object.__setattr__(self, "beam_deg", beam)
        if (self.power_w is None) == (self.intensity_w_sr is None):
            raise AquaspecError("a lamp needs exactly one of power_w (W) and intensity_w_sr "
                                "(W/sr), over 400-700 nm")
        if self.power_w is not None:
            object.__setattr__(self, "power_w", _positive(self.power_w, "power", "W"))
        else:
            object.__setattr__(self, "intensity_w_sr",
                               _positive(self.intensity_w_sr, "intensity", "W/sr"))
        object.__setattr__(self, "spectrum", lamp_spectrum(self.spectrum))

    # ---- the beam -------------------------------------------------------------
    @property
    def cone_rad(self) -> float:
        return float(np.radians(self.cone_deg))

    def relative_intensity(self, alpha_rad) -> np.ndarray:
        """``f(alpha)``: the profile at angles ``alpha_rad`` from the axis (0 ... 1)."""
        a = np.degrees(np.asarray(alpha_rad, dtype=float))
        if self.profile is not None:
            p = self.profile
            return np.interp(a, p.angle_deg, p.relative, right=0.0)
        cone, beam = self.cone_deg, self.beam_deg
        if cone == beam:
            return np.where(a <= cone, 1.0, 0.0)
        return np.clip((cone - a) / (cone - beam), 0.0, 1.0)

    def solid_angle_sr(self) -> float:
        """``Omega = 2 pi int_0^pi f(alpha) sin(alpha) dalpha``, sr: power / on-axis intensity."""
        alpha = np.linspace(0.0, self.cone_rad, 20001)
        if self.profile is not None:
            alpha = np.unique(np.concatenate([alpha, np.radians(self.profile.angle_deg)]))
        elif 0.0 < self.beam_deg < self.cone_deg:
            alpha = np.unique(np.concatenate([alpha, [np.radians(self.beam_deg)]]))
        y = self.relative_intensity(alpha) * np.sin(alpha)
        return float(2.0 * np.pi * np.trapezoid(y, alpha))

    @property
    def on_axis_w_sr(self) -> float:
        """``I0``: the on-axis intensity over 400-700 nm, W/sr."""
        if self.intensity_w_sr is not None:
            return self.intensity_w_sr
        return self.power_w / self.solid_angle_sr()

    def intensity_on(self, bands: Bands) -> np.ndarray:
        """``I0 s`` per band, the on-axis intensity, W sr^-1 nm^-1."""
        return self.on_axis_w_sr * self.spectrum.on_bands(bands)

    # ---- where it is ----------------------------------------------------------
    def placed(self, camera=None) -> "Lamp":
        """The lamp in the world: itself for ``frame="world"``, else carried by
        ``camera`` (:class:`aquaspec.scene.camera.Camera`); it must be under water."""
        if self.frame == "world":
            return self
        if camera is None:
            raise AquaspecError(f"lamp {self.name!r} is fixed to the camera: place it with a "
                                "camera")
        axes = np.stack([camera.right, camera.true_up, -camera.forward], axis=1)
        pos = camera.position + axes @ self.position
        if pos[1] >= 0:
            raise AquaspecError(f"lamp {self.name!r} on the camera is at y = {pos[1]:g} m, not "
                                "under water; accepted: y < 0 (the water surface is y = 0)")
        return Lamp(pos, axes @ self.direction, self.cone_deg,
                    None if self.profile is not None else self.beam_deg,
                    self.power_w, self.intensity_w_sr, self.spectrum, self.profile, "world",
                    self.name)

    def describe(self) -> dict:
        out = {"name": self.name, "frame": self.frame, "position_m": self.position.tolist(),
               "direction": self.direction.tolist(), "cone_deg": self.cone_deg,
               "beam_deg": self.beam_deg, "spectrum": self.spectrum.describe(),
               "on_axis_intensity_w_sr_400_700": self.on_axis_w_sr,
               "profile": ("mitsuba-spot: 1 inside beam_deg, linear in angle to 0 at cone_deg"
                           if self.profile is None else f"measured: {self.profile.source}")}
        if self.power_w is not None:
            out["power_w_400_700"] = self.power_w
        return out


#: Presets of :func:`parse_lamps`: name -> (description, lamps).
PRESETS = {
    "rov-pair": ("two white LED lamps fixed to the camera 0.5 m either side, looking "
                 "ahead, cone 50 degrees, 20 W each",
                 lambda: [Lamp((-0.5, 0.0, 0.0), (0.0, 0.0, -1.0), 50.0, power_w=20.0,
                               spectrum="led", name="rov-left"),
                          Lamp((0.5, 0.0, 0.0), (0.0, 0.0, -1.0), 50.0, power_w=20.0,
                               spectrum="led", name="rov-right")]),
    "torch": ("a dive torch in the diver's hand, 0.3 m right of and below the camera, "
              "cone 12 degrees, 10 W, white LED",
              lambda: [Lamp((0.3, -0.3, 0.0), (0.0, 0.0, -1.0), 12.0, power_w=10.0,
                            spectrum="led", name="torch")]),
}

#: Keys of a ``--lamp`` SPEC and what they take.
SPEC_KEYS = {
    "pos": "x,y,z in m (camera frame: x right, y up, -z ahead; world: y < 0)",
    "dir": "x,y,z, the beam's axis (default 0,0,-1)",
    "cone": "cut-off half-angle in degrees, up to 180 (default 30; 180: a point light)",
    "beam": "full-intensity half-angle in degrees (default 0.75 cone)",
    "power": "radiant flux over 400-700 nm, W",
    "intensity": "on-axis intensity over 400-700 nm, W/sr (instead of power)",
    "spectrum": "led, halogen, metal-halide, uniform, blackbody:T or a .csv (default led)",
    "profile": "a .csv angle_deg,relative: a measured beam profile instead of cone/beam",
    "frame": "camera (default) or world",
    "name": "a label for the sidecar",
}


def _numbers(text, key, spec) -> tuple:
    try:
        vals = tuple(float(x) for x in text.split(","))
    except ValueError:
        vals = ()
    if len(vals) != 3:
        raise AquaspecError(f"lamp {spec!r}: {key}={text!r}; accepted: three numbers x,y,z")
    return vals


def parse_lamp(spec: str) -> list[Lamp]:
    """One ``--lamp`` SPEC: a preset name (:data:`PRESETS`) or
    ``key=value`` pairs separated by ``;`` (:data:`SPEC_KEYS`), e.g.
    ``pos=0.25,0,0;dir=0,0,-1;cone=30;power=20;spectrum=led``."""
    text = str(spec).strip()
    if text in PRESETS:
        return PRESETS[text][1]()
    if "=" not in text:
        raise AquaspecError(f"lamp {text!r}; accepted: a preset ({', '.join(PRESETS)}) or "
                            "key=value pairs separated by ';' (keys: "
                            f"{', '.join(SPEC_KEYS)})")
    kw = {}
    for part in filter(None, (p.strip() for p in text.split(";"))):
        key, _, value = part.partition("=")
        key, value = key.strip(), value.strip()
        if key not in SPEC_KEYS:
            raise AquaspecError(f"lamp {text!r}: unknown key {key!r}; accepted: "
                                f"{', '.join(SPEC_KEYS)}")
        if key in kw:
            raise AquaspecError(f"lamp {text!r}: {key} is given twice")
        kw[key] = value
    if "pos" not in kw:
        raise AquaspecError(f"lamp {text!r}: no pos=x,y,z; accepted: " + SPEC_KEYS["pos"])
    args = {"position": _numbers(kw["pos"], "pos", text),
            "direction": _numbers(kw.get("dir", "0,0,-1"), "dir", text),
            "spectrum": kw.get("spectrum", "led"), "frame": kw.get("frame", "camera"),
            "name": kw.get("name", "lamp")}
    for key, arg in (("cone", "cone_deg"), ("beam", "beam_deg"), ("power", "power_w"),
                     ("intensity", "intensity_w_sr")):
        if key in kw:
            try:
                args[arg] = float(kw[key])
            except ValueError:
                raise AquaspecError(f"lamp {text!r}: {key}={kw[key]!r}; accepted: a number "
                                    f"({SPEC_KEYS[key]})") from None
    if "profile" in kw:
        args["profile"] = profile_from_csv(kw["profile"])
    return [Lamp(**args)]


def parse_lamps(specs) -> tuple[Lamp, ...]:
    """Every lamp of a list of ``--lamp`` SPECs (or Lamps), in order."""
    out = []
    for s in specs or ():
        out.extend([s] if isinstance(s, Lamp) else parse_lamp(s))
    return tuple(out)
