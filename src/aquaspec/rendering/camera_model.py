"""``render(camera_model=...)``: the image through a real camera's port, lens and sensor.

A :class:`aquaspec.optics.presets.CameraModel` turns the renderer's pinhole
into an underwater camera, in two steps around the shading:

1. :func:`camera_view`, before shading: behind a flat port the pinhole is
   rendered *in water* with a narrower field of view (the sensor's focal
   lengths divided by the port's ratio,
   :func:`aquaspec.optics.remap.water_intrinsics`); a dome or no port keeps
   the camera as it is.
2. :func:`through_camera`, after shading (and after the image-formation
   layers, which stay in the pinhole's pixels, as does the G-buffer):

   - the flat port's image: per band when the band radiance is at hand
     (``return_radiance``), otherwise per camera channel at the channel's
     response-weighted mean wavelength (the GPU's default output is camera
     RGB: the spread of the port's lateral colour *within* a channel is
     then left out; :mod:`aquaspec.optics.remap`);
   - the lens: depth of field from each pixel's distance (the G-buffer's,
     seen through the port as its virtual image) and cos^4 vignetting
     (:mod:`aquaspec.optics.lens`);
   - the sensor, in camera RGB before any white balance: photoelectrons
     (:mod:`aquaspec.optics.exposure`), auto or fixed exposure, EMVA 1288
     noise and ADC (:mod:`aquaspec.optics.sensor`), seeded.

The result's ``linear_rgb`` is then the camera's raw frame as linear camera
RGB in the renderer's units (noisy, black level and dark signal taken off,
divided by the gain and the electrons per unit RGB: the display settings
keep their meaning); ``raw`` holds the digital numbers themselves.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.errors import AquaspecError
from aquaspec.optics.dome_port import DomePort
from aquaspec.optics.exposure import auto_exposure, electron_rate
from aquaspec.optics.flat_port import FlatPort
from aquaspec.optics.lens import defocus
from aquaspec.optics.presets import CameraModel, get_camera_model
from aquaspec.optics.remap import (Intrinsics, axial_depth, port_coordinates, port_image,
                                   sample, water_intrinsics)
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera


@dataclass(frozen=True)
class CameraPass:
    """A camera model on one render: the sensor's camera (in air) and the
    pinhole rendered (in water behind a flat port, else the same)."""

    model: CameraModel
    sensor_camera: Camera
    water_camera: Camera


def camera_view(view, camera_model, setup: SpectralSetup):
    """Step 1: ``(view, CameraPass or None)``; ``view`` (render's ``_View``) with
    the pinhole in water a flat port needs."""
    model = get_camera_model(camera_model)
    if model is None:
        return view, None
    cam = view.camera
    if isinstance(model.port, FlatPort):
        if view.from_rgbd:
            raise AquaspecError("a flat port needs a render made for it (a narrower field "
                                "in water); an RGB-D photograph has its own view; accepted: "
                                "a camera model with a dome port with an RGB-D image")
        water = water_intrinsics(Intrinsics.of(cam), model.port, setup.bands.centers_nm,
                                 model.min_distance_m)
        view = dataclasses.replace(view, camera=dataclasses.replace(cam, fx=water.fx,
                                                                     fy=water.fy))
    return view, CameraPass(model, cam, view.camera)


def channel_wavelengths(setup: SpectralSetup) -> np.ndarray:
    """Each camera channel's mean wavelength weighted by its (positive) response, nm."""
    weights = np.clip(setup.sensor.band_weights(setup.bands, outside=setup.outside), 0, None)
    total = weights.sum(axis=0)
    lam = setup.bands.centers_nm
    return np.where(total > 0, lam @ weights / np.where(total > 0, total, 1.0), lam.mean())


def _distance(shaded, view) -> np.ndarray:
    """The pinhole render's ray distances, m (inf: open water)."""
    gbuffer = shaded.gbuffer if shaded.gbuffer is not None else view.gbuffer
    if gbuffer is None:
        r = shaded.renderer
        gbuffer = r.raster.read_gbuffer(view.scene, view.camera, r.deferred.gbuffer.textures)
        shaded.gbuffer = gbuffer
    return np.asarray(gbuffer.distance, dtype=float)


def through_camera(cp: CameraPass | None, shaded, setup: SpectralSetup, view, say):
    """Step 2: ``(shaded, raw, params)``: ``shaded`` with the camera's linear
    image (and port-resampled radiance), the raw digital numbers (uint16) and
    the camera's parameters for the sidecar; ``(shaded, None, {})`` without a
    camera model."""
    if cp is None:
        return shaded, None, {}
    model = cp.model
    say(f"camera model {model.name}: port, lens and sensor")
    sensor_i, water_i = Intrinsics.of(cp.sensor_camera), Intrinsics.of(cp.water_camera)
    lam_c = channel_wavelengths(setup)
    distance = _distance(shaded, view)
    linear, radiance = shaded.linear, shaded.radiance
    tx, ty = sensor_i.tangents()
    rho = np.hypot(tx, ty)[..., None]
    port, centres = model.port, setup.bands.centers_nm
    if isinstance(port, FlatPort):
        z = axial_depth(distance, water_i)
        if radiance is not None:
            radiance = (port_image(radiance, centres, port, sensor_i, water_i, z)
                        * port.radiance_factor(rho, centres))
        else:
            linear = (port_image(linear, lam_c, port, sensor_i, water_i, z)
                      * port.radiance_factor(rho, lam_c))
        row, col = port_coordinates(port, sensor_i, water_i, float(lam_c[1]), z)
        z_port = sample(z, row, col, order=0)
    else:
        if isinstance(port, DomePort):
            if radiance is not None:
                radiance = radiance * port.radiance_factor(centres)
            else:
                linear = linear * port.radiance_factor(lam_c)
        z_port = axial_depth(distance, water_i)
    if radiance is not None and port is not None:
        linear = radiance_to_rgb(radiance, setup.sensor.band_weights(setup.bands,
                                                                     outside=setup.outside))
    linear = _lens(model, linear, z_port, tx, ty, float(lam_c[1]), sensor_i.fx)
    raw, noisy, info = _expose(model, linear, lam_c, setup)
    info["pinhole_in_water"] = cp.water_camera.describe()
    info["channel_wavelength_nm"] = lam_c.tolist()
    # The image is the sensor camera's: its intrinsics in the sidecar, not the pinhole's.
    return (dataclasses.replace(shaded, linear=noisy, radiance=radiance), raw,
            {"camera": cp.sensor_camera.describe(),
             "camera_model": {**model.describe(), **info}})


def _virtual_axial(model: CameraModel, z_axial, tan_air, lam):
    """Axial distance of the virtual image the lens sees of a surface at axial
    depth ``z_axial`` in water (the port's), m; and of the focus distance."""
    port, focus = model.port, model.lens.focus_distance_m
    cos_a = 1.0 / np.sqrt(1.0 + tan_air ** 2)
    if isinstance(port, FlatPort):
        n_w, _ = port.indices(lam)
        cos_w = np.sqrt(1.0 - (np.sin(np.arctan(tan_air)) / n_w) ** 2)
        front = port.gap_m + port.thickness_m
        s_w = np.maximum(z_axial - front, 0.0) / cos_w
        virtual = port.virtual_distance(tan_air, lam, s_w) * cos_a
        return virtual, float(port.virtual_distance(0.0, lam, max(focus - front, 0.0)))
    if isinstance(port, DomePort):
        reach = np.maximum(z_axial / cos_a, 1.01 * port.radius_m)
        return (port.virtual_distance(reach, lam) * cos_a,
                float(port.virtual_distance(max(focus, 1.01 * port.radius_m), lam)))
    return z_axial, focus


def _lens(model: CameraModel, linear, z_axial, tx, ty, lam, f_px):
    """Depth of field and vignetting on the port's image."""
    lens = model.lens
    if model.depth_of_field:
        virtual, focus = _virtual_axial(model, z_axial, np.hypot(tx, ty), lam)
        linear = defocus(linear, lens.blur_diameter_px(virtual, focus, f_px))
    return linear * lens.vignetting_factor(tx, ty)[..., None]


def electrons_per_unit(model: CameraModel, lam_c, setup: SpectralSetup) -> np.ndarray:
    """Photoelectrons per second per unit of each channel's camera RGB (3,)
    (:func:`aquaspec.optics.exposure.electron_rate`)."""
    s = model.sensor
    response_max = float(np.max(setup.sensor.on_bands(setup.bands, outside=setup.outside)))
    return electron_rate(np.ones(3), lam_c, response_max, f_number=model.lens.f_number,
                         transmittance=model.lens.transmittance,
                         pixel_pitch_um=s.pixel_pitch_um, quantum_efficiency=s.quantum_efficiency)


def _expose(model: CameraModel, linear, lam_c, setup: SpectralSetup):
    """The sensor: ``(raw DN uint16, noisy linear camera RGB, info)``."""
    s = model.sensor
    per_unit = electrons_per_unit(model, lam_c, setup)
    rate = np.clip(linear, 0.0, None) * per_unit
    t, iso = exposure_settings(model, float(rate[..., 1].mean()))
    rng = np.random.default_rng(model.seed)
    dn = s.capture(rate * t, t, iso, rng)
    k = s.gain(iso)
    dark = s.black_level_dn + k * s.dark_current_e_per_s * t
    noisy = (dn - dark) / (k * per_unit * t)
    mean_e = rate.reshape(-1, 3).mean(axis=0) * t
    info = {"exposure_s_used": t, "iso_used": iso, "gain_dn_per_e_used": k,
            "electrons_per_unit_rgb_per_s": per_unit.tolist(),
            "mean_photoelectrons_rgb": mean_e.tolist(),
            "saturated_fraction": float(np.mean(dn >= s.max_dn)),
            "linear_rgb": "the raw frame as camera RGB: (DN - black level - K mu_I t) / "
                          "(K * electrons per unit RGB per s * t); noisy, unbalanced",
            "raw": "digital numbers, black level included"}
    return dn.astype(np.uint16), noisy, info


def exposure_settings(model: CameraModel, mean_green_rate: float) -> tuple[float, float]:
    """``(exposure_s, iso)`` of the frame: the model's, or metered."""
    s = model.sensor
    if model.exposure_s != "auto" and model.iso != "auto":
        return float(model.exposure_s), float(model.iso)
    if model.exposure_s == "auto":
        fixed_iso = model.iso != "auto"
        lo_iso = float(model.iso) if fixed_iso else s.base_iso
        hi_iso = float(model.iso) if fixed_iso else s.max_iso
        rate = mean_green_rate * lo_iso / s.base_iso
        t, gain = auto_exposure(rate, full_well_e=s.full_well_e, min_s=model.min_exposure_s,
                                max_s=model.max_exposure_s, base_iso=1.0,
                                max_iso=hi_iso / lo_iso)
        return t, lo_iso * gain
    t = float(model.exposure_s)
    _, iso = auto_exposure(mean_green_rate, full_well_e=s.full_well_e, min_s=t, max_s=t,
                           base_iso=s.base_iso, max_iso=s.max_iso)
    return t, iso
