"""The sun's shadow map on the GPU: the scene rasterised depth-only along the refracted beam.

The scene's draw calls (:meth:`aquaspec.gpu.passes.raster.RasterPass.draws`,
the geometry pass's vertex buffers) drawn through
:class:`aquaspec.gpu.passes.depth_maps.DepthMapArray` (one layer) with
:meth:`aquaspec.scene.shadowmap.ShadowMapSpec.clip_matrix` into a ``depth32float`` texture of :data:`aquaspec.scene.shadowmap.DEFAULT_MAP_SIZE`
texels a side, which :class:`aquaspec.gpu.passes.sun.SunPass` reads. NumPy
twin: :mod:`aquaspec.scene.shadowmap` (the same map, read the same way).

The map is kept from frame to frame, as real-time renderers keep the shadow
maps of static geometry: it is drawn again only when the sun, the scene's
bounds or its uploaded vertex and index buffers change, or the camera crosses
into another cell of the map's snapped centre (cells of twice
:data:`aquaspec.scene.shadowmap.DEFAULT_MAP_MARGIN_M` across the beam; a
2048^2 map cost 10-15 ms a 1280x720 frame on lavapipe).
"""

from __future__ import annotations

from aquaspec.scene.shadowmap import (DEFAULT_MAP_MARGIN_M, DEFAULT_MAP_RADIUS_M, DEFAULT_MAP_SIZE,
                                      ShadowMapSpec, shadow_map_spec)
from aquaspec.gpu.passes.depth_maps import DepthMapArray


class SunShadowPass:
    """The shadow map of ``map_size`` texels a side on ``device``."""

    def __init__(self, device, map_size: int = DEFAULT_MAP_SIZE):
        self.device = device
        self.map_size = int(map_size)
        self._maps = DepthMapArray(device, self.map_size, 1, label="sun shadow map")
        #: The map's texture view (what the sun pass binds).
        self.view = self._maps.layer_view(0)
        #: The map's geometry of the last :meth:`encode` (None: nothing shadowed).
        self.spec: ShadowMapSpec | None = None
        self.shadowed = False

    @property
    def draw_count(self) -> int:
        """Maps drawn so far (the other encodes kept the map)."""
        return self._maps.draw_count

    def encode(self, encoder, raster, scene, camera, to_sun, *,
               radius_m: float = DEFAULT_MAP_RADIUS_M,
               margin_m: float = DEFAULT_MAP_MARGIN_M) -> ShadowMapSpec | None:
        """Record the shadow map of ``scene`` around ``camera`` for a sun in direction
        ``to_sun`` (under water); None for no scene: nothing is shadowed.

        The map is kept (not drawn again) while its geometry
        (:func:`aquaspec.scene.shadowmap.shadow_map_spec`: the same for every
        camera in a cell of ``2 margin_m`` across the beam) and the scene's
        buffers are the same."""
        spec = None
        if scene is not None and scene.meshes:
            spec = shadow_map_spec(scene.bounds(), camera.position, to_sun,
                                   size=self.map_size, radius_m=radius_m, margin_m=margin_m)
        self.spec, self.shadowed = spec, spec is not None
        if spec is not None:
            self._maps.encode(encoder, raster.draws(scene), [spec])
        return spec

    def forget(self) -> None:
        """Draw the map again on the next :meth:`encode` (e.g. after editing a mesh's
        vertices in place, as :meth:`aquaspec.gpu.passes.raster.RasterPass.invalidate`)."""
        self._maps.forget()

    def no_shadows(self) -> None:
        """Nothing shadows the sun until the next :meth:`encode` (e.g. RGB-D images)."""
        self.spec, self.shadowed = None, False

    def read(self):
        """The last shadow map as heights ``h`` (size, size) float64 (``-inf``
        where no surface), for tests; None when nothing is shadowed."""
        return self._maps.read(self.spec, 0) if self.shadowed else None
