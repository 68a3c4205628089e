"""The Ray executor: synth samples rendered by Ray actors on a cluster.

The same :class:`aquaspec.apps.synth.task.SampleTask` as the local pool,
held by one Ray actor per worker (each owns its wgpu device, renderers and
set-ups) and fed work units through :class:`ray.util.ActorPool`. Each actor
asks for one CPU, and one GPU where the cluster has GPUs. The actors write
the samples' files where the configuration says: on a cluster of several
machines the output folder (and the inputs) must be on a file system every
node sees at the same path, and aquaspec installed on every node.

``address``: None starts a Ray on this machine for the run (stopped at the
end); ``"auto"`` joins the cluster this machine is part of; ``HOST:PORT``
joins that head node. If Ray is already initialised in this process (a
notebook, a test) it is used as it is.
"""

from __future__ import annotations

import time

from aquaspec.apps.synth.config import SynthConfig
from aquaspec.apps.synth.task import SampleTask
from aquaspec.errors import AquaspecError


class SynthActor:
    """A worker: a :class:`SampleTask` kept across the units it is given."""

    def __init__(self, cfg: SynthConfig):
        self.task = SampleTask(cfg)

    def run(self, unit) -> list[dict]:
        return self.task.run(unit)

    def ready(self) -> bool:
        return True


def _ray():
    try:
        # deferred: ray is the optional synth extra and takes seconds to import
        import ray
    except ImportError as exc:
        raise AquaspecError("--ray needs Ray: pip install 'aquaspec[synth]'") from exc
    return ray


def run_ray(cfg: SynthConfig, units: list, workers: int | None, address: str | None,
            on_records) -> dict:
    """Render ``units`` on Ray actors (``workers`` of them; None: one per
    GPU of the cluster, else one per CPU), calling ``on_records(records)`` as
    each unit finishes; returns what was used (``address``, ``actors``,
    ``gpus_per_actor``, ``startup_seconds``: Ray started or joined and the
    actors ready)."""
    t0 = time.perf_counter()
    ray = _ray()
    # deferred: part of ray (above)
    from ray.util import ActorPool
    started = not ray.is_initialized()
    if started:
        kwargs = {"include_dashboard": False, "log_to_driver": False}
        ray.init(address="local" if address is None else address, **kwargs)
    try:
        resources = ray.cluster_resources()
        gpus = float(resources.get("GPU", 0.0))
        if workers is None:
            workers = int(gpus) if gpus >= 1 else max(1, int(resources.get("CPU", 1)))
        actor = ray.remote(num_cpus=1, num_gpus=1 if gpus >= 1 else 0)(SynthActor)
        actors = [actor.remote(cfg) for _ in range(max(1, min(workers, len(units))))]
        ray.get([a.ready.remote() for a in actors])
        startup = time.perf_counter() - t0
        if units:
            pool = ActorPool(actors)
            for records in pool.map_unordered(lambda a, unit: a.run.remote(unit), units):
                on_records(records)
        return {"address": address or "local", "actors": len(actors),
                "gpus_per_actor": 1 if gpus >= 1 else 0, "startup_seconds": startup}
    finally:
        if started:
            ray.shutdown()
