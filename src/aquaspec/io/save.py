"""Writing a render's files as one set: PNG, sidecar, linear image, layers; all or none.

Every file is staged under a temporary name and synced before any is
renamed into place (:func:`aquaspec.io.atomic.write_atomically`), so an
error while writing any of them leaves no new file behind.
"""

from __future__ import annotations

from pathlib import Path

from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import check_writable, write_atomically
from aquaspec.io.layers_file import plan_layers
from aquaspec.io.linear import plan_linear
from aquaspec.io.metadata import metadata_json, stamped
from aquaspec.io.png import PNG_SUFFIXES, png_writer
from aquaspec.io.sidecar import sidecar_path, sidecar_writer


def save_image(path, display_image, linear_rgb=None, params=None, *, linear_path=None,
               layers=None, layers_path=None) -> dict:
    """Write the PNG, its sidecar and optionally the linear image, all or none.

    Parameters
    ----------
    path : str or os.PathLike
        The PNG (``.png``); the sidecar is ``<path>.json``.
    display_image : ndarray, uint8 or uint16
        Display pixels (from :func:`aquaspec.colour.display.to_display`).
    linear_rgb : ndarray (H, W, 3), optional
        Linear camera RGB; written only when ``linear_path`` is given.
    params : dict, optional
        Every parameter of the render; stored in the sidecar, the PNG and the
        EXR header, with ``files`` (names of what was written),
        ``aquaspec_version`` and ``timestamp`` added.
    linear_path : str or os.PathLike, optional
        ``.exr`` or ``.npy`` destination for ``linear_rgb`` (EXR falls back
        to NPY as in :func:`aquaspec.io.linear.write_linear`).
    layers : dict, optional
        Image-formation layers (``RenderResult.layers``); written only when
        ``layers_path`` is given.
    layers_path : str or os.PathLike, optional
        ``.exr`` or ``.npz`` destination for ``layers``
        (:func:`aquaspec.io.layers_file.write_layers`).

    Returns
    -------
    dict
        ``png``, ``sidecar``, ``linear``, ``layers`` (paths as str, None when
        not written), ``linear_format``, ``warnings`` (list of str).
    """
    png = check_writable(path, suffixes=PNG_SUFFIXES)
    side = check_writable(sidecar_path(png))
    if linear_path is not None and linear_rgb is None:
        raise AquaspecError(f"linear_path={str(linear_path)!r} was given without linear_rgb")
    if layers_path is not None and layers is None:
        raise AquaspecError(f"layers_path={str(layers_path)!r} was given without layers "
                            "(render with layers=True)")
    doc = stamped(params)
    jobs, result = [], {"png": str(png), "sidecar": str(side), "linear": None,
                        "layers": None, "linear_format": None, "warnings": []}
    if linear_path is not None:
        lin, lin_write, lin_info = plan_linear(linear_path, linear_rgb, doc)
        result.update(linear=str(lin), linear_format=lin_info["format"])
        if lin_info["warning"]:
            result["warnings"].append(lin_info["warning"])
        jobs.append((lin, lin_write))
    if layers_path is not None:
        lay, lay_write = plan_layers(layers_path, layers, doc)
        result["layers"] = str(lay)
        jobs.append((lay, lay_write))
    doc["files"] = {"png": png.name, "sidecar": side.name,
                    "linear": None if result["linear"] is None else Path(result["linear"]).name}
    if result["layers"] is not None:
        doc["files"]["layers"] = Path(result["layers"]).name
    if result["warnings"]:
        doc["warnings"] = list(result["warnings"])
    jobs.append((png, png_writer(display_image, metadata_json(doc))))
    jobs.append((side, sidecar_writer(doc)))
    write_atomically(jobs)
    return result
