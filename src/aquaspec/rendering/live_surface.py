"""The surface seen from below in live frames: Snell's window moved by the
waves, and the sun's disc through it (issue 30).

A still render adds them after its shading
(:func:`aquaspec.rendering.surface_view.surface_seen_from_water`);
:meth:`aquaspec.rendering.renderer.Renderer.encode_frame` records the same
GPU pass (:class:`aquaspec.gpu.passes.below_waves.BelowWavesPass`, reading the
frame's G-buffer) between the shading and the display transform, and adds
its camera-RGB change to the shading's linear image on the GPU
(:class:`aquaspec.gpu.passes.add_rgb.AddRgbPass`): :class:`LiveSurface`.
It is drawn where the still render draws it (:func:`surface_drawn`): a
camera under the water (not at the waterline), the light-field model with
the flat surface's light field, and a wind sea or a sun. A camera at the
waterline gets the still render's sky over the rays going up instead
(:func:`aquaspec.rendering.above.waterline_sky`, on the GPU
:class:`aquaspec.gpu.passes.waterline_sky.WaterlineSkyPass`): the
half-and-half frame.

The sea is the one whose caustics the frame shows: with the renderer's wave
time (:meth:`~aquaspec.rendering.renderer.Renderer.set_wave_time`) the
looping sea (:func:`aquaspec.light.waves.looping`) of the caustics' loop at
that time, its slopes exact at the time (:func:`facets_at`; the caustics
are mixed between the loop's frames, exact at each frame's time); without
one, the setup's sea at its own instant, as a still render has it.
"""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import scipy.fft as sfft

from aquaspec.errors import AquaspecError
from aquaspec.gpu.passes.add_rgb import AddRgbPass
from aquaspec.gpu.passes.below_waves import BelowWavesPass
from aquaspec.gpu.passes.waterline_sky import WaterlineSkyPass
from aquaspec.light.wave_facets import SurfaceFacets, surface_facets, unresolved_variance
from aquaspec.light.waves import Waves, _amplitudes, angular_frequency, looping, wavenumbers
from aquaspec.parallel import workers
from aquaspec.rendering.above import above_water, at_waterline, check_waterline_view
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.shading.above_water import sky_radiance_above, sun_in_air


def surface_drawn(setup: SpectralSetup, camera) -> bool:
    """Whether a frame of ``camera`` under ``setup`` gets a surface pass, as
    :func:`aquaspec.rendering.surface_view.surface_seen_from_water` adds one,
    and some ray goes up: a camera at the waterline (the sky's half), or under
    the water with the light-field model under the flat surface and waves or a sun."""
    if not np.any(_corner_rays_y(camera) > 0):
        return False            # (no ray meets the surface: the frame keeps its fused display)
    if at_waterline(camera):
        return True
    return (not above_water(camera) and setup.ms_model == "lightfield"
            and setup.surface == "flat"
            and (setup.waves is not None or setup.light.sun is not None))


def _corner_rays_y(camera) -> np.ndarray:
    """The upward parts ``d_y`` (4,) of ``camera``'s rays through its image's
    corners (unnormalised): ``d_y`` is linear over the image plane, so some
    ray goes up iff one of these is positive, and all do iff all are (the
    corners lie half a pixel beyond the outer pixels' centres: a ray going
    up there alone draws a pass that changes nothing)."""
    x = (np.array([0.0, camera.width]) - camera.cx) / camera.fx
    y = (np.array([0.0, camera.height]) - camera.cy) / camera.fy
    return (camera.right[1] * x[:, None] - camera.true_up[1] * y[None, :]
            + camera.forward[1]).ravel()


@functools.lru_cache(maxsize=2)
def _sea_at_rest(sea: Waves):
    """The looping sea's complex amplitudes at ``t = 0``, its frequencies
    (rad/s) and wavenumbers (rad/m) on the tile's grid, and ``s2``."""
    kx, kz = wavenumbers(sea.grid, sea.tile_m)
    return (_amplitudes(sea), angular_frequency(np.hypot(kx, kz), sea.period_s), kx, kz,
            float(unresolved_variance(sea)))


def facets_at(waves: Waves, time_s: float) -> SurfaceFacets:
    """The facets of the looping sea of ``waves`` at ``time_s`` seconds: what
    :func:`aquaspec.light.wave_facets.surface_facets` gives for
    ``replace(looping(waves), time_s=time_s)``, with the sea's amplitudes at
    rest kept (:func:`aquaspec.light.waves.surface`'s sum moved in time,
    ``A(k) exp(-i omega t)``, two inverse FFTs a frame)."""
    sea = replace(looping(waves), time_s=0.0)
    amp0, omega, kx, kz, s2 = _sea_at_rest(sea)
    amp = amp0 * np.exp(-1j * omega * float(time_s))
    scale = float(sea.grid) ** 2
    hx, hz = (sfft.ifft2(1j * k * amp, workers=workers()).real * scale for k in (kx, kz))
    return SurfaceFacets(np.stack([hx, hz], axis=-1).astype(np.float32), float(sea.tile_m), s2)


class SeaUploads:
    """What a live pass of the sea's surface must upload for a frame: its
    whole medium when the setup changed (or whether its sea moves), only the
    wave tile's slopes when the sea's time did (the tables would take a
    quarter of a second on a loaded host); shared by :class:`LiveSurface`
    and :class:`aquaspec.rendering.live_above.LiveAbove`."""

    def __init__(self):
        self._setup = self._moving = self._time = None

    def update(self, setup: SpectralSetup, wave_time_s: float | None, set_medium,
               set_slopes) -> None:
        """Call ``set_medium(facets)`` (the facets None for a flat sea) or
        ``set_slopes(facets)`` as the frame of ``setup`` at ``wave_time_s``
        (None: the setup's instant) needs, or neither."""
        sea = setup.waves
        moving = sea is not None and wave_time_s is not None
        if self._setup is not setup or self._moving != moving:
            set_medium(None if sea is None else (facets_at(sea, wave_time_s) if moving
                                                 else surface_facets(sea)))
            self._setup, self._moving, self._time = setup, moving, wave_time_s
        elif moving and wave_time_s != self._time:
            set_slopes(facets_at(sea, wave_time_s))
            self._time = wave_time_s


class LiveSurface:
    """The surface seen from below for frames of ``width`` x ``height`` on
    ``device`` (module docstring)."""

    def __init__(self, device, width: int, height: int):
        self.below = BelowWavesPass(device, width, height)
        self.add = AddRgbPass(device, width, height)
        self._uploads = SeaUploads()
        self._sky = self._sky_rgb = None

    def encode(self, encoder, setup: SpectralSetup, camera, surface_texture, rgb_buffer,
               wave_time_s: float | None) -> None:
        """Record the pass for ``camera`` reading the G-buffer's
        ``surface_texture``, and add its change into ``rgb_buffer`` (the
        shading's linear camera RGB); the sea at ``wave_time_s`` (None: the
        setup's instant). The medium is uploaded when the setup changed, the
        tile's slopes when the sea or its time did. At the waterline the
        rays going up get the sky instead (:class:`WaterlineSkyPass`)."""
        if at_waterline(camera):
            self._encode_sky(encoder, setup, camera, rgb_buffer)
            return
        def set_medium(facets):
            med = setup.medium([])
            self.below.set_medium(setup.lightfield_tables(), facets, a=med["a"], b=med["b"],
                                  e0=med["e0"], response_weights=med["response_weights"],
                                  sun=setup.sun_inputs())

        self._uploads.update(setup, wave_time_s, set_medium, self.below.set_slopes)
        self.below.encode(encoder, camera, surface_texture)
        self.add.encode(encoder, self.below.rgb_buffer, rgb_buffer)

    def _encode_sky(self, encoder, setup: SpectralSetup, camera, rgb_buffer) -> None:
        """The half-and-half frame's sky (:func:`aquaspec.rendering.above.waterline_sky`)."""
        if setup.surface != "flat":
            raise AquaspecError("a camera at the waterline sees the sea through the real "
                                f"surface: surface 'flat' (got {setup.surface!r})")
        if np.all(_corner_rays_y(camera) > 0):
            check_waterline_view(camera)        # (refuses a view without water, as render())
        if self._sky is None:
            self._sky = WaterlineSkyPass(self.add.device, self.add.width, self.add.height)
        if self._sky_rgb is None or self._sky_rgb[0] is not setup:
            med = setup.medium([])
            self._sky_rgb = (setup, sky_radiance_above(setup.lightfield_tables(), med["e0"])
                             @ np.asarray(med["response_weights"], dtype=np.float64))
        sun = setup.sun_inputs(caustics=False)
        self._sky.encode(encoder, camera, self._sky_rgb[1], rgb_buffer,
                         sun_air=None if sun is None else sun_in_air(sun)[0])
