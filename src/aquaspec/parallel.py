"""Spreading NumPy work over the machine's cores with threads.

NumPy's array operations release the GIL, so a list of independent,
array-heavy jobs (the shadow's receiver rays, the multiple-scattering
kernels) runs on all cores from a thread pool, without copying arrays
between processes.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor


def workers() -> int:
    """The cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:                      # (not on Linux)
        return max(1, os.cpu_count() or 1)


def in_threads(fn, items) -> list:
    """``[fn(x) for x in items]``, in this order, over :func:`workers` threads."""
    items = list(items)
    n = min(workers(), len(items))
    if n < 2:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(max_workers=n) as pool:
        return list(pool.map(fn, items))
