"""The G-buffer's texture format: the host packing of the surface texel."""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.gbuffer import (oct_decode, oct_encode, pack_snorm16x2, unpack_snorm16x2,
                                  unpack_surface)


class TestSurfacePacking:
    def test_octahedral_round_trip(self):
        """Host packing of the surface texel: n_y exact, the rest within 16-bit quantisation."""
        rng = np.random.default_rng(3)
        n = rng.normal(size=(4000, 3))
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        n[:6] = [[0, 1, 0], [0, -1, 0], [1, 0, 0], [0, 0, -1], [-0.6, 0, 0.8], [0, 0.6, -0.8]]
        np.testing.assert_allclose(oct_decode(oct_encode(n)), n, atol=1e-12)
        words = pack_snorm16x2(oct_encode(n))
        assert np.abs(unpack_snorm16x2(words) - oct_encode(n)).max() <= 0.5 / 32767 + 1e-12
        surface = np.zeros((len(n), 4), np.uint32)
        surface[:, 0] = np.float32(2.5).view(np.uint32)
        surface[:, 1] = n[:, 1].astype(np.float32).view(np.uint32)
        surface[:, 2] = words
        surface[:, 3] = 7
        distance, normal, material = unpack_surface(surface)
        np.testing.assert_array_equal(normal[:, 1], n[:, 1].astype(np.float32))
        np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-12)
        np.testing.assert_allclose(normal, n, atol=1e-4)
        assert np.all(distance == 2.5) and np.all(material == 7)
