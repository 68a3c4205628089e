"""Uniform layouts defined once, in Python.

A :class:`UniformLayout` lists named fields with WGSL types. From it come the
NumPy structured dtype (with WGSL's alignment and padding rules for uniform
buffers) used to fill the buffer, and the WGSL ``struct`` declaration pasted
into the shader, so the two cannot drift apart.
"""

from __future__ import annotations

import numpy as np

# WGSL type -> (alignment, size, numpy base type, element count)
_TYPES = {
    "f32": (4, 4, np.float32, 1),
    "u32": (4, 4, np.uint32, 1),
    "i32": (4, 4, np.int32, 1),
    "vec2<f32>": (8, 8, np.float32, 2),
    "vec3<f32>": (16, 12, np.float32, 3),
    "vec4<f32>": (16, 16, np.float32, 4),
    "vec2<u32>": (8, 8, np.uint32, 2),
    "vec4<u32>": (16, 16, np.uint32, 4),
    "mat4x4<f32>": (16, 64, np.float32, 16),
}


class UniformLayout:
    """A WGSL uniform struct and its matching NumPy dtype.

    Parameters
    ----------
    name : str
        The WGSL struct name.
    fields : list of (str, str)
        ``(field_name, wgsl_type)`` in order; types from ``f32, u32, i32,
        vec2/3/4<f32>, vec2/4<u32>, mat4x4<f32>``.
    """

    def __init__(self, name: str, fields):
        self.name = name
        self.fields = list(fields)
        names, formats, offsets = [], [], []
        offset, align_max = 0, 16
        for fname, wtype in self.fields:
            if wtype not in _TYPES:
                raise ValueError(f"unsupported WGSL type {wtype!r} for field {fname!r}; "
                                 f"supported: {', '.join(_TYPES)}")
            align, size, base, count = _TYPES[wtype]
            offset = -(-offset // align) * align
            names.append(fname)
            formats.append((base, (count,)) if count > 1 else base)
            offsets.append(offset)
            offset += size
        self.size = -(-offset // align_max) * align_max
        self.dtype = np.dtype({"names": names, "formats": formats,
                               "offsets": offsets, "itemsize": self.size})

    def wgsl(self) -> str:
        """The WGSL ``struct`` declaration."""
        body = "\n".join(f"    {n}: {t}," for n, t in self.fields)
        return f"struct {self.name} {{\n{body}\n}};\n"

    def pack(self, **values) -> bytes:
        """Bytes of one struct; every field must be given."""
        missing = [n for n, _ in self.fields if n not in values]
        extra = [k for k in values if k not in self.dtype.names]
        if missing or extra:
            raise KeyError(f"{self.name}: missing fields {missing}, unknown fields {extra}")
        arr = np.zeros(1, dtype=self.dtype)
        for k, v in values.items():
            arr[k] = v
        return arr.tobytes()
