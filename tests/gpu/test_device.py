"""Adapter choice and the error when there is none."""

from __future__ import annotations

import pytest

from aquaspec.errors import GPUUnavailableError
from aquaspec.gpu import device


class FakeAdapter:
    def __init__(self, name, kind):
        self.info = {"device": name, "adapter_type": kind, "backend_type": "Vulkan"}


ADAPTERS = [FakeAdapter("llvmpipe (LLVM 15)", "CPU"), FakeAdapter("Big GPU 9000", "DiscreteGPU")]


def test_prefers_a_real_gpu():
    assert device._choose(ADAPTERS, None).info["device"] == "Big GPU 9000"


@pytest.mark.parametrize("want,name", [("cpu", "llvmpipe (LLVM 15)"), ("gpu", "Big GPU 9000"),
                                       ("llvm", "llvmpipe (LLVM 15)")])
def test_forced(want, name):
    assert device._choose(ADAPTERS, want).info["device"] == name


def test_forced_unknown():
    with pytest.raises(GPUUnavailableError, match="AQUASPEC_ADAPTER='tpu'.*llvmpipe"):
        device._choose(ADAPTERS, "tpu")


def test_no_adapter_names_the_package(monkeypatch):
    import wgpu
    import wgpu.backends.auto  # noqa: F401  (wgpu.gpu is the backend's, not the stand-in
    #                                         that replaces itself on first use)
    monkeypatch.setattr(wgpu.gpu, "enumerate_adapters_sync", lambda: [])
    device.get_device.cache_clear()
    try:
        with pytest.raises(GPUUnavailableError, match="mesa-vulkan-drivers"):
            device.get_device()
    finally:
        device.get_device.cache_clear()


@pytest.mark.gpu
def test_white_patch_makes_a_grey_card_neutral():
    import numpy as np
    from aquaspec.rendering.api import render
    res = render(water="3C", depth_m=9.0, size=(64, 36), bands=8, white_balance="white-patch",
                 sensor="nikon-5100-npl")
    gains = np.array(res.params["display"]["white_balance_gains"])
    assert gains[0] > gains[1] and gains[0] > gains[2]   # green water: red is boosted
