"""Loading user meshes (OBJ, PLY, glTF/GLB, STL, OFF) with trimesh.

Convention: a loaded file is taken to be in **metres, in world coordinates,
y up**, with the water surface at y = 0 (glTF's own convention is metres and
y up; OBJ/PLY/STL carry no units, so metres are assumed). Node transforms in
the file are baked into the vertices. A model authored elsewhere (at the
origin, in centimetres, ...) can be put in front of a camera with
:func:`place_in_front`, which scales and moves it and returns a scene with a
camera.

Colours: a texture image (sRGB-encoded, as in OBJ/MTL and glTF) is decoded
to linear RGB; glTF's ``baseColorFactor`` and an MTL ``Kd`` are reflectances
and are taken as linear; PLY/OBJ vertex colours and face colours (8-bit,
sRGB-encoded by habit of scanners and viewers) are decoded to linear.

Normal maps: glTF's ``normalTexture`` and an MTL ``norm`` map (or a
``map_Bump``/``bump`` map that is a normal map, as Blender's OBJ exporter
writes them: mean colour near (0.5, 0.5, 1)) become the mesh's tangent-space
normal map (:func:`aquaspec.scene.texture.decode_normal_map`; glTF's
``normalTexture.scale`` is not kept by trimesh and taken as 1). A bump map
that is a height map is not used (its height unit is not defined) and is
reported as ignored.

What each material of the file held is reported in ``Scene.info["materials"]``
(one entry per mesh: base colour texture size and factor, normal map,
glTF ``metallicFactor``/``roughnessFactor`` with the defaults of glTF 2.0
(1.0 each) when absent, and whether a metallic-roughness texture was given):
only the diffuse part (the base colour) is rendered, the rest is reported
so that a user sees what was dropped.
"""

from __future__ import annotations

import os

import numpy as np

from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.srgb import srgb_decode
from aquaspec.errors import AquaspecError
from aquaspec.io.limits import check_file_size
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene, image_to_linear_rgb
from aquaspec.scene.texture import decode_normal_map

#: File suffixes :func:`load_mesh` accepts.
MESH_FORMATS = (".obj", ".ply", ".gltf", ".glb", ".stl", ".off")

#: Albedo of meshes whose file gives no colour (a mid grey).
DEFAULT_ALBEDO = (0.5, 0.5, 0.5)


def rgb_material(rgb, name: str):
    """A reflectance object for a linear albedo triple (via aquaspec.colour.reflectance)."""
    return Reflectance.from_rgb(tuple(float(c) for c in rgb), name=name)


def _check_albedo(albedo):
    a = np.asarray(albedo, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
        raise AquaspecError(f"albedo {albedo!r} must be a linear RGB triple in [0, 1]")
    return a


def _formats_text():
    return ", ".join(MESH_FORMATS)


def _texture_of(material):
    """(image, linear colour factor) of a trimesh material; either may be None.

    glTF multiplies its base-colour texture by ``baseColorFactor`` (glTF 2.0
    specification, "metallic-roughness material"); for MTL the texture is
    used alone, as common viewers do, and ``Kd`` only colours untextured
    meshes.
    """
    pbr_image = getattr(material, "baseColorTexture", None)
    if hasattr(material, "baseColorFactor"):
        factor = material.baseColorFactor
        image = pbr_image
    else:
        factor = getattr(material, "diffuse", None)
        image = getattr(material, "image", None)
    factor = None if factor is None else np.asarray(factor, dtype=float)[:3] / 255.0
    return image, factor


#: Largest distance of a bump map's mean colour from (0.5, 0.5, 1) for it to
#: be taken as a normal map rather than a height map.
NORMAL_MAP_MEAN_TOL = 0.15


def _image_size(image):
    return None if image is None else [int(image.size[0]), int(image.size[1])]


def _obj_map(material, keys, base_dir):
    """The PIL image an MTL statement (``norm``, ``map_bump``, ...) names, or None
    (trimesh keeps the statements it does not know as lists of words)."""
    from PIL import Image  # deferred: as trimesh, only loading a mesh needs it

    kwargs = getattr(material, "kwargs", None) or {}
    for key in keys:
        words = kwargs.get(key)
        if not words:
            continue
        name = words[-1] if isinstance(words, (list, tuple)) else str(words)
        path = os.path.join(base_dir, name)
        if os.path.isfile(path):
            with Image.open(path) as img:
                return key, img.convert("RGB")
    return None, None


def _normal_map_of(material, base_dir, info):
    """The decoded normal map of a trimesh material, or None; fills ``info``."""
    image = getattr(material, "normalTexture", None)
    if image is not None:
        info["normal_map"] = {"source": "glTF normalTexture", "size": _image_size(image)}
        return decode_normal_map(np.asarray(image.convert("RGB")), what="glTF normalTexture")
    key, image = _obj_map(material, ("norm", "map_bump", "bump"), base_dir)
    if image is None:
        return None
    rgb = np.asarray(image, dtype=np.float64) / 255.0
    mean = rgb.reshape(-1, 3).mean(axis=0)
    if key != "norm" and np.abs(mean - [0.5, 0.5, 1.0]).max() > NORMAL_MAP_MEAN_TOL:
        info["ignored"] = info.get("ignored", []) + [f"MTL {key} (a height map)"]
        return None
    info["normal_map"] = {"source": f"MTL {key}", "size": _image_size(image)}
    return decode_normal_map(np.asarray(image), what=f"MTL {key} map")


def _pbr_info(material, info):
    """glTF metallic-roughness parameters (reported, not rendered)."""
    if not hasattr(material, "baseColorFactor"):
        return
    metallic = getattr(material, "metallicFactor", None)
    roughness = getattr(material, "roughnessFactor", None)
    info["metallic_factor"] = 1.0 if metallic is None else float(metallic)
    info["roughness_factor"] = 1.0 if roughness is None else float(roughness)
    mr = getattr(material, "metallicRoughnessTexture", None)
    info["metallic_roughness_texture"] = _image_size(mr)
    info["rendered"] = "base colour only (Lambertian); metallic-roughness reported, not used"


def _mesh_from_trimesh(geom, transform, name, scene: Scene, albedo, base_dir=""):
    vertices = np.asarray(geom.vertices, dtype=float)
    faces = np.asarray(geom.faces, dtype=np.int64)
    normals = np.asarray(geom.vertex_normals, dtype=float)
    # Degenerate faces can leave a vertex with a zero normal; recompute there.
    if not np.all(np.linalg.norm(normals, axis=1) > 0):
        normals = None
    visual = getattr(geom, "visual", None)
    kind = getattr(visual, "kind", None)
    kwargs = {}
    colour = factor = None
    info = {"mesh": name}
    material = getattr(visual, "material", None)
    uv = getattr(visual, "uv", None)
    has_uv = uv is not None and len(uv) == len(vertices)
    if material is not None:
        info["material"] = str(getattr(material, "name", None) or "")
        _pbr_info(material, info)
        if has_uv:
            nm = _normal_map_of(material, base_dir, info)
            if nm is not None:
                kwargs.update(uv=np.asarray(uv, dtype=float), normal_map=nm)
    if albedo is not None:
        colour = albedo
    elif kind == "texture":
        image, factor = _texture_of(material)
        if image is not None and has_uv:
            tex = image_to_linear_rgb(np.asarray(image.convert("RGB")), is_srgb=True,
                                      what=f"texture of {name!r}")
            if factor is not None and hasattr(material, "baseColorFactor"):
                tex = tex * factor.astype(np.float32)
            kwargs.update(uv=np.asarray(uv, dtype=float), texture=tex)
            info["base_colour_texture"] = _image_size(image)
        else:
            colour = factor
    elif kind == "vertex":
        kwargs["vertex_rgb"] = srgb_decode(np.asarray(visual.vertex_colors)[:, :3] / 255.0)
        info["vertex_colours"] = True
    elif kind == "face":
        # Faceted per-face colours: split vertices so each face owns its colour.
        fc = srgb_decode(np.asarray(visual.face_colors)[:, :3] / 255.0)
        idx = faces.reshape(-1)
        scene.info.setdefault("materials", []).append({**info, "face_colours": True})
        return Mesh(vertices[idx], np.arange(len(idx)).reshape(-1, 3),
                    None if normals is None else normals[idx],
                    vertex_rgb=np.repeat(fc, 3, axis=0), name=name).transformed(transform)
    if "texture" not in kwargs and "vertex_rgb" not in kwargs:
        colour = DEFAULT_ALBEDO if colour is None else colour
        kwargs["material"] = scene.add_material(rgb_material(colour, name))
        info["albedo_linear_rgb"] = [float(c) for c in colour]
    elif colour is None and "texture" in kwargs and factor is not None:
        info["base_colour_factor"] = [float(c) for c in factor]
    scene.info.setdefault("materials", []).append(info)
    return Mesh(vertices, faces, normals, name=name, **kwargs).transformed(transform)


def load_mesh(path, *, albedo=None) -> Scene:
    """Load a mesh file into a :class:`Scene` (metres, world coordinates, y up).

    Parameters
    ----------
    path : str or os.PathLike
        An OBJ, PLY, glTF/GLB, STL or OFF file. All triangle meshes in the
        file are loaded, with their node transforms applied.
    albedo : (3,) float, optional
        A linear RGB albedo in [0, 1] that replaces every colour and texture
        in the file.

    Returns
    -------
    Scene
        One :class:`Mesh` per geometry; textured and vertex-coloured meshes
        are per-pixel, the others get a material built from their colour
        (:data:`DEFAULT_ALBEDO` when the file gives none). No camera is set:
        see :func:`place_in_front`.

    Raises
    ------
    AquaspecError
        Missing file, unsupported suffix, a file over the size ceiling of
        :mod:`aquaspec.io.limits`, unreadable or corrupt file, or a file
        without triangles; the message names the path and the formats.
    """
    import trimesh  # deferred: trimesh takes about 0.9 s to import; only loading a mesh needs it

    path = os.fspath(path)
    if albedo is not None:
        albedo = _check_albedo(albedo)
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in MESH_FORMATS:
        raise AquaspecError(f"mesh file {path!r} has suffix {suffix!r}; accepted formats: "
                            f"{_formats_text()}")
    if not os.path.isfile(path):
        raise AquaspecError(f"mesh file {path!r} does not exist; accepted formats: "
                            f"{_formats_text()}")
    check_file_size(path, "mesh", "mesh file")
    try:
        # process=False keeps the file's vertex split (hard edges keep their
        # own normals) instead of merging duplicate vertices.
        loaded = trimesh.load(path, force="scene", process=False)
    except Exception as exc:  # trimesh raises many types for corrupt files
        raise AquaspecError(f"could not read mesh file {path!r} ({type(exc).__name__}: "
                            f"{exc}); accepted formats: {_formats_text()}") from exc
    scene = Scene()
    for node in loaded.graph.nodes_geometry:
        transform, geom_name = loaded.graph[node]
        geom = loaded.geometry.get(geom_name)
        faces = getattr(geom, "faces", None)
        if faces is None or len(faces) == 0:
            continue
        scene.add(_mesh_from_trimesh(geom, transform, str(node), scene, albedo,
                                     os.path.dirname(os.path.abspath(path))))
    if not scene.meshes:
        raise AquaspecError(f"mesh file {path!r} contains no triangles; accepted formats "
                            f"with triangle meshes: {_formats_text()}")
    return scene


def place_in_front(scene: Scene, *, depth_m: float, distance_m: float = 3.0,
                   size_m: float | None = None, width: int = 1280, height: int = 720,
                   fov_y_deg: float = 60.0) -> Scene:
    """Move (and optionally scale) a scene in front of a camera at a depth.

    The camera is put at ``(0, -depth_m, 0)`` looking along -z; the scene's
    bounding-box centre is moved to ``distance_m`` in front of it, at the
    camera's depth. With ``size_m`` the scene is first scaled uniformly so
    that its largest bounding-box side is ``size_m`` metres.

    Returns
    -------
    Scene
        A new scene (same materials) whose ``camera`` is that camera.

    Raises
    ------
    AquaspecError
        Bad depth, distance or size, or when the placed object would reach
        above the water surface (y > 0).
    """
    for name, v in (("depth_m", depth_m), ("distance_m", distance_m)):
        if not (np.isfinite(v) and v >= 0):
            raise AquaspecError(f"{name}={v!r} must be a finite number >= 0")
    if size_m is not None and not (np.isfinite(size_m) and size_m > 0):
        raise AquaspecError(f"size_m={size_m!r} must be a positive number of metres")
    lo, hi = scene.bounds()
    scale = 1.0
    if size_m is not None:
        extent = float(np.max(hi - lo))
        if extent <= 0:
            raise AquaspecError("scene has zero size; it cannot be scaled to size_m")
        scale = size_m / extent
    centre = 0.5 * (lo + hi)
    target = np.array([0.0, -depth_m, -distance_m])
    m = np.eye(4)
    m[:3, :3] *= scale
    m[:3, 3] = target - scale * centre
    placed = scene.transformed(m)
    top = placed.bounds()[1, 1]
    if top > 0:
        raise AquaspecError(f"placed at depth {depth_m} m the object reaches {top:.3g} m "
                            "above the water surface; use a larger depth_m or a smaller size_m")
    placed.camera = Camera.look_at((0.0, -depth_m, 0.0), target, width=width, height=height,
                                   fov_y_deg=fov_y_deg)
    return placed
