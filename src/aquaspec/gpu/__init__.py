"""GPU layer: wgpu device selection, WGSL loading, uniform layouts, passes."""
