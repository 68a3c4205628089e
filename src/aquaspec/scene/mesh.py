"""Triangle meshes and scenes: what the geometry pass rasterises.

Conventions (the same as the rest of aquaspec): world units are metres, y is
up, the water surface is the plane y = 0, so everything under water has
y < 0. A :class:`Mesh` is already in world coordinates (no scene graph: the
loader bakes node transforms in).

A mesh's reflectance is either one material (``material``: an index into
``Scene.materials``), or varies over its surface: a texture sampled with
per-vertex UVs, or per-vertex colours. Those colours are stored as *linear*
RGB in [0, 1]; the geometry pass turns them into Jakob-Hanika sigmoid
coefficients once per texel or vertex (:meth:`Mesh.texture_sigmoid`) and
interpolates the coefficients. A texture is mip-mapped (the chain is built
in linear RGB and each level fitted: :meth:`Mesh.texture_mips`). Any mesh
with ``uv`` can also carry a tangent-space normal map (``normal_map``,
:mod:`aquaspec.scene.texture`), which perturbs the shading normal.

``Scene.materials`` holds reflectance objects. Only a duck type is assumed
here: an object with a ``name`` and either ``rgb`` (a linear albedo triple
in [0, 1]) or ``wavelength_nm``/``values`` (a measured spectrum), as
:class:`aquaspec.colour.reflectance.Reflectance` provides.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from aquaspec.colour.reflectance import fit_sigmoid_image
from aquaspec.colour.srgb import srgb_decode
from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import Camera
from aquaspec.scene.texture import mip_chain, quantise_unorm8, vertex_tangents


def image_to_linear_rgb(image, *, is_srgb: bool = True, what: str = "image") -> np.ndarray:
    """An (H, W), (H, W, 3) or (H, W, 4) image as linear RGB float32 in [0, 1].

    Integer images are scaled by their type's maximum (uint8: 255, uint16:
    65535); float images must already be in [0, 1]. Alpha is dropped and a
    grey image is repeated into three channels.
    """
    img = np.asarray(image)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=-1)
    if img.ndim != 3 or img.shape[2] not in (3, 4) or img.shape[0] == 0 or img.shape[1] == 0:
        raise AquaspecError(f"{what} has shape {img.shape}; accepted: (H, W), (H, W, 3) "
                            "or (H, W, 4) with H, W >= 1")
    img = img[..., :3]
    if img.dtype in (np.uint8, np.uint16):
        x = img.astype(np.float64) / np.iinfo(img.dtype).max
    elif np.issubdtype(img.dtype, np.floating):
        x = img.astype(np.float64)
        bad = ~np.isfinite(x) | (x < 0) | (x > 1)
        if bad.any():
            i, j, _ = np.argwhere(bad)[0]
            raise AquaspecError(f"{what} has {int(bad.any(axis=-1).sum())} pixels outside "
                                f"[0, 1] or not finite (first at row {i}, column {j}: "
                                f"{img[i, j].tolist()}); float images must be in [0, 1]")
    else:
        raise AquaspecError(f"{what} has dtype {img.dtype}; accepted: uint8, uint16 or "
                            "float in [0, 1]")
    return (srgb_decode(x) if is_srgb else x).astype(np.float32)


def _as_array(x, name, shape_tail, dtype):
    a = np.asarray(x, dtype=dtype)
    if a.ndim != 1 + len(shape_tail) or a.shape[1:] != shape_tail:
        raise AquaspecError(f"mesh {name} has shape {a.shape}; expected (N, "
                            f"{', '.join(map(str, shape_tail))})")
    return a


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit normals of triangles (counter-clockwise winding), shape (F, 3).

    Degenerate triangles get a zero normal.
    """
    tri = vertices[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted vertex normals, shape (V, 3) (smooth shading)."""
    tri = vertices[faces]
    # The un-normalised cross product is twice the area times the normal,
    # so summing it weights each face by its area.
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    acc = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(acc, faces[:, k], n)
    length = np.linalg.norm(acc, axis=1, keepdims=True)
    # A vertex used only by degenerate faces gets an arbitrary unit normal
    # (never a zero or NaN normal in the G-buffer).
    out = np.tile(np.array([0.0, 1.0, 0.0]), (len(vertices), 1))
    np.divide(acc, length, out=out, where=length > 0)
    return out


@dataclass
class Mesh:
    """A triangle mesh in world coordinates (metres, y up).

    Parameters
    ----------
    vertices : (V, 3) float
        Vertex positions in metres.
    faces : (F, 3) int
        Vertex indices of each triangle.
    normals : (V, 3) float, optional
        Unit per-vertex normals; computed (area-weighted, smooth) when not
        given. Use :meth:`flat` for faceted objects.
    material : int
        Index into ``Scene.materials``; used where the mesh has neither a
        texture nor vertex colours.
    uv : (V, 2) float, optional
        Texture coordinates, origin at the *bottom-left* of the texture
        (OBJ / trimesh convention; the image's row 0 is its top).
    texture : (H, W, 3) float32, optional
        Linear RGB in [0, 1] (decode sRGB images with
        :func:`image_to_linear_rgb`). Needs ``uv``.
    vertex_rgb : (V, 3) float, optional
        Linear per-vertex colours in [0, 1] (scanned meshes), interpolated
        over each triangle.
    name : str
    normal_map : (H, W, 3) float, optional
        Tangent-space unit normals (glTF convention: +x along u, +y along v,
        +z out of the surface; decode images with
        :func:`aquaspec.scene.texture.decode_normal_map`). Needs ``uv``.
    """

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    material: int = 0
    uv: np.ndarray | None = None
    texture: np.ndarray | None = None
    vertex_rgb: np.ndarray | None = None
    name: str = "mesh"
    normal_map: np.ndarray | None = None

    def __post_init__(self):
        self.vertices = _as_array(self.vertices, "vertices", (3,), np.float64)
        if not np.all(np.isfinite(self.vertices)):
            raise AquaspecError(f"mesh {self.name!r} has non-finite vertex positions")
        faces = np.asarray(self.faces)
        if faces.size and not np.issubdtype(faces.dtype, np.integer):
            raise AquaspecError(f"mesh {self.name!r} faces have dtype {faces.dtype}; "
                                "expected integer vertex indices")
        self.faces = _as_array(faces.reshape(-1, 3) if faces.size == 0 else faces,
                               "faces", (3,), np.int64)
        if len(self.faces) == 0:
            raise AquaspecError(f"mesh {self.name!r} has no triangles")
        if self.faces.min() < 0 or self.faces.max() >= len(self.vertices):
            raise AquaspecError(f"mesh {self.name!r} faces index vertices "
                                f"{self.faces.min()}..{self.faces.max()}, but it has "
                                f"{len(self.vertices)} vertices")
        if self.normals is None:
            self.normals = vertex_normals(self.vertices, self.faces)
        else:
            n = _as_array(self.normals, "normals", (3,), np.float64)
            if n.shape != self.vertices.shape:
                raise AquaspecError(f"mesh {self.name!r} has {len(n)} normals for "
                                    f"{len(self.vertices)} vertices")
            length = np.linalg.norm(n, axis=1, keepdims=True)
            if not np.all(np.isfinite(length)) or np.any(length == 0):
                raise AquaspecError(f"mesh {self.name!r} has zero or non-finite normals")
            self.normals = n / length
        if isinstance(self.material, bool) or not isinstance(self.material, (int, np.integer)) \
                or self.material < 0:
            raise AquaspecError(f"mesh {self.name!r} material index {self.material!r}; "
                                "expected an integer >= 0")
        self.material = int(self.material)
        if self.uv is not None:
            self.uv = _as_array(self.uv, "uv", (2,), np.float64)
            if len(self.uv) != len(self.vertices) or not np.all(np.isfinite(self.uv)):
                raise AquaspecError(f"mesh {self.name!r} needs one finite uv per vertex "
                                    f"(got {len(self.uv)} for {len(self.vertices)})")
        if self.texture is not None:
            if self.uv is None:
                raise AquaspecError(f"mesh {self.name!r} has a texture but no uv coordinates")
            self.texture = image_to_linear_rgb(self.texture, is_srgb=False,
                                               what=f"texture of mesh {self.name!r}")
        if self.normal_map is not None:
            if self.uv is None:
                raise AquaspecError(f"mesh {self.name!r} has a normal map but no uv coordinates")
            nm = np.asarray(self.normal_map, dtype=np.float32)
            if nm.ndim != 3 or nm.shape[2] != 3 or min(nm.shape[:2]) < 1 \
                    or not np.all(np.isfinite(nm)):
                raise AquaspecError(f"normal map of mesh {self.name!r} has shape {nm.shape}; "
                                    "expected finite (H, W, 3) tangent-space normals")
            length = np.linalg.norm(nm, axis=-1, keepdims=True)
            if np.any(length < 1e-6) or np.any(nm[..., 2] < 0):
                raise AquaspecError(f"normal map of mesh {self.name!r} must hold non-zero "
                                    "vectors with z >= 0 (decode images with "
                                    "aquaspec.scene.texture.decode_normal_map)")
            self.normal_map = nm / length
        if self.vertex_rgb is not None:
            c = _as_array(self.vertex_rgb, "vertex_rgb", (3,), np.float64)
            if len(c) != len(self.vertices) or not np.all((c >= 0) & (c <= 1)):
                raise AquaspecError(f"mesh {self.name!r} vertex_rgb must be one linear "
                                    "RGB triple in [0, 1] per vertex")
            self.vertex_rgb = c

    @classmethod
    def flat(cls, vertices, faces, **kwargs) -> "Mesh":
        """A faceted mesh: every triangle gets its own vertices and face normal.

        Per-vertex ``uv``/``vertex_rgb`` in ``kwargs`` are split alongside.
        """
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces, dtype=np.int64)
        n = np.repeat(face_normals(v, f), 3, axis=0)
        for key in ("uv", "vertex_rgb"):
            if kwargs.get(key) is not None:
                kwargs[key] = np.asarray(kwargs[key])[f.reshape(-1)]
        return cls(v[f.reshape(-1)], np.arange(3 * len(f)).reshape(-1, 3), n, **kwargs)

    def texture_sigmoid(self) -> np.ndarray:
        """Jakob-Hanika coefficients of every texel, (H, W, 3) float32 (mip level 0)."""
        return self.texture_mips()[0]

    def texture_mips(self) -> list:
        """Jakob-Hanika coefficients of each mip level of the texture, level 0
        first, each (h, w, 3) float32 (cached): the chain is box-filtered in
        linear RGB (:func:`aquaspec.scene.texture.mip_chain`), then every
        level is fitted."""
        cached = getattr(self, "_texture_mips", None)
        if cached is None or cached[0] is not self.texture:
            levels = [fit_sigmoid_image(level).astype(np.float32)
                      for level in mip_chain(self.texture)]
            cached = (self.texture, levels)
            self._texture_mips = cached
        return cached[1]

    def normal_mips(self) -> list:
        """Mip levels of the normal map (averaged vectors, not renormalised),
        each (h, w, 3) float32 (cached), quantised as the GPU stores them
        (8-bit unorm of (n + 1) / 2, :func:`aquaspec.scene.texture.quantise_unorm8`)."""
        cached = getattr(self, "_normal_mips", None)
        if cached is None or cached[0] is not self.normal_map:
            cached = (self.normal_map, [quantise_unorm8(lv).astype(np.float32)
                                        for lv in mip_chain(self.normal_map)])
            self._normal_mips = cached
        return cached[1]

    def tangents(self) -> np.ndarray:
        """Per-vertex unit tangents with handedness (V, 4) from the uv
        (:func:`aquaspec.scene.texture.vertex_tangents`); needs ``uv``."""
        if self.uv is None:
            raise AquaspecError(f"mesh {self.name!r} has no uv coordinates, so no tangents")
        cached = getattr(self, "_tangents", None)
        if cached is None or cached[0] is not self.vertices:
            cached = (self.vertices, vertex_tangents(self.vertices, self.faces, self.normals,
                                                     self.uv))
            self._tangents = cached
        return cached[1]

    def vertex_sigmoid(self) -> np.ndarray:
        """Jakob-Hanika coefficients of the vertex colours, (V, 3) float32 (cached)."""
        cached = getattr(self, "_vertex_sigmoid", None)
        if cached is None or cached[0] is not self.vertex_rgb:
            coeffs = fit_sigmoid_image(self.vertex_rgb[:, None, :])[:, 0, :]
            cached = (self.vertex_rgb, coeffs.astype(np.float32))
            self._vertex_sigmoid = cached
        return cached[1]

    @property
    def per_pixel(self) -> bool:
        """True when the reflectance comes from a texture or vertex colours."""
        return self.texture is not None or self.vertex_rgb is not None

    def transformed(self, matrix) -> "Mesh":
        """A copy moved by a 4x4 affine ``matrix`` (normals by its inverse transpose)."""
        m = np.asarray(matrix, dtype=np.float64)
        if m.shape != (4, 4) or not np.all(np.isfinite(m)):
            raise AquaspecError(f"transform has shape {m.shape}; expected a finite 4x4 matrix")
        lin = m[:3, :3]
        if abs(np.linalg.det(lin)) < 1e-12:
            raise AquaspecError("transform is singular (zero scale)")
        v = self.vertices @ lin.T + m[:3, 3]
        n = self.normals @ np.linalg.inv(lin)
        faces = self.faces
        if np.linalg.det(lin) < 0:
            # A mirror flips the winding; keep counter-clockwise front faces.
            faces = faces[:, ::-1]
        return Mesh(v, faces, n, self.material, self.uv, self.texture, self.vertex_rgb,
                    self.name, self.normal_map)


@dataclass
class Scene:
    """Meshes plus the reflectance objects they index, and an optional camera.

    Parameters
    ----------
    meshes : list of Mesh
    materials : list
        Reflectance objects (see the module docstring); ``Mesh.material``
        indexes this list.
    camera : Camera, optional
        A default viewpoint (the built-in scene and :func:`place_in_front`
        set one).
    seabed : aquaspec.scene.seabed.Seabed, optional
        The flat seabed the light field takes as its lower boundary (the
        built-in scene sets its terrain's); None: deep water below.
    info : dict
        What the scene's source reported, JSON-ready (the loader's
        per-mesh material report, the built-in scene's variant and
        materials); a render's metadata carries it.
    """

    meshes: list = field(default_factory=list)
    materials: list = field(default_factory=list)
    camera: Camera | None = None
    seabed: object = None
    info: dict = field(default_factory=dict)

    def add_material(self, material) -> int:
        """Append a reflectance object and return its index."""
        if not hasattr(material, "name"):
            raise AquaspecError(f"material {material!r} has no name; expected a "
                                "Reflectance-like object")
        self.materials.append(material)
        return len(self.materials) - 1

    def add(self, mesh: Mesh) -> Mesh:
        self.meshes.append(mesh)
        return mesh

    def validate(self):
        """Check that every mesh's material index exists; returns self."""
        if not self.meshes:
            raise AquaspecError("scene has no meshes")
        for m in self.meshes:
            if not m.per_pixel and m.material >= len(self.materials):
                raise AquaspecError(f"mesh {m.name!r} uses material {m.material} but the "
                                    f"scene has {len(self.materials)} materials")
        return self

    @property
    def n_triangles(self) -> int:
        return int(sum(len(m.faces) for m in self.meshes))

    def bounds(self) -> np.ndarray:
        """(2, 3) min and max corner of all vertices, metres."""
        self.validate()
        v = np.concatenate([m.vertices for m in self.meshes])
        return np.stack([v.min(axis=0), v.max(axis=0)])

    def transformed(self, matrix) -> "Scene":
        """A copy with every mesh moved by the 4x4 affine ``matrix`` (camera dropped)."""
        return Scene([m.transformed(matrix) for m in self.meshes], list(self.materials),
                     info=dict(self.info))
