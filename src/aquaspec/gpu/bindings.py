"""Bind-group layouts and entries for the compute passes, from ``{binding: kind}``.

Every compute pass states its bindings once, as a dict of binding number ->
kind (:func:`bind_group_layout`), and binds its resources as a dict of binding
number -> buffer, texture, view or sampler (:func:`bind_group_entries`); the
binding numbers are the ones written in the pass's WGSL.
"""

from __future__ import annotations

import wgpu

#: Buffer binding kinds.
_BUFFERS = {"uniform": wgpu.BufferBindingType.uniform,
            "read": wgpu.BufferBindingType.read_only_storage,
            "write": wgpu.BufferBindingType.storage}
#: Sampled texture kinds: (sample type, view dimension).
_TEXTURES = {"float": (wgpu.TextureSampleType.unfilterable_float, wgpu.TextureViewDimension.d2),
             "uint": (wgpu.TextureSampleType.uint, wgpu.TextureViewDimension.d2),
             "float_array": (wgpu.TextureSampleType.unfilterable_float,
                             wgpu.TextureViewDimension.d2_array),
             "filterable_array": (wgpu.TextureSampleType.float,
                                  wgpu.TextureViewDimension.d2_array),
             "filterable": (wgpu.TextureSampleType.float, wgpu.TextureViewDimension.d2),
             "filterable_3d": (wgpu.TextureSampleType.float, wgpu.TextureViewDimension.d3),
             "depth": (wgpu.TextureSampleType.depth, wgpu.TextureViewDimension.d2),
             "depth_array": (wgpu.TextureSampleType.depth, wgpu.TextureViewDimension.d2_array)}
_SAMPLERS = {"sampler": wgpu.SamplerBindingType.filtering,
             "nonfiltering_sampler": wgpu.SamplerBindingType.non_filtering,
             "comparison_sampler": wgpu.SamplerBindingType.comparison}
#: Every kind :func:`bind_group_layout` accepts.
#: Write-only storage textures: (format, view dimension).
_STORAGE = {"storage_rgba32float": (wgpu.TextureFormat.rgba32float,
                                    wgpu.TextureViewDimension.d2),
            "storage_rgba16float_array": (wgpu.TextureFormat.rgba16float,
                                          wgpu.TextureViewDimension.d2_array)}
BINDING_KINDS = (*_BUFFERS, *_TEXTURES, *_STORAGE, *_SAMPLERS)


def _entry(binding: int, kind: str) -> dict:
    visible = {"binding": binding, "visibility": wgpu.ShaderStage.COMPUTE}
    if kind in _TEXTURES:
        sample_type, dimension = _TEXTURES[kind]
        return {**visible, "texture": {"sample_type": sample_type, "view_dimension": dimension}}
    if kind in _STORAGE:
        fmt, dimension = _STORAGE[kind]
        return {**visible, "storage_texture": {"access": wgpu.StorageTextureAccess.write_only,
                                               "format": fmt, "view_dimension": dimension}}
    if kind in _SAMPLERS:
        return {**visible, "sampler": {"type": _SAMPLERS[kind]}}
    if kind in _BUFFERS:
        return {**visible, "buffer": {"type": _BUFFERS[kind]}}
    raise ValueError(f"unknown binding kind {kind!r} for binding {binding}; accepted: "
                     + ", ".join(BINDING_KINDS))


def bind_group_layout(device, bindings):
    """Compute-stage layout for ``bindings``: {binding: kind}.

    Kinds: ``"uniform"``, ``"read"`` / ``"write"`` (storage buffers),
    ``"float"`` / ``"uint"`` (unfilterable 2-D textures of that sample type),
    ``"filterable"`` (2-D filterable float), ``"float_array"`` /
    ``"filterable_array"`` (2-D array textures, unfilterable / filterable
    float), ``"filterable_3d"`` (a 3-D filterable float texture), ``"depth"`` / ``"depth_array"`` (a 2-D depth texture, or an array of them), ``"storage_rgba32float"``, ``"storage_rgba16float_array"`` (write-only
    storage texture),
    ``"sampler"`` / ``"nonfiltering_sampler"`` / ``"comparison_sampler"``.
    """
    return device.create_bind_group_layout(entries=[_entry(b, k)
                                                    for b, k in sorted(bindings.items())])


def bind_group_entries(resources) -> list:
    """Bind-group entries for {binding: buffer, texture, texture view or sampler}
    (whole buffers, default texture views)."""
    out = []
    for b, r in sorted(resources.items()):
        if isinstance(r, wgpu.GPUTexture):
            out.append({"binding": b, "resource": r.create_view()})
        elif isinstance(r, (wgpu.GPUSampler, wgpu.GPUTextureView)):
            out.append({"binding": b, "resource": r})
        else:
            out.append({"binding": b, "resource": {"buffer": r, "offset": 0, "size": r.size}})
    return out
