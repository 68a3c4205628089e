"""The sun's passes as ``aquaspec bench`` times them (:mod:`aquaspec.apps.bench`).

:class:`SunFrame` splits a frame's sun into timed passes: with the light field the
shadow map, the froxels and the shading pass adding the sun in its band loop
with the display fused (:class:`FusedSun`); with the seeds' model the shadow
map, the froxels and the per-pixel pass. :class:`OnePass` records one pass of
a method that records several.
"""

from __future__ import annotations

from aquaspec.errors import AquaspecError


class Unlit:
    """The light-field shading pass without the sun (linear image only)."""

    def __init__(self, shading):
        self.shading = shading

    def encode(self, encoder, timestamp_writes=None):
        self.shading.set_sun(None)
        self.shading.encode(encoder, timestamp_writes)


class FusedSun:
    """The light-field shading pass adding ``sun``'s light in its band loop, the
    display fused (:meth:`aquaspec.gpu.passes.lightfield.LightfieldPass.set_sun`)."""

    def __init__(self, shading, sun):
        self.shading, self.sun = shading, sun

    def encode(self, encoder, timestamp_writes=None):
        self.shading.set_sun(self.sun)
        self.shading.encode(encoder, timestamp_writes, display=True)


class _Dropped:
    """A pass that records nothing (see :class:`OnePass`)."""

    def __getattr__(self, name):
        return lambda *args, **kwargs: None


class OnePass:
    """A command encoder that records only the ``keep``-th pass begun on it.

    The other render or compute passes are dropped, and the kept one carries
    ``timestamp_writes``: one pass of a method that records several together
    (:meth:`aquaspec.gpu.passes.sun.SunPass.encode`: the froxels, then the
    per-pixel pass) is timed through the method itself, with its uniform
    uploads and bind groups, as the renderer runs it.
    """

    def __init__(self, encoder, keep: int, timestamp_writes=None):
        self.encoder, self.keep, self.timestamp_writes = encoder, keep, timestamp_writes
        self.begun = 0

    def _begin(self, kind, kwargs):
        i, self.begun = self.begun, self.begun + 1
        if i != self.keep:
            return _Dropped()
        if self.timestamp_writes is not None:
            kwargs = {**kwargs, "timestamp_writes": self.timestamp_writes}
        return getattr(self.encoder, kind)(**kwargs)

    def begin_render_pass(self, **kwargs):
        return self._begin("begin_render_pass", kwargs)

    def begin_compute_pass(self, **kwargs):
        return self._begin("begin_compute_pass", kwargs)

    def __getattr__(self, name):
        return getattr(self.encoder, name)


class SunFrame:
    """The sun's passes (a :class:`~aquaspec.gpu.passes.sun.SunPass` with its inputs
    set) on the renderer's G-buffer.

    With the light field (``fused``) the shadow map and the froxels come
    before the shading pass, which adds the sun's light in its band loop with
    the display fused (:class:`FusedSun`); with the seeds' model the
    per-pixel pass adds it into the shading pass's linear image.
    :meth:`encode` records the sun's own passes (a frame's, with the shading
    between for the seeds' model); :meth:`parts` are the timed passes:
    ``"shadow_map"`` as a frame runs it (kept from the frame before when
    nothing moved: then nothing is recorded), ``"shadow_map_redraw"`` (drawn
    again, not part of the still frame), ``"froxels"``, and ``"shade_display"``
    (fused) or ``"pixels"``.
    """

    def __init__(self, renderer, sun, scene, camera, shading):
        self.r, self.sun, self.scene, self.camera, self.shading = (renderer, sun, scene, camera,
                                                                   shading)
        self.fused = hasattr(shading, "set_sun")

    def _shadow_map(self, encoder):
        self.sun.encode_shadow_map(encoder, self.r.raster, self.scene, self.camera)

    def _shadow_map_redraw(self, encoder):
        self.sun.shadow_map.forget()
        self._shadow_map(encoder)

    def _froxels(self, encoder):
        self.sun.encode_froxels(encoder, self.camera)

    def _light(self, encoder):
        self.sun.encode(encoder, self.camera, self.r.deferred.gbuffer.textures,
                        self.shading.rgb_buffer)

    def encode(self, encoder):
        self._shadow_map(encoder)
        if self.fused:
            self._froxels(encoder)
        else:
            self._light(encoder)

    def parts(self) -> dict:
        """Name -> timed pass (see the class docstring)."""
        out = {"shadow_map": SunPart(self._shadow_map, 0, "shadow_map", optional=True),
               "shadow_map_redraw": SunPart(self._shadow_map_redraw, 0, "shadow_map_redraw")}
        if self.fused:
            out["froxels"] = SunPart(self._froxels, 0, "froxels")
            out["shade_display"] = FusedSun(self.shading, self.sun)
        else:
            out["froxels"] = SunPart(self._light, 0, "froxels")
            out["pixels"] = SunPart(self._light, 1, "pixels")
        return out

    def frame_parts(self) -> tuple:
        """The parts a still frame's sun runs (:meth:`parts` but the redraw)."""
        return (("shadow_map", "froxels", "shade_display") if self.fused
                else ("shadow_map", "froxels", "pixels"))


class SunPart:
    """One pass of the sun's (see :class:`SunFrame`), as one timed pass (``optional``:
    the method may record nothing, e.g. a shadow map kept from the frame before)."""

    def __init__(self, record, index: int, name: str, optional: bool = False):
        self.record, self.index, self.name, self.optional = record, index, name, optional

    def encode(self, encoder, timestamp_writes=None):
        rec = OnePass(encoder, self.index, timestamp_writes)
        self.record(rec)
        if self.optional and rec.begun == 0:
            # Nothing to do this frame: an empty pass carries the timestamps.
            rec.begin_compute_pass().end()
            return
        if rec.begun <= self.index:
            raise AquaspecError(f"the sun pass recorded {rec.begun} pass(es) where bench "
                                f"times its {self.name} as pass {self.index + 1}; "
                                "aquaspec.apps.sun_passes.SunFrame.parts needs updating")
