"""The GPU passes: each a Python module beside its WGSL, ``<name>.py`` + ``<name>.wgsl``.

=============  ==========================================================  ===========================
module         what it does                                                NumPy twin
=============  ==========================================================  ===========================
raster         meshes -> G-buffer (render pass, depth test)                :func:`aquaspec.scene.raycast.raycast_gbuffer`
deferred       G-buffer -> camera RGB, the seeds' analytic model           :func:`aquaspec.shading.shade.shade_gbuffer`
lightfield     G-buffer -> camera RGB, the light-field model               :func:`aquaspec.transport.lightfield.compiled.shade_compiled`
watertable     the light-field pass's water table per camera depth        :func:`aquaspec.transport.lightfield.compiled.water_table`
conespread     the forward cone spread over the image (a pyramid)          :func:`aquaspec.transport.lightfield.conespread.spread`
sun            the sun's froxels and radiance, added to the image         :func:`aquaspec.shading.sun.sun_radiance`
sun_shadow     the sun's shadow map (depth-only render pass)              :mod:`aquaspec.scene.shadowmap`
shadow_hit     the scene's shadow along rays that end on a surface        :meth:`~aquaspec.transport.lightfield.shadow.ShadowContext.hit_rays`
shadow_open    the scene's shadow along open-water rays                   :meth:`~aquaspec.transport.lightfield.shadow.ShadowContext.open_ray`
display        linear RGB -> sRGB RGBA8                                    :func:`aquaspec.colour.display.to_display`
copy           reads the G-buffer, writes the output (benchmark floor)    --
=============  ==========================================================  ===========================

``shadow_rays`` has no WGSL: :class:`~aquaspec.gpu.passes.shadow_rays.ShadowRays`
drives the two shadow ray passes for :func:`aquaspec.transport.lightfield.shadow.ambient_shadow`.
Each pass has a twin test in ``tests/gpu/passes/``.

The interface every pass has
----------------------------
- ``__init__(...)`` makes its buffers and its bind-group layout, stated once
  as ``{binding: kind}`` (:func:`aquaspec.gpu.bindings.bind_group_layout`),
  with the binding numbers written in its WGSL as module constants ``B_*``;
  a uniform is a :class:`aquaspec.gpu.layout.UniformLayout` (``PARAMS_LAYOUT``)
  whose WGSL struct is pasted into the shader.
- ``set_*(...)`` upload inputs (``set_medium``, ``set_weights``, ``set_inputs``,
  ``set_settings`` / ``set_display``); the shading passes read a shared
  :class:`aquaspec.gpu.gbuffer.GBufferTextures`, which the raster pass renders
  into, and write through a :class:`aquaspec.gpu.shading_output.ShadingOutput`.
- ``pipeline(...)`` returns the compiled pipeline for the shader's
  compile-time constants (made when first used, cached), ``bind_group()`` the
  bind group (rebuilt when a bound resource is replaced).
- ``encode(encoder, timestamp_writes=None)`` records the pass into a command
  encoder (what :func:`aquaspec.gpu.timing.time_passes` times), ``run()``
  records and submits it, ``read*()`` reads results back, checked.

Shared plumbing lives one level up, in :mod:`aquaspec.gpu`: the device
(:mod:`~aquaspec.gpu.device`), buffers and textures (:mod:`~aquaspec.gpu.buffers`),
bindings (:mod:`~aquaspec.gpu.bindings`), pipelines and dispatches
(:mod:`~aquaspec.gpu.dispatch`), WGSL loading (:mod:`~aquaspec.gpu.shaders`;
the shared WGSL includes are in ``gpu/wgsl/``), uniform layouts
(:mod:`~aquaspec.gpu.layout`), the camera's uniform fields
(:mod:`~aquaspec.gpu.camera`), the G-buffer (:mod:`~aquaspec.gpu.gbuffer`),
the material table (:mod:`~aquaspec.gpu.materials`), the display transform
(:mod:`~aquaspec.gpu.display_transform`), the shading passes' outputs
(:mod:`~aquaspec.gpu.shading_output`), the shadow ray passes' base
(:mod:`~aquaspec.gpu.band_rays`) and timing (:mod:`~aquaspec.gpu.timing`).
"""
