"""The light-field pass's water table on the GPU, built per camera depth.

The camera-RGB water table over ray directions and distances
(:mod:`aquaspec.transport.lightfield.compiled`; twin:
:func:`aquaspec.transport.lightfield.compiled.water_table`) which
:class:`aquaspec.gpu.passes.lightfield.LightfieldPass` samples per pixel. WGSL:
``watertable.wgsl`` beside this module, two dispatches (the open-water
column, then the hit columns, which read it) into a storage buffer, copied
into a 2-D array texture (layers: camera RGB, with the cone spread the cone's
share; with the multiple-scattering spread one per lambda node). Deep water
and tables with a seabed alike (the line of sight going down ends on the
seabed: a compile-time constant, the seabed's depth and radiance as
uniforms). ``tests/gpu/passes/test_watertable_pass.py`` holds it against the
twin.

Bindings of watertable.wgsl: 0 uniform :data:`WATER_PARAMS_LAYOUT`; 1 uniform
per band group :func:`water_band_fields`; 2 the ``ln F`` prefactor as a 2-D
array texture (:func:`aquaspec.gpu.passes.lightfield.band_group_texture`); 3
the table out, ``(layers, directions, DISTANCES)`` vec4; 4 the surface seen
from below at each direction node, :func:`top_fields`.
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.transport.lightfield import compiled as lfc
from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import (create_array_texture, create_storage_buffer,
                                  create_uniform_buffer, read_buffer, upload_buffer)
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatches
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl

WATER_PARAMS_LAYOUT = UniformLayout("WaterTableParams", [
    ("depth_o", "f32"), ("window_cos", "f32"), ("max_depth", "f32"), ("alpha", "f32"),
    ("n_out", "u32"), ("n_in", "u32"), ("fb_mean", "f32"), ("seabed_depth", "f32"),
    ("alpha_lo", "vec4<f32>"), ("alpha_hi", "vec4<f32>"),
])

#: Most lambda nodes of the multiple-scattering spread the shaders take.
MAX_NODES = 8


def alpha_vec4s(alpha) -> dict:
    """``alpha_lo``, ``alpha_hi`` of the uniforms (this pass's and the light-field
    pass's): the nodes' kept shares when ``alpha`` is a tuple (else zeros)."""
    v = np.zeros(MAX_NODES)
    if isinstance(alpha, tuple):
        v[:len(alpha)] = alpha
    return {"alpha_lo": v[:4], "alpha_hi": v[4:]}


def water_band_fields(tables, *, a, b, e0, response_weights) -> np.ndarray:
    """Per band group the fields of watertable.wgsl: (8, ceil(n / 4), 4) float64.

    ``c, kappa_1, c' = c - f b, b E0 / (4 pi), w_r, w_g, w_b, L_bed``
    (``L_bed`` the seabed's radiance,
    :meth:`aquaspec.transport.lightfield.tables.LightfieldTables.seabed_radiance`;
    zero in deep water), four bands per vec4 (zero past the last band).
    """
    a, b, e0 = (np.asarray(x, dtype=np.float64) for x in (a, b, e0))
    w = np.asarray(response_weights, dtype=np.float64)
    n = a.size
    f = np.asarray(tables.forward_fraction, dtype=np.float64)
    c = a + b
    l_bed = tables.seabed_radiance(e0) if tables.has_seabed else np.zeros(n)
    rows = np.stack([c, np.asarray(tables.k_inf, np.float64), c - f * b,
                     b * e0 / (4.0 * np.pi), w[:, 0], w[:, 1], w[:, 2], l_bed])
    groups = -(-n // 4)
    out = np.zeros((rows.shape[0], groups * 4))
    out[:, :n] = rows
    # Padding bands: c = 1 keeps their (unused) path integrals finite.
    out[0, n:] = 1.0
    out[2, n:] = 1.0
    return out.reshape(rows.shape[0], groups, 4)


def top_fields(tables, *, e0) -> np.ndarray:
    """The surface seen from below at each direction node of the water table
    (:func:`aquaspec.transport.lightfield.compiled.direction_nodes`), per band
    group: (directions, ceil(n / 4), 4) float64
    (:meth:`aquaspec.transport.lightfield.tables.LightfieldTables.top_radiance`;
    zero for nodes looking level or down)."""
    v, _ = lfc.direction_nodes(tables.window_cos)
    top = tables.top_radiance(v, np.asarray(e0, dtype=np.float64))         # (J, n)
    n = top.shape[1]
    groups = -(-n // 4)
    out = np.zeros((v.size, groups * 4))
    out[:, :n] = top
    return out.reshape(v.size, groups, 4)


class WaterTablePass:
    """The water table of one medium on ``device``, rebuilt when the camera's depth
    or the spread's kept share changes (:meth:`encode`); :attr:`texture` is what
    the light-field pass samples."""

    def __init__(self, device):
        self.device = device
        self._params = create_uniform_buffer(device, WATER_PARAMS_LAYOUT,
                                             label="water table params")
        self._layout = bind_group_layout(device, {0: "uniform", 1: "uniform",
                                                  2: "float_array", 3: "write", 4: "read"})
        self._pipelines = {}
        #: The table's ``2d-array`` view (None before the first build).
        self.texture = None
        self._tex = self._out = self._shape = self._table_shape = None
        #: Incremented whenever :attr:`texture` is replaced.
        self.texture_version = 0
        #: ``(depth_o, alpha)`` of the table built last (None: none yet).
        self.key = None

    def set_medium(self, tables, *, a, b, e0, response_weights, log_prefactor,
                   shape: dict, spread: bool, nodes: int, seabed: bool) -> None:
        """The medium whose table to build (the next :meth:`encode` builds it).

        ``log_prefactor``: the ``ln F`` texels (:func:`band_group_texture`);
        ``shape``: ``n_depth, n_mu, window_cos, max_depth, fb_mean``;
        ``spread``, ``nodes``: the cone spread and its lambda nodes (0: single
        scattering); ``seabed``: whether the tables have a seabed (at
        ``tables.seabed_depth_m``).
        """
        if bool(seabed) != tables.has_seabed:
            raise AquaspecError(f"seabed={seabed!r} but the tables have "
                                f"{'a' if tables.has_seabed else 'no'} seabed")
        self._seabed_depth = float(tables.seabed_depth_m) if tables.has_seabed else 0.0
        self._shape = shape
        self.spread, self.nodes, self.seabed = bool(spread), int(nodes), bool(seabed)
        self._bands = water_band_fields(tables, a=a, b=b, e0=e0,
                                        response_weights=response_weights)
        data = self._bands.reshape(-1, 4).astype(np.float32)
        self._band_buffer = create_uniform_buffer(self.device, data.nbytes,
                                                  label="water table bands")
        upload_buffer(self.device, self._band_buffer, data)
        self._log_prefactor = create_array_texture(self.device, log_prefactor,
                                                   label="lightfield ln F")
        top = top_fields(tables, e0=e0).reshape(-1, 4).astype(np.float32)
        self._top = create_storage_buffer(self.device, top.nbytes, label="water table top")
        upload_buffer(self.device, self._top, top)
        self.key = None

    def forget(self) -> None:
        """Rebuild the table at the next :meth:`encode` even for the same depth."""
        self.key = None

    def pipelines(self):
        """The two pipelines ``(open_column, main)`` of watertable.wgsl for this medium's
        sizes (made when first used)."""
        sh = self._shape
        key = (self._bands.shape[1], sh["n_depth"], sh["n_mu"], self.spread, self.nodes,
               self.seabed)
        if key not in self._pipelines:
            src = load_wgsl("watertable.wgsl", params_struct=WATER_PARAMS_LAYOUT.wgsl(),
                            params_struct_name=WATER_PARAMS_LAYOUT.name,
                            n_groups=self._bands.shape[1], n_depth=sh["n_depth"],
                            n_mu=sh["n_mu"], distances=lfc.DISTANCES,
                            length_scale=f"{float(lfc.LENGTH_SCALE_M)!r}",
                            split="true" if self.spread else "false",
                            nodes=self.nodes, node_array=max(1, self.nodes),
                            seabed="true" if self.seabed else "false",
                            band_len=self._bands.shape[0] * self._bands.shape[1])
            self._pipelines[key] = tuple(
                compute_pipeline(self.device, self._layout, src,
                                 f"lightfield water table {entry}", entry)
                for entry in ("open_column", "main"))
        return self._pipelines[key]

    def encode(self, encoder, depth_o, alpha) -> None:
        """Build the water table for the camera's depth on the GPU (watertable.wgsl)
        when the depth, the medium or (with the spread) alpha changed: layer 0
        holds ``W0 + alpha W1`` with the spread (:func:`lightfield_compiled.spread_plan`);
        with the multiple-scattering spread ``alpha`` is the tuple of the nodes'
        shares and the table has a layer per node (:func:`lightfield_compiled.water_table`)."""
        key = (depth_o, alpha)
        if self.key == key:
            return
        dev = self.device
        n_out, n_in = lfc.direction_split(self._shape["window_cos"])
        rows = n_out + n_in
        layers = (1 + self.nodes) if self.nodes else (2 if self.spread else 1)
        if self.texture is None or self._table_shape != (layers, rows):
            tex = dev.create_texture(
                label="lightfield water table", size=(lfc.DISTANCES, rows, layers),
                format="rgba32float", dimension="2d", mip_level_count=1, sample_count=1,
                usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
            self._tex = tex
            self.texture = tex.create_view(dimension="2d-array")
            self._out = create_storage_buffer(dev, layers * rows * lfc.DISTANCES * 16,
                                              label="lightfield water table out")
            self._table_shape = (layers, rows)
            self.texture_version += 1
        self._encode_dispatches(encoder, depth_o, alpha, n_out, n_in, rows)
        encoder.copy_buffer_to_texture(
            {"buffer": self._out, "offset": 0, "bytes_per_row": lfc.DISTANCES * 16,
             "rows_per_image": rows},
            {"texture": self._tex, "mip_level": 0, "origin": (0, 0, 0)},
            (lfc.DISTANCES, rows, layers))
        self.key = key

    def _encode_dispatches(self, encoder, depth_o, alpha, n_out, n_in, rows):
        """watertable.wgsl's two dispatches into the water table buffer."""
        dev = self.device
        open_column, hits = self.pipelines()
        upload_buffer(dev, self._params, WATER_PARAMS_LAYOUT.pack(
            depth_o=depth_o, window_cos=self._shape["window_cos"],
            max_depth=self._shape["max_depth"], alpha=0.0 if self.nodes else alpha,
            n_out=n_out, n_in=n_in, fb_mean=self._shape["fb_mean"],
            seabed_depth=self._seabed_depth, **alpha_vec4s(alpha)))
        group = dev.create_bind_group(layout=self._layout, entries=bind_group_entries(
            {0: self._params, 1: self._band_buffer, 2: self._log_prefactor, 3: self._out,
             4: self._top}))
        # The open-water column first: the hit columns read it.
        record_dispatches(encoder, [
            (open_column, group, (-(-rows // 64), 1, 1)),
            (hits, group, (-(-(lfc.DISTANCES - 1) // 8), -(-rows // 8), 1))])

    def distances(self, depth_o: float) -> np.ndarray:
        """The hit columns' distances of the water table ``(directions, DISTANCES - 1)``
        as watertable.wgsl's ``s``: up rays' clipped at the surface and, with a
        seabed, down rays' finite ones at the seabed."""
        v, _ = lfc.direction_nodes(self._shape["window_cos"])
        s = np.broadcast_to(lfc.distance_nodes(), (v.size, lfc.DISTANCES - 1))
        up = v[:, None] > 0
        with np.errstate(over="ignore"):       # up rays within 1e-30 of level
            to_surface = depth_o / np.where(up, v[:, None], 1.0)
        s = np.where(up, np.minimum(s, to_surface), s)
        if self.seabed:
            down = v[:, None] < 0
            to_bed = (self._seabed_depth - depth_o) / np.where(down, -v[:, None], 1.0)
            s = np.where(down & np.isfinite(s), np.minimum(s, to_bed), s)
        return s

    def read(self, channels: int = 3) -> np.ndarray:
        """The last water table built, ``(layers, directions, DISTANCES, channels)``
        float32 (tests; the fourth channel of layer 0 is the multiple-scattering
        spread's kept share)."""
        if self.key is None:
            raise AquaspecError("no water table yet: run the pass first")
        layers, rows = self._table_shape
        return read_buffer(self.device, self._out, np.float32,
                           (layers, rows, lfc.DISTANCES, 4))[..., :channels]
