"""``aquaspec synth``'s sampling plan: the samples, their identity and their groups.

A sample is one input pair with one value of each plan dimension
(:data:`aquaspec.apps.synth.config.PLAN_KEYS`). ``mode = "grid"`` takes every
combination of the listed values (a range with ``steps`` gives that many
evenly spaced values) for every input; ``mode = "random"`` draws
``samples_per_input`` samples per input, each dimension uniformly from its
list or its range (rounded to :data:`aquaspec.apps.synth.config.DRAW_DECIMALS`
decimals). The draws of an input come from a generator seeded with the seed
and the input's name, so they do not change when inputs are added or
removed, nor with the order in which samples run.

A sample's id is the first 16 hex digits of the SHA-256 of its input (name,
files, intrinsics, depth rule), its parameters, the render and output
options and the seed, as canonical JSON: the same config gives the same
ids, and a changed option gives new ones (a new sample, not an old one
overwritten). The sun's angles and the wind are dropped (None) when the
light has no sun, and a wind of 0 is a flat surface.

Samples sharing water, data source, sensor, bands and light (sun and wind
included) share their spectral set-up (light-field tables, sensor weights,
caustics): :func:`chunks` keeps each group together so a worker pays for
its set-up once per group.
"""

from __future__ import annotations

import hashlib
import itertools
import json
from dataclasses import dataclass

import numpy as np

from aquaspec.apps.synth.config import DRAW_DECIMALS, PLAN_KEYS, Dimension, SynthConfig
from aquaspec.apps.synth.inputs import InputPair, MeshInput, depth_unit_of
from aquaspec.colour.bands import MAX_BANDS, MIN_BANDS
from aquaspec.colour.display import EV_LIMIT, WHITE_BALANCE_METHODS
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import LIGHTS
from aquaspec.light.sun import check_azimuth, check_elevation
from aquaspec.medium.water import get_water

#: Dimensions that need a sun (dropped for lights without one).
SUN_KEYS = ("sun_elevation_deg", "sun_azimuth_deg", "wind_m_s")
#: Dimensions that decide a sample's spectral set-up (its group).
GROUP_KEYS = ("water", "source", "sensor", "bands", "light", *SUN_KEYS)
#: The lights with a sun (:data:`aquaspec.light.sky.LIGHTS`).
SUN_LIGHTS = ("sun-sky",)
#: Hex digits of a sample id.
ID_DIGITS = 16


@dataclass(frozen=True)
class Sample:
    """One sample: its id, its input (an RGB-D pair or a mesh) and its
    parameters (a dict over :data:`aquaspec.apps.synth.config.PLAN_KEYS`)."""

    sample_id: str
    pair: InputPair | MeshInput
    params: dict

    @property
    def group(self) -> tuple:
        """What decides the sample's spectral set-up (:data:`GROUP_KEYS`)."""
        return tuple(self.params[k] for k in GROUP_KEYS)


def plan_samples(cfg: SynthConfig, pairs: list) -> list[Sample]:
    """Every sample of ``cfg``'s plan over ``pairs``, in plan order (inputs
    by name, then draws or grid combinations).

    Raises
    ------
    AquaspecError
        A plan with zero samples, naming why.
    """
    plan = cfg.plan
    if not pairs:
        raise AquaspecError("the plan has zero samples: no input pairs were found; accepted: "
                            "rgb/ and depth/ with matching names, or a manifest with rows")
    if plan.mode == "grid":
        axes = [_grid_values(k, plan.dimensions[k]) for k in PLAN_KEYS]
        combos = [dict(zip(PLAN_KEYS, values)) for values in itertools.product(*axes)]
        params_of = {p.name: combos for p in pairs}
    else:
        if plan.samples_per_input == 0:
            raise AquaspecError("the plan has zero samples: [plan] samples_per_input = 0; "
                                "accepted: an integer >= 1")
        params_of = {p.name: [_draw(plan.dimensions, _rng(plan.seed, p.name, k))
                              for k in range(plan.samples_per_input)] for p in pairs}
    empty = [k for k in PLAN_KEYS if not plan.dimensions[k].is_range
             and not plan.dimensions[k].values]
    if empty:
        raise AquaspecError(f"the plan has zero samples: [plan] {empty[0]} is an empty list; "
                            "accepted: a value, a non-empty list or a range")
    samples, seen = [], set()
    for pair in pairs:
        for params in params_of[pair.name]:
            params = _with_light(params)
            sid = sample_id(cfg, pair, params)
            if sid not in seen:         # a grid over a dropped dimension repeats samples
                seen.add(sid)
                samples.append(Sample(sid, pair, params))
    return samples


def _grid_values(key: str, dim: Dimension) -> list:
    if not dim.is_range:
        return list(dim.values)
    if dim.steps == 1:
        return [_rounded(dim.low)]
    return [_rounded(v) for v in np.linspace(dim.low, dim.high, dim.steps)]


def _rounded(x) -> float:
    return round(float(x), DRAW_DECIMALS) + 0.0      # + 0.0: no -0.0


def _rng(seed: int, name: str, k: int) -> np.random.Generator:
    digest = hashlib.sha256(name.encode("utf-8")).digest()
    return np.random.default_rng([seed, int.from_bytes(digest[:8], "little"), k])


def _draw(dims: dict, rng: np.random.Generator) -> dict:
    out = {}
    for key in PLAN_KEYS:               # one draw per dimension, in this order, always
        d = dims[key]
        if d.is_range:
            out[key] = _rounded(rng.uniform(d.low, d.high))
        else:
            out[key] = d.values[int(rng.integers(len(d.values)))]
    return out


def _with_light(params: dict) -> dict:
    """``params`` with the sun's dimensions None without a sun, a wind of 0
    as None (a flat surface), numbers as floats and bands as an int."""
    out = dict(params)
    for key in ("depth_m", *SUN_KEYS):
        if out[key] is not None and not isinstance(out[key], str):
            out[key] = float(out[key])
    if isinstance(out["exposure"], (int, float)) and not isinstance(out["exposure"], bool):
        out["exposure"] = float(out["exposure"])
    if not isinstance(out["bands"], bool) and isinstance(out["bands"], (int, float)) \
            and float(out["bands"]).is_integer():
        out["bands"] = int(out["bands"])
    if out["light"] not in SUN_LIGHTS:
        for key in SUN_KEYS:
            out[key] = None
    elif not out["wind_m_s"]:
        out["wind_m_s"] = None
    return out


def canonical_json(obj) -> str:
    """``obj`` as JSON with sorted keys and no spaces: the text a sample id hashes."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
                      allow_nan=False)


def sample_id(cfg: SynthConfig, pair: InputPair | MeshInput, params: dict) -> str:
    """The id of ``params`` on ``pair`` under ``cfg`` (see the module docstring)."""
    inputs = cfg.inputs
    identity = {
        "input": pair.describe(),
        "depth": None if isinstance(pair, MeshInput) else {
            "unit": depth_unit_of(pair, inputs), "scale": inputs.depth_scale,
            "holes": inputs.holes},
        "params": params,
        "render": cfg.render.describe(),
        "output": {"linear": cfg.output.linear, "layers": cfg.output.layers},
        "seed": cfg.plan.seed,
    }
    return hashlib.sha256(canonical_json(identity).encode("ascii")).hexdigest()[:ID_DIGITS]


#: Work units per worker a group is cut into (at least): small enough that
#: the workers finish together, while each keeps its set-ups across units.
UNITS_PER_WORKER = 4


def chunks(samples: list[Sample], workers: int, max_size: int = 8) -> list[list[Sample]]:
    """``samples`` cut into work units of one group each, the groups in order
    of their first sample: a group of ``n`` samples is cut into at least
    :data:`UNITS_PER_WORKER` units per worker (of at most ``max_size``
    samples) so the workers share the work evenly and the progress moves; a
    worker keeps a group's set-up from one unit to the next."""
    groups: dict[tuple, list[Sample]] = {}
    for s in samples:
        groups.setdefault(_group_key(s), []).append(s)
    out = []
    for members in groups.values():
        size = max(1, min(max_size, len(members) // (UNITS_PER_WORKER * max(1, workers))))
        out += [members[i:i + size] for i in range(0, len(members), size)]
    return out


def _group_key(sample: Sample) -> str:
    # As text: the values mix None, numbers and strings, which do not sort.
    return canonical_json(sample.group)


def check_values(cfg: SynthConfig) -> None:
    """Refuse, before any work, a plan value no sample could render: an unknown
    water, source, sensor, light, white balance or band count, a sun out of
    its range, an exposure that is neither ``"auto"`` nor a number of EV."""
    dims = cfg.plan.dimensions
    camspec = cfg.render.camspec
    if camspec is not None and not camspec.is_file():
        raise AquaspecError(f"[render] camspec {str(camspec)!r} does not exist")

    def listed(key):
        d = dims[key]
        return list(d.values) if not d.is_range else [d.low, d.high]

    for key in ("water", "source", "sensor", "light", "white_balance"):
        for v in listed(key):
            if not isinstance(v, str):
                raise AquaspecError(f"[plan] {key} has the value {v!r}; accepted: a name")
    for water in listed("water"):
        for source in listed("source"):
            get_water(cfg.data_path(water), source)
    for sensor in listed("sensor"):
        get_sensor(cfg.data_path(sensor), camspec)
    _within("light", listed("light"), LIGHTS)
    _within("white_balance", listed("white_balance"), WHITE_BALANCE_METHODS)
    for n in listed("bands"):
        if isinstance(n, bool) or not isinstance(n, (int, float)) or not float(n).is_integer() \
                or not MIN_BANDS <= n <= MAX_BANDS:
            raise AquaspecError(f"[plan] bands has the value {n!r}; accepted: integers "
                                f"{MIN_BANDS} to {MAX_BANDS}")
    for v in listed("sun_elevation_deg"):
        check_elevation(v)
    for v in listed("sun_azimuth_deg"):
        check_azimuth(v)
    for v in listed("depth_m"):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v < 0:
            raise AquaspecError(f"[plan] depth_m has the value {v!r}; accepted: metres >= 0")
    for v in listed("wind_m_s"):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v < 0:
            raise AquaspecError(f"[plan] wind_m_s has the value {v!r}; accepted: m/s >= 0 "
                                "(0: a flat surface)")
    for v in listed("exposure"):
        if v != "auto" and (isinstance(v, bool) or not isinstance(v, (int, float))
                            or abs(v) > EV_LIMIT):
            raise AquaspecError(f"[plan] exposure has the value {v!r}; accepted: 'auto' or "
                                f"EV from {-EV_LIMIT:g} to {EV_LIMIT:g}")


def _within(key, values, accepted) -> None:
    for v in values:
        if v not in accepted:
            raise AquaspecError(f"[plan] {key} has the value {v!r}; accepted: "
                                f"{', '.join(accepted)}")
