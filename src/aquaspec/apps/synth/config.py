"""``aquaspec synth``'s configuration: a TOML file read into frozen dataclasses.

The file has four tables (paths are relative to the file's folder)::

    [inputs]                       # where the RGB-D pairs are
    folder = "nyu"                 # rgb/ and depth/ under it, matched by file stem
    # manifest = "pairs.csv"       # or a CSV/Parquet list: image, depth[, name, fx, fy, cx, cy]
    depth_unit = "mm"              # mm | cm | m (default: mm for 16-bit PNG, m for .npy/.exr)
    depth_scale = 1.0              # multiplies after the unit (e.g. 0.2 for 1/5000 m steps)
    intrinsics = [518.8, 519.5, 325.6, 253.7]   # fx, fy, cx, cy (pixels) of every image
    holes = "mask"                 # depth holes: mask | fill | error
    missing_depth = "error"        # an image without a depth map: error | skip
    # meshes = "models"            # and/or meshes (a folder or a list of files) as scenes
    # mesh_size = [640, 480]       # their image size

    [plan]                         # what each sample is
    mode = "random"                # random | grid
    seed = 7
    samples_per_input = 4          # random draws per image
    water = ["IB", "II", "3C"]     # a value, a list (a choice), or {min, max[, steps]}
    depth_m = {min = 2, max = 12}
    sensor = "nikon-5100-npl"
    bands = 16
    light = ["overcast", "sun-sky"]
    sun_elevation_deg = {min = 30, max = 80}

    [render]                       # the same for every sample
    ms_model = "lightfield"

    [output]
    folder = "out"
    linear = true                  # linear camera RGB, float32 EXR
    layers = false                 # the image-formation layers, EXR
    manifest = ["csv", "parquet"]

Every table and key is checked when the file is read; a bad one is an
:class:`aquaspec.errors.AquaspecError` naming it and what is accepted.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from aquaspec.colour.display import TONEMAPS
from aquaspec.errors import AquaspecError
from aquaspec.optics.flat_port import FlatPort
from aquaspec.optics.presets import get_camera_model
from aquaspec.scene.particles import parse_marine_snow
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODEL_CHOICES

#: Depth units and their metres.
DEPTH_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
#: What happens to depth holes (NaN, infinite, zero or negative values):
#: ``mask`` fills them from the nearest valid pixel to render, then zeroes
#: them in every output and writes a validity mask; ``fill`` only fills;
#: ``error`` fails the sample.
HOLE_RULES = ("mask", "fill", "error")
MISSING_DEPTH_RULES = ("error", "skip")
PLAN_MODES = ("random", "grid")
MANIFEST_FORMATS = ("csv", "parquet")
#: The plan's dimensions, in the order they are drawn (this order is part of
#: what a seed means: a new dimension goes at the end).
PLAN_KEYS = ("water", "source", "depth_m", "sensor", "bands", "light", "sun_elevation_deg",
             "sun_azimuth_deg", "wind_m_s", "exposure", "white_balance")
#: A dimension's value when the plan does not name it.
PLAN_DEFAULTS = {"water": "IB", "source": "solonenko2015", "depth_m": 5.0,
                 "sensor": "human", "bands": 16, "light": "overcast",
                 "sun_elevation_deg": 60.0, "sun_azimuth_deg": 0.0, "wind_m_s": 0.0,
                 "exposure": "auto", "white_balance": "none"}
#: Dimensions that may be drawn from a range ``{min, max}`` (numbers).
NUMERIC_KEYS = ("depth_m", "sun_elevation_deg", "sun_azimuth_deg", "wind_m_s", "exposure")
#: Decimals kept of a number drawn from a range (so a sample's parameters are
#: short, exact in JSON and TOML, and the same on every machine).
DRAW_DECIMALS = 4
TABLES = ("inputs", "plan", "render", "output")


@dataclass(frozen=True)
class InputsConfig:
    """``[inputs]``: where the pairs are, and how their depth is read."""

    folder: Path | None = None
    manifest: Path | None = None
    depth_unit: str | None = None
    depth_scale: float = 1.0
    intrinsics: tuple | None = None
    holes: str = "mask"
    missing_depth: str = "error"
    #: A folder of meshes (or a list of mesh files) rendered as scenes: each
    #: placed 3 m in front of the camera (:func:`aquaspec.scene.load.place_in_front`).
    meshes: tuple = ()
    #: Image size of the mesh samples (width, height), pixels.
    mesh_size: tuple = (640, 480)


@dataclass(frozen=True)
class Dimension:
    """One dimension of the plan: a list of values, or a range of numbers."""

    values: tuple = ()
    low: float | None = None
    high: float | None = None
    steps: int | None = None

    @property
    def is_range(self) -> bool:
        return self.low is not None


@dataclass(frozen=True)
class PlanConfig:
    """``[plan]``: grid or seeded random draws over :data:`PLAN_KEYS`."""

    mode: str = "random"
    seed: int = 0
    samples_per_input: int = 1
    dimensions: dict = field(default_factory=dict)


@dataclass(frozen=True)
class RenderConfig:
    """``[render]``: options of :func:`aquaspec.rendering.api.render` shared by all samples."""

    ms_model: str = DEFAULT_MS_MODEL
    phase: str = "petzold"
    wavelength_range: tuple = (400.0, 700.0)
    camspec: Path | None = None
    tonemap: str = "filmic"
    colour_matrix: str = "auto"
    backend: str = "gpu"
    #: A ``--camera-model`` preset (port, lens, noisy sensor), or None: the pinhole.
    camera_model: str | None = None
    #: A ``--marine-snow`` spec (each sample's particles seeded from its id), or None.
    marine_snow: str | None = None

    def describe(self) -> dict:
        return {"ms_model": self.ms_model, "phase": self.phase,
                "wavelength_range": list(self.wavelength_range),
                "camspec": None if self.camspec is None else self.camspec.name,
                "tonemap": self.tonemap, "colour_matrix": self.colour_matrix,
                "backend": self.backend,
                # Only when set: a sample's id hashes this, and a run without a
                # camera model keeps the ids it had before the key existed.
                **({"camera_model": self.camera_model} if self.camera_model else {}),
                **({"marine_snow": self.marine_snow} if self.marine_snow else {})}


@dataclass(frozen=True)
class OutputConfig:
    """``[output]``: the folder and what is written per sample."""

    folder: Path
    linear: bool = True
    layers: bool = False
    manifest: tuple = MANIFEST_FORMATS


@dataclass(frozen=True)
class SynthConfig:
    """A whole ``aquaspec synth`` configuration (:func:`load_config`)."""

    inputs: InputsConfig
    plan: PlanConfig
    render: RenderConfig
    output: OutputConfig
    path: Path | None = None
    #: The folder the file's relative paths start from.
    base: Path = Path(".")

    def data_path(self, value):
        """A plan value naming a file (a water or sensor ``.csv``) as a path
        from :attr:`base`; other values as they are. (The plan keeps the
        value as written, so sample ids do not depend on where the files are.)"""
        if isinstance(value, str) and value.lower().endswith(".csv"):
            return str(self.base / value)
        return value


def load_config(path, *, output=None, layers: bool | None = None) -> SynthConfig:
    """Read and check a synth TOML file.

    Parameters
    ----------
    path : path
        The TOML file; relative paths in it are relative to its folder.
    output : path, optional
        Overrides ``[output] folder`` (relative to the current folder).
    layers : bool, optional
        Overrides ``[output] layers``.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise AquaspecError(f"config {str(p)!r} cannot be read ({exc.strerror or exc})") from exc
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise AquaspecError(f"config {str(p)!r} is not valid TOML ({exc})") from exc
    return config_from_dict(doc, base=p.resolve().parent, path=p, output=output, layers=layers)


def config_from_dict(doc: dict, *, base=".", path=None, output=None,
                     layers: bool | None = None) -> SynthConfig:
    """A :class:`SynthConfig` from the TOML document ``doc`` (paths relative to ``base``)."""
    base = Path(base)
    _only(doc, TABLES, "the config's tables")
    for name in TABLES:
        if name in doc and not isinstance(doc[name], dict):
            raise AquaspecError(f"[{name}] must be a table, got {doc[name]!r}")
    out = _output(doc.get("output", {}), base)
    if output is not None:
        out = OutputConfig(Path(output).absolute(), out.linear, out.layers, out.manifest)
    if layers is not None:
        out = OutputConfig(out.folder, out.linear, bool(layers), out.manifest)
    inputs, render = _inputs(doc.get("inputs", {}), base), _render(doc.get("render", {}), base)
    if (render.camera_model is not None and (inputs.folder or inputs.manifest)
            and isinstance(get_camera_model(render.camera_model).port, FlatPort)):
        raise AquaspecError(f"[render] camera_model = {render.camera_model!r} has a flat port, "
                            "which RGB-D inputs cannot be seen through (their view is fixed); "
                            "accepted: a camera model with a dome port, or mesh inputs")
    return SynthConfig(inputs, _plan(doc.get("plan", {})), render, out,
                       None if path is None else Path(path), base)


def _only(table: dict, keys, what: str) -> None:
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise AquaspecError(f"unknown key {unknown[0]!r} in {what}; accepted: {', '.join(keys)}")


def _choice(table, key, accepted, default, where):
    value = table.get(key, default)
    if value is not None and value not in accepted:
        raise AquaspecError(f"{where} {key} = {value!r}; accepted: {', '.join(map(str, accepted))}")
    return value


def _number(value, what, *, positive=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
            or (positive and value <= 0):
        raise AquaspecError(f"{what} = {value!r}; accepted: a finite number"
                            + (" > 0" if positive else ""))
    return float(value)


def _inputs(t: dict, base: Path) -> InputsConfig:
    _only(t, ("folder", "manifest", "depth_unit", "depth_scale", "intrinsics", "holes",
              "missing_depth", "meshes", "mesh_size"), "[inputs]")
    if ("folder" in t and "manifest" in t) or not ({"folder", "manifest", "meshes"} & set(t)):
        raise AquaspecError("[inputs] needs one of folder (with rgb/ and depth/ in it) or "
                            "manifest (a CSV or Parquet list of image and depth paths), "
                            "and/or meshes (a folder or list of mesh files)")
    meshes = t.get("meshes", ())
    if isinstance(meshes, str):
        meshes = (meshes,)
    if not isinstance(meshes, (list, tuple)) or not all(isinstance(m, str) for m in meshes):
        raise AquaspecError(f"[inputs] meshes = {meshes!r}; accepted: a folder or a list of "
                            "mesh files")
    size = t.get("mesh_size", [640, 480])
    if not isinstance(size, list) or len(size) != 2 or not all(
            isinstance(v, int) and not isinstance(v, bool) and v >= 2 for v in size):
        raise AquaspecError(f"[inputs] mesh_size = {size!r}; accepted: [width, height] in "
                            "pixels, at least 2 each")
    intr = t.get("intrinsics")
    if intr is not None:
        if not isinstance(intr, list) or len(intr) != 4:
            raise AquaspecError(f"[inputs] intrinsics = {intr!r}; accepted: [fx, fy, cx, cy] "
                                "in pixels")
        intr = tuple(_number(v, "[inputs] intrinsics value") for v in intr)
        if intr[0] <= 0 or intr[1] <= 0:
            raise AquaspecError(f"[inputs] intrinsics = {list(intr)}: fx and fy must be > 0 pixels")
    return InputsConfig(
        folder=base / t["folder"] if "folder" in t else None,
        manifest=base / t["manifest"] if "manifest" in t else None,
        depth_unit=_choice(t, "depth_unit", DEPTH_UNITS, None, "[inputs]"),
        depth_scale=_number(t.get("depth_scale", 1.0), "[inputs] depth_scale", positive=True),
        intrinsics=intr,
        holes=_choice(t, "holes", HOLE_RULES, "mask", "[inputs]"),
        missing_depth=_choice(t, "missing_depth", MISSING_DEPTH_RULES, "error", "[inputs]"),
        meshes=tuple(base / m for m in meshes), mesh_size=tuple(size))


def _dimension(key: str, value) -> Dimension:
    where = f"[plan] {key}"
    if isinstance(value, dict):
        _only(value, ("min", "max", "steps"), where)
        if key not in NUMERIC_KEYS:
            raise AquaspecError(f"{where} = {value!r}: a range is for numbers; accepted: a value "
                                f"or a list (ranges: {', '.join(NUMERIC_KEYS)})")
        if "min" not in value or "max" not in value:
            raise AquaspecError(f"{where} = {value!r}; accepted: {{min = A, max = B}} "
                                "(and steps = N for a grid)")
        low, high = _number(value["min"], f"{where} min"), _number(value["max"], f"{where} max")
        if high < low:
            raise AquaspecError(f"{where}: max {high:g} < min {low:g}")
        steps = value.get("steps")
        if steps is not None and (isinstance(steps, bool) or not isinstance(steps, int)
                                  or steps < 1):
            raise AquaspecError(f"{where} steps = {steps!r}; accepted: an integer >= 1")
        return Dimension(low=low, high=high, steps=steps)
    values = tuple(value) if isinstance(value, list) else (value,)
    for v in values:
        if isinstance(v, (dict, list)) or (isinstance(v, float) and not math.isfinite(v)):
            raise AquaspecError(f"{where} has the value {v!r}; accepted: numbers or strings")
    return Dimension(values=values)


def _plan(t: dict) -> PlanConfig:
    _only(t, ("mode", "seed", "samples_per_input", *PLAN_KEYS), "[plan]")
    mode = _choice(t, "mode", PLAN_MODES, "random", "[plan]")
    seed = t.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise AquaspecError(f"[plan] seed = {seed!r}; accepted: an integer >= 0")
    per_input = t.get("samples_per_input", 1)
    if isinstance(per_input, bool) or not isinstance(per_input, int) or per_input < 0:
        raise AquaspecError(f"[plan] samples_per_input = {per_input!r}; accepted: an integer >= 0")
    if mode == "grid" and "samples_per_input" in t:
        raise AquaspecError("[plan] samples_per_input is for mode = 'random'; a grid has one "
                            "sample per combination of the listed values")
    dims = {k: _dimension(k, t.get(k, PLAN_DEFAULTS[k])) for k in PLAN_KEYS}
    if mode == "grid":
        for k, d in dims.items():
            if d.is_range and d.steps is None:
                raise AquaspecError(f"[plan] {k}: a grid needs steps in a range "
                                    f"({{min, max, steps = N}}) or a list of values")
    return PlanConfig(mode, seed, per_input, dims)


def _render(t: dict, base: Path) -> RenderConfig:
    _only(t, ("ms_model", "phase", "wavelength_range", "camspec", "tonemap", "colour_matrix",
              "backend", "camera_model", "marine_snow"), "[render]")
    marine_snow = t.get("marine_snow")
    if marine_snow is not None:
        if isinstance(marine_snow, bool) or not isinstance(marine_snow, (str, int, float)):
            raise AquaspecError(f"[render] marine_snow = {marine_snow!r}; accepted: a spec "
                                "'DENSITY[,SEED][,KEY=VALUE...]', e.g. \"200\"")
        marine_snow = str(marine_snow)
        parse_marine_snow(marine_snow)
    camera_model = t.get("camera_model")
    if camera_model is not None:
        if not isinstance(camera_model, str):
            raise AquaspecError(f"[render] camera_model = {camera_model!r}; accepted: a preset "
                                "name, e.g. \"machine-vision-dome\"")
        get_camera_model(camera_model)
    wr = t.get("wavelength_range", [400.0, 700.0])
    if not isinstance(wr, list) or len(wr) != 2:
        raise AquaspecError(f"[render] wavelength_range = {wr!r}; accepted: [min_nm, max_nm]")
    wr = tuple(_number(v, "[render] wavelength_range value", positive=True) for v in wr)
    phase = t.get("phase", "petzold")
    if not isinstance(phase, str):
        raise AquaspecError(f"[render] phase = {phase!r}; accepted: a phase function's name")
    return RenderConfig(
        ms_model=_choice(t, "ms_model", MS_MODEL_CHOICES, DEFAULT_MS_MODEL, "[render]"),
        phase=phase, wavelength_range=wr,
        camspec=base / t["camspec"] if "camspec" in t else None,
        tonemap=_choice(t, "tonemap", tuple(TONEMAPS), "filmic", "[render]"),
        colour_matrix=_choice(t, "colour_matrix", ("auto", "none"), "auto", "[render]"),
        backend=_choice(t, "backend", ("gpu", "numpy"), "gpu", "[render]"),
        camera_model=camera_model, marine_snow=marine_snow)


def _output(t: dict, base: Path) -> OutputConfig:
    _only(t, ("folder", "linear", "layers", "manifest"), "[output]")
    for key in ("linear", "layers"):
        if key in t and not isinstance(t[key], bool):
            raise AquaspecError(f"[output] {key} = {t[key]!r}; accepted: true or false")
    formats = t.get("manifest", list(MANIFEST_FORMATS))
    formats = [formats] if isinstance(formats, str) else formats
    if not isinstance(formats, list) or not formats or \
            any(f not in MANIFEST_FORMATS for f in formats):
        raise AquaspecError(f"[output] manifest = {t.get('manifest')!r}; accepted: one or more of "
                            f"{', '.join(MANIFEST_FORMATS)}")
    return OutputConfig(base / t.get("folder", "synth_out"), t.get("linear", True),
                        t.get("layers", False), tuple(dict.fromkeys(formats)))
