"""Live frames of a camera above the sea (issue 30): the view from above of
:func:`aquaspec.rendering.api.render` on a renderer's frames.

:meth:`aquaspec.rendering.renderer.Renderer.encode_frame` with a camera above
``y = 0`` records :class:`LiveAbove`: the still render's GPU pass
(:class:`aquaspec.gpu.passes.above.AbovePass`, :mod:`aquaspec.rendering.above`:
the sky mirrored, the water's light field through the surface down to its
seabed, with a sun its beam's single scattering and glint, with waves the
tile's facets and the glitter), then the display transform. Its tables are
uploaded once per setup; a moving sea (the renderer's wave time) uploads the
tile's slopes at that time alone (:func:`aquaspec.rendering.live_surface.facets_at`),
so the glitter moves with the caustics' sea. What the still render leaves out
from above it leaves out too (:data:`aquaspec.rendering.above.NOT_DRAWN`),
and more: the scene's meshes and the seabed's caustics, which the still
render ray casts in NumPy (:mod:`aquaspec.shading.above_meshes`), are not
drawn live, only the light field's seabed; what the still render refuses is
refused (:func:`check_live_above`). (A camera at the
waterline is drawn as under the water, the sky filled in over its upper
half: :mod:`aquaspec.rendering.live_surface`.)
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.buffers import read_buffer
from aquaspec.gpu.passes.above import AbovePass
from aquaspec.rendering.above import check_above_setup
from aquaspec.rendering.live_surface import SeaUploads
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.gbuffer import GBuffer


def check_live_above(setup: SpectralSetup, scene, *, camera_model=None,
                     marine_snow=None) -> None:
    """Refuse a live frame from above that the still render would refuse or
    that live frames do not draw, naming it."""
    check_above_setup(setup, from_rgbd=isinstance(scene, GBuffer))
    if camera_model is not None:
        raise AquaspecError("a camera model's port looks into water; a camera above the sea "
                            "takes none yet (accepted: set_camera_model(None))")
    if marine_snow is not None:
        raise AquaspecError("marine snow is drawn around a camera in the water; live frames "
                            "from above take none (accepted: set_marine_snow(None))")


class LiveAbove:
    """The view from above for frames of ``width`` x ``height`` on ``device``
    (module docstring)."""

    def __init__(self, device, width: int, height: int):
        self.gpu = AbovePass(device, width, height)
        self._uploads = SeaUploads()

    def encode(self, encoder, setup: SpectralSetup, camera, wave_time_s: float | None,
               timestamp_writes=None) -> None:
        """Record the pass for ``camera`` (linear camera RGB into
        :attr:`rgb_buffer`), the sea at ``wave_time_s`` (None: the setup's instant)."""
        def set_medium(facets):
            med = setup.medium([])
            self.gpu.set_medium(setup.lightfield_tables(), a=med["a"], b=med["b"],
                                e0=med["e0"], response_weights=med["response_weights"],
                                sun=setup.sun_inputs(caustics=False), facets=facets)

        self._uploads.update(setup, wave_time_s, set_medium, self.gpu.set_slopes)
        self.gpu.encode(encoder, camera, timestamp_writes)

    @property
    def rgb_buffer(self):
        """Linear camera RGB of the last frame ((H, W) vec4)."""
        return self.gpu.rgb_buffer

    def render(self, setup: SpectralSetup, camera, wave_time_s: float | None) -> np.ndarray:
        """One frame's linear camera RGB (H, W, 3) float32, read back (to meter it)."""
        device = self.gpu.device
        encoder = device.create_command_encoder()
        self.encode(encoder, setup, camera, wave_time_s)
        device.queue.submit([encoder.finish()])
        out = read_buffer(device, self.gpu.rgb_buffer, np.float32,
                          (self.gpu.height, self.gpu.width, 4))
        return out[..., :3]
