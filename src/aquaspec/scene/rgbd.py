"""G-buffers from RGB-D images (a photograph plus a depth map).

The camera sits at ``(0, -camera_depth_m, 0)`` (metres, y up, water surface
at y = 0), looking along ``forward`` (default -z) with the given pinhole
intrinsics ``(fx, fy, cx, cy)`` in pixels (image y down, pixel centres at
``j + 0.5, i + 0.5`` as in :mod:`aquaspec.scene.camera`).

The depth map is the **metric z-depth** along the optical axis, which is what
depth cameras (Kinect, RealSense, ZED) and monocular depth estimators give,
not the distance along each pixel's ray; it is converted to the G-buffer's
distance ``S = z / (d . forward)`` with ``d`` the pixel's unit ray.

Normals come from the back-projected points by finite differences: along
each image axis the one-sided difference (forward or backward) with the
smaller step is used, so a pixel on a depth edge takes its tangent from its
own surface instead of straddling the edge; border pixels use the one side
they have. Where the two tangents are parallel (no surface information) the
normal faces the camera.

The photograph's colour becomes per-pixel reflectance: the linear RGB is
fitted to Jakob-Hanika sigmoid coefficients
(:func:`aquaspec.colour.reflectance.fit_sigmoid_image`), and every pixel's material
is :data:`aquaspec.scene.gbuffer.PER_PIXEL`. Note that an underwater photograph's
colours are not albedos (the water has already attenuated them); use a
colour-corrected or in-air image for physically meaningful results.
"""

from __future__ import annotations


import numpy as np
from PIL import Image

from aquaspec.colour.reflectance import fit_sigmoid_image
from aquaspec.errors import AquaspecError
from aquaspec.io.exr import openexr
from aquaspec.io.limits import check_input_file
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.scene.mesh import image_to_linear_rgb

#: Colour image suffixes :func:`load_rgbd` reads.
IMAGE_FORMATS = (".png", ".jpg", ".jpeg")
#: Depth file suffixes: 16-bit PNG in millimetres, NumPy .npy in metres, OpenEXR in metres.
DEPTH_FORMATS = (".png", ".npy", ".exr")
#: Channels tried, in order, when reading a depth EXR.
EXR_DEPTH_CHANNELS = ("Z", "depth", "Y", "R")


def _check_intrinsics(intrinsics):
    try:
        vals = [float(v) for v in intrinsics]
    except (TypeError, ValueError):
        vals = None
    if vals is None or len(vals) != 4 or not all(np.isfinite(vals)):
        raise AquaspecError(f"intrinsics {intrinsics!r} must be four finite numbers "
                            "(fx, fy, cx, cy) in pixels")
    fx, fy, cx, cy = vals
    if fx <= 0 or fy <= 0:
        raise AquaspecError(f"intrinsics {intrinsics!r}: focal lengths fx={fx}, fy={fy} "
                            "must be positive numbers of pixels")
    return fx, fy, cx, cy


def check_depth_map(depth_m, what: str = "depth map") -> np.ndarray:
    """A (H, W) depth map as float64; every value must be finite and > 0.

    Raises
    ------
    AquaspecError
        Naming how many pixels are NaN, infinite, zero or negative and the
        first one's row and column.
    """
    d = np.asarray(depth_m)
    if d.ndim == 3 and d.shape[2] == 1:
        d = d[..., 0]
    if d.ndim != 2 or d.size == 0:
        raise AquaspecError(f"{what} has shape {d.shape}; expected (H, W)")
    if not (np.issubdtype(d.dtype, np.floating) or np.issubdtype(d.dtype, np.integer)):
        raise AquaspecError(f"{what} has dtype {d.dtype}; expected numbers in metres")
    d = d.astype(np.float64)
    nan, inf = np.isnan(d), np.isinf(d)
    nonpos = ~nan & (d <= 0)
    bad = nan | inf | nonpos
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise AquaspecError(
            f"{what} has {int(bad.sum())} invalid pixels ({int(nan.sum())} NaN, "
            f"{int(inf.sum())} infinite, {int(nonpos.sum())} zero or negative); the first "
            f"is at row {i}, column {j} (value {d[i, j]!r}). Depth must be finite and > 0 "
            "metres everywhere: fill or crop holes first")
    return d


def _holes_as_nan(depth_m, what: str) -> np.ndarray:
    """A (H, W) depth map as float64 with its non-finite and non-positive values NaN."""
    d = np.asarray(depth_m)
    if not (np.issubdtype(d.dtype, np.floating) or np.issubdtype(d.dtype, np.integer)):
        check_depth_map(d, what)        # refuses the dtype, naming it
    d = d.astype(np.float64)
    valid = np.isfinite(d) & (d > 0)
    shape = check_depth_map(np.where(valid, d, 1.0), what).shape   # the shape, holes aside
    return np.where(valid, d, np.nan).reshape(shape)


def _tangent(points, axis):
    """Finite-difference tangent along ``axis``: the shorter one-sided step."""
    p = np.moveaxis(points, axis, 0)
    fwd = np.empty_like(p)
    bwd = np.empty_like(p)
    fwd[:-1] = p[1:] - p[:-1]
    fwd[-1] = p[-1] - p[-2]
    bwd[1:] = p[1:] - p[:-1]
    bwd[0] = p[1] - p[0]
    use_fwd = np.linalg.norm(fwd, axis=-1) <= np.linalg.norm(bwd, axis=-1)
    return np.moveaxis(np.where(use_fwd[..., None], fwd, bwd), 0, axis)


def normals_from_points(points, view_dirs) -> np.ndarray:
    """Unit normals (H, W, 3) of back-projected points, facing the camera.

    ``points`` (H, W, 3) world positions, ``view_dirs`` (H, W, 3) unit rays
    from the camera; see the module docstring for the differencing rule.
    """
    n = np.cross(_tangent(points, 1), _tangent(points, 0))
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    n = np.where(length > 0, n / np.where(length > 0, length, 1.0), -view_dirs)
    away = np.einsum("ijk,ijk->ij", n, view_dirs) > 0
    return np.where(away[..., None], -n, n)


def gbuffer_from_rgbd(rgb, depth_m, intrinsics, *, camera_depth_m: float,
                      rgb_is_srgb: bool = True, forward=(0.0, 0.0, -1.0),
                      up=(0.0, 1.0, 0.0)) -> GBuffer:
    """A G-buffer from a colour image and its metric z-depth map.

    Parameters
    ----------
    rgb : (H, W, 3) array
        uint8, uint16 or float in [0, 1] (alpha, if any, is dropped).
    depth_m : (H, W) array
        Z-depth along the optical axis in metres (finite, > 0).
    intrinsics : (fx, fy, cx, cy)
        Pinhole intrinsics in pixels.
    camera_depth_m : float
        Depth of the camera below the water surface, metres (>= 0).
    rgb_is_srgb : bool
        Decode the sRGB transfer curve (True for ordinary photographs).
    forward, up : (3,) arrays
        Camera orientation in world space (default: looking along -z, level).

    Returns
    -------
    GBuffer
        ``distance`` along each pixel's ray, ``normal`` from the depth map,
        ``material`` PER_PIXEL everywhere, ``sigmoid`` the fitted
        coefficients; no shared materials.

    Raises
    ------
    AquaspecError
        Images of different sizes, invalid depth values (with how many and
        where), bad intrinsics or camera depth, images smaller than 2x2.
    """
    fx, fy, cx, cy = _check_intrinsics(intrinsics)
    if isinstance(camera_depth_m, bool) or not isinstance(camera_depth_m, (int, float, np.number)) \
            or not np.isfinite(camera_depth_m) or camera_depth_m < 0:
        raise AquaspecError(f"camera_depth_m={camera_depth_m!r}; give a finite depth in "
                            "metres >= 0 (the water surface is at 0)")
    colour = image_to_linear_rgb(rgb, is_srgb=rgb_is_srgb, what="RGB image")
    depth_arr = np.asarray(depth_m)
    if depth_arr.shape[:2] != colour.shape[:2]:
        raise AquaspecError(f"RGB image is {colour.shape[1]}x{colour.shape[0]} (WxH) but the "
                            f"depth map has shape {depth_arr.shape}; they must be the same size")
    depth = check_depth_map(depth_arr)
    h, w = depth.shape
    if h < 2 or w < 2:
        raise AquaspecError(f"RGB-D image is {w}x{h}; normals need at least 2x2 pixels")
    camera = Camera((0.0, -float(camera_depth_m), 0.0), forward, up, w, h, fx, fy, cx, cy)
    dirs = camera.ray_directions()
    distance = depth / (dirs @ camera.forward)
    points = camera.position + dirs * distance[..., None]
    sigmoid = fit_sigmoid_image(colour)
    return GBuffer(camera, distance, normals_from_points(points, dirs),
                   np.full((h, w), PER_PIXEL, dtype=np.uint32), sigmoid, [])


def _read_depth(path, suffix):
    if suffix == ".npy":
        try:
            # Memory-mapped first: a header claiming more data than the file
            # holds fails here instead of allocating it.
            return np.array(np.load(path, mmap_mode="r", allow_pickle=False))
        except Exception as exc:
            raise AquaspecError(f"could not read depth file {path!r} as .npy ({exc})") from exc
    if suffix == ".exr":
        exr = openexr()
        if exr is None:
            raise AquaspecError("reading EXR depth needs the OpenEXR package: "
                                "pip install 'aquaspec[exr]'")
        try:
            channels = exr.File(path).channels()
        except Exception as exc:
            raise AquaspecError(f"could not read depth file {path!r} as OpenEXR ({exc})") from exc
        for name in EXR_DEPTH_CHANNELS:
            if name in channels:
                return np.asarray(channels[name].pixels)
        if len(channels) == 1:
            px = np.asarray(next(iter(channels.values())).pixels)
            if px.ndim == 2:
                return px
        raise AquaspecError(f"depth EXR {path!r} has channels {sorted(channels)}; expected one "
                            f"of {', '.join(EXR_DEPTH_CHANNELS)} or a single channel")
    try:
        with Image.open(path) as im:
            mode = im.mode
            arr = np.array(im)
    except Exception as exc:
        raise AquaspecError(f"could not read depth file {path!r} as PNG ({exc})") from exc
    if mode not in ("I;16", "I;16B", "I") or arr.ndim != 2:
        raise AquaspecError(f"depth PNG {path!r} has mode {mode!r}; expected a single-channel "
                            "16-bit PNG in millimetres")
    return arr.astype(np.float64) * 1e-3


def load_rgbd(image_path, depth_path, *, allow_holes: bool = False):
    """Read a colour image and a depth map from files.

    Parameters
    ----------
    image_path : path
        PNG or JPEG colour image (sRGB-encoded).
    depth_path : path
        A single-channel 16-bit PNG in **millimetres** (the usual depth-camera
        format), a ``.npy`` array in metres, or an OpenEXR file in metres
        (channel Z, depth, Y or R, or its only channel).
    allow_holes : bool
        Return depth values that are NaN, infinite, zero or negative (holes:
        no reading) as NaN instead of refusing them; the caller fills or
        masks them (``aquaspec synth``).

    Returns
    -------
    rgb : (H, W, 3) uint8 array, or (H, W) uint16 for a 16-bit grey image
    depth_m : (H, W) float64 array, metres
        Checked: same size as the image, every value finite and > 0 (or NaN
        with ``allow_holes``).
    """
    image_path, _ = check_input_file(image_path, IMAGE_FORMATS, "image file", "image")
    depth_path, suffix = check_input_file(depth_path, DEPTH_FORMATS, "depth file", "depth")
    try:
        with Image.open(image_path) as im:
            rgb = np.array(im.convert("RGB") if im.mode not in ("RGB", "I;16") else im)
    except Exception as exc:
        raise AquaspecError(f"could not read image file {image_path!r} ({exc}); accepted: "
                            f"{', '.join(IMAGE_FORMATS)}") from exc
    what = f"depth map {depth_path!r}"
    raw = _read_depth(depth_path, suffix)
    depth = _holes_as_nan(raw, what) if allow_holes else check_depth_map(raw, what=what)
    if depth.shape != rgb.shape[:2]:
        raise AquaspecError(f"image {image_path!r} is {rgb.shape[1]}x{rgb.shape[0]} but depth "
                            f"{depth_path!r} is {depth.shape[1]}x{depth.shape[0]}; they must "
                            "be the same size")
    return rgb, depth
