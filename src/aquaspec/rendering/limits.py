"""How much memory a render takes, estimated before it starts.

Where the memory goes (measured with ``tracemalloc`` and the peak resident
size, 16-200 bands, 160x90 and 320x180 pixels):

- The light field (``ms_model="lightfield"``), per band: baking its tables
  (:func:`aquaspec.transport.lightfield.bake.bake_tables`) evaluates the
  field on a grid of ``n_depth x n_mu`` points for each of its ``2N + 1``
  modes (``N`` streams per hemisphere, the sun's beam one more), about six
  float64 arrays of that size at once: 12.1-12.5 MB per band at the default
  64 x 65 grid and 32 streams; the GPU's water table
  (:func:`aquaspec.transport.lightfield.compiled.water_table`), made after
  it, takes about 10 MB per band. The image's size does not enter.
- The NumPy backend, per pixel and band: the whole radiance image (H, W, n)
  float64 is kept (the forward cone's spread and the scene's shadow need
  it), the cone term too, and the shading works on row chunks: 61 bytes
  per pixel and band measured at 320x180 x 64 bands; estimated as five
  float64 values.
- The GPU backend holds camera RGB per pixel, not bands: a few hundred bytes
  a pixel (G-buffer, cone pyramid, read-backs).
- The interpreter with NumPy, wgpu and the data: about 300 MB.

At 1000 bands the light field alone is about 13 GB: :func:`check_render_memory`
refuses what the machine cannot give (:func:`aquaspec.io.limits.check_memory`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.bands import MAX_BANDS, MIN_BANDS
from aquaspec.io.limits import check_memory
from aquaspec.transport.lightfield.tables import DEFAULT_N_DEPTH, DEFAULT_N_MU
from aquaspec.transport.models import LIGHTFIELD, ms_model_name

#: Streams per hemisphere of the light field's tables (``lightfield_tables``' default).
LIGHTFIELD_STREAMS = 32
#: float64 arrays of the tables' grid x modes alive at once while baking.
LIGHTFIELD_GRID_ARRAYS = 6
#: float64 values per pixel and band in the NumPy backend.
NUMPY_VALUES_PER_PIXEL_BAND = 5
#: Bytes per pixel on the GPU backend, independent of the bands.
GPU_BYTES_PER_PIXEL = 512
#: The process before any render-sized array.
BASE_BYTES = 300 * 1024 * 1024


def lightfield_bytes(n_bands: int) -> int:
    """Peak bytes of baking the light field's tables for ``n_bands`` bands."""
    modes = 2 * LIGHTFIELD_STREAMS + 1
    return LIGHTFIELD_GRID_ARRAYS * 8 * DEFAULT_N_DEPTH * DEFAULT_N_MU * modes * int(n_bands)


def render_memory_bytes(n_bands: int, width: int, height: int, *, lightfield: bool,
                        backend: str) -> int:
    """Estimated peak memory of a render, bytes (see the module docstring)."""
    pixels = int(width) * int(height)
    if backend == "numpy":
        image = NUMPY_VALUES_PER_PIXEL_BAND * 8 * pixels * int(n_bands)
    else:
        image = GPU_BYTES_PER_PIXEL * pixels
    return BASE_BYTES + (lightfield_bytes(n_bands) if lightfield else 0) + image


def check_render_memory(n_bands, width: int, height: int, *, ms_model: str, backend: str,
                        available: int | None = None) -> None:
    """Refuse a render whose estimate exceeds what the machine has, naming both.

    A band count that is not an integer from ``MIN_BANDS`` to ``MAX_BANDS`` is
    left to :class:`aquaspec.colour.bands.Bands` to refuse.
    """
    if (not isinstance(n_bands, (int, np.integer)) or isinstance(n_bands, bool)
            or not MIN_BANDS <= n_bands <= MAX_BANDS):
        return
    lightfield = ms_model_name(ms_model) == LIGHTFIELD
    need = render_memory_bytes(n_bands, width, height, lightfield=lightfield, backend=backend)
    model = "the light field" if lightfield else "the seeds' model"
    check_memory(need, f"a {width}x{height} render of {n_bands} bands with {model} "
                 f"({backend})", "accepted: fewer bands (--bands)"
                 + (", a smaller image (--size)" if backend == "numpy" else "")
                 + (" or --ms-model seeds" if lightfield else ""), available=available)
