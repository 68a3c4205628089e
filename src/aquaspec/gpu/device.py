"""Choosing a wgpu adapter and device.

A real GPU is used when present; on machines without one, Mesa's lavapipe
Vulkan driver runs the same WGSL on the CPU. ``AQUASPEC_ADAPTER`` forces a
choice: ``gpu`` (a discrete or integrated GPU), ``cpu`` (a software adapter
such as lavapipe), or a substring of the adapter's device name.

wgpu falls back to OpenGL when no Vulkan driver is installed; its OpenGL
backend is a "downlevel" one without the float storage textures the passes
write (Rgba32Float), so OpenGL adapters are never chosen and, when they are
all there is, the error says which driver to install.
"""

from __future__ import annotations

import functools
import os
import tempfile

import wgpu

from aquaspec.errors import GPUUnavailableError
from aquaspec.gpu import ffi_types

ADAPTER_ENV = "AQUASPEC_ADAPTER"
_DEBIAN_HINT = ("install a Vulkan driver (on Debian/Ubuntu without a GPU: "
                "sudo apt-get install -y mesa-vulkan-drivers libvulkan1), or render with "
                "--backend numpy (backend='numpy'), the slower reference")
#: wgpu backends whose adapters lack what the passes need (downlevel).
UNSUPPORTED_BACKENDS = ("OpenGL",)


def _ensure_runtime_dir():
    # wgpu's Vulkan loader warns when XDG_RUNTIME_DIR is unset or unwritable.
    d = os.environ.get("XDG_RUNTIME_DIR")
    if not d or not os.access(d, os.W_OK):
        d = os.path.join(tempfile.gettempdir(), f"aquaspec-xdg-{os.getuid()}")
        os.makedirs(d, mode=0o700, exist_ok=True)
        os.environ["XDG_RUNTIME_DIR"] = d


def _choose(adapters, want: str | None):
    usable = [a for a in adapters if a.info.get("backend_type") not in UNSUPPORTED_BACKENDS]
    if adapters and not usable:
        names = ", ".join(f"{a.info.get('device')} ({a.info.get('backend_type')})"
                          for a in adapters)
        raise GPUUnavailableError(
            f"no Vulkan adapter found, only {names}, whose limits aquaspec's passes exceed "
            f"(no float storage textures); {_DEBIAN_HINT}")
    adapters = usable
    vulkan_first = sorted(adapters, key=lambda a: a.info.get("backend_type") != "Vulkan")
    if not want:
        hw = [a for a in vulkan_first if a.info.get("adapter_type") in
              ("DiscreteGPU", "IntegratedGPU")]
        return (hw or vulkan_first)[0]
    w = want.lower()
    if w == "gpu":
        picked = [a for a in vulkan_first if a.info.get("adapter_type") in
                  ("DiscreteGPU", "IntegratedGPU")]
    elif w == "cpu":
        picked = [a for a in vulkan_first if a.info.get("adapter_type") == "CPU"]
    else:
        picked = [a for a in vulkan_first if w in a.info.get("device", "").lower()]
    if not picked:
        names = ", ".join(f"{a.info.get('device')} ({a.info.get('adapter_type')})"
                          for a in adapters) or "none"
        raise GPUUnavailableError(
            f"{ADAPTER_ENV}={want!r} matches no adapter; accepted: 'gpu', 'cpu' "
            f"or part of a device name; available: {names}")
    return picked[0]


@functools.lru_cache(maxsize=1)
def get_device():
    """The shared ``(adapter, device)`` pair, created on first use."""
    _ensure_runtime_dir()
    # (About 1.2 s less start-up per process: see ffi_types.)
    ffi_types.install()
    try:
        adapters = wgpu.gpu.enumerate_adapters_sync()
    except Exception as exc:  # the native library raises various types
        raise GPUUnavailableError(f"no wgpu adapter could be listed ({exc}); {_DEBIAN_HINT}") from exc
    if not adapters:
        raise GPUUnavailableError(f"no wgpu adapter found; {_DEBIAN_HINT}")
    adapter = _choose(adapters, os.environ.get(ADAPTER_ENV))
    limits = {}
    for key in ("max-storage-buffer-binding-size", "max-buffer-size",
                "max-texture-dimension-2d", "max-storage-buffers-per-shader-stage"):
        if key in adapter.limits:
            limits[key] = adapter.limits[key]
    # float32-filterable: the light-field pass samples its float tables with
    # bilinear filtering when the device allows it (else it interpolates itself).
    features = [f for f in ("timestamp-query", "float32-filterable") if f in adapter.features]
    device = adapter.request_device_sync(required_limits=limits,
                                         required_features=features)
    return adapter, device


def max_texture_size() -> int:
    """The device's largest 2-D texture side, texels."""
    _, device = get_device()
    return int(device.limits["max-texture-dimension-2d"])


def adapter_info() -> dict:
    """Name, type and backend of the adapter in use (for sidecars and bench)."""
    adapter, _ = get_device()
    info = adapter.info
    return {k: info.get(k) for k in ("device", "adapter_type", "backend_type", "description")}
