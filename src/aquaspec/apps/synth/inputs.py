"""``aquaspec synth``'s inputs: finding the RGB-D pairs and reading one.

Two layouts of RGB-D pairs are read (:class:`aquaspec.apps.synth.config.InputsConfig`):

- a folder with ``rgb/`` and ``depth/`` in it, an image and its depth map
  matched by their path below those folders without the suffix
  (``rgb/kitchen/0001.jpg`` and ``depth/kitchen/0001.png`` are the pair
  ``kitchen/0001``);
- a manifest, CSV or Parquet, with the columns ``image`` and ``depth``
  (paths relative to the manifest's folder) and optionally ``name`` and the
  intrinsics ``fx, fy, cx, cy`` of each image (all four, in pixels).

Meshes (``[inputs] meshes``: folders or files) are inputs too, rendered as
scenes: :class:`MeshInput`.

Depth is metric z-depth. Its unit is ``[inputs] depth_unit`` (default: mm for
16-bit PNG, as depth cameras write it, and m for ``.npy`` and ``.exr``),
multiplied by ``depth_scale``. A map whose median comes out beyond
:data:`PLAUSIBLE_DEPTH_M` is refused as being in another unit.

Holes (NaN, infinite, zero or negative values: no reading) follow
``[inputs] holes``: ``mask`` (default) and ``fill`` give each hole the depth
of the nearest valid pixel, so the whole image is rendered; with ``mask``
the hole pixels are then set to 0 in every output and a validity mask is
written (:mod:`aquaspec.apps.synth.task`). Both count them in the manifest.
``error`` fails the sample, naming the first hole.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from aquaspec.apps.synth.config import DEPTH_UNITS, InputsConfig
from aquaspec.errors import AquaspecError
from aquaspec.scene.load import MESH_FORMATS
from aquaspec.scene.rgbd import DEPTH_FORMATS, IMAGE_FORMATS, check_depth_map, load_rgbd

#: Median depths outside this range (m) mean the unit is wrong.
PLAUSIBLE_DEPTH_M = (1e-3, 1000.0)
#: The unit of a depth file without ``depth_unit``: 16-bit PNG in mm, the others in m.
DEFAULT_UNIT = {".png": "mm", ".npy": "m", ".exr": "m"}
#: Names of pairs shown in an error about many of them.
SHOWN = 5


@dataclass(frozen=True)
class InputPair:
    """One RGB-D pair: its ``name`` (unique in the data set), the files
    (relative to ``root``) and its intrinsics ``(fx, fy, cx, cy)`` in pixels."""

    name: str
    root: Path
    image: str
    depth: str
    intrinsics: tuple

    def describe(self) -> dict:
        fx, fy, cx, cy = self.intrinsics
        return {"input": self.name, "kind": "rgbd", "image": self.image, "depth": self.depth,
                "fx": fx, "fy": fy, "cx": cx, "cy": cy}


@dataclass(frozen=True)
class MeshInput:
    """A mesh rendered as a scene (:func:`aquaspec.scene.load.place_in_front`:
    3 m in front of the camera), its image ``size`` (width, height)."""

    name: str
    root: Path
    mesh: str
    size: tuple

    def describe(self) -> dict:
        return {"input": self.name, "kind": "mesh", "mesh": self.mesh,
                "width": self.size[0], "height": self.size[1]}


@dataclass(frozen=True)
class RGBD:
    """A pair as rendered: the image, its depth in metres (holes filled) and
    where the holes were (``holes`` (H, W) bool)."""

    rgb: np.ndarray
    depth_m: np.ndarray
    holes: np.ndarray

    @property
    def hole_count(self) -> int:
        return int(self.holes.sum())


def discover(cfg: InputsConfig) -> tuple[list, list[str]]:
    """The inputs of ``cfg`` sorted by name (:class:`InputPair` and
    :class:`MeshInput`), and the names of images without a depth map that
    ``missing_depth = "skip"`` left out (with ``"error"`` they are an
    :class:`AquaspecError` naming them)."""
    if cfg.folder is not None:
        found = _from_folder(cfg.folder)
    elif cfg.manifest is not None:
        found = _from_manifest(cfg.manifest)
    else:
        found = []
    pairs, missing = [], []
    for name, root, image, depth, intr in found:
        if depth is None or not (root / depth).is_file():
            missing.append(name)
            continue
        intr = intr or cfg.intrinsics
        if intr is None:
            raise AquaspecError(f"image {name!r} has no intrinsics; accepted: [inputs] "
                                "intrinsics = [fx, fy, cx, cy] or the manifest columns fx, fy, "
                                "cx, cy")
        pairs.append(InputPair(name, root, image, depth, tuple(float(v) for v in intr)))
    if missing and cfg.missing_depth == "error":
        raise AquaspecError(
            f"{len(missing)} image(s) have no depth map: {', '.join(missing[:SHOWN])}"
            + (" ..." if len(missing) > SHOWN else "") + "; accepted: a depth file of the same "
            f"name with suffix {', '.join(DEPTH_FORMATS)} (in depth/, or the manifest's depth "
            "column), or [inputs] missing_depth = 'skip'")
    return sorted(pairs + _meshes(cfg), key=lambda p: p.name), missing


def _meshes(cfg: InputsConfig) -> list[MeshInput]:
    """The mesh inputs: the mesh files of each folder (sub-folders followed)
    or each file in ``cfg.meshes``, named ``mesh:`` and their path without
    the suffix."""
    out = []
    for entry in cfg.meshes:
        if entry.is_dir():
            files = [(entry, p) for p in sorted(entry.rglob("*"))
                     if p.is_file() and p.suffix.lower() in MESH_FORMATS]
            if not files:
                raise AquaspecError(f"[inputs] meshes folder {str(entry)!r} has no mesh file; "
                                    f"accepted suffixes: {', '.join(MESH_FORMATS)}")
        elif entry.is_file() and entry.suffix.lower() in MESH_FORMATS:
            files = [(entry.parent, entry)]
        else:
            raise AquaspecError(f"[inputs] meshes entry {str(entry)!r} is neither a folder nor "
                                f"a mesh file; accepted suffixes: {', '.join(MESH_FORMATS)}")
        for root, p in files:
            rel = p.relative_to(root).as_posix()
            out.append(MeshInput(f"mesh:{p.relative_to(root).with_suffix('').as_posix()}",
                                 root, rel, tuple(cfg.mesh_size)))
    names = [m.name for m in out]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise AquaspecError(f"[inputs] meshes name {twice[0]!r} twice; accepted: one file per "
                            "name")
    return out


def _stems(folder: Path, formats, what: str) -> dict:
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.suffix.lower() in formats and not p.name.startswith("."):
            rel = p.relative_to(folder)
            name = rel.with_suffix("").as_posix()
            if name in out:
                raise AquaspecError(f"{what} {out[name]!r} and {rel.as_posix()!r} have the same "
                                    "name; accepted: one file per name")
            out[name] = rel.as_posix()
    return out


def _from_folder(folder: Path):
    rgb_dir, depth_dir = folder / "rgb", folder / "depth"
    for d in (rgb_dir, depth_dir):
        if not d.is_dir():
            raise AquaspecError(f"input folder {str(folder)!r} has no {d.name}/ folder; "
                                "accepted: a folder with rgb/ (images) and depth/ (depth maps) "
                                "matched by name, or [inputs] manifest")
    images = _stems(rgb_dir, IMAGE_FORMATS, "image")
    depths = _stems(depth_dir, DEPTH_FORMATS, "depth map")
    return [(name, folder, f"rgb/{rel}", f"depth/{depths[name]}" if name in depths else None,
             None) for name, rel in images.items()]


def _manifest_rows(path: Path) -> list[dict]:
    if not path.is_file():
        raise AquaspecError(f"input manifest {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix == ".csv":
        with open(path, newline="", encoding="utf-8") as f:
            return list(csv.DictReader(f))
    if suffix == ".parquet":
        try:
            # deferred: pyarrow is the optional synth extra, needed only for Parquet
            import pyarrow.parquet as pq
        except ImportError as exc:
            raise AquaspecError("reading a Parquet manifest needs pyarrow: "
                                "pip install 'aquaspec[synth]'") from exc
        return pq.read_table(path).to_pylist()
    raise AquaspecError(f"input manifest {str(path)!r} has suffix {suffix!r}; accepted: .csv, "
                        ".parquet")


def _from_manifest(path: Path):
    rows = _manifest_rows(path)
    root = path.parent
    out, seen = [], set()
    for i, row in enumerate(rows, start=2):
        if not row.get("image"):
            raise AquaspecError(f"input manifest {str(path)!r} row {i} has no image; accepted "
                                "columns: image, depth, and optionally name, fx, fy, cx, cy")
        image = str(row["image"])
        name = str(row.get("name") or Path(image).with_suffix("").as_posix())
        if name in seen:
            raise AquaspecError(f"input manifest {str(path)!r} names {name!r} twice (row {i}); "
                                "accepted: one row per name")
        seen.add(name)
        given = [row.get(k) for k in ("fx", "fy", "cx", "cy")]
        intr = None
        if any(v not in (None, "") for v in given):
            try:
                intr = tuple(float(v) for v in given)
            except (TypeError, ValueError):
                intr = None
            if intr is None or not all(np.isfinite(intr)) or intr[0] <= 0 or intr[1] <= 0:
                raise AquaspecError(f"input manifest {str(path)!r} row {i} has intrinsics "
                                    f"{given!r}; accepted: fx, fy > 0 and cx, cy, all four "
                                    "finite numbers of pixels")
        depth = row.get("depth") or None
        out.append((name, root, image, None if depth is None else str(depth), intr))
    return out


def depth_unit_of(pair: InputPair, cfg: InputsConfig) -> str:
    """The unit of ``pair``'s depth file: ``depth_unit``, or its format's default."""
    return cfg.depth_unit or DEFAULT_UNIT[Path(pair.depth).suffix.lower()]


def read_pair(pair: InputPair, cfg: InputsConfig) -> RGBD:
    """Read ``pair`` (:func:`aquaspec.scene.rgbd.load_rgbd`), its depth in metres
    with the holes filled as the module docstring says."""
    rgb, read_m = load_rgbd(pair.root / pair.image, pair.root / pair.depth, allow_holes=True)
    suffix = Path(pair.depth).suffix.lower()
    # load_rgbd reads 16-bit PNG as mm and the others as m.
    scale = DEPTH_UNITS[depth_unit_of(pair, cfg)] / DEPTH_UNITS[DEFAULT_UNIT[suffix]]
    depth = read_m * (scale * cfg.depth_scale)
    holes = np.isnan(depth)
    what = f"depth map {pair.depth!r} of {pair.name!r}"
    if holes.all():
        raise AquaspecError(f"{what} has no valid pixel (all NaN, infinite, zero or "
                            "negative); accepted: a map with metric depths")
    median = float(np.median(depth[~holes]))
    low, high = PLAUSIBLE_DEPTH_M
    if not low <= median <= high:
        raise AquaspecError(
            f"{what} has a median of {median:.6g} m read as {depth_unit_of(pair, cfg)!r} "
            f"times {cfg.depth_scale:g}: not a scene's depth; accepted: [inputs] depth_unit "
            f"{', '.join(DEPTH_UNITS)} and depth_scale giving medians of {low:g} to {high:g} m")
    if holes.any():
        if cfg.holes == "error":
            try:
                check_depth_map(depth, what)
            except AquaspecError as exc:
                raise AquaspecError(f"{exc}; or [inputs] holes = 'mask' or 'fill'") from None
        idx = ndimage.distance_transform_edt(holes, return_distances=False, return_indices=True)
        depth = depth[tuple(idx)]
    return RGBD(rgb, depth, holes)
