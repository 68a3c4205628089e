"""Options shared by several commands, and turning them into objects."""

from __future__ import annotations

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, LIGHTS, surface_light
from aquaspec.light.waves import Waves
from aquaspec.medium.water import DEFAULT_SOURCE, SOURCES, get_water
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODEL_CHOICES
from aquaspec.transport.monzon2022 import AMBIENT_MODELS, DEFAULT_AMBIENT


def add_water_options(p, *, required=True):
    p.add_argument("--water", required=required, metavar="TYPE|FILE.csv",
                   help="Jerlov water type (I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C) or a CSV "
                        "with columns wavelength_nm,a,b[,Kd] in 1/m")
    p.add_argument("--source", default=DEFAULT_SOURCE, choices=SOURCES,
                   help=f"published data set for Jerlov types (default {DEFAULT_SOURCE})")


def add_sensor_options(p):
    p.add_argument("--sensor", default="human", metavar="NAME|FILE.csv",
                   help="camera response: 'human' (CIE 1931 -> linear sRGB), a built-in camera, "
                        "a camera of --camspec, or a CSV wavelength_nm,r,g,b (default human)")
    p.add_argument("--camspec", metavar="PATH",
                   help="a camspec_database.txt (Jiang et al. 2013) whose cameras --sensor can name")
    p.add_argument("--outside-zero", action="store_true",
                   help="take the sensor's response as zero outside its wavelength range "
                        "instead of refusing such bands")


def add_band_options(p, default=16):
    p.add_argument("--bands", type=int, default=default, metavar="N",
                   help=f"number of wavelength bands (default {default}; 3 = RGB-like)")
    p.add_argument("--range", default="400-700", metavar="MIN-MAX",
                   help="wavelength range in nm (default 400-700)")


def add_sun_options(p, light_help="light at the surface (default overcast: equal energy)"):
    """--light and where its sun stands."""
    p.add_argument("--light", default="overcast", choices=LIGHTS, help=light_help)
    p.add_argument("--sun-elevation", type=float, default=60.0, metavar="DEG",
                   help="sun elevation for --light sun-sky (default 60)")
    p.add_argument("--sun-azimuth", type=float, default=DEFAULT_SUN_AZIMUTH_DEG, metavar="DEG",
                   help="sun compass angle for --light sun-sky, from -z (the built-in camera's "
                        "view: 0 = sun ahead, 180 = behind) towards +x (default "
                        f"{DEFAULT_SUN_AZIMUTH_DEG:g})")


def add_sun_rendering_options(p, wind_help):
    """How the renderer draws the sun: its shadow map and the waves' caustics
    (read back with :func:`waves_from`)."""
    p.add_argument("--sun-shadow-map", type=int, default=None, metavar="TEXELS",
                   help="--light sun-sky: side of the sun's shadow map (default 2048; shadows "
                        "are resolved within 40 m of the camera)")
    p.add_argument("--wind", type=float, default=None, metavar="M_S", help=wind_help)
    p.add_argument("--wind-azimuth", type=float, default=0.0, metavar="DEG",
                   help="--wind: the way the waves run, compass as --sun-azimuth (default 0)")
    p.add_argument("--wave-time", type=float, default=0.0, metavar="S",
                   help="--wind: the instant, seconds (the waves move; default 0)")
    p.add_argument("--wave-seed", type=int, default=0, metavar="N",
                   help="--wind: seed of the sea's random phases (default 0)")


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
    p.add_argument("--irradiance", type=float, default=None, metavar="W_M2",
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
    p.add_argument("--forward-cone", type=float, default=None, metavar="DEG",
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
    return get_sensor(args.sensor, args.camspec)


def light_from(args):
    return surface_light(args.light, total_w_m2=args.irradiance,
                         sun_elevation_deg=args.sun_elevation,
                         sun_azimuth_deg=args.sun_azimuth)
