"""``render(marine_snow=...)`` and live frames with marine snow.

The particles (:mod:`aquaspec.scene.particles`) around the frame's camera
are shaded on the host (:class:`aquaspec.shading.particles.ParticleLight`:
the light field, the sun's beam and the lamps of the frame's
:class:`aquaspec.rendering.setup.SpectralSetup`) and drawn as discs over the
shaded image, depth-tested against the G-buffer: on the GPU by
:class:`aquaspec.gpu.passes.particles.ParticlePass`, in NumPy by
:func:`aquaspec.shading.particles.splat_image`.

In :func:`aquaspec.rendering.api.render` the particles are added to the
linear camera RGB after the lamps and before the camera model
(:mod:`aquaspec.rendering.camera_model`), in the pinhole's pixels: a flat
port resamples them with the rest, and the lens's depth of field sets each
particle's blur circle from its own distance
(:meth:`aquaspec.optics.lens.ThinLens.blur_diameter_px`, the port's virtual
image left out); the camera model's gather then blurs the image by the
surfaces' distance, the particles included (so an in-focus particle in
front of a far background is blurred twice). The image-formation layers and
the per-band radiance do not include them.
"""

from __future__ import annotations

import dataclasses
import weakref

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.passes.particles import ParticlePass
from aquaspec.gpu.passes.snow_field import SnowFieldPass
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.particles import MarineSnow, SnowField, parse_marine_snow  # noqa: F401
from aquaspec.shading.particles import (MAX_RADIUS_PX, ParticleLight, composite, in_view,
                                        splat_image, splats)

_PASSES = weakref.WeakKeyDictionary()      # Renderer -> ParticlePass of its size
_FIELDS: dict = {}                          # MarineSnow -> SnowField (the last few)


def snow_field(snow: MarineSnow) -> SnowField:
    """The particles of ``snow`` (kept: the same spec draws them once)."""
    if snow not in _FIELDS:
        if len(_FIELDS) >= 4:
            _FIELDS.pop(next(iter(_FIELDS)))
        _FIELDS[snow] = SnowField(snow)
    return _FIELDS[snow]


def particle_light(setup: SpectralSetup, camera, snow: MarineSnow,
                   visible=None, sun_shadow=None) -> ParticleLight:
    """What lights the particles under ``setup`` for ``camera`` (its lamps placed;
    ``sun_shadow``: the scene's shadow map of the sun, ``(height_map, spec)``, or None)."""
    bw = setup.water.on_bands(setup.bands)
    medium = setup.medium([])
    return ParticleLight.of(snow.albedo, tables=setup.lightfield_tables(), e0=medium["e0"],
                            a=bw.a, b=bw.b, response_weights=medium["response_weights"],
                            sun=setup.sun_inputs(), lamps=setup.lamp_inputs(camera),
                            visible=visible, sun_shadow=sun_shadow)


def frame_splats(snow: MarineSnow, light: ParticleLight, camera, time_s: float = 0.0,
                 coc_px=None) -> np.ndarray:
    """The splat records (:func:`aquaspec.shading.particles.splats`) of ``snow``'s
    particles for ``camera`` at ``time_s`` (s)."""
    pos, diam = snow_field(snow).at(camera.position, time_s, camera=camera,
                                    margin_px=MAX_RADIUS_PX + 1.0)
    seen = in_view(pos, camera, MAX_RADIUS_PX + 1.0)
    pos, diam = pos[seen], diam[seen]
    return splats(pos, diam, light.rgb(pos, camera.position), camera, blur_px=snow.blur_px,
                  coc_px=coc_px)


def _coc(optics):
    """The lens's blur-circle diameter (pixels) as a function of axial distance, or None."""
    if optics is None or not optics.model.depth_of_field:
        return None
    lens, f_px = optics.model.lens, float(optics.sensor_camera.fx)
    return lambda z: lens.blur_diameter_px(z, lens.focus_distance_m, f_px)


def add_marine_snow(marine_snow, shaded, setup: SpectralSetup, view, optics, backend,
                    say, *, above: bool = False):
    """``(shaded, params)``: ``shaded`` (render's ``_Shaded``) with the
    particles over its linear image, and ``{"marine_snow": ...}`` for the
    sidecar; ``(shaded, {})`` without marine snow."""
    snow = parse_marine_snow(marine_snow)
    if snow is None:
        return shaded, {}
    if above:
        raise AquaspecError("marine snow hangs in the water; this camera is above it; "
                            "accepted: marine_snow=None for a view from above")
    if shaded.radiance is not None:
        raise AquaspecError("marine snow is drawn in camera RGB, not per band; accepted: "
                            "return_radiance=False with marine_snow")
    camera = view.camera
    light = particle_light(setup, camera, snow, sun_shadow=_sun_shadow(shaded, backend))
    records = frame_splats(snow, light, camera, 0.0, _coc(optics))
    say(f"marine snow: {len(records)} particles drawn ({snow.count} in the cube)")
    if backend == "gpu" and shaded.renderer is not None:
        r = shaded.renderer
        gpu = _PASSES.get(r)
        if gpu is None:
            gpu = _PASSES[r] = ParticlePass(r.deferred.device, r.width, r.height)
        gpu.set_splats(records)
        enc = r.deferred.device.create_command_encoder()
        gpu.encode_splat(enc, r.deferred.gbuffer.textures["surface"])
        r.deferred.device.queue.submit([enc.finish()])
        acc = gpu.read_accumulated()
    else:
        gbuffer = shaded.gbuffer if shaded.gbuffer is not None else view.gbuffer
        acc = splat_image(records, gbuffer.distance)
    linear = composite(shaded.linear, acc)
    info = {**snow.describe(), "particles_drawn": int(len(records)),
            "blur": "the lens's circle of confusion" if optics is not None
            and optics.model.depth_of_field else f"fixed, {snow.blur_px:g} px at least",
            "drawn_on": "GPU" if backend == "gpu" else "NumPy"}
    return dataclasses.replace(shaded, linear=linear), {"marine_snow": info}


def _sun_shadow(shaded, backend):
    """The frame's shadow map of the sun ``(height_map, spec)``, or None."""
    if backend != "gpu":
        return shaded.sun_shadow
    sun = None if shaded.renderer is None else shaded.renderer.sun
    if sun is None or not sun.shadowed:
        return None
    return sun.read_shadow_map(), sun.spec


class LiveSnow:
    """Marine snow on a :class:`aquaspec.rendering.renderer.Renderer`'s live
    frames: the particles at :attr:`time_s` composed over the shading pass's
    image before the display (:meth:`encode`).

    Lit by the light field alone (no sun, no lamps), the particles are moved,
    culled, lit and splatted on the GPU
    (:class:`aquaspec.gpu.passes.snow_field.SnowFieldPass`); with the sun or
    lamps their light is computed on the host (:func:`frame_splats`) and
    their discs splatted by :class:`aquaspec.gpu.passes.particles.ParticlePass`."""

    def __init__(self, snow, device, width: int, height: int):
        self.snow = parse_marine_snow(snow)
        if self.snow is None:
            raise AquaspecError("LiveSnow needs marine snow; accepted: a MarineSnow or a spec")
        self.gpu = ParticlePass(device, width, height)
        self.field = SnowFieldPass(self.gpu)
        #: The instant of the particles' drift, s.
        self.time_s = 0.0
        self._light_key = None
        self._light = None
        self._drawn = 0

    @property
    def drawn(self) -> int:
        """Particles drawn in the last frame (waits for the GPU when it drew them)."""
        return self.field.read_drawn() if self._drawn is None else self._drawn

    def light(self, setup: SpectralSetup, camera) -> ParticleLight:
        """The frame's :class:`ParticleLight` (the light field's part kept per setup)."""
        if setup.lamps or self._light_key is not setup:
            visible = self._light.visible if (self._light is not None
                                              and self._light_key is setup) else None
            self._light = particle_light(setup, camera, self.snow, visible)
            self._light_key = setup
        return self._light

    def encode(self, encoder, rgb_buffer, surface_texture, camera, setup: SpectralSetup, *,
               display: bool = False):
        """Record the particles for ``camera`` over ``rgb_buffer`` (in place), or
        with ``display`` composed and shown into ``self.gpu.output`` (the
        display settings given to ``self.gpu.set_display``)."""
        self.encode_splat(encoder, surface_texture, camera, setup)
        if display:
            self.gpu.encode_display(encoder, rgb_buffer)
        else:
            self.gpu.encode_compose(encoder, rgb_buffer)

    def encode_splat(self, encoder, surface_texture, camera, setup: SpectralSetup):
        """Record the splat alone (into ``self.gpu.accum``), for a shading pass
        that composes it itself
        (:meth:`aquaspec.gpu.passes.lightfield.LightfieldPass.set_snow`)."""
        light = self.light(setup, camera)
        if light.sun is None and not light.lamps:
            self.field.set_field(snow_field(self.snow))
            self.field.set_light(light)
            self.field.encode(encoder, surface_texture, camera, self.time_s)
            self._drawn = None
            return
        records = frame_splats(self.snow, light, camera, self.time_s)
        self._drawn = len(records)
        self.gpu.set_splats(records)
        self.gpu.encode_splat(encoder, surface_texture)
