"""Procedural detail for the built-in scenes: tileable noise, sand and fouling
textures, rocks with crevices, seagrass blades, a fouled pipe.

Everything is seeded (``numpy.random.Generator``) and made here; nothing is
downloaded. Units: metres, y up. Textures are linear RGB in [0, 1] with
tangent-space normal maps (:mod:`aquaspec.scene.texture`), both repeating.
"""

from __future__ import annotations

import numpy as np

from aquaspec.scene.mesh import Mesh
from aquaspec.scene.texture import height_to_normal_map


def tileable_noise(rng, n: int, cells: int) -> np.ndarray:
    """Periodic value noise (n, n) in [-1, 1]: random values on a ``cells`` x
    ``cells`` lattice, interpolated with a smoothstep, wrapping at the edges."""
    lattice = rng.uniform(-1.0, 1.0, (cells, cells))
    x = np.arange(n) * cells / n
    i0 = np.floor(x).astype(int)
    f = x - i0
    f = f * f * (3 - 2 * f)
    i1 = (i0 + 1) % cells
    rows = lattice[i0] * (1 - f)[:, None] + lattice[i1] * f[:, None]
    return rows[:, i0] * (1 - f)[None, :] + rows[:, i1] * f[None, :]


def fbm(rng, n: int, base_cells: int, octaves: int, gain: float = 0.5) -> np.ndarray:
    """Fractal sum of :func:`tileable_noise` octaves (each twice as fine), (n, n),
    normalised to a maximum magnitude of 1."""
    out = np.zeros((n, n))
    amp = 1.0
    for k in range(octaves):
        cells = min(base_cells * 2 ** k, n)
        out += amp * tileable_noise(rng, n, cells)
        amp *= gain
    return out / np.abs(out).max()


def sand_maps(rng, rgb, *, n: int = 256, tile_m: float = 1.6, ripple_m: float = 0.16,
              ripple_height_m: float = 0.012):
    """Texture and normal map of rippled sand over a ``tile_m`` square tile.

    Ripples: crests ``ripple_m`` apart (wave ripples are 0.05-0.2 m apart and
    a few centimetres high), bent by low-frequency noise; grain: fine noise
    in the height and a speckle of darker and lighter grains in the colour,
    the troughs a little darker (finer, darker sediment settles there).
    Returns ``(texture (n, n, 3), normal_map (n, n, 3), height (n, n) m)``.
    """
    y, x = np.mgrid[0:n, 0:n] / n * tile_m
    waves = round(tile_m / ripple_m)
    bend = 0.6 * fbm(rng, n, 2, 3)
    phase = 2 * np.pi * (waves * x / tile_m + bend)
    # Asymmetric ripple profile: steeper lee side.
    ripple = np.sin(phase) + 0.25 * np.sin(2 * phase)
    grain = fbm(rng, n, 64, 2)
    height = 0.5 * ripple_height_m * ripple + 0.0008 * grain
    normal = height_to_normal_map(height, tile_m / n)
    speckle = rng.normal(0.0, 1.0, (n, n))
    shade = 1.0 + 0.10 * fbm(rng, n, 4, 3) + 0.06 * np.clip(speckle, -2.5, 2.5) \
        + 0.08 * ripple / 1.25
    dark_grains = rng.uniform(size=(n, n)) < 0.015
    shade = np.where(dark_grains, 0.45, shade)
    tex = np.clip(np.asarray(rgb, float)[None, None, :] * shade[..., None], 0.0, 1.0)
    return tex.astype(np.float32), normal.astype(np.float32), height


def fouling_maps(rng, base_rgb, growth_rgb, *, n: int = 128, cover: float = 0.45):
    """Texture and normal map of a fouled surface (rusty metal under patches of
    encrusting growth): growth where a noise field exceeds a threshold set
    so that about ``cover`` of the surface is covered; the growth is raised
    (bumps in the normal map). Returns ``(texture, normal_map, growth)``,
    ``growth`` (n, n) in [0, 1] (1: covered)."""
    field = fbm(rng, n, 4, 4)
    threshold = np.quantile(field, 1.0 - cover)
    growth = np.clip((field - threshold) / 0.08, 0.0, 1.0)
    streaks = 1.0 + 0.15 * fbm(rng, n, 8, 3)
    base = np.asarray(base_rgb, float) * streaks[..., None]
    lumps = growth * (0.6 + 0.4 * fbm(rng, n, 32, 2))
    tex = base * (1 - growth[..., None]) + np.asarray(growth_rgb, float) * growth[..., None] \
        * (0.8 + 0.3 * lumps[..., None])
    normal = height_to_normal_map(0.004 * lumps, 1.0 / n)
    return np.clip(tex, 0, 1).astype(np.float32), normal.astype(np.float32), growth


def _noise3(rng, n_waves: int, wavelength_m):
    d = rng.normal(size=(n_waves, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    lam = np.exp(rng.uniform(np.log(wavelength_m[0]), np.log(wavelength_m[1]), n_waves))
    phase = rng.uniform(0, 2 * np.pi, n_waves)
    amp = lam / lam.max()

    def f(p):
        return np.sin(p @ (d.T * (2 * np.pi / lam)) + phase) @ amp / np.sqrt(n_waves)
    return f


def crevice_rock(rng, sphere_v, sphere_f, size_m, centre, rotation, rgb, *,
                 name="rock") -> Mesh:
    """A rock: a unit icosphere (``sphere_v``, ``sphere_f``) flattened and
    displaced by a smooth field plus *ridged* noise (``-|noise|``: narrow
    creases, the crevices), scaled to ``size_m`` and placed. Its colour
    varies per vertex: darker in the crevices, lighter on the tops where
    encrusting growth catches light."""
    smooth = _noise3(rng, 10, (0.6, 2.5))
    ridged = _noise3(rng, 14, (0.15, 0.6))
    v = np.asarray(sphere_v, float)
    crease = np.abs(ridged(v))                    # 0 on the crease lines
    crevice = np.exp(-crease / 0.12)              # 1 in a crevice
    r = 1.0 + 0.18 * smooth(v) - 0.16 * crevice
    scale = size_m / 2 * np.array([rng.uniform(0.8, 1.2), rng.uniform(0.45, 0.7),
                                   rng.uniform(0.7, 1.0)])
    p = (v * r[:, None]) * scale
    p = p @ rotation.T + np.asarray(centre, float)
    up = np.clip(v[:, 1], 0, 1)
    shade = (1.0 - 0.55 * crevice) * (0.85 + 0.3 * up) * (1 + 0.15 * smooth(3.1 * v))
    colour = np.clip(np.asarray(rgb, float)[None] * shade[:, None], 0.0, 1.0)
    return Mesh(p, sphere_f, vertex_rgb=colour, name=name)


def blade_strips(rng, roots, *, length_m=(0.25, 0.7), width_m=0.025, segments=5,
                 current=(0.3, 0.0, -0.1)):
    """Seagrass / algae blades: one ribbon of ``segments`` quads per root point
    (N, 3), rising from the seabed and bending with the ``current``
    direction (unitless lean per metre of height). Returns one
    ``(vertices, faces)`` pair for all blades (double-sided: the geometry
    pass shades the side the camera sees)."""
    roots = np.asarray(roots, float)
    verts, faces = [], []
    lean_dir = np.asarray(current, float)
    for k, root in enumerate(roots):
        length = rng.uniform(*length_m)
        heading = rng.uniform(0, 2 * np.pi)
        across = np.array([np.cos(heading), 0.0, np.sin(heading)])
        lean = lean_dir * rng.uniform(0.6, 1.4) + 0.15 * rng.normal(size=3) * [1, 0, 1]
        t = np.linspace(0.0, 1.0, segments + 1)
        centre = root[None] + np.stack([np.zeros_like(t), t * length, np.zeros_like(t)], 1) \
            + (t ** 2 * length)[:, None] * lean[None]
        w = width_m * (1.0 - 0.7 * t)[:, None] / 2
        left, right = centre - w * across, centre + w * across
        base = sum(len(a) for a in verts)
        verts.append(np.concatenate([left, right]))
        i = np.arange(segments)
        a, b = base + i, base + i + 1
        c, d = base + segments + 1 + i, base + segments + 2 + i
        faces.append(np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)]))
    return np.concatenate(verts), np.concatenate(faces)


def pipe_mesh(radius, length, centre, rotation, *, segments=40, rings=24, uv_scale=(1.0, 4.0),
              name="pipe", **kwargs) -> Mesh:
    """An open cylinder along its local y with uv (u around, v along; the seam
    has its own vertices so the uv does not jump), smooth normals."""
    a = np.linspace(0, 2 * np.pi, segments + 1)
    yv = np.linspace(-length / 2, length / 2, rings + 1)
    aa, yy = np.meshgrid(a, yv)
    ring = np.stack([np.cos(aa), np.zeros_like(aa), np.sin(aa)], -1)
    v = (ring * radius + yy[..., None] * np.array([0, 1.0, 0])).reshape(-1, 3)
    n = ring.reshape(-1, 3)
    uv = np.stack([aa / (2 * np.pi) * uv_scale[0], (yy / length + 0.5) * uv_scale[1]],
                  -1).reshape(-1, 2)
    idx = np.arange(v.shape[0]).reshape(rings + 1, segments + 1)
    p, q = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    r, s = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([p, r, q], 1), np.stack([q, r, s], 1)])
    return Mesh(v @ rotation.T + np.asarray(centre, float), faces, n @ rotation.T, uv=uv,
                name=name, **kwargs)


def split_by_face(mesh: Mesh, labels, materials, names) -> list:
    """``mesh`` cut into one mesh per label (faces with ``labels == k`` get
    ``materials[k]`` and ``names[k]``; empty parts are dropped). The parts
    share the vertices, normals, uv and normal map: colour varies per face
    with single-material meshes, which keeps the G-buffer and the shading
    on their one-material paths (per-pixel materials cost about a fifth of
    a frame on lavapipe)."""
    labels = np.asarray(labels)
    out = []
    for k, (material, name) in enumerate(zip(materials, names)):
        faces = mesh.faces[labels == k]
        if len(faces):
            out.append(Mesh(mesh.vertices, faces, mesh.normals, material, mesh.uv, None, None,
                            name, mesh.normal_map))
    return out


def rock_face_labels(rock: Mesh, rng, *, crevice_shade: float = 0.75,
                     encrusted: float = 0.35) -> np.ndarray:
    """Per face of a :func:`crevice_rock`: 0 bare rock, 1 crevice (its vertex
    colours darker than ``crevice_shade`` of the rock's median), 2 encrusted
    (an upward-facing face, about ``encrusted`` of them, in patches)."""
    lum = rock.vertex_rgb.mean(axis=1)[rock.faces].mean(axis=1)
    up = rock.normals[rock.faces].mean(axis=1)[:, 1]
    patch = _noise3(rng, 8, (0.3, 1.2))(rock.vertices[rock.faces].mean(axis=1))
    labels = np.zeros(len(rock.faces), int)
    labels[(up > 0.35) & (patch > np.quantile(patch, 1.0 - encrusted))] = 2
    labels[lum < crevice_shade * np.median(lum)] = 1
    return labels
