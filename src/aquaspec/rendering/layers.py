"""Image-formation layers of a render: ground truth for underwater image restoration.

Methods that remove the water from underwater photographs (dehazing, colour
restoration, depth from attenuation) are trained and tested on what a
render knows and a photograph does not. The linear camera RGB ``I`` of a
render splits into what the water adds and what the surfaces send, the
backscatter and the direct signal of Akkaynak & Treibitz's revised image
formation model (CVPR 2018), ``I = D + B``:

- ``backscatter`` B: the image rendered again with every surface of the
  G-buffer black (reflectance 0). It is the water's own light, still
  shaped by the surfaces: they hide the water and sky behind them (and,
  with the scene's shadow, ``ambient_shadow``, they block light in the
  water).
- ``direct`` D = I - B: the surfaces' own light at the camera, attenuated
  along the ray, with the part the water scatters forward (the light
  field's forward cone; with the cone spread, spread over neighbouring
  pixels, so a little of it lands on open water beside a target).
- ``surface`` J: the light leaving each visible surface towards the
  camera, at the surface, with no water in between: camera RGB of
  ``rho E(d, n) / pi`` with the model's irradiance at the surface's depth
  and orientation (:func:`aquaspec.transport.monzon2022.ambient_irradiance`, or the light
  field's :func:`aquaspec.transport.lightfield.solve.surface_radiance`), plus with a sun
  its beam on the surface, shadows included (:func:`aquaspec.light.sun.surface_irradiance`).
- ``albedo``: camera RGB of ``rho E0 / pi``, the surface under the light
  just below the water surface (``E0``): the colour cast the water gives
  the light on its way down is taken out too (what colour restoration
  aims at).
- ``transmission`` t: per channel, the share of the surface's light that
  stays in the camera ray's beam, ``RGB(T L_surf) / RGB(L_surf)`` with
  ``T = exp(-c' S)`` per band and ``c'`` the beam's extinction (``c``; in
  the light field ``c - f b``, its forward cone counted as unscattered); 0
  where there is no surface. The ratio is taken in camera RGB, after the
  bands are summed, so it belongs to this surface's spectrum, and it lies
  between the bands' smallest and largest T. Without the cone spread and
  the scene's shadow, ``D = t J`` (the NumPy backend to rounding; the GPU
  within its compiled model's error, see :mod:`aquaspec.transport.lightfield.compiled`)
  for every sensor whose response is nowhere negative, as real cameras';
  ``human`` (CIE 1931 to linear sRGB) has negative lobes, which the ratio
  takes by magnitude, so that t stays a transmittance there too.
- ``range_m``: the distance along the ray to the surface, m; 0 for open
  water (rays that reach the water surface first count as open water).

All colour layers are linear camera RGB like the linear image; every layer
is finite. Files: :func:`write_layers` (EXR with layers ``backscatter.R``
... and the channel ``range_m``, or NPZ), read back with :func:`read_layers`.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from aquaspec.transport import monzon2022 as model
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.io.output import METADATA_KEY
from aquaspec.colour.reflectance import Reflectance

#: The colour layers, (H, W, 3) each, in file order; ``range_m`` (H, W) follows.
COLOUR_LAYERS = ("backscatter", "direct", "surface", "albedo", "transmission")
#: Every layer name.
LAYER_NAMES = COLOUR_LAYERS + ("range_m",)
#: Accepted file suffixes of :func:`write_layers`.
LAYER_SUFFIXES = (".exr", ".npz")

_BLACK = Reflectance("black", np.array([100.0, 2000.0]), np.zeros(2),
                     source="aquaspec.rendering.layers: reflectance 0, for the backscatter layer")
# Hit pixels per chunk of the NumPy layers (times the band count, float64).
_CHUNK_ELEMENTS = 4_000_000


def black_gbuffer(gbuffer: GBuffer) -> GBuffer:
    """``gbuffer`` with every surface black: same geometry, one material of
    reflectance 0 (the backscatter layer is the image of it)."""
    if not isinstance(gbuffer, GBuffer):
        raise AquaspecError(f"gbuffer must be an aquaspec.scene.gbuffer.GBuffer, got "
                            f"{type(gbuffer).__name__}")
    material = np.zeros_like(gbuffer.material)
    return GBuffer(gbuffer.camera, gbuffer.distance, gbuffer.normal, material,
                   np.zeros_like(gbuffer.sigmoid), [_BLACK])


def surface_layers(gbuffer: GBuffer, *, a, b, kd, e0, response_weights, material_bands,
                   sigmoid_centers_t, ambient: str = model.DEFAULT_AMBIENT,
                   lightfield: dict | None = None, sun=None, sun_visibility=None) -> dict:
    """``surface``, ``albedo``, ``transmission`` (H, W, 3) and ``range_m`` (H, W),
    float64, from the G-buffer and the medium (the keywords of
    :func:`aquaspec.shading.shade.shade_gbuffer`; ``lightfield``: its tables, for
    the light-field model's irradiance and beam; None: the seeds' model;
    ``sun``: :class:`aquaspec.light.sun.SunInputs` with ``sun_visibility`` (H, W),
    the share of the beam each surface gets, :func:`aquaspec.light.sun.surface_visibility`).
    See the module docstring for the definitions."""
    from aquaspec.shading.shade import _hit_reflectance, _reached, camera_depth, check_medium
    a, b, kd, e0, w, mb, t = check_medium(a, b, kd, e0, response_weights, material_bands,
                                          sigmoid_centers_t, ambient,
                                          n_materials=len(gbuffer.materials))
    cam = gbuffer.camera
    hgt, wid, n = cam.height, cam.width, a.size
    d_o = camera_depth(cam)
    v_y = cam.ray_directions()[..., 1].reshape(-1)
    s = gbuffer.distance.reshape(-1).astype(float)
    hit = _reached(s, v_y, d_o)
    out = {k: np.zeros((hgt * wid, 3)) for k in ("surface", "albedo", "transmission")}
    if lightfield is None:
        c_beam = a + b
    else:
        from aquaspec.transport.lightfield.solve import _beam_extinction
        c_beam = _beam_extinction(lightfield, a, b)
    idx = np.flatnonzero(hit)
    mat = gbuffer.material.reshape(-1)
    sig = gbuffer.sigmoid.reshape(-1, 3)
    n_y = gbuffer.normal[..., 1].reshape(-1).astype(float)
    o_y = float(cam.position[1])
    step = max(1, _CHUNK_ELEMENTS // n)
    for i0 in range(0, idx.size, step):
        p = idx[i0:i0 + step]
        rho = _hit_reflectance(mat[p], sig[p], mb, t)
        depth = -(o_y + s[p] * v_y[p])
        if lightfield is None:
            l_surf = model.lambertian_radiance(
                rho, model.ambient_irradiance(e0, kd, depth[:, None], n_y[p, None], ambient))
        else:
            from aquaspec.transport.lightfield.solve import surface_radiance
            l_surf = surface_radiance(lightfield, rho, depth, n_y[p], e0)
        if sun is not None:
            from aquaspec.light.sun import surface_irradiance
            vis = 1.0 if sun_visibility is None else sun_visibility.reshape(-1)[p]
            normal = gbuffer.normal.reshape(-1, 3)[p].astype(float)
            l_surf = l_surf + model.lambertian_radiance(rho, surface_irradiance(
                sun.beam0, sun.c_sun, depth, normal, sun.to_sun, vis))
        out["surface"][p] = model.radiance_to_rgb(l_surf, w)
        out["albedo"][p] = model.radiance_to_rgb(model.lambertian_radiance(rho, e0), w)
        # (|w|: a channel with negative lobes keeps t within the bands' T.)
        j = model.radiance_to_rgb(l_surf, np.abs(w))
        kept = model.radiance_to_rgb(model.transmittance(c_beam, s[p, None]) * l_surf,
                                     np.abs(w))
        out["transmission"][p] = np.where(j > 0, kept / np.where(j > 0, j, 1.0), 0.0)
    layers = {k: v.reshape(hgt, wid, 3) for k, v in out.items()}
    layers["range_m"] = np.where(hit, s, 0.0).reshape(hgt, wid)
    for k, v in layers.items():
        if not np.all(np.isfinite(v)):
            raise AquaspecError(f"the {k} layer came out non-finite; check the water "
                                "coefficients and the G-buffer")
    return layers


def image_layers(linear_rgb, backscatter_rgb, gbuffer: GBuffer, medium: dict,
                 lightfield: dict | None = None, sun=None, sun_visibility=None) -> dict:
    """Every layer (:data:`LAYER_NAMES`) of an image ``linear_rgb`` whose
    G-buffer was ``gbuffer``, given ``backscatter_rgb``, the image of
    :func:`black_gbuffer` rendered the same way; ``medium`` as for
    :func:`surface_layers`."""
    linear = np.asarray(linear_rgb, dtype=float)
    back = np.asarray(backscatter_rgb, dtype=float)
    shape = (gbuffer.camera.height, gbuffer.camera.width, 3)
    for name, arr in (("linear image", linear), ("backscatter image", back)):
        if arr.shape != shape:
            raise AquaspecError(f"the {name} has shape {arr.shape}; the G-buffer's camera "
                                f"needs {shape}")
        if not np.all(np.isfinite(arr)):
            raise AquaspecError(f"the {name} is not finite")
    layers = {"backscatter": back, "direct": linear - back}
    layers.update(surface_layers(gbuffer, **medium, lightfield=lightfield, sun=sun,
                                 sun_visibility=sun_visibility))
    return {k: layers[k] for k in LAYER_NAMES}


def _checked(layers) -> dict:
    """The layers as float32, checked for names, shapes and finiteness."""
    missing = [k for k in LAYER_NAMES if k not in layers]
    if missing:
        raise AquaspecError(f"layers lack {missing}; accepted: a dict with {list(LAYER_NAMES)}")
    out = {}
    shape = None
    for k in LAYER_NAMES:
        with np.errstate(over="ignore"):
            arr = np.asarray(layers[k], dtype=np.float32)
        want = 3 if k in COLOUR_LAYERS else 2
        if arr.ndim != want or (want == 3 and arr.shape[2] != 3):
            raise AquaspecError(f"layer {k!r} has shape {arr.shape}; accepted: "
                                + ("(height, width, 3)" if want == 3 else "(height, width)"))
        if shape is None:
            shape = arr.shape[:2]
        elif arr.shape[:2] != shape:
            raise AquaspecError(f"layer {k!r} is {arr.shape[:2]}; the others are {shape}")
        if not np.all(np.isfinite(arr)):
            raise AquaspecError(f"layer {k!r} has NaN or infinite values (or values beyond "
                                "float32); nothing was written")
        out[k] = arr
    return out


def check_layers_path(path):
    """The layers' output path (a ``Path``), refused before any work if its
    suffix is not one of :data:`LAYER_SUFFIXES`, its directory cannot be
    written, or it is an EXR without the OpenEXR module."""
    from aquaspec.io.output import _openexr, check_writable
    p = check_writable(path, suffixes=LAYER_SUFFIXES)
    if p.suffix.lower() == ".exr" and _openexr() is None:
        raise AquaspecError(f"writing {str(p)!r} needs the OpenEXR module (pip install "
                            "openexr); or give a .npz path")
    return p


def plan_layers(path, layers, metadata: dict):
    """``(final_path, writer)`` of :func:`write_layers` for a staged, atomic write
    (:func:`aquaspec.io.output.save_image` writes it with the other files);
    ``metadata`` is serialised when the file is written."""
    from aquaspec.io.output import _dumps, exr_writer
    p = check_layers_path(path)
    arrays = _checked(layers)
    if p.suffix.lower() == ".exr":
        channels = {f"{k}.{c}": np.ascontiguousarray(arrays[k][..., i])
                    for k in COLOUR_LAYERS for i, c in enumerate("RGB")}
        channels["range_m"] = arrays["range_m"]
        write = exr_writer(channels, metadata)
    else:
        def write(tmp):
            with open(tmp, "wb") as f:     # a file object: np.savez(name) adds ".npz"
                np.savez_compressed(f, **arrays, **{METADATA_KEY: np.array(_dumps(metadata))})
    return p, write


def write_layers(path, layers, metadata=None) -> Path:
    """Write ``layers`` (:data:`LAYER_NAMES`, e.g. ``RenderResult.layers``) to
    ``path``, atomically: ``.exr`` (float32, ZIP; the colour layers as
    ``backscatter.R`` ... ``transmission.B``, the channel ``range_m``, the
    parameters as JSON in the header attribute ``aquaspec``) or ``.npz``
    (one float32 array per layer and ``aquaspec``, the parameters as JSON).
    Non-finite values are refused and nothing is written."""
    from aquaspec.io.output import _stamped, _write_atomically
    p, write = plan_layers(path, layers, _stamped(metadata))
    _write_atomically([(p, write)])
    return p


def read_layers(path) -> tuple[dict, dict]:
    """``(layers, metadata)`` of a file written by :func:`write_layers`."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in LAYER_SUFFIXES:
        raise AquaspecError(f"layers file {str(p)!r}; accepted suffixes: "
                            + ", ".join(LAYER_SUFFIXES))
    if not p.is_file():
        raise AquaspecError(f"no layers file {str(p)!r}")
    if suffix == ".npz":
        with np.load(p, allow_pickle=False) as z:
            missing = [k for k in LAYER_NAMES + (METADATA_KEY,) if k not in z.files]
            if missing:
                raise AquaspecError(f"{str(p)!r} lacks {missing}; has {sorted(z.files)}")
            return ({k: z[k] for k in LAYER_NAMES}, json.loads(str(z[METADATA_KEY])))
    from aquaspec.io.output import read_exr_channels
    ch, header = read_exr_channels(
        p, [f"{k}.{c}" for k in COLOUR_LAYERS for c in "RGB"] + ["range_m"])
    layers = {k: np.stack([ch[f"{k}.{c}"] for c in "RGB"], axis=-1) for k in COLOUR_LAYERS}
    layers["range_m"] = ch["range_m"]
    meta = header.get(METADATA_KEY)
    return layers, (json.loads(meta) if meta else {})
