"""Write a procedural textured crate as a GLB (base colour, normal map, metallic-roughness).

The gallery's "user's textured glTF" (docs/gallery.md): a 0.8 m wooden crate
whose planks, gaps and nail heads are drawn here (seeded, nothing downloaded)
and stored as glTF 2.0 PBR textures, as an asset from a modelling tool
would be. Usage: python tools/textured_crate_glb.py OUT.glb [--seed N]
"""

from __future__ import annotations

import argparse

import numpy as np
import trimesh
from PIL import Image

from aquaspec.scene.procedural import fbm
from aquaspec.scene.texture import height_to_normal_map


def crate_maps(seed: int, n: int = 256):
    """(base colour uint8 (n, n, 3), normal map uint8 (n, n, 3)) of five planks."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:n, 0:n] / n
    plank = np.floor(y * 5).astype(int)
    gap = np.abs((y * 5) % 1.0 - 0.5) > 0.47
    grain = fbm(rng, n, 4, 4)
    streak = np.sin(2 * np.pi * (x * 3 + 0.8 * grain)) * 0.5 + 0.5
    tone = rng.uniform(0.8, 1.2, 5)[plank]
    wood = np.array([0.55, 0.36, 0.20])[None, None] * (tone * (0.75 + 0.25 * streak))[..., None]
    nails = (((x * 8) % 1 - 0.5) ** 2 + ((y * 5) % 1 - 0.5) ** 2 < 0.004) & (
        np.abs((x * 8) % 1 - 0.5) < 0.1)
    colour = np.where(gap[..., None], 0.08, wood)
    colour = np.where(nails[..., None], 0.25, colour)
    height = -0.002 * gap + 0.0004 * grain + 0.001 * nails
    normal = height_to_normal_map(height, 0.8 / n)
    srgb = np.clip(colour, 0, 1) ** (1 / 2.2)
    return ((srgb * 255).round().astype(np.uint8),
            ((normal + 1) / 2 * 255).round().astype(np.uint8))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args(argv)
    colour, normal = crate_maps(a.seed)
    box = trimesh.creation.box((0.8, 0.8, 0.8))
    box = trimesh.Trimesh(box.vertices[box.faces].reshape(-1, 3),
                          np.arange(3 * len(box.faces)).reshape(-1, 3), process=False)
    # Each face gets the whole texture: uv from the two axes it spans.
    fn = np.repeat(box.face_normals, 3, axis=0)
    axis = np.argmax(np.abs(fn), axis=1)
    v = box.vertices / 0.8 + 0.5
    uv = np.where((axis == 0)[:, None], v[:, [2, 1]],
                  np.where((axis == 1)[:, None], v[:, [0, 2]], v[:, [0, 1]]))
    material = trimesh.visual.material.PBRMaterial(
        baseColorTexture=Image.fromarray(colour), normalTexture=Image.fromarray(normal),
        metallicFactor=0.0, roughnessFactor=0.9)
    box.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    # Turned 35 degrees about the vertical, so that two sides show.
    box.apply_transform(trimesh.transformations.rotation_matrix(np.radians(35), [0, 1, 0]))
    box.export(a.out)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
