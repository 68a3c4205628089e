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


class FakeGLAdapter(FakeAdapter):
    def __init__(self, name):
        super().__init__(name, "CPU")
        self.info["backend_type"] = "OpenGL"


def test_opengl_fallback_is_refused_naming_the_driver():
    """wgpu falls back to OpenGL without a Vulkan driver; its downlevel
    adapter cannot run the passes, so the error says what to install."""
    with pytest.raises(GPUUnavailableError, match=r"no Vulkan adapter found, only llvmpipe "
                       r"\(OpenGL\).*mesa-vulkan-drivers libvulkan1.*--backend numpy"):
        device._choose([FakeGLAdapter("llvmpipe")], None)


def test_opengl_adapters_are_passed_over():
    adapters = [FakeGLAdapter("Big GPU 9000 GL"), FakeAdapter("llvmpipe (LLVM 15)", "CPU")]
    assert device._choose(adapters, None).info["device"] == "llvmpipe (LLVM 15)"
    with pytest.raises(GPUUnavailableError, match="matches no adapter"):
        device._choose(adapters, "9000")


def test_without_a_vulkan_driver_the_cli_says_what_to_install(tmp_path):
    """The real case: no Vulkan ICD, so wgpu offers only its OpenGL adapter
    (or none): exit status 2, one line, the packages named, nothing written."""
    import os
    import subprocess
    import sys
    env = {**os.environ, "VK_ICD_FILENAMES": str(tmp_path / "nonexistent.json")}
    done = subprocess.run([sys.executable, "-m", "aquaspec", "render", "--size", "8x6",
                           "--bands", "3", "-o", str(tmp_path / "x.png")],
                          capture_output=True, text=True, env=env, timeout=120)
    assert done.returncode == 2, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("aquaspec render: error: no ") and "Traceback" not in done.stderr
    assert "mesa-vulkan-drivers libvulkan1" in last and "--backend numpy" in last
    assert not (tmp_path / "x.png").exists()


@pytest.mark.gpu
def test_max_texture_size(device):
    from aquaspec.gpu.device import max_texture_size
    assert max_texture_size() == device.limits["max-texture-dimension-2d"] >= 2048
