"""The sample task: render one synth sample and write its files.

:class:`SampleTask` is what a worker holds, in a local pool process or a
Ray actor alike: it keeps, across the samples it is given, the spectral
objects of each group (water, sensor, light, waves) and a
:class:`aquaspec.rendering.renderer.Renderer` per image size and band count,
so the compiled passes and the light-field tables are made once per worker
and group (:func:`aquaspec.rendering.api.render` with ``renderer=``).

A sample's files are written on a thread of the worker while the next
sample renders; they are written as :func:`aquaspec.io.save.save_image`
writes them, atomically and the sidecar last, so a killed worker leaves
only temporary files of the sample it was writing.

A sample's outputs carry no time stamp and no timing (``timestamp`` is
null, ``render_seconds`` dropped), so the same sample gives the same bytes
on every run and every worker; times are in the run's summary. The
sidecar's ``synth`` entry holds the sample's id, input, parameters, hole
count and files: the manifest's row of a done sample.

An RGB-D pair is rendered from its own camera (``rgbd=``), a mesh placed
3 m in front of the camera (``mesh=``) at ``[inputs] mesh_size``.

A sample that fails (unreadable input, mismatched sizes, depth in the wrong
unit, a render error) is recorded in ``failures/ID.json`` with its error and
the run goes on; a later success removes the record.
"""

from __future__ import annotations

import dataclasses
import time
import zlib
from collections import OrderedDict
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aquaspec.apps.synth.config import SynthConfig
from aquaspec.apps.synth.files import SampleFiles
from aquaspec.apps.synth.inputs import RGBD, MeshInput, read_pair
from aquaspec.apps.synth.plan import SUN_LIGHTS, Sample
from aquaspec.colour.sensors import Sensor, get_sensor
from aquaspec.io.atomic import write_atomically, write_file_atomically
from aquaspec.io.metadata import metadata_json, to_jsonable
from aquaspec.io.png import png_writer
from aquaspec.io.save import save_image
from aquaspec.io.sidecar import sidecar_writer
from aquaspec.light.sky import SurfaceLight, surface_light
from aquaspec.light.waves import Waves
from aquaspec.medium.water import Water, get_water
from aquaspec.optics.presets import get_camera_model
from aquaspec.scene.particles import parse_marine_snow
from aquaspec.rendering.api import render
from aquaspec.rendering.renderer import Renderer

#: Groups (spectral objects) and renderers a worker keeps, least recently used dropped.
KEEP_GROUPS = 8
KEEP_RENDERERS = 2


@dataclass(frozen=True)
class GroupObjects:
    """The spectral objects a group of samples shares."""

    water: Water
    sensor: Sensor
    light: SurfaceLight
    waves: Waves | None


class SampleTask:
    """Renders samples of one configuration into its output folder.

    Parameters
    ----------
    cfg : SynthConfig
    """

    def __init__(self, cfg: SynthConfig):
        self.cfg = cfg
        self.root = Path(cfg.output.folder)
        self._groups: OrderedDict = OrderedDict()
        self._renderers: OrderedDict = OrderedDict()

    def run(self, samples: list[Sample]) -> list[dict]:
        """Render ``samples``; one record each: ``sample_id``, ``status``
        (``done``, ``failed``), ``error``, ``seconds`` (from the start of its
        render to the end of its writing) and, when done, ``synth`` (the
        sidecar's entry).

        A sample's files are written on a thread while the next sample
        renders (encoding and compressing them is a quarter of a sample's
        time); at most one sample waits to be written."""
        futures = []
        with ThreadPoolExecutor(max_workers=1) as writer:
            for sample in samples:
                files = SampleFiles(self.root, sample.sample_id)
                t0 = time.perf_counter()
                try:
                    write = self._render(sample, files)
                except Exception as exc:    # any failure is the sample's, recorded
                    futures.append(_done(self._failed(sample, files, exc, t0)))
                    continue
                if futures:
                    futures[-1].result()
                futures.append(writer.submit(self._write, sample, files, write, t0))
        return [f.result() for f in futures]

    def _write(self, sample: Sample, files: SampleFiles, write, t0: float) -> dict:
        try:
            synth = write()
        except Exception as exc:            # any failure is the sample's, recorded
            return self._failed(sample, files, exc, t0)
        files.failure.unlink(missing_ok=True)
        return {"sample_id": sample.sample_id, "status": "done", "error": None,
                "seconds": time.perf_counter() - t0, "synth": synth}

    @staticmethod
    def _failed(sample: Sample, files: SampleFiles, exc: Exception, t0: float) -> dict:
        error = f"{type(exc).__name__}: {exc}"
        _record_failure(files, sample, error)
        return {"sample_id": sample.sample_id, "status": "failed", "error": error,
                "seconds": time.perf_counter() - t0, "synth": None}

    def _objects(self, sample: Sample) -> GroupObjects:
        key = sample.group
        if key not in self._groups:
            p = sample.params
            sun = {} if p["light"] not in SUN_LIGHTS else {
                "sun_elevation_deg": p["sun_elevation_deg"],
                "sun_azimuth_deg": p["sun_azimuth_deg"]}
            self._groups[key] = GroupObjects(
                get_water(self.cfg.data_path(p["water"]), p["source"]),
                get_sensor(self.cfg.data_path(p["sensor"]), self.cfg.render.camspec),
                surface_light(p["light"], **sun),
                None if p["wind_m_s"] is None else Waves(p["wind_m_s"]))
            if len(self._groups) > KEEP_GROUPS:
                self._groups.popitem(last=False)
        self._groups.move_to_end(key)
        return self._groups[key]

    def _renderer(self, width: int, height: int, n_bands: int) -> Renderer | None:
        if self.cfg.render.backend != "gpu":
            return None
        key = (width, height, n_bands)
        if key not in self._renderers:
            self._renderers[key] = Renderer(width, height, n_bands)
            if len(self._renderers) > KEEP_RENDERERS:
                self._renderers.popitem(last=False)
        self._renderers.move_to_end(key)
        return self._renderers[key]

    def _render(self, sample: Sample, files: SampleFiles):
        """Render ``sample``; returns ``write()``, which writes its files
        (the sidecar last) and returns the sidecar's ``synth`` entry."""
        cfg, p = self.cfg, sample.params
        if isinstance(sample.pair, MeshInput):
            rgbd = None
            width, height = sample.pair.size
            view = {"mesh": sample.pair.root / sample.pair.mesh, "size": (width, height)}
        else:
            rgbd = read_pair(sample.pair, cfg.inputs)
            height, width = rgbd.depth_m.shape
            view = {"rgbd": (rgbd.rgb, rgbd.depth_m, sample.pair.intrinsics)}
        holes = 0 if rgbd is None else rgbd.hole_count
        objs = self._objects(sample)
        res = render(water=objs.water, depth_m=p["depth_m"], sensor=objs.sensor,
                     bands=p["bands"], wavelength_range=cfg.render.wavelength_range,
                     **view, light=objs.light,
                     waves=objs.waves, ms_model=cfg.render.ms_model, phase=cfg.render.phase,
                     exposure=p["exposure"], white_balance=p["white_balance"],
                     tonemap=cfg.render.tonemap,
                     colour_matrix=None if cfg.render.colour_matrix == "none" else "auto",
                     layers=cfg.output.layers, backend=cfg.render.backend,
                     renderer=self._renderer(width, height, p["bands"]),
                     camera_model=_camera_model(cfg.render.camera_model, sample.sample_id),
                     marine_snow=_marine_snow(cfg.render.marine_snow, sample.sample_id))
        display, linear, layers = _masked(res.display, res.linear_rgb, res.layers, rgbd,
                                          cfg.inputs.holes == "mask" and holes > 0)
        written = {"png": files.png, "sidecar": files.sidecar,
                   "linear": files.linear if cfg.output.linear else None,
                   "layers": files.layers if cfg.output.layers else None,
                   "mask": files.mask if holes else None}
        synth = {"sample_id": sample.sample_id, **sample.pair.describe(), **p,
                 "seed": cfg.plan.seed, "width": width, "height": height,
                 "depth_holes": holes, "holes": None if rgbd is None else cfg.inputs.holes,
                 "exposure_ev": res.params["display"].get("exposure_ev"),
                 "files": {k: None if v is None else files.relative(v)
                           for k, v in written.items()}}
        synth = to_jsonable(synth, "synth")
        params = {k: v for k, v in res.params.items() if k != "render_seconds"}
        params.update(synth=synth, timestamp=None)

        def write():
            files.folder.mkdir(parents=True, exist_ok=True)
            if holes:
                valid = np.where(rgbd.holes, 0, 255).astype(np.uint8)
                write_file_atomically(files.mask, png_writer(valid, metadata_json(
                    {"sample_id": sample.sample_id, "valid": 255, "hole": 0})))
            save_image(files.png, display, linear if cfg.output.linear else None, params,
                       linear_path=written["linear"], layers=layers,
                       layers_path=written["layers"])
            return synth
        return write


def _camera_model(spec, sample_id: str):
    """The ``[render] camera_model`` of one sample: its sensor noise seeded
    from the sample's id (each sample its own noise, the same on a rerun)."""
    model = get_camera_model(spec)
    if model is None:
        return None
    return dataclasses.replace(model, seed=zlib.crc32(sample_id.encode("utf-8")))


def _marine_snow(spec, sample_id: str):
    """The ``[render] marine_snow`` of one sample: its particles seeded from the
    sample's id (each sample its own particles, the same on a rerun)."""
    snow = parse_marine_snow(spec)
    if snow is None:
        return None
    return dataclasses.replace(snow, seed=zlib.crc32(sample_id.encode("utf-8")))


def _masked(display, linear, layers, rgbd: RGBD | None, mask: bool):
    """The outputs with the depth holes set to 0 (``mask``), else as they are."""
    if not mask:
        return display, linear, layers
    holes = rgbd.holes

    def zeroed(arr):
        arr = np.array(arr, copy=True)
        arr[holes] = 0
        return arr
    return (zeroed(display), zeroed(linear),
            None if layers is None else {k: zeroed(v) for k, v in layers.items()})


def _record_failure(files: SampleFiles, sample: Sample, error: str) -> None:
    files.failure.parent.mkdir(parents=True, exist_ok=True)
    doc = {"sample_id": sample.sample_id, "input": sample.pair.name,
           "params": sample.params, "error": error}
    write_atomically([(files.failure, sidecar_writer(doc))])


def _done(record: dict) -> Future:
    """``record`` as a finished future (beside the writer's)."""
    future = Future()
    future.set_result(record)
    return future
