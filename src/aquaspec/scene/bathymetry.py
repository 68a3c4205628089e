"""A seabed from a bathymetry grid: depths on a regular grid become a
height-field mesh the renderer draws from below and from above the sea.

Conventions: metres, y up, the surface ``y = 0``; a grid ``depth_m`` (rows
along +z, columns along +x) of depths *below* the surface (> 0), sample
spacing ``spacing_m``, centred on the point below the origin unless
``origin_xz`` puts its first sample (row 0, column 0) elsewhere.

Files (:func:`load_bathymetry`):

- ``.asc``: an ESRI ASCII grid (the format GEBCO and NOAA's viewers export:
  a header ``ncols``, ``nrows``, ``xllcorner``/``xllcenter``,
  ``yllcorner``/``yllcenter``, ``cellsize``, optional ``NODATA_value``, then
  rows from north to south). Its values are *elevations* (negative below
  sea level), so depth = -value; ``cellsize`` is the spacing (metres: a
  grid in degrees must be projected first).
- ``.npy``: a 2-D float array of depths in metres.
- ``.csv`` / ``.txt``: a 2-D table of depths in metres (comma or white
  space separated).
- ``.png``: a single-channel 16-bit image of depths in millimetres (as
  RGB-D depth maps are).

A grid that cannot be read, holds NaN, infinity or no-data values, or puts
the bottom at or above the surface is refused, naming the file, the value
and where it is.

The light field (plane-parallel) takes the grid's mean depth as its seabed
(:meth:`Bathymetry.seabed`), with the same reflectance: the mesh is what the
camera sees, the flat seabed what the water's light field reflects from
and what is seen beyond the grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.colour.benthic import benthic_reflectance
from aquaspec.errors import AquaspecError
from aquaspec.io.limits import check_input_file
from aquaspec.scene.mesh import Mesh, Scene, vertex_normals
from aquaspec.scene.seabed import Seabed

#: File suffixes :func:`load_bathymetry` reads.
BATHYMETRY_FORMATS = (".asc", ".npy", ".csv", ".txt", ".png")
#: Largest grid side, samples (a 4096 x 4096 grid is 33 M triangles).
MAX_SIDE = 4096
#: ESRI ASCII grid header keys (lower case).
_ASC_KEYS = ("ncols", "nrows", "xllcorner", "yllcorner", "xllcenter", "yllcenter",
             "cellsize", "nodata_value")


@dataclass
class Bathymetry:
    """Depths (m, > 0 below the surface) on a regular grid (module docstring).

    ``depth_m`` (rows, cols) with at least 2 x 2 samples; ``spacing_m`` > 0;
    ``origin_xz``: world (x, z) of sample (0, 0), or None to centre the grid
    on the origin; ``reflectance``: a Reflectance (default: the built-in
    scene's sand, :func:`aquaspec.colour.benthic.benthic_reflectance`);
    ``source``: where it came from (metadata)."""

    depth_m: np.ndarray
    spacing_m: float
    origin_xz: tuple | None = None
    reflectance: object = None
    source: str = "array"

    def __post_init__(self):
        d = np.asarray(self.depth_m)
        if d.ndim != 2 or min(d.shape) < 2 or max(d.shape) > MAX_SIDE:
            raise AquaspecError(f"bathymetry grid of shape {d.shape}; accepted: a 2-D grid of "
                                f"2 to {MAX_SIDE} samples a side")
        if not np.issubdtype(d.dtype, np.number) or np.issubdtype(d.dtype, np.complexfloating):
            raise AquaspecError(f"bathymetry grid of dtype {d.dtype}; accepted: real numbers "
                                "(depths in metres)")
        d = d.astype(np.float64)
        bad = ~np.isfinite(d)
        if bad.any():
            i, j = np.argwhere(bad)[0]
            raise AquaspecError(f"bathymetry {self.source}: {int(bad.sum())} samples are NaN or "
                                f"infinite (no data), the first at row {i}, column {j}; "
                                "accepted: a depth in metres at every sample (fill the gaps "
                                "first)")
        above = d <= 0
        if above.any():
            i, j = np.argwhere(above)[0]
            raise AquaspecError(f"bathymetry {self.source}: the bottom at row {i}, column {j} "
                                f"is {d[i, j]:g} m deep, at or above the surface "
                                f"({int(above.sum())} such samples); accepted: depths > 0 m "
                                "(land and drying banks are not modelled)")
        self.depth_m = d
        s = self.spacing_m
        if isinstance(s, bool) or not isinstance(s, (int, float, np.number)) \
                or not np.isfinite(s) or s <= 0:
            raise AquaspecError(f"bathymetry spacing {s!r}; accepted: a finite spacing > 0 m")
        self.spacing_m = float(s)
        if self.origin_xz is not None:
            o = np.asarray(self.origin_xz, dtype=float)
            if o.shape != (2,) or not np.all(np.isfinite(o)):
                raise AquaspecError(f"bathymetry origin_xz {self.origin_xz!r}; accepted: "
                                    "finite (x, z) in metres, or None (centred)")
        if self.reflectance is None:
            self.reflectance = benthic_reflectance("sand")
        elif not hasattr(self.reflectance, "on_bands"):
            raise AquaspecError(f"bathymetry reflectance {self.reflectance!r}; accepted: a "
                                "Reflectance (aquaspec.colour.reflectance)")

    def origin(self) -> np.ndarray:
        """World (x, z) of sample (0, 0), m."""
        if self.origin_xz is not None:
            return np.asarray(self.origin_xz, dtype=float)
        rows, cols = self.depth_m.shape
        return -0.5 * self.spacing_m * np.array([cols - 1, rows - 1], dtype=float)

    def depth_at(self, x, z) -> np.ndarray:
        """The bottom's depth (m) under world points (x, z), bilinear in the
        grid (clamped at its edges)."""
        x0, z0 = self.origin()
        rows, cols = self.depth_m.shape
        u = np.clip((np.asarray(x, float) - x0) / self.spacing_m, 0, cols - 1)
        v = np.clip((np.asarray(z, float) - z0) / self.spacing_m, 0, rows - 1)
        i0 = np.minimum(np.floor(v).astype(int), rows - 2)
        j0 = np.minimum(np.floor(u).astype(int), cols - 2)
        fu, fv = u - j0, v - i0
        d = self.depth_m
        return ((1 - fv) * ((1 - fu) * d[i0, j0] + fu * d[i0, j0 + 1])
                + fv * ((1 - fu) * d[i0 + 1, j0] + fu * d[i0 + 1, j0 + 1]))

    def seabed(self) -> Seabed:
        """The light field's flat seabed: the grid's mean depth, its reflectance."""
        return Seabed(float(self.depth_m.mean()), self.reflectance)

    def describe(self) -> dict:
        rows, cols = self.depth_m.shape
        return {"source": self.source, "rows": rows, "cols": cols,
                "spacing_m": self.spacing_m, "origin_xz_m": self.origin().tolist(),
                "depth_range_m": [float(self.depth_m.min()), float(self.depth_m.max())],
                "reflectance": getattr(self.reflectance, "name", "?")}


def bathymetry_mesh(bathy: Bathymetry, material: int = 0) -> Mesh:
    """The grid as a height field of triangles facing up (two per cell),
    vertex normals from the faces, of material index ``material``."""
    d = bathy.depth_m
    rows, cols = d.shape
    x0, z0 = bathy.origin()
    xs = x0 + bathy.spacing_m * np.arange(cols)
    zs = z0 + bathy.spacing_m * np.arange(rows)
    gx, gz = np.meshgrid(xs, zs)
    vertices = np.stack([gx, -d, gz], axis=-1).reshape(-1, 3)
    k = np.arange(rows * cols).reshape(rows, cols)
    a, b = k[:-1, :-1].reshape(-1), k[:-1, 1:].reshape(-1)
    c, e = k[1:, :-1].reshape(-1), k[1:, 1:].reshape(-1)
    # Counter-clockwise seen from above (+y): (a, c, b) and (b, c, e).
    faces = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, e], 1)])
    return Mesh(vertices, faces, vertex_normals(vertices, faces), material, name="bathymetry")


def bathymetry_scene(bathy: Bathymetry, camera=None) -> Scene:
    """A scene of the grid's mesh, with the light field's seabed
    (:meth:`Bathymetry.seabed`) and ``camera`` as its default view;
    its info carries the grid's description."""
    scene = Scene([], [bathy.reflectance], camera=camera, seabed=bathy.seabed(),
                  info={"bathymetry": bathy.describe()})
    scene.add(bathymetry_mesh(bathy, 0))
    return scene


def load_bathymetry(path, *, spacing_m: float | None = None, origin_xz=None,
                    reflectance=None) -> Bathymetry:
    """Read a bathymetry grid (module docstring for the formats). ``spacing_m``
    is needed for the formats without one (all but ``.asc``) and overrides
    the ``.asc`` header's ``cellsize`` when given."""
    path, suffix = check_input_file(path, BATHYMETRY_FORMATS, "bathymetry file", "bathymetry")
    if suffix == ".asc":
        depth, cellsize = _read_asc(path)
        spacing_m = cellsize if spacing_m is None else spacing_m
    else:
        if spacing_m is None:
            raise AquaspecError(f"bathymetry file {path!r} has no sample spacing; give one "
                                "(spacing_m=, --bathymetry FILE,SPACING_M)")
        depth = _read_grid(path, suffix)
    return Bathymetry(depth, spacing_m, origin_xz, reflectance, source=path)


def _read_grid(path, suffix) -> np.ndarray:
    try:
        if suffix == ".npy":
            return np.array(np.load(path, mmap_mode="r", allow_pickle=False))
        if suffix in (".csv", ".txt"):
            with open(path, encoding="utf-8") as f:
                text = f.read()
            return np.loadtxt(text.replace(",", " ").splitlines(), ndmin=2)
        from PIL import Image            # deferred: only images need it
        with Image.open(path) as im:
            mode, arr = im.mode, np.array(im)
    except AquaspecError:
        raise
    except Exception as exc:
        raise AquaspecError(f"could not read bathymetry file {path!r} as {suffix} "
                            f"({exc})") from exc
    if mode not in ("I;16", "I;16B", "I") or arr.ndim != 2:
        raise AquaspecError(f"bathymetry PNG {path!r} has mode {mode!r}; expected a "
                            "single-channel 16-bit PNG of depths in millimetres")
    return arr.astype(np.float64) * 1e-3


def _read_asc(path):
    """``(depth (rows, cols), cellsize)`` of an ESRI ASCII grid; no-data
    samples become NaN (refused by :class:`Bathymetry`, naming them)."""
    header = {}
    try:
        with open(path, encoding="utf-8") as f:
            lines = f.read().splitlines()
        k = 0
        while k < len(lines) and lines[k].split() and lines[k].split()[0].lower() in _ASC_KEYS:
            key, value = lines[k].split()[:2]
            header[key.lower()] = float(value)
            k += 1
        values = np.loadtxt(lines[k:], ndmin=2)
    except Exception as exc:
        raise AquaspecError(f"could not read bathymetry file {path!r} as an ESRI ASCII grid "
                            f"({exc})") from exc
    missing = [key for key in ("ncols", "nrows", "cellsize") if key not in header]
    if missing:
        raise AquaspecError(f"bathymetry file {path!r}: the ESRI ASCII header lacks "
                            f"{', '.join(missing)}")
    rows, cols = int(header["nrows"]), int(header["ncols"])
    if values.shape != (rows, cols):
        raise AquaspecError(f"bathymetry file {path!r}: the header says {rows} x {cols} "
                            f"samples, the file holds {values.shape[0]} x {values.shape[1]}")
    if "nodata_value" in header:
        values = np.where(values == header["nodata_value"], np.nan, values)
    # Rows run north to south; the grid's rows run along +z (south): kept.
    return -values, header["cellsize"]


def bathymetry_from_text(text: str) -> Bathymetry:
    """``FILE[,SPACING_M]`` (the CLI's ``--bathymetry``) -> :func:`load_bathymetry`."""
    path, _, spacing = str(text).partition(",")
    value = None
    if spacing.strip():
        try:
            value = float(spacing)
        except ValueError:
            raise AquaspecError(f"--bathymetry {text!r}: spacing {spacing!r} is not a number; "
                                "accepted: FILE or FILE,SPACING_M (e.g. seabed.npy,0.5)") from None
    return load_bathymetry(path.strip(), spacing_m=value)


def check_camera_over(bathy: Bathymetry, camera) -> None:
    """Refuse a camera under the water whose bottom, there, is not below it."""
    x, y, z = (float(c) for c in camera.position)
    if y >= 0:
        return
    floor = float(bathy.depth_at(x, z))
    if floor <= -y:
        raise AquaspecError(f"the bathymetry's bottom under the camera is {floor:g} m deep, "
                            f"not below the camera at {-y:g} m; accepted: a camera depth "
                            f"shallower than {floor:g} m there (--depth), or a camera above "
                            "the sea (--camera-height)")
