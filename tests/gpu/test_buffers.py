"""GPU buffers and textures: round trips through the device."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.errors import AquaspecError


class TestBufferHelpers:
    def test_storage_round_trip(self, device):
        from aquaspec.gpu.buffers import create_storage_buffer, read_buffer, upload_buffer
        data = np.arange(10, dtype=np.float32) * 1.5
        buf = create_storage_buffer(device, data, label="round trip")
        assert buf.size % 16 == 0 and buf.size >= data.nbytes
        np.testing.assert_array_equal(read_buffer(device, buf, np.float32, (10,)), data)
        upload_buffer(device, buf, np.array([7, 8], dtype=np.uint32), offset=8)
        back = read_buffer(device, buf, np.uint32, (10,))
        assert back[2:4].tolist() == [7, 8]
        with pytest.raises(AquaspecError, match="do not fit"):
            upload_buffer(device, buf, np.zeros(100, np.float32))
        with pytest.raises(AquaspecError, match="needs"):
            read_buffer(device, buf, np.float32, (100,))

    def test_texture_round_trip(self, device):
        from aquaspec.gpu.buffers import create_texture, read_texture, upload_texture
        # 5 x 3 rgba32float: rows of 80 bytes, not a multiple of 256.
        data = np.random.default_rng(0).random((3, 5, 4)).astype(np.float32)
        tex = create_texture(device, 5, 3, "rgba32float", label="round trip")
        upload_texture(device, tex, data)
        np.testing.assert_array_equal(read_texture(device, tex, np.float32, 4), data)
        with pytest.raises(AquaspecError, match="5x3"):
            upload_texture(device, tex, data[:2])
