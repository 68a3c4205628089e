"""Options shared by several commands, and turning them into objects."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from aquaspec.colour.bands import MAX_BANDS, MIN_BANDS, Bands
from aquaspec.colour.display import EV_LIMIT
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, LIGHTS, surface_light
from aquaspec.light.sun import check_azimuth, check_elevation
from aquaspec.light.waves import Waves
from aquaspec.medium.water import DEFAULT_SOURCE, SOURCES, get_water
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODEL_CHOICES
from aquaspec.transport.monzon2022 import AMBIENT_MODELS, DEFAULT_AMBIENT

#: The deepest a camera can be: the Challenger Deep, about 10,935 m
#: (Greenaway et al. 2021, doi:10.1177/00368504211000541), rounded up.
MAX_OCEAN_DEPTH_M = 11000.0
#: Default sun elevation of ``--light sun-sky``, degrees.
DEFAULT_SUN_ELEVATION_DEG = 60.0
#: Sides of the sun's shadow map the renderer accepts, texels
#: (:func:`aquaspec.scene.shadowmap.shadow_map_spec`).
SHADOW_MAP_TEXELS = (16, 8192)
#: Where ``--camspec`` files come from (not shipped with aquaspec).
CAMSPEC_ORIGIN = ("camspec_database.txt is the camera database of Jiang et al. 2013 ('What is "
                  "the space of spectral sensitivity functions for digital color cameras?', "
                  "WACV 2013), downloaded from its authors' page; it is not shipped with "
                  "aquaspec")


class Parser(argparse.ArgumentParser):
    """argparse with a one-line error (``aquaspec render: error: ...``, exit
    status 2) instead of the command's whole usage."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")

    def _get_values(self, action, arg_strings):
        # Python 3.11's argparse turns ``--opt=--`` into [] without calling
        # the option's type (found by tests/cli/test_fuzz_options.py).
        if action.option_strings and action.nargs is None and arg_strings == ["--"]:
            raise argparse.ArgumentError(action, "expected one value, not '--'")
        return super()._get_values(action, arg_strings)


def finite_float(text) -> float:
    """argparse type: a finite number (nan and inf are refused before any work)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not accepted; give a finite number")
    return value


def depth_metres(text) -> float:
    """argparse type of ``--depth``: a finite number of metres, at most
    :data:`MAX_OCEAN_DEPTH_M` (negative depths are refused, naming the
    command's range, where the depth is used)."""
    value = finite_float(text)
    if value > MAX_OCEAN_DEPTH_M:
        raise argparse.ArgumentTypeError(
            f"depth {text!r} m is deeper than the deepest ocean; accepted: 0 to "
            f"{MAX_OCEAN_DEPTH_M:g} m")
    return value


def band_count(text) -> int:
    """argparse type of ``--bands``: an integer within the accepted band counts."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not MIN_BANDS <= n <= MAX_BANDS:
        raise argparse.ArgumentTypeError(f"{text!r} bands; accepted: {MIN_BANDS} to "
                                         f"{MAX_BANDS}")
    return n


def exposure_value(text):
    """argparse type of ``--exposure``: ``"auto"`` or a finite number of stops
    within +-:data:`aquaspec.colour.display.EV_LIMIT`."""
    if str(text).strip().lower() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and abs(value) <= EV_LIMIT):
        raise argparse.ArgumentTypeError(
            f"exposure {text!r} is not accepted; give 'auto' or a number of stops (EV) in "
            f"[-{EV_LIMIT:g}, {EV_LIMIT:g}]")
    return value


def check_camspec(path):
    """``path`` when it names a file; else an error saying where such files come from."""
    if path is not None and not Path(path).is_file():
        raise AquaspecError(f"camspec file {str(path)!r} does not exist; {CAMSPEC_ORIGIN}")
    return path


def add_water_options(p, *, required=True):
    p.add_argument("--water", required=required, metavar="TYPE|FILE.csv",
                   help="Jerlov water type (I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C) or a CSV "
                        "with columns wavelength_nm,a,b[,Kd] in 1/m")
    p.add_argument("--source", default=DEFAULT_SOURCE, choices=SOURCES,
                   help=f"published data set for Jerlov types (default {DEFAULT_SOURCE})")


def add_camspec_option(p):
    p.add_argument("--camspec", metavar="PATH",
                   help="a camspec_database.txt (Jiang et al. 2013; not shipped) whose cameras "
                        "--sensor can name")


def add_sensor_options(p):
    p.add_argument("--sensor", default="human", metavar="NAME|FILE.csv",
                   help="camera response: 'human' (CIE 1931 -> linear sRGB), a built-in camera, "
                        "a camera of --camspec, or a CSV wavelength_nm,r,g,b (default human)")
    add_camspec_option(p)
    p.add_argument("--outside-zero", action="store_true",
                   help="take the sensor's response as zero outside its wavelength range "
                        "instead of refusing such bands")


def add_band_options(p, default=16):
    p.add_argument("--bands", type=band_count, default=default, metavar="N",
                   help=f"number of wavelength bands (default {default}; 3 = RGB-like)")
    p.add_argument("--range", default="400-700", metavar="MIN-MAX",
                   help="wavelength range in nm (default 400-700)")


def add_sun_options(p, light_help="light at the surface (default overcast: equal energy)"):
    """--light and where its sun stands."""
    p.add_argument("--light", default="overcast", choices=LIGHTS, help=light_help)
    p.add_argument("--sun-elevation", type=finite_float, default=None, metavar="DEG",
                   help=f"sun elevation for --light sun-sky, 1-90 (default "
                        f"{DEFAULT_SUN_ELEVATION_DEG:g})")
    p.add_argument("--sun-azimuth", type=finite_float, default=None, metavar="DEG",
                   help="sun compass angle for --light sun-sky, from -z (the built-in camera's "
                        "view: 0 = sun ahead, 180 = behind) towards +x (default "
                        f"{DEFAULT_SUN_AZIMUTH_DEG:g})")


def add_sun_rendering_options(p, wind_help):
    """How the renderer draws the sun: its shadow map and the waves' caustics
    (read back with :func:`waves_from`)."""
    p.add_argument("--sun-shadow-map", type=int, default=None, metavar="TEXELS",
                   help=f"--light sun-sky: side of the sun's shadow map, {SHADOW_MAP_TEXELS[0]} "
                        f"to {SHADOW_MAP_TEXELS[1]} and at most the GPU's largest texture "
                        "(default 2048; shadows are resolved within 40 m of the camera)")
    p.add_argument("--wind", type=finite_float, default=None, metavar="M_S", help=wind_help)
    p.add_argument("--wind-azimuth", type=finite_float, default=0.0, metavar="DEG",
                   help="--wind: the way the waves run, compass as --sun-azimuth (default 0)")
    p.add_argument("--wave-time", type=finite_float, default=0.0, metavar="S",
                   help="--wind: the instant, seconds (the waves move; default 0)")
    p.add_argument("--wave-seed", type=int, default=0, metavar="N",
                   help="--wind: seed of the sea's random phases (default 0)")


def sun_from(args) -> tuple[float, float]:
    """``(elevation_deg, azimuth_deg)`` of :func:`add_sun_options` (the
    defaults when left out); placing a sun needs ``--light sun-sky``."""
    for opt, val in (("--sun-elevation", args.sun_elevation),
                     ("--sun-azimuth", args.sun_azimuth)):
        if val is not None and args.light != "sun-sky":
            raise AquaspecError(f"{opt} places the sun: it needs --light sun-sky, not "
                                f"--light {args.light}")
    elevation = (DEFAULT_SUN_ELEVATION_DEG if args.sun_elevation is None
                 else check_elevation(args.sun_elevation))
    azimuth = DEFAULT_SUN_AZIMUTH_DEG if args.sun_azimuth is None else args.sun_azimuth
    check_azimuth(azimuth)
    return elevation, azimuth


def shadow_map_from(args, max_texture=None):
    """``--sun-shadow-map`` checked (None when left out): it needs ``--light
    sun-sky`` and lies within :data:`SHADOW_MAP_TEXELS` and ``max_texture``
    (the GPU's largest texture side, None for the NumPy backend)."""
    size = args.sun_shadow_map
    if size is None:
        return None
    if args.light != "sun-sky":
        raise AquaspecError(f"--sun-shadow-map is the sun's shadow map: it needs --light "
                            f"sun-sky, not --light {args.light}")
    lo, hi = SHADOW_MAP_TEXELS
    if max_texture is not None and max_texture < hi:
        hi = int(max_texture)
    if not lo <= size <= hi:
        limit = ("" if max_texture is None else
                 f"; this GPU's largest texture is {int(max_texture)} texels")
        raise AquaspecError(f"--sun-shadow-map {size}; accepted: an integer {lo} to {hi} "
                            f"texels{limit}")
    return size


def waves_from(args):
    """The :class:`aquaspec.light.waves.Waves` of :func:`add_sun_rendering_options`, or None."""
    if args.wind is None:
        for opt, val, default in (("--wind-azimuth", args.wind_azimuth, 0.0),
                                  ("--wave-time", args.wave_time, 0.0),
                                  ("--wave-seed", args.wave_seed, 0)):
            if val != default:
                raise AquaspecError(f"{opt} describes the waves: it needs --wind M_S")
        return None
    if args.light != "sun-sky":
        raise AquaspecError(f"--wind focuses the sun into caustics: it needs --light "
                            f"sun-sky, not {args.light!r}")
    return Waves(args.wind, wind_azimuth_deg=args.wind_azimuth, time_s=args.wave_time,
                 seed=args.wave_seed)


def add_light_options(p):
    add_sun_options(p)
    p.add_argument("--irradiance", type=finite_float, default=None, metavar="W_M2",
                   help="total surface irradiance over 400-700 nm, W/m^2 (default 100)")
    p.add_argument("--ambient", default=DEFAULT_AMBIENT, choices=list(AMBIENT_MODELS),
                   help=f"seeds model: how surface irradiance depends on the normal (default "
                        f"{DEFAULT_AMBIENT})")
    p.add_argument("--ms-model", default=DEFAULT_MS_MODEL, choices=list(MS_MODEL_CHOICES),
                   help="multiple-scattering model: 'monzon2022' (thesis Eq. 4.7 from Kd; "
                        "alias 'seeds') or 'lightfield' (discrete-ordinates light field with "
                        f"a phase function) (default {DEFAULT_MS_MODEL})")
    p.add_argument("--phase", default="petzold", choices=("petzold", "ff", "hg", "isotropic"),
                   help="phase function for --ms-model lightfield (default petzold)")
    p.add_argument("--forward-cone", type=finite_float, default=None, metavar="DEG",
                   help="--ms-model lightfield: scattering within DEG of forward stays in the "
                        "beam towards surfaces (default 15, or 40 with --cone-spread; 0 = off)")


def add_spread_scattering_option(p):
    p.add_argument("--spread-scattering", choices=("single", "multiple"), default="single",
                   help="--cone-spread: the cone's light scattered once inside the cone (single, the "
                        "default) or a Poisson number of times with mean f b S (multiple: "
                        "kernels at six lambda nodes; closer to the path tracer in turbid "
                        "water, above all on targets seen from above, 8-11 %% slower)")


def parse_range(text):
    try:
        lo, hi = (float(x) for x in str(text).split("-"))
    except ValueError:
        raise AquaspecError(f"wavelength range {text!r} is not MIN-MAX in nm, e.g. 400-700") from None
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise AquaspecError(f"wavelength range {text!r}; accepted: finite MIN-MAX in nm, "
                            "e.g. 400-700")
    return lo, hi


def parse_depth_albedo(text, flag: str, accepted: str, default_albedo: float = 0.2):
    """``M[,ALBEDO]`` -> ``(M, ALBEDO)``: M > 0 metres, ALBEDO in [0, 1]
    (``default_albedo`` when left out); else an error naming ``flag`` and
    ``accepted``."""
    try:
        values = [float(x) for x in str(text).split(",")]
    except ValueError:
        values = []
    if not 1 <= len(values) <= 2 or not values[0] > 0 or not (
            len(values) == 1 or 0.0 <= values[1] <= 1.0):
        raise AquaspecError(f"{flag} {text!r}; accepted: {accepted}")
    return values[0], values[1] if len(values) == 2 else default_albedo


def bands_from(args) -> Bands:
    lo, hi = parse_range(args.range)
    return Bands(args.bands, lo, hi)


def water_from(args):
    return get_water(args.water, args.source)


def sensor_from(args):
    return get_sensor(args.sensor, check_camspec(args.camspec))


def light_from(args):
    elevation, azimuth = sun_from(args)
    return surface_light(args.light, total_w_m2=args.irradiance,
                         sun_elevation_deg=elevation, sun_azimuth_deg=azimuth)


def add_rgbd_options(p, what="the photograph is seen through the water"):
    """``--rgbd IMAGE DEPTH`` and ``--intrinsics fx,fy,cx,cy`` (:func:`rgbd_from`)."""
    p.add_argument("--rgbd", nargs=2, metavar=("IMAGE", "DEPTH"),
                   help="an RGB image and its metric depth map (16-bit PNG in mm, .npy or .exr "
                        f"in m): {what}")
    p.add_argument("--intrinsics", metavar="fx,fy,cx,cy",
                   help="pinhole intrinsics for --rgbd, pixels")


def comma_floats(text, n: int, what: str) -> tuple:
    """``n`` comma-separated finite numbers (an option's value named ``what``)."""
    try:
        vals = tuple(float(x) for x in str(text).split(","))
    except ValueError:
        vals = ()
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise AquaspecError(f"{what} {text!r} must be {n} comma-separated finite numbers")
    return vals


def rgbd_from(args):
    """``(image, depth, (fx, fy, cx, cy))`` of ``--rgbd`` and ``--intrinsics``, or None."""
    if args.rgbd:
        if not args.intrinsics:
            raise AquaspecError("--rgbd needs --intrinsics fx,fy,cx,cy (pixels)")
        return args.rgbd[0], args.rgbd[1], comma_floats(args.intrinsics, 4, "--intrinsics")
    if args.intrinsics:
        raise AquaspecError("--intrinsics is only used with --rgbd")
    return None
