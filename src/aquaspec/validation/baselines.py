"""Baselines rendered through the same scenes as aquaspec's spectral model.

- ``rgb``: aquaspec's own model with n = 3 wideband bands (the thesis's
  "RGB implementation"): just ``Bands(3)`` through the same code.
- ``unreal``: the single-layer water of Unreal Engine (seed 004): per RGB
  channel, ``L = T L_surf + scattering (1 - T) / extinction * incoming``
  with ``T = exp(-extinction S)``. As in the engine, the scene behind the
  water is lit by the light above it (``E0``, no attenuation with depth)
  and ``incoming`` is that light, ``E0 / (4 pi)`` per unit scattering
  (isotropic).
- ``ifm``: the image-formation model of most underwater synthesis tools,
  ``I = J exp(-beta z) + B_inf (1 - exp(-beta z))``, per channel: ``J`` is
  the object's unattenuated radiance (lit like aquaspec's surfaces), ``z``
  the distance, ``beta`` the camera-weighted extinction and ``B_inf`` the
  camera RGB of open water seen horizontally at the camera's depth.

Camera-weighted wideband coefficients: ``x_c = sum_i w_i R_c,i x_i /
sum_i w_i R_c,i`` over fine bands (``REFERENCE_BANDS``).
"""

from __future__ import annotations

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.transport import monzon2022 as model

BASELINES = ("rgb", "unreal", "ifm")
FINE = Bands(60)


def wideband(values_fine, weights_fine):
    """Camera-weighted average of a per-band quantity: (n,) x (n, 3) -> (3,)."""
    w = np.clip(np.asarray(weights_fine, dtype=float), 0.0, None)
    return (np.asarray(values_fine, dtype=float) @ w) / np.maximum(w.sum(axis=0), 1e-300)


def _rgb_inputs(water, light, sensor):
    bw = water.on_bands(FINE)
    w = sensor.band_weights(FINE, outside="zero")
    e0 = light.on_bands(FINE)
    coeffs = {k: wideband(getattr(bw, k), w) for k in ("a", "b", "kd")}
    coeffs["c"] = coeffs["a"] + coeffs["b"]
    e0_rgb = e0 @ w                        # camera RGB of E0 (per-channel "irradiance")
    return coeffs, e0_rgb, w


def render_baseline(method, gbuffer, water, light, sensor, *, ambient=model.DEFAULT_AMBIENT):
    """Linear camera RGB (H, W, 3) of a G-buffer by baseline ``method``."""
    if method not in ("unreal", "ifm"):
        raise AquaspecError(f"unknown baseline {method!r}; accepted: unreal, ifm "
                            "(the 'rgb' baseline is aquaspec with bands=3)")
    cam = gbuffer.camera
    d_o = cam.depth_m
    coeffs, e0_rgb, w = _rgb_inputs(water, light, sensor)
    c, b, kd = coeffs["c"], coeffs["b"], coeffs["kd"]
    dirs = cam.ray_directions()
    s = gbuffer.distance.astype(float)[..., None]
    hit = np.isfinite(s)
    s_f = np.where(hit, s, 0.0)
    surf_depth = np.where(hit, -(cam.position[1] + s_f * dirs[..., 1:2]), d_o)
    n_y = gbuffer.normal[..., 1:2].astype(float)
    rho = np.zeros(s.shape[:2] + (3,))
    for m, mat in enumerate(gbuffer.materials):
        sel = gbuffer.material == m
        rho[sel] = wideband(mat.on_bands(FINE), w)
    t = np.where(hit, np.exp(-c * s_f), 0.0)
    if method == "unreal":
        j_air = model.lambertian_radiance(rho, model.ambient_irradiance(
            e0_rgb, 0.0, 0.0, n_y, ambient))
        return t * j_air + b * (1 - t) / c * e0_rgb / (4 * np.pi)
    j_surf = model.lambertian_radiance(
        rho, model.ambient_irradiance(e0_rgb, kd, surf_depth, n_y, ambient))
    b_inf = b * e0_rgb / (4 * np.pi) * np.exp(-kd * d_o) / c
    return t * j_surf + b_inf * (1 - t)
