"""GPU layer: wgpu device, buffers, bindings, WGSL loading, uniform layouts, and the
passes (:mod:`aquaspec.gpu.passes`, each beside its WGSL)."""
