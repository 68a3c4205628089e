"""The lamps on the GPU: their shadow maps and their light, added to an image in camera RGB.

Two steps (maths in :mod:`aquaspec.transport.lamp_scattering`, NumPy twin
:func:`aquaspec.shading.lamp.lamp_radiance`):

- the shadow maps (:meth:`LampPass.encode_shadow_maps`): every lamp's faces
  (:func:`aquaspec.scene.lamp_shadow.lamp_shadow_faces`: one perspective
  face along a spot lamp's axis, or the six of a cube for wide lamps)
  rasterised depth-only through :class:`aquaspec.gpu.passes.depth_maps.DepthMapArray`,
  one layer per face, kept while the lamps and the scene stay;
- the veil (``lamps.wgsl`` beside this module, ``build_veil``): per lamp the
  single scattering integrated once along each column of
  :func:`aquaspec.transport.lamp_froxels.lamp_tile` pixels square, over
  :data:`aquaspec.transport.lamp_froxels.LAMP_SLICES` equiangular slices of
  the column's ray cut to the cone, with the lamp's shadow at each, in camera
  RGB;
- the per-pixel pass (``main``): per lamp the veil read from the columns at
  the pixel's distance and a lit surface's light, summed over the bands in
  camera RGB and added to a vec4-per-pixel buffer: a shading pass's linear
  image, or the pass's own (:meth:`LampPass.read_rgb`). Both in one compute
  pass.

Bindings of lamps.wgsl: 0 uniform :data:`PARAMS_LAYOUT`; 1, 2 the G-buffer's
surface and sigmoid textures; 3 material band reflectances (M * n f32; uniform
when they fit in 64 KiB, else storage); 4 eight vec4 per four bands (uniform; lamps.wgsl's ``bands``); 5
``ln p`` four bands a vec4 (:func:`grouped_rows` of
:func:`aquaspec.transport.sun_scattering.log_phase_table`; uniform up to 32 bands,
else storage); 6 the lamps
(:data:`LAMP_DTYPE`, uniform, :data:`MAX_LAMPS`); 7 their on-axis intensity per
band (uniform, four bands a vec4); 8 their beam profiles (:data:`PROFILE_SIZE`
values over ``[0, cone]``, uniform); 9 the shadow faces (uniform); 10 the shadow
maps (a depth array); 11 their comparison sampler; 12 the image; 13 the veil as
build_veil writes it (storage), 14 the same as a 3-D texture (columns x rows x
depths, every lamp's summed, :func:`aquaspec.gpu.passes.sun.froxel_format`), 15 its linear
clamped sampler; 16 the lamps' glow's table (:func:`grouped_rows` of
:func:`aquaspec.transport.lamp_halo.lamp_halo_table`, the first lamp's: every lamp
has the same water; uniform up to 64 bands, else storage); 17 their spot factors
(a 2-D array texture, read through 15). Every table read per pixel or per sample is in a uniform
buffer or a texture: storage reads were most of the pass's time on lavapipe. The
band loops work on four bands a vec4 (the tables are laid out so).
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import (create_storage_buffer, create_uniform_buffer, read_buffer,
                                  upload_buffer)
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.display_transform import DISPLAY_LAYOUT, display_template, display_uniform
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.passes.depth_maps import DepthMapArray
from aquaspec.gpu.passes.sun import froxel_format
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.scene.lamp_shadow import (BIAS_TEXELS, DEFAULT_LAMP_MAP_SIZE, FAR_M, NEAR_M,
                                        NORMAL_OFFSET_TEXELS, lamp_shadow_faces)
from aquaspec.transport.lamp_froxels import (DEPTH_M0, DEPTH_MAX_M, LAMP_DEPTHS, LAMP_SLICES,
                                             depth_step, lamp_tile)
from aquaspec.transport.lamp_halo import (MIN_HALO_RANGE_M, SPOT_ANGLES, lamp_halo_table,
                                          lamp_spot_table)
from aquaspec.transport.lamp_scattering import MIN_DISTANCE_M, MIN_RANGE_M, LampInputs
from aquaspec.transport.sun_scattering import PHASE_TABLE_SIZE

PARAMS_LAYOUT = UniformLayout("LampParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_lamps", "u32"), ("shadowed", "u32"),
    ("surfaces", "u32"), ("tile", "u32"), ("cols_x", "u32"), ("cols_y", "u32"),
    ("veil_row", "u32"), ("split_cone", "u32"), ("coarse_w", "u32"), ("coarse_h", "u32"),
    ("block", "u32"), ("alpha", "f32"), ("fb_mean", "f32"),
])
#: One lamp as lamps.wgsl's ``LampGpu``.
LAMP_DTYPE = np.dtype([("position", np.float32, 3), ("cos_cut", np.float32),
                       ("direction", np.float32, 3), ("cone", np.float32),
                       ("first_face", np.uint32), ("n_faces", np.uint32), ("clip", np.uint32),
                       ("iso", np.float32)])
#: Entries of each lamp's profile table over [0, cone].
PROFILE_SIZE = 513
#: Most lamps one pass takes, and most shadow-map faces (a cube each).
MAX_LAMPS = 16
MAX_FACES = 6 * MAX_LAMPS
#: Material reflectances in a uniform buffer up to this many vec4 (64 KiB).
MATERIAL_VEC4 = 4096
WORKGROUP = (8, 8)
_BINDINGS = {0: "uniform", 1: "uint", 2: "float", 3: "read", 4: "uniform", 5: "read",
             6: "uniform", 7: "uniform", 8: "uniform", 9: "uniform", 10: "depth_array",
             11: "comparison_sampler", 12: "write", 13: "write", 14: "filterable_3d",
             15: "sampler", 16: "uniform", 17: "filterable_array", 18: "uniform", 19: "write",
             20: "write", 21: "write"}
#: Bindings held in uniform buffers (the phase table and the materials too when
#: they fit): storage reads per band were most of the pass's time on lavapipe
#: (577 -> 226 ms at 160x90, 8 bands, two lamps, for the per-band constants).
_UNIFORM = (4, 6, 7, 8, 9, 16)
#: The phase table goes in a uniform buffer too when it fits WebGPU's 64 KiB
#: (up to 32 bands of PHASE_TABLE_SIZE entries), else in storage.
UNIFORM_BYTES = 65536


def profile_table(lamp) -> np.ndarray:
    """``f`` of a lamp at :data:`PROFILE_SIZE` angles over ``[0, cone]`` (float32)."""
    alpha = np.linspace(0.0, lamp.cone_rad, PROFILE_SIZE)
    return lamp.relative_intensity(alpha).astype(np.float32)


def grouped_rows(table, groups: int) -> np.ndarray:
    """A per-band table (n, m, c) as lamps.wgsl reads it four bands a vec4:
    (groups * m * c, 4) float32, row ``(q * m + j) * c + l`` holding entry
    ``(j, l)`` of bands ``4q ... 4q + 3`` (0 past the last band)."""
    table = np.asarray(table, dtype=np.float32)
    table = table.reshape(table.shape[:2] + (-1,))
    n, m, c = table.shape
    out = np.zeros((4 * groups, m, c), np.float32)
    out[:n] = table
    return np.ascontiguousarray(out.reshape(groups, 4, m, c).transpose(0, 2, 3, 1)
                                .reshape(-1, 4))


def face_rows(faces) -> np.ndarray:
    """Three vec4 per face: right and focal length (texels), up, forward and size."""
    out = np.zeros((len(faces), 3, 4), np.float32)
    for k, face in enumerate(faces):
        cam = face.camera
        out[k, 0, :3], out[k, 0, 3] = cam.right, cam.fx
        out[k, 1, :3] = cam.true_up
        out[k, 2, :3], out[k, 2, 3] = cam.forward, face.size
    return out


class LampPass:
    """The lamps' shadow maps and light for one image size and band count.

    Parameters
    ----------
    device : wgpu.GPUDevice
    width, height, n_bands : int
    map_size : int
        Side of each shadow-map face, texels.
    slices : int
        Equiangular slices per column and lamp.
    """

    def __init__(self, device, width: int, height: int, n_bands: int, *,
                 map_size: int = DEFAULT_LAMP_MAP_SIZE, slices: int = LAMP_SLICES):
        if not (isinstance(slices, (int, np.integer)) and 1 <= slices <= 1024):
            raise AquaspecError(f"lamp slices {slices!r}; accepted: an integer 1 ... 1024")
        self.device = device
        self.width, self.height, self.n_bands = int(width), int(height), int(n_bands)
        self.map_size, self.slices = int(map_size), int(slices)
        self._groups = -(-self.n_bands // 4)
        self._phase_uniform = 16 * self._groups * PHASE_TABLE_SIZE <= UNIFORM_BYTES
        # The glow's table (a vec4 per band and distance) in a uniform buffer up to 64 bands.
        self._halo_uniform = 64 * self._groups * LAMP_DEPTHS <= UNIFORM_BYTES
        self.veil_format = froxel_format(device)
        self._texel = 8 if self.veil_format == "rgba16float" else 16
        self._pipelines = {}
        self._layouts = {}
        self._veil = None
        self._group = None
        self._params = create_uniform_buffer(device, PARAMS_LAYOUT, label="lamp params")
        #: The pass's own image (vec4 per pixel), when no other is given to :meth:`encode`.
        self.rgb_buffer = create_storage_buffer(device, 16 * self.width * self.height,
                                                label="lamp rgb")
        self._shadow_sampler = device.create_sampler(
            address_mode_u=wgpu.AddressMode.clamp_to_edge,
            address_mode_v=wgpu.AddressMode.clamp_to_edge,
            mag_filter=wgpu.FilterMode.nearest, min_filter=wgpu.FilterMode.nearest,
            compare=wgpu.CompareFunction.less_equal)
        self._veil_sampler = device.create_sampler(
            address_mode_u=wgpu.AddressMode.clamp_to_edge,
            address_mode_v=wgpu.AddressMode.clamp_to_edge,
            address_mode_w=wgpu.AddressMode.clamp_to_edge,
            mag_filter=wgpu.FilterMode.linear, min_filter=wgpu.FilterMode.linear)
        self._no_maps = DepthMapArray(device, 16, 1, label="no lamp shadows")
        #: The display transform fused into the per-pixel pass (:meth:`set_display`).
        self._display = create_uniform_buffer(device, DISPLAY_LAYOUT, label="lamp display")
        self.display_buffer = create_storage_buffer(device, 4 * self.width * self.height,
                                                    label="lamp display rgba8")
        self._status = create_storage_buffer(device, 16, label="lamp display status")
        self.display_settings = None
        self._maps = None
        self._buffers = None
        self._lamps = []
        self._faces = []
        self.shadowed = False
        #: The light field's cone spread the lit surfaces' cone share goes to
        #: (:meth:`set_cone_spread`): ``(ConeSpreadPass, start level, alpha)`` or None.
        self.cone_spread = None
        self._no_cone = create_storage_buffer(self.device, 16, label="no lamp cone share")

    def _use_pipelines(self, materials_in_uniform: bool) -> None:
        """Select (compiling once) the pipelines for where the materials are."""
        self._mat_key = bool(materials_in_uniform)
        self._pipeline, self._build, self._cone = self._pipelines_for(self._mat_key, None)
        self._layout = self._layouts[self._mat_key]

    def _pipelines_for(self, key: bool, tonemap):
        """``(main, build_veil, cone_share)`` for materials in a uniform buffer (``key``) and the
        display transform with ``tonemap`` fused in main (None: linear RGB out)."""
        if (key, tonemap) not in self._pipelines:
            phase_vec4 = self._groups * PHASE_TABLE_SIZE
            half = self.veil_format == "rgba16float"
            src = load_wgsl(
                "lamps.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                params_struct_name=PARAMS_LAYOUT.name, n_bands=self.n_bands,
                phase_size=PHASE_TABLE_SIZE, profile_size=PROFILE_SIZE, slices=self.slices,
                depths=LAMP_DEPTHS, depth_m0=f"{DEPTH_M0:.9g}", depth_max=f"{DEPTH_MAX_M:.9g}",
                depth_step=f"{depth_step():.9g}",
                veil_word="vec2<u32>" if half else "vec4<f32>",
                veil_pack=("vec2<u32>(pack2x16float(sum.xy), "
                           "pack2x16float(vec2<f32>(sum.z, 0.0)))") if half
                else "vec4<f32>(sum, 0.0)",
                veil_unpack=("vec3<f32>(unpack2x16float(veil_out[i].x), "
                             "unpack2x16float(veil_out[i].y).x)") if half
                else "veil_out[i].xyz",
                near=f"{NEAR_M:.9g}", far=f"{FAR_M:.9g}", band_vec4=8 * self._groups,
                phase_binding=(f"var<uniform> log_phase: array<vec4<f32>, {phase_vec4}>"
                               if self._phase_uniform
                               else "var<storage, read> log_phase: array<vec4<f32>>"),
                material_binding=("@group(0) @binding(3) var<uniform> materials: "
                                  f"array<vec4<f32>, {MATERIAL_VEC4}>;") if key else
                "@group(0) @binding(3) var<storage, read> materials: array<f32>;",
                material_read="materials[k / 4u][k % 4u]" if key else "materials[k]",
                max_lamps=MAX_LAMPS, intensity_vec4=MAX_LAMPS * self._groups,
                halo_binding=(f"var<uniform> halo: array<vec4<f32>, "
                              f"{4 * self._groups * LAMP_DEPTHS}>"
                              if self._halo_uniform else
                              "var<storage, read> halo: array<vec4<f32>>"),
                spot_angles=SPOT_ANGLES,
                min_halo_range=f"{MIN_HALO_RANGE_M:.9g}",
                profile_vec4=-(-MAX_LAMPS * PROFILE_SIZE // 4), face_vec4=3 * MAX_FACES,
                bias_texels=f"{BIAS_TEXELS:.9g}",
                normal_offset_texels=f"{NORMAL_OFFSET_TEXELS:.9g}",
                min_distance=f"{MIN_DISTANCE_M:.9g}", min_range=f"{MIN_RANGE_M:.9g}",
                **display_template(tonemap))
            module = self.device.create_shader_module(label="lamps.wgsl", code=src)
            if key not in self._layouts:
                kinds = {**_BINDINGS, 3: "uniform" if key else "read",
                         5: "uniform" if self._phase_uniform else "read",
                         16: "uniform" if self._halo_uniform else "read"}
                self._layouts[key] = bind_group_layout(self.device, kinds)
            layout = self.device.create_pipeline_layout(bind_group_layouts=[self._layouts[key]])
            self._pipelines[(key, tonemap)] = tuple(
                self.device.create_compute_pipeline(
                    label=f"lamps {entry}", layout=layout,
                    compute={"module": module, "entry_point": entry})
                for entry in ("main", "build_veil", "cone_share"))
        return self._pipelines[(key, tonemap)]

    # ---- inputs ---------------------------------------------------------------
    def set_inputs(self, lamps, *, response_weights, material_bands, sigmoid_centers_t) -> None:
        """Upload the lamps (placed in the world; :class:`LampInputs`, one per lamp),
        the per-band constants and the materials. The per-band water and phase
        are the first lamp's (a setup gives every lamp the same)."""
        lamps = list(lamps)
        n = self.n_bands
        if not 1 <= len(lamps) <= MAX_LAMPS:
            raise AquaspecError(f"{len(lamps)} lamps; the lamp pass takes 1 ... {MAX_LAMPS}")
        for k, inp in enumerate(lamps):
            if not isinstance(inp, LampInputs) or np.asarray(inp.b).size != n:
                raise AquaspecError(f"lamps[{k}] must be LampInputs of {n} bands")
        w = np.asarray(response_weights, dtype=float)
        if w.shape != (n, 3):
            raise AquaspecError(f"response_weights has shape {w.shape}; expected ({n}, 3)")
        first = lamps[0]
        per_band = np.zeros((4 * self._groups, 8), np.float32)
        per_band[:n, 0], per_band[:n, 1], per_band[:n, 2] = first.c_lamp, first.c_view, first.b
        per_band[:n, 3], per_band[:n, 4:7] = sigmoid_centers_t, w
        per_band[:n, 7] = first.forward_share * np.asarray(first.b, dtype=float)
        self._fb_mean = float(np.mean(per_band[:n, 7]))
        band = per_band.reshape(self._groups, 4, 8).transpose(0, 2, 1)
        intensity = np.zeros((MAX_LAMPS, 4 * self._groups), np.float32)
        for k, inp in enumerate(lamps):
            intensity[k, :n] = inp.intensity
        faces, rows = [], np.zeros(len(lamps), LAMP_DTYPE)
        for k, inp in enumerate(lamps):
            lamp = inp.lamp
            own = lamp_shadow_faces(lamp, self.map_size)
            rows[k] = (lamp.position, np.cos(lamp.cone_rad), lamp.direction, lamp.cone_rad,
                       len(faces), len(own), int(lamp.cone_deg < 90.0),
                       inp.iso_fraction if inp.halo else 0.0)
            faces += own
        if len(faces) > MAX_FACES:
            raise AquaspecError(f"{len(faces)} shadow-map faces; the lamp pass takes {MAX_FACES}")
        mb = np.asarray(material_bands if material_bands is not None else np.zeros((0, n)),
                        np.float32).reshape(-1)
        in_uniform = mb.size <= 4 * MATERIAL_VEC4
        self._use_pipelines(in_uniform)
        table = np.zeros(4 * MATERIAL_VEC4 if in_uniform else max(mb.size, 4), np.float32)
        table[:mb.size] = mb
        profiles = np.zeros(4 * -(-MAX_LAMPS * PROFILE_SIZE // 4), np.float32)
        profiles[:len(lamps) * PROFILE_SIZE] = np.concatenate([profile_table(i.lamp)
                                                               for i in lamps])
        lamp_rows = np.zeros(MAX_LAMPS, LAMP_DTYPE)
        lamp_rows[:len(lamps)] = rows
        face_table = np.zeros((MAX_FACES, 3, 4), np.float32)
        face_table[:len(faces)] = face_rows(faces)
        data = {3: table, 4: band, 5: grouped_rows(first.log_phase, self._groups),
                6: lamp_rows, 7: intensity, 8: profiles, 9: face_table,
                16: grouped_rows(lamp_halo_table(first), self._groups)}
        self._buffers = {}
        for b, arr in data.items():
            arr = np.ascontiguousarray(arr)
            if ((b in _UNIFORM and not (b == 16 and not self._halo_uniform))
                    or (b == 5 and self._phase_uniform) or (b == 3 and in_uniform)):
                self._buffers[b] = create_uniform_buffer(self.device, arr.nbytes,
                                                         label=f"lamps binding {b}")
                upload_buffer(self.device, self._buffers[b], arr)
            else:
                self._buffers[b] = create_storage_buffer(self.device, arr,
                                                         label=f"lamps binding {b}")
        self._spot = self._spot_texture(lamps)
        self._lamps, self._faces = lamps, faces
        self._veil = None
        if self._maps is None or self._maps.layers != len(faces):
            self._maps = DepthMapArray(self.device, self.map_size, len(faces),
                                       label="lamp shadow maps")
        self.shadowed = False

    def _spot_texture(self, lamps):
        """The lamps' spot factors (:func:`aquaspec.transport.lamp_halo.lamp_spot_table`)
        as a 2-D array texture: layer ``k * groups + g`` holds lamp k's bands
        4g ... 4g + 3 (rgba) over the distances (x) and angles (y); 1 without the glow."""
        groups, n = self._groups, self.n_bands
        most = self.device.limits.get("max-texture-array-layers", 256)
        if len(lamps) * groups > most:
            raise AquaspecError(f"{len(lamps)} lamps x {groups} groups of four bands need "
                                f"{len(lamps) * groups} texture layers; this device takes {most}")
        data = np.ones((len(lamps) * groups, SPOT_ANGLES, LAMP_DEPTHS, 4), np.float32)
        for k, inp in enumerate(lamps):
            if not inp.halo:
                continue
            spot = np.zeros((4 * groups, LAMP_DEPTHS, SPOT_ANGLES))
            spot[:n] = lamp_spot_table(inp)
            data[k * groups:(k + 1) * groups] = np.transpose(
                spot.reshape(groups, 4, LAMP_DEPTHS, SPOT_ANGLES), (0, 3, 2, 1))
        half = self.veil_format == "rgba16float"
        tex = self.device.create_texture(
            label="lamp spot factors", size=(LAMP_DEPTHS, SPOT_ANGLES, data.shape[0]),
            format=self.veil_format, dimension="2d",
            usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
        self.device.queue.write_texture(
            {"texture": tex, "mip_level": 0, "origin": (0, 0, 0)},
            np.ascontiguousarray(data, np.float16 if half else np.float32),
            {"offset": 0, "bytes_per_row": (8 if half else 16) * LAMP_DEPTHS,
             "rows_per_image": SPOT_ANGLES}, (LAMP_DEPTHS, SPOT_ANGLES, data.shape[0]))
        return tex.create_view(dimension="2d-array")

    # ---- shadows ----------------------------------------------------------------
    def encode_shadow_maps(self, encoder, raster, scene) -> bool:
        """Record the lamps' shadow maps of ``scene`` (drawn again only when the
        faces or the scene's buffers changed); None or an empty scene: nothing
        is shadowed. Returns whether the maps are read."""
        if self._buffers is None:
            raise AquaspecError("LampPass.set_inputs() first")
        self.shadowed = scene is not None and bool(scene.meshes)
        if self.shadowed:
            self._maps.encode(encoder, raster.draws(scene), self._faces)
        return self.shadowed

    def forget_shadow_maps(self) -> None:
        """Have the next :meth:`encode_shadow_maps` draw the maps again (what a
        moving camera costs camera-fixed lamps)."""
        if self._maps is not None:
            self._maps.forget()

    def read_shadow_depths(self, face: int) -> np.ndarray:
        """Face ``face``'s map as view depths (size, size), m (``inf``: no surface); tests."""
        z = self._maps.read_raw(face).astype(float)
        return np.where(z >= 1.0, np.inf, NEAR_M * FAR_M / (FAR_M - z * (FAR_M - NEAR_M)))

    # ---- the light ----------------------------------------------------------------
    def _veil_for(self, camera):
        """The veil's columns, buffer and texture for ``camera`` (made when its
        columns or the lamps' count change): ``(tile, (cols_x, cols_y), row)``."""
        tile = lamp_tile(camera)
        cols = (-(-self.width // tile), -(-self.height // tile))
        row = -(-cols[0] * self._texel // 256) * 256 // self._texel
        depth = LAMP_DEPTHS + 1
        key = tile
        if self._veil is None or self._veil[0] != key:
            buf = create_storage_buffer(self.device, self._texel * row * cols[1] * depth,
                                        label="lamp veil (written)")
            tex = self.device.create_texture(
                label="lamp veil", size=(cols[0], cols[1], depth), format=self.veil_format,
                dimension="3d",
                usage=wgpu.TextureUsage.COPY_DST | wgpu.TextureUsage.TEXTURE_BINDING)
            self._veil = (key, buf, tex, tex.create_view())
        return tile, cols, row

    def encode(self, encoder, camera, gbuffer_textures: dict, rgb_buffer=None,
               timestamp_writes=None, *, surfaces: bool = True,
               veil_timestamp_writes=None) -> None:
        """Record the lamps' light added into ``rgb_buffer`` (vec4 per pixel; None:
        the pass's own, cleared first): :meth:`encode_veil` (its compute pass
        bracketed by ``veil_timestamp_writes``) then :meth:`encode_pixels`
        (``timestamp_writes``). ``surfaces=False``: the water's light alone,
        every surface black (the backscatter layer; the rays still end on the
        surfaces)."""
        self.encode_veil(encoder, camera, gbuffer_textures, rgb_buffer, veil_timestamp_writes,
                         surfaces=surfaces)
        self.encode_pixels(encoder, timestamp_writes)

    def encode_veil(self, encoder, camera, gbuffer_textures: dict, rgb_buffer=None,
                    timestamp_writes=None, *, surfaces: bool = True) -> None:
        """Upload the frame's parameters and record the veil's columns and their
        copy into the 3-D texture; :meth:`encode_pixels` then adds the light
        into ``rgb_buffer`` (None: the pass's own, cleared here)."""
        if self._buffers is None:
            raise AquaspecError("LampPass.set_inputs() first")
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height}; the lamp pass was "
                                f"made for {self.width}x{self.height}")
        if rgb_buffer is None:
            rgb_buffer = self.rgb_buffer
            encoder.clear_buffer(rgb_buffer)
        tile, cols, row = self._veil_for(camera)
        _, veil_buf, veil_tex, veil_view = self._veil
        upload_buffer(self.device, self._params, PARAMS_LAYOUT.pack(
            **camera_fields(camera), width=self.width, height=self.height,
            n_lamps=len(self._lamps), shadowed=int(self.shadowed), surfaces=int(surfaces),
            tile=tile, cols_x=cols[0], cols_y=cols[1], veil_row=row,
            **self._cone_fields()))
        maps = self._maps if self.shadowed else self._no_maps
        self._group = self.device.create_bind_group(
            layout=self._layout, entries=bind_group_entries({
                0: self._params, 1: gbuffer_textures["surface"].create_view(),
                2: gbuffer_textures["sigmoid"].create_view(), **self._buffers,
                10: maps.view, 11: self._shadow_sampler, 12: rgb_buffer, 13: veil_buf,
                14: veil_view, 15: self._veil_sampler, 17: self._spot, 18: self._display,
                19: self.display_buffer, 20: self._status,
                21: self._no_cone if self.cone_spread is None else self.cone_spread[0].extra}))
        cp = encoder.begin_compute_pass(timestamp_writes=timestamp_writes)
        cp.set_pipeline(self._build)
        cp.set_bind_group(0, self._group)
        cp.dispatch_workgroups(-(-cols[0] // 8), -(-cols[1] // 8), 1)
        cp.end()
        encoder.copy_buffer_to_texture(
            {"buffer": veil_buf, "offset": 0, "bytes_per_row": self._texel * row,
             "rows_per_image": cols[1]},
            {"texture": veil_tex, "mip_level": 0, "origin": (0, 0, 0)},
            (cols[0], cols[1], LAMP_DEPTHS + 1))

    def set_cone_spread(self, spread_pass=None, start: int = 0, alpha: float = 0.0) -> None:
        """Send the forward cone's share of the lit surfaces' light to the light
        field's cone spread (:mod:`aquaspec.shading.lamp`): ``spread_pass`` its
        :class:`aquaspec.gpu.passes.conespread.ConeSpreadPass` (one slot) for
        the frame's camera, ``start`` the spread's start level, ``alpha`` the
        share a pixel keeps (:func:`aquaspec.transport.lightfield.spreadplan.spread_plan`);
        None: no spread, the share stays on the pixel. Set before
        :meth:`encode_veil`; then :meth:`encode_cone` before the light field's
        pass, :meth:`encode_pixels` after it."""
        if spread_pass is not None and not 0.0 <= alpha <= 1.0:
            raise AquaspecError(f"kept share alpha {alpha!r}; accepted: 0 ... 1")
        self.cone_spread = None if spread_pass is None else (spread_pass, int(start),
                                                             float(alpha))

    def _cone_fields(self) -> dict:
        if self.cone_spread is None:
            return dict(split_cone=0, coarse_w=0, coarse_h=0, block=1, alpha=0.0, fb_mean=0.0)
        sp, start, alpha = self.cone_spread
        return dict(split_cone=1, coarse_w=sp.width, coarse_h=sp.height, block=2 ** start,
                    alpha=alpha, fb_mean=self._fb_mean)

    def encode_cone(self, encoder, timestamp_writes=None) -> None:
        """Record the lit surfaces' cone share into the spread's extra input
        (:meth:`set_cone_spread`; after :meth:`encode_veil`, before the light
        field's pass) and switch that input on."""
        if self._group is None or self.cone_spread is None:
            raise AquaspecError("LampPass.set_cone_spread() and encode_veil() first")
        sp = self.cone_spread[0]
        sp.set_extra(True)
        cp = encoder.begin_compute_pass(timestamp_writes=timestamp_writes)
        cp.set_pipeline(self._cone)
        cp.set_bind_group(0, self._group)
        cp.dispatch_workgroups(-(-sp.width // 8), -(-sp.height // 8))
        cp.end()

    def set_display(self, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0), matrix=None,
                    tonemap="filmic") -> None:
        """The display transform :meth:`encode_pixels` fuses in with ``display=True``
        (as :meth:`aquaspec.gpu.passes.display.DisplayPass.set_settings`)."""
        data, self.display_settings = display_uniform(
            self.width, self.height, exposure_ev=exposure_ev,
            white_balance_gains=white_balance_gains, matrix=matrix, tonemap=tonemap)
        upload_buffer(self.device, self._display, data)

    def encode_pixels(self, encoder, timestamp_writes=None, *, display: bool = False) -> None:
        """Record the per-pixel pass of the last :meth:`encode_veil`: the lamps'
        light added to its image; ``display=True``: that image through the
        display transform of :meth:`set_display` into :attr:`display_buffer`
        (packed RGBA8, read with :meth:`read_display`) instead, saving the
        display pass."""
        if self._group is None:
            raise AquaspecError("LampPass.encode_veil() first")
        pipeline = self._pipeline
        if display:
            if self.display_settings is None:
                raise AquaspecError("LampPass.set_display() first")
            self.device.queue.write_buffer(self._status, 0,
                                           np.array([0, 0xFFFFFFFF, 0, 0], np.uint32))
            pipeline = self._pipelines_for(self._mat_key, self.display_settings["tonemap"])[0]
        cp = encoder.begin_compute_pass(timestamp_writes=timestamp_writes)
        cp.set_pipeline(pipeline)
        cp.set_bind_group(0, self._group)
        cp.dispatch_workgroups(-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]))
        cp.end()

    def read_display(self) -> np.ndarray:
        """The last fused display image (H, W, 3) uint8; refuses one with
        non-finite pixels (as :meth:`aquaspec.gpu.passes.display.DisplayPass.read`)."""
        status = read_buffer(self.device, self._status, np.uint32, (4,))
        if status[0]:
            row, col = divmod(int(status[1]), self.width)
            raise AquaspecError(f"{int(status[0])} pixel(s) not finite after the lamps and the "
                                f"display transform, the first at row {row}, column {col}")
        rgba = read_buffer(self.device, self.display_buffer, np.uint32,
                           (self.height, self.width))
        return np.stack([(rgba >> (8 * c)) & 0xFF for c in range(3)], axis=-1).astype(np.uint8)

    def read_rgb(self) -> np.ndarray:
        """The pass's own image (H, W, 3) float32 in camera RGB."""
        return read_buffer(self.device, self.rgb_buffer, np.float32,
                           (self.height, self.width, 4))[..., :3]
