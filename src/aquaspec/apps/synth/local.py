"""The local pool: synth samples rendered by worker processes on this machine.

Each of ``workers`` processes (started with the ``spawn`` method: a fresh
interpreter, no GPU state inherited from the driver) owns its wgpu device
and one :class:`aquaspec.apps.synth.task.SampleTask`, kept from one work
unit to the next, so its renderers and spectral set-ups serve every unit
of their group it is given.

If the driver is killed its workers end within :data:`PARENT_POLL_S`
(a sample being written is left as temporary files, removed by the next
run); if a worker is killed the pool is broken, the driver stops after
writing the manifest, and a rerun goes on from the samples done.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool

from aquaspec.apps.synth.config import SynthConfig
from aquaspec.apps.synth.task import SampleTask
from aquaspec.errors import AquaspecError

#: How often a worker checks that the driver is alive, s.
PARENT_POLL_S = 0.5
#: The worker process's task (set by :func:`_start_worker`).
_TASK: SampleTask | None = None


def _start_worker(cfg: SynthConfig) -> None:
    global _TASK
    _TASK = SampleTask(cfg)
    threading.Thread(target=_exit_with_parent, args=(os.getppid(),), daemon=True).start()


def _exit_with_parent(parent: int) -> None:
    """End this worker soon after the driver dies (killed: its queue never
    closes, since the worker holds an end of it too). A sample being written
    is left as temporary files, which never count as done."""
    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    os._exit(1)


def _run_unit(unit) -> list[dict]:
    return _TASK.run(unit)


def run_local(cfg: SynthConfig, units: list, workers: int, on_records) -> None:
    """Render ``units`` (lists of samples) on ``workers`` processes, calling
    ``on_records(records)`` in the driver as each unit finishes."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise AquaspecError(f"workers={workers!r}; accepted: an integer >= 1")
    if not units:
        return
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=min(workers, len(units)), mp_context=context,
                               initializer=_start_worker, initargs=(cfg,))
    try:
        futures = [pool.submit(_run_unit, unit) for unit in units]
        for future in as_completed(futures):
            on_records(future.result())
    except BrokenProcessPool as exc:
        raise AquaspecError(f"a worker process died ({exc}); the samples finished so far are "
                            "kept: run the same command again to go on") from None
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
