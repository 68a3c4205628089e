"""Analytic G-buffers for the GPU shading tests, and the deferred pass they run.

The G-buffers are built from ray-plane and ray-box intersections per pixel,
so neither the GPU pass nor its NumPy reference (shade_gbuffer) supplies the
geometry it is tested on. Used by tests/gpu/passes/test_deferred_pass.py,
test_copy_pass.py and tests/gpu/test_timing.py.
"""

import warnings

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.scene.camera import Camera
from aquaspec.medium.interface import snell_window_cos
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer

W, H = 64, 48

#: Per-pixel relative tolerance between the f32 GPU and the f64 reference.
RTOL = 1e-4
#: Absolute floor, as a fraction of the image's largest value. f32 keeps about
#: 7 digits of the brightest pixel's scale, and exp(-c S) of long paths in
#: turbid water falls into f32's denormal / flush-to-zero range (~1e-38), so
#: pixels whose value is a few 1e-7 of the image maximum carry no f32 digits
#: to compare at 1e-4.
ATOL_FRACTION = 1e-6


#: The passes of deferred_pass, by (n, debug).
PASSES = {}


def deferred_pass(device, n, *, debug=False):
    """One DeferredPass per (n, debug) for the module: pipelines compile once."""
    from aquaspec.gpu.passes.deferred import DeferredPass
    key = (n, debug)
    if key not in PASSES:
        PASSES[key] = DeferredPass(W, H, n, device=device, debug_radiance=debug)
    return PASSES[key]


# ------------------------------------------------------------------ inputs
def medium(water_name, n, ambient="cosine"):
    """Realistic per-band inputs: Jerlov water, a smooth daylight-like E0,
    Gaussian RGB responses, two materials, band-centre t."""
    from aquaspec.medium.water import load_water
    bands = Bands(n)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # 3C's gap-filling warnings
        w = load_water(water_name).on_bands(bands)
    lam = bands.centers_nm
    e0 = 1.1 * np.exp(-((lam - 480.0) / 220.0) ** 2)
    resp = np.stack([np.exp(-0.5 * ((lam - mu) / 40.0) ** 2) for mu in (600, 540, 460)], axis=1)
    grey = np.full(n, 0.18)
    red = 0.1 + 0.5 / (1.0 + np.exp(-(lam - 600.0) / 20.0))
    return dict(a=w.a, b=w.b, kd=w.kd, e0=e0, response_weights=resp * bands.width_nm,
                material_bands=np.stack([grey, red]), sigmoid_centers_t=(lam - 550.0) / 100.0,
                ambient=ambient)


def plane_distance(cam, y0):
    """Distance to the horizontal plane y = y0 along each ray (inf if not hit)."""
    d = cam.ray_directions()
    num = y0 - cam.position[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = num / d[..., 1]
    return np.where(np.isfinite(s) & (s > 0), s, np.inf)


def box_distance(cam, lo, hi):
    """Slab-method ray/box distance and outward normal per pixel."""
    d = cam.ray_directions()
    o = cam.position
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1 = (np.asarray(lo) - o) * inv
        t2 = (np.asarray(hi) - o) * inv
    tmin = np.nan_to_num(np.minimum(t1, t2), nan=-np.inf)
    tmax = np.nan_to_num(np.maximum(t1, t2), nan=np.inf)
    t_near = tmin.max(axis=-1)
    t_far = tmax.min(axis=-1)
    hit = (t_near <= t_far) & (t_near > 0)
    axis = tmin.argmax(axis=-1)
    normal = np.zeros(d.shape)
    np.put_along_axis(normal, axis[..., None],
                      -np.sign(np.take_along_axis(d, axis[..., None], axis=-1)), axis=-1)
    return np.where(hit, t_near, np.inf), normal


def compose(cam, layers):
    """Nearest of several (distance, normal, material, sigmoid) layers."""
    s = np.full((cam.height, cam.width), np.inf)
    nrm = np.zeros((cam.height, cam.width, 3))
    mat = np.zeros((cam.height, cam.width), np.uint32)
    sig = np.zeros((cam.height, cam.width, 3))
    for ls, ln, lm, lsig in layers:
        closer = ls < s
        s = np.where(closer, ls, s)
        nrm[closer] = np.broadcast_to(ln, nrm.shape)[closer]
        mat[closer] = np.broadcast_to(lm, mat.shape)[closer]
        sig[closer] = np.broadcast_to(lsig, sig.shape)[closer]
    return GBuffer(cam, s, nrm, mat, sig, materials=["grey", "red"])


def sigmoid_field(cam, s):
    """Per-pixel sigmoid coefficients varying with the hit position."""
    p = cam.position + cam.ray_directions() * np.where(np.isfinite(s), s, 0.0)[..., None]
    return np.stack([0.3 * np.sin(p[..., 0]), -1.5 + 0.2 * p[..., 2], 0.5 * np.cos(p[..., 0])],
                    axis=-1)


def scene_seabed():
    """Seabed at 9 m ending in a drop-off at z = 25 m (open water beyond it),
    seen at an angle; the top of the image sees the surface from below,
    Snell's window included; a pillar breaks the surface."""
    cam = Camera.look_at((0.0, -4.0, 0.0), (0.0, -3.0, 6.0), width=W, height=H, fov_y_deg=100.0)
    s_floor = plane_distance(cam, -9.0)
    z_floor = cam.position[2] + cam.ray_directions()[..., 2] * np.where(
        np.isfinite(s_floor), s_floor, 0.0)
    s_floor = np.where(z_floor < 25.0, s_floor, np.inf)
    half = np.where(cam.ray_directions()[..., 0] < 0, PER_PIXEL, 0).astype(np.uint32)
    s_pillar, n_pillar = box_distance(cam, (1.5, -9.0, 5.0), (3.0, 2.0, 6.0))
    return compose(cam, [(s_floor, (0.0, 1.0, 0.0), half, sigmoid_field(cam, s_floor)),
                          (s_pillar, n_pillar, 1, 0.0)])


def scene_up():
    """Looking straight up through Snell's window at a floating plate."""
    cam = Camera.look_at((0.0, -6.0, 0.0), (0.0, 0.0, 0.0), width=W, height=H, fov_y_deg=110.0,
                         up=(0.0, 0.0, 1.0))
    s_plate = plane_distance(cam, -1.5)
    p = cam.position + cam.ray_directions() * np.where(np.isfinite(s_plate), s_plate, 0)[..., None]
    s_plate = np.where(np.hypot(p[..., 0] - 1.0, p[..., 2]) < 1.2, s_plate, np.inf)
    return compose(cam, [(s_plate, (0.0, -1.0, 0.0), PER_PIXEL, sigmoid_field(cam, s_plate))])


def scene_box():
    """A box on a seabed at 12 m, camera at 8 m looking down at it."""
    cam = Camera.look_at((-3.0, -8.0, -4.0), (0.0, -11.0, 2.0), width=W, height=H, fov_y_deg=70.0)
    s_floor = plane_distance(cam, -12.0)
    s_box, n_box = box_distance(cam, (-1.0, -12.0, 1.0), (1.0, -10.5, 3.0))
    return compose(cam, [(s_floor, (0.0, 1.0, 0.0), 0, 0.0),
                          (s_box, n_box, PER_PIXEL, np.array([0.4, -0.8, 0.3]))])


SCENES = {"seabed": scene_seabed, "up": scene_up, "box": scene_box}


def comparable(gbuffer):
    """Pixels whose branch cannot flip between f64 and f32: not on the rim of
    Snell's window, not where a hit lies at the water surface itself."""
    cam = gbuffer.camera
    v_y = cam.ray_directions()[..., 1]
    rim = np.abs(v_y - snell_window_cos()) < 1e-5
    with np.errstate(divide="ignore", invalid="ignore"):
        to_surface = np.where(v_y > 0, cam.depth_m / v_y, np.inf)
        at_surface = (gbuffer.hit & (v_y > 0)
                      & (np.abs(gbuffer.distance - to_surface) <= 1e-5 * to_surface))
    mask = ~(rim | at_surface)
    # Guard against the mask silently excluding most of the image.
    assert mask.mean() > 0.97
    return mask


def assert_matches(gpu, ref, mask):
    atol = ATOL_FRACTION * np.abs(ref).max()
    np.testing.assert_allclose(gpu[mask], ref[mask], rtol=RTOL, atol=atol)


def run_gpu(device, gbuffer, med, n, **kw):
    p = deferred_pass(device, n, **kw)
    p.gbuffer.upload(gbuffer)
    p.set_medium(**med)
    p.run()
    return p


def gbuffer_textures(device, packed, label="raster"):
    """Textures in the deferred pass's G-buffer layout, filled with ``packed``."""
    import wgpu
    from aquaspec.gpu.buffers import create_texture, upload_texture
    from aquaspec.gpu.gbuffer import GBUFFER_FORMATS
    out = {}
    for name, arr in packed.items():
        out[name] = create_texture(device, arr.shape[1], arr.shape[0],
                                   GBUFFER_FORMATS[name], label=f"{label} {name}",
                                   usage=wgpu.TextureUsage.TEXTURE_BINDING
                                   | wgpu.TextureUsage.COPY_DST)
        upload_texture(device, out[name], arr)
    return out
