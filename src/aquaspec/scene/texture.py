"""Texture mip chains, level-of-detail selection, tangent frames and normal maps (NumPy).

What the geometry pass (:mod:`aquaspec.gpu.passes.raster`) does with a mesh's
textures, written once in float64 so that the ray-cast reference
(:func:`aquaspec.scene.raycast.raycast_gbuffer`) and the tests share it.

Conventions: ``uv`` has its origin at the *bottom-left* of a texture whose
row 0 is its top (OBJ / trimesh); textures repeat. Texel centres sit at
half-integers.

Mip chain (:func:`mip_chain`)
    Level ``k + 1`` has ``max(1, n // 2)`` texels a side for ``n`` of level
    ``k``; each texel is the mean of the 2x2 texels it covers (an odd last
    row or column is dropped, the box filter of most GPU drivers' mip
    generators). The chain of a colour texture is built from the *linear RGB*
    and each level is then fitted to Jakob-Hanika sigmoid coefficients
    (:meth:`aquaspec.scene.mesh.Mesh.texture_mips`): averaging reflectances
    is what a pixel that covers many texels sees, averaging the sigmoid
    coefficients is not (they are non-linear in the reflectance). The chain
    of a normal map averages the unit vectors and leaves them unnormalised;
    they are normalised after filtering.

Level of detail (:func:`mip_lod`)
    ``lod = log2(max(|d(uv * size) / dx|, |d(uv * size) / dy|))``, clamped to
    ``[0, levels - 1]`` (the isotropic rule of the OpenGL 4.6 specification,
    section 8.14), from the screen-space derivatives the fragment shader
    takes with ``dpdxFine``/``dpdyFine``: differences between the two pixels
    of the row / column of the pixel's 2x2 quad, uv extrapolated over the
    triangle's plane where a neighbour lies off the triangle
    (:func:`quad_uv_differences`). Sampling is trilinear: bilinear on the
    two nearest levels, mixed by the fraction of ``lod``
    (:func:`sample_trilinear`).

    The GPU samples with its texture units (``textureSampleGrad`` with these
    derivatives, a repeating trilinear sampler), whose level of detail is
    implementation-defined: lavapipe approximates ``rho`` and ``log2`` and
    filters "brilinearly" (the fraction snapped towards whole levels). Its
    result is therefore a trilinear sample at a level within a fraction of a
    level of this module's; the tests hold it to the envelope of this
    module's samples over ``lod +- 0.6`` (``bias`` of :func:`mip_lod`). A
    first version filtered by hand with ``textureLoad`` and matched this
    module exactly, but made the geometry pass of the detailed scene's
    seabed about 3x slower on lavapipe than the texture units.

Tangent frames (:func:`vertex_tangents`)
    Per triangle ``T = dP/du`` and ``B = dP/dv`` (Lengyel 2001), summed per
    vertex, ``T`` made orthogonal to the vertex normal (Gram-Schmidt) and
    normalised; ``w = +1`` when ``cross(N, T)`` points along ``B`` and -1 for
    mirrored uv. Tangent-space normal maps follow glTF 2.0 (+x along u, +y
    along v, +z out of the surface; "OpenGL" green channel), decoded from
    [0, 1] colour to [-1, 1] before they reach a mesh.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.numerics import bilinear_blend, repeat_cell

#: Most mip levels a texture gets (a 32768-texel side has 16).
MAX_LEVELS = 16


def mip_chain(image: np.ndarray) -> list[np.ndarray]:
    """Box-filtered mip levels of ``image`` (H, W, C), level 0 first, down to 1x1."""
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3 or img.shape[0] < 1 or img.shape[1] < 1:
        raise AquaspecError(f"texture has shape {img.shape}; expected (H, W, C) with H, W >= 1")
    levels = [img]
    while max(levels[-1].shape[:2]) > 1 and len(levels) < MAX_LEVELS:
        a = levels[-1]
        h, w = a.shape[:2]
        if h > 1:
            a = 0.5 * (a[0:h - 1:2] + a[1:h:2])
        if w > 1:
            a = 0.5 * (a[:, 0:w - 1:2] + a[:, 1:w:2])
        levels.append(a)
    return levels


def quantise_unorm8(values) -> np.ndarray:
    """Values in [-1, 1] as an 8-bit unorm texture holds them: (x + 1) / 2
    rounded to 1/255, decoded back to [-1, 1] (normal maps on the GPU)."""
    q = np.clip(np.rint((np.asarray(values, dtype=np.float64) + 1.0) * 127.5), 0, 255)
    return q / 127.5 - 1.0


def bilinear_repeat(image, uv):
    """Bilinear sample of ``image`` (H, W, C) at ``uv`` (N, 2) with repeat wrapping,
    texel centres at half-integers, v up: as raster.wgsl samples one mip level."""
    h, w = image.shape[:2]
    xa, xb, fx = repeat_cell(uv[:, 0] * w - 0.5, w)
    ya, yb, fy = repeat_cell((1.0 - uv[:, 1]) * h - 0.5, h)
    return bilinear_blend(image[ya, xa], image[ya, xb], image[yb, xa], image[yb, xb],
                          fy[:, None], fx[:, None])


def mip_lod(duv_dx, duv_dy, size, levels: int, bias: float = 0.0) -> np.ndarray:
    """Level of detail (N,) from uv differences along x and y (N, 2) for a level-0
    texture of ``size = (height, width)`` texels with ``levels`` mip levels;
    ``bias`` is added before clamping."""
    scale = np.array([size[1], size[0]], dtype=np.float64)
    rho = np.maximum(np.linalg.norm(np.asarray(duv_dx) * scale, axis=-1),
                     np.linalg.norm(np.asarray(duv_dy) * scale, axis=-1))
    with np.errstate(divide="ignore"):
        lod = np.log2(rho)
    lod = np.nan_to_num(lod, nan=0.0, neginf=-np.inf)
    return np.clip(lod + bias, 0.0, levels - 1)


def sample_trilinear(levels: list, uv, lod) -> np.ndarray:
    """Trilinear sample (N, C) of a mip chain at ``uv`` (N, 2) and ``lod`` (N,)."""
    uv = np.asarray(uv, dtype=np.float64)
    lod = np.clip(np.asarray(lod, dtype=np.float64), 0.0, len(levels) - 1)
    lo = np.floor(lod).astype(np.int64)
    hi = np.minimum(lo + 1, len(levels) - 1)
    f = (lod - lo)[:, None]
    out = np.zeros((len(uv), levels[0].shape[2]))
    for k in np.unique(np.concatenate([lo, hi])):
        a = lo == k
        if a.any():
            out[a] += (1.0 - f[a]) * bilinear_repeat(levels[k], uv[a])
        b = hi == k
        if b.any():
            out[b] += f[b] * bilinear_repeat(levels[k], uv[b])
    return out


def pixel_rays(camera, rows, cols) -> np.ndarray:
    """Unnormalised ray directions (N, 3) through pixel centres ``(rows, cols)``
    (any integers, also outside the image), as :meth:`Camera.ray_directions`."""
    x = (np.asarray(cols, dtype=np.float64) + 0.5 - camera.cx) / camera.fx
    y = (np.asarray(rows, dtype=np.float64) + 0.5 - camera.cy) / camera.fy
    return (camera.right[None] * x[:, None] - camera.true_up[None] * y[:, None]
            + camera.forward[None])


def plane_barycentrics(tri, origin, dirs) -> np.ndarray:
    """Barycentrics (N, 3) where rays ``origin + t dirs`` (N, 3) meet the planes of
    triangles ``tri`` (N, 3, 3), extrapolated outside the triangles."""
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    p = np.cross(dirs, e2)
    det = np.einsum("nk,nk->n", p, e1)
    det = np.where(np.abs(det) > 1e-300, det, 1e-300)
    s = origin - tri[:, 0]
    u = np.einsum("nk,nk->n", p, s) / det
    q = np.cross(s, e1)
    v = np.einsum("nk,nk->n", dirs, q) / det
    return np.stack([1.0 - u - v, u, v], axis=1)


def quad_uv_differences(tri, tri_uv, camera, rows, cols):
    """``dpdxFine(uv)``, ``dpdyFine(uv)`` (each (N, 2)) at pixels ``(rows, cols)``
    on triangles ``tri`` (N, 3, 3) with vertex uv ``tri_uv`` (N, 3, 2).

    Fine derivatives: along x, uv at the right minus the left pixel of the
    pixel's row in its 2x2 quad; along y, the lower minus the upper pixel
    of its column (rows grow downwards); uv of a neighbour comes from the
    triangle's plane.
    """
    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)

    def uv_at(r, c):
        b = plane_barycentrics(tri, camera.position, pixel_rays(camera, r, c))
        return np.einsum("nk,nkj->nj", b, tri_uv)

    c0, r0 = cols & ~1, rows & ~1
    dx = uv_at(rows, c0 + 1) - uv_at(rows, c0)
    dy = uv_at(r0 + 1, cols) - uv_at(r0, cols)
    return dx, dy


def vertex_tangents(vertices, faces, normals, uv) -> np.ndarray:
    """Unit tangents with handedness, (V, 4): xyz along du, orthogonal to the
    normal; w = +1 or -1 (see the module docstring). A vertex whose
    triangles have degenerate uv gets any unit vector orthogonal to its
    normal and w = +1."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n = np.asarray(normals, dtype=np.float64)
    t_uv = np.asarray(uv, dtype=np.float64)[f]
    tri = v[f]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    d1, d2 = t_uv[:, 1] - t_uv[:, 0], t_uv[:, 2] - t_uv[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    ok = np.abs(det) > 1e-20
    r = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    # Triangles weighted by area: the cross product's length over the uv area.
    area = np.linalg.norm(np.cross(e1, e2), axis=1)[:, None] * np.abs(det)[:, None]
    t_face = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * r * area
    b_face = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * r * area
    t_acc = np.zeros_like(v)
    b_acc = np.zeros_like(v)
    for k in range(3):
        np.add.at(t_acc, f[:, k], t_face)
        np.add.at(b_acc, f[:, k], b_face)
    t = t_acc - n * np.einsum("ij,ij->i", n, t_acc)[:, None]
    length = np.linalg.norm(t, axis=1)
    bad = ~(length > 1e-12 * np.maximum(np.linalg.norm(t_acc, axis=1), 1e-300))
    # Fallback: any unit vector orthogonal to the normal.
    axis = np.where(np.abs(n[:, 0:1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    alt = axis - n * np.einsum("ij,ij->i", n, axis)[:, None]
    t = np.where(bad[:, None], alt, t)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    w = np.where(np.einsum("ij,ij->i", np.cross(n, t), b_acc) < 0, -1.0, 1.0)
    return np.concatenate([t, w[:, None]], axis=1)


def perturb_normals(normal, tangent, sample) -> np.ndarray:
    """World normals (N, 3) from interpolated vertex normals and tangents
    (N, 3) / (N, 4) and filtered tangent-space normal-map samples (N, 3)."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    t = np.asarray(tangent, dtype=np.float64)
    t3 = t[:, :3] - n * np.einsum("ij,ij->i", n, t[:, :3])[:, None]
    tl = np.linalg.norm(t3, axis=1, keepdims=True)
    t3 = t3 / np.where(tl > 0, tl, 1.0)
    w = np.where(t[:, 3] < 0, -1.0, 1.0)[:, None]
    b = np.cross(n, t3) * w
    m = np.asarray(sample, dtype=np.float64)
    out = t3 * m[:, 0:1] + b * m[:, 1:2] + n * m[:, 2:3]
    length = np.linalg.norm(out, axis=1, keepdims=True)
    return np.where(length > 0, out / np.where(length > 0, length, 1.0), n)


def decode_normal_map(image, *, scale: float = 1.0, what: str = "normal map") -> np.ndarray:
    """Tangent-space normals (H, W, 3) in [-1, 1] from a normal-map image.

    ``image``: (H, W, 3/4) uint8/uint16 or float in [0, 1] (colour = (n + 1) / 2,
    *not* sRGB-encoded, as glTF requires); ``scale`` multiplies x and y
    (glTF ``normalTexture.scale``). Returns unit vectors with z >= 0.
    """
    img = np.asarray(image)
    if img.ndim != 3 or img.shape[2] not in (3, 4) or min(img.shape[:2]) < 1:
        raise AquaspecError(f"{what} has shape {img.shape}; accepted: (H, W, 3) or (H, W, 4)")
    img = img[..., :3]
    if img.dtype in (np.uint8, np.uint16):
        x = img.astype(np.float64) / np.iinfo(img.dtype).max
    elif np.issubdtype(img.dtype, np.floating) and np.all(np.isfinite(img)) \
            and img.min() >= 0 and img.max() <= 1:
        x = img.astype(np.float64)
    else:
        raise AquaspecError(f"{what} has dtype {img.dtype} or values outside [0, 1]; "
                            "accepted: uint8, uint16 or float in [0, 1]")
    if not np.isfinite(scale):
        raise AquaspecError(f"{what} scale {scale!r} must be finite")
    n = 2.0 * x - 1.0
    n[..., :2] *= scale
    n[..., 2] = np.maximum(n[..., 2], 0.0)
    length = np.linalg.norm(n, axis=-1, keepdims=True)
    flat = np.array([0.0, 0.0, 1.0])
    return np.where(length > 1e-6, n / np.where(length > 1e-6, length, 1.0), flat)


def height_to_normal_map(height, texel_m: float) -> np.ndarray:
    """Tangent-space normals (H, W, 3) of a repeating height field ``height``
    (H, W) in metres whose texels are ``texel_m`` metres apart; row 0 is the
    top (largest v), so +y of the map is towards row 0."""
    h = np.asarray(height, dtype=np.float64)
    dhdu = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / (2 * texel_m)
    dhdv = (np.roll(h, 1, axis=0) - np.roll(h, -1, axis=0)) / (2 * texel_m)
    n = np.stack([-dhdu, -dhdv, np.ones_like(h)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)
