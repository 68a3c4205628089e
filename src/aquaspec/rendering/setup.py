"""The spectral setup of a render: water, light, sensor and model on a set of bands.

:class:`SpectralSetup` names what a frame's shading depends on besides the
geometry, and derives per band what the shading passes need: the medium's
coefficients and the sensor's weights (:meth:`SpectralSetup.medium`), the
light field's tables (:meth:`SpectralSetup.lightfield_tables`) and the sun's
inputs (:meth:`SpectralSetup.sun_inputs`), and the lamps' per camera
(:meth:`SpectralSetup.lamp_inputs`). The light field and the sun cost up to
seconds, so a setup computes them once and keeps them in its
:class:`SetupCache`, the one mutable part of an otherwise frozen object.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import normalised_wavelength
from aquaspec.colour.sensors import Sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.caustic_scatter import ScatterTransfer
from aquaspec.light.caustics import cached_caustic_map
from aquaspec.light.lamp import Lamp
from aquaspec.light.sky import SurfaceLight
from aquaspec.medium.water import Water
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.lightfield.bake import lightfield_tables
from aquaspec.transport.lightfield.cone import forward_cone
from aquaspec.transport.lightfield.tables import LightfieldTables
from aquaspec.transport.models import DEFAULT_MS_MODEL, MONZON2022, cone_spread_for, ms_model_name
from aquaspec.transport.lamp_scattering import LampInputs
from aquaspec.transport.sun_scattering import SunInputs, log_phase_table


#: How the lamps are rendered, for a render's metadata.
#: The water surface seen from below, as renders name it, and the light
#: field's top boundary for each (:func:`aquaspec.medium.interface.below_surface`):
#: ``flat`` the real flat interface (Snell's window with Fresnel transmission,
#: the water's light mirrored outside it), ``index-matched`` no interface (the
#: path-traced validation's setting and the thesis's).
SURFACE_MODELS = {"index-matched": "null", "flat": "fresnel"}


def render_surface(surface, ms_model) -> str:
    """The surface a render uses: ``surface``, or for None the default, the
    real flat surface with the light-field model (renders are for real water;
    its level, upward and downward views match the path tracer's dielectric
    surface within a few per cent, docs/validation.md) and the index-matched
    one with the seeds' model, whose light has no top boundary to change.
    The validation study's :class:`SpectralSetup` keeps ``index-matched``."""
    if surface is not None:
        return surface
    return "flat" if ms_model_name(ms_model) == "lightfield" else "index-matched"

LAMP_MODEL = ("aquaspec.transport.lamp_scattering: direct light on surfaces "
              "I(alpha) exp(-c_lamp r) max(0, n.l) / r^2 with a shadow map per lamp, and "
              "single scattering along each view ray (equiangular midpoint rule); c_lamp "
              "= c_view = the surfaces' extinction towards the camera (c - f b with the "
              "light field's forward cone, c with monzon2022); no multiple scattering")


@dataclass
class SetupCache:
    """What a :class:`SpectralSetup` derived from its fields, kept for its
    next frames: the light field's tables and the sun's inputs (None until
    first asked for).

    A setup's fields never change, so neither does what they give; the cache
    only saves recomputing it. It is not a parameter: it takes no part in
    comparisons, and ``dataclasses.replace`` gives the new setup an empty one.
    """

    lightfield_tables: LightfieldTables | None = None
    #: ``E0`` per band that the tables were solved for (:meth:`SpectralSetup.e0_on_bands`).
    e0: np.ndarray | None = None
    sun_inputs: SunInputs | None = None
    #: The lamps' per-band quantities that do not depend on the camera.
    lamp_bands: dict | None = None


@dataclass(frozen=True)
class SpectralSetup:
    """Everything per band the shading needs: water, light, sensor on ``bands``."""

    water: Water
    sensor: Sensor
    light: SurfaceLight
    bands: Bands
    ambient: str = model.DEFAULT_AMBIENT
    outside: str = "error"
    ms_model: str = DEFAULT_MS_MODEL
    phase: str = "petzold"
    #: Parameters of the phase function, e.g. ``(("g", 0.92),)`` for ``hg``.
    phase_params: tuple = ()
    #: Forward cone counted as unscattered towards targets (light field),
    #: degrees; None: the model's default (:func:`aquaspec.transport.lightfield.cone.forward_cone`:
    #: 15, or 40 with ``cone_spread``).
    forward_cone_deg: float | None = None
    #: Spread the cone's light over the image from where the cone points
    #: (:mod:`aquaspec.transport.lightfield.conespread`, an image pyramid; GPU and NumPy); None:
    #: the model's default (:func:`aquaspec.transport.models.cone_spread_for`: on for the
    #: light field). Resolved to a bool when the setup is made.
    cone_spread: bool | None = None
    #: With ``cone_spread``: the cone's light scattered once (``"single"``) or
    #: a Poisson number of times (``"multiple"``; :mod:`aquaspec.transport.lightfield.conespread`).
    spread_scattering: str = "single"
    #: The scene's first-order shadow in the light field (:mod:`aquaspec.transport.lightfield.shadow`;
    #: planned in NumPy from the G-buffer, seconds per image; the GPU renderer
    #: integrates its rays on its device:
    #: :meth:`aquaspec.rendering.renderer.Renderer.subtract_shadow`).
    ambient_shadow: bool = False
    #: The scene's occlusion of the ambient light field: on surfaces (the GPU's
    #: :class:`aquaspec.gpu.passes.occlusion.OcclusionPass`, NumPy's
    #: :func:`aquaspec.transport.lightfield.occlusion.occlusion_factor`) and, in
    #: NumPy, the water's own shadow (:mod:`aquaspec.transport.lightfield.water_occlusion`).
    occlusion: bool = False
    #: The light field's lower boundary (:class:`aquaspec.scene.seabed.Seabed`);
    #: None: deep water. The seeds' model has none.
    seabed: object = None
    #: A wind-roughened surface (:class:`aquaspec.light.waves.Waves`) focusing the
    #: sun's beam into caustics; None: a flat surface. Needs a sun.
    waves: object = None
    #: Lamps (:class:`aquaspec.light.lamp.Lamp`), in the world or fixed to the
    #: camera: their light on surfaces and scattered once in the water
    #: (:mod:`aquaspec.transport.lamp_scattering`).
    lamps: tuple = ()
    #: The water surface seen from below (:data:`SURFACE_MODELS`; light-field model).
    surface: str = "index-matched"
    #: What the setup derived and keeps (:class:`SetupCache`); not a parameter.
    cache: SetupCache = field(default_factory=SetupCache, init=False, repr=False,
                              compare=False)

    def __post_init__(self):
        # Resolving the default is part of making the setup, as validating is.
        # (The model by its canonical name, once the cone's check has named it as given.)
        canonical = ms_model_name(self.ms_model)
        object.__setattr__(self, "cone_spread",
                           cone_spread_for(self.ms_model, self.cone_spread))
        object.__setattr__(self, "ms_model", canonical)
        if self.waves is not None and self.light.sun is None:
            raise AquaspecError("waves focus the sun's beam into caustics: they need a light "
                                "with a sun (light 'sun-sky')")
        if self.ambient_shadow and self.ms_model != "lightfield":
            raise AquaspecError(f"ambient_shadow is part of the light-field model; ms_model="
                                f"{self.ms_model!r}; accepted: 'lightfield'")
        if self.occlusion and self.ms_model != "lightfield":
            raise AquaspecError(f"occlusion is part of the light-field model; ms_model="
                                f"{self.ms_model!r}; accepted: 'lightfield'")
        object.__setattr__(self, "lamps", tuple(self.lamps))
        for k, lamp in enumerate(self.lamps):
            if not isinstance(lamp, Lamp):
                raise AquaspecError(f"lamps[{k}] is {lamp!r}; accepted: aquaspec.light.lamp.Lamp "
                                    "(aquaspec.light.lamp.parse_lamps for --lamp specs)")
        if self.surface not in SURFACE_MODELS:
            raise AquaspecError(f"surface {self.surface!r}; accepted: "
                                f"{', '.join(SURFACE_MODELS)}")
        if self.surface != "index-matched" and self.ms_model != "lightfield":
            raise AquaspecError(f"surface {self.surface!r} is the light field's top boundary; "
                                f"ms_model={self.ms_model!r}; accepted: 'lightfield'")
        if self.occlusion and self.ambient_shadow:
            raise AquaspecError("occlusion and ambient_shadow both take the scene's shadow out "
                                "of the water's light; accepted: one of them")

    @property
    def cone_deg(self) -> float:
        """The forward cone in degrees, ``forward_cone_deg`` or the model's default."""
        return forward_cone(self.forward_cone_deg, self.cone_spread)

    def lightfield_tables(self) -> LightfieldTables | None:
        """Light-field tables for ``ms_model="lightfield"`` (None for the seeds' model).

        With a sun (``light.sun``) the field is the sky's and the sun's
        diffuse light, still per unit of the whole ``E0``. Computed on the
        first call and kept in :attr:`cache`.
        """
        if self.ms_model != "lightfield":
            return None
        if self.cache.lightfield_tables is None:
            bed = ({} if self.seabed is None else
                   {"seabed_depth_m": float(self.seabed.depth_m),
                    "seabed_albedo": self.seabed.albedo_on(self.bands)})

            def solve(e0):
                extra = {}
                if self.light.sun is not None:
                    extra = {"sun_mu0": self.light.sun.mu0,
                             "sun_fraction": np.clip(self.light.sun_horizontal_on(self.bands)
                                                     / np.where(e0 > 0, e0, 1.0), 0.0, 1.0)}
                return lightfield_tables(
                    self.water.on_bands(self.bands), phase=self.phase,
                    forward_cone_deg=self.cone_deg, cone_spread=self.cone_spread,
                    spread_scattering=self.spread_scattering,
                    ambient_shadow=self.ambient_shadow, surface=SURFACE_MODELS[self.surface],
                    **bed, **extra, **dict(self.phase_params))

            e0 = self.light.on_bands(self.bands)
            tables = solve(e0)
            if self.light.sun is not None and tables.surface == "fresnel":
                # The light's E0 is what the sky and the sun send through the
                # surface; under a mirroring surface E_d(0) also holds the
                # water's light sent back down, the share m = 1 - sky_share -
                # sun_fraction of it, so E0 (1 - m) = sky + sun. m is linear in
                # the sun's share s = sun / E0 (the field is linear in its
                # sources), m = alpha + beta s: two solves give alpha and beta,
                # then E0 = (sky + sun (1 + beta)) / (1 - alpha) exactly, and a
                # third solve is the field for it.
                sun = self.light.sun_horizontal_on(self.bands)

                def mirrored(t):
                    return 1.0 - t.sky_share() - np.asarray(t.sun_fraction, dtype=float)

                s0, m0 = np.asarray(tables.sun_fraction, dtype=float), mirrored(tables)
                e1 = e0 / (1.0 - m0)
                t1 = solve(e1)
                s1, m1 = np.asarray(t1.sun_fraction, dtype=float), mirrored(t1)
                ds = s1 - s0
                beta = np.divide(m1 - m0, ds, out=np.zeros_like(ds), where=np.abs(ds) > 1e-9)
                alpha = m0 - beta * s0
                e0 = (e0 + beta * sun) / (1.0 - alpha)
                tables = solve(e0)
            self.cache.e0 = e0
            self.cache.lightfield_tables = tables
        return self.cache.lightfield_tables

    def e0_on_bands(self) -> np.ndarray:
        """``E0`` per band, the downwelling irradiance just below the surface:
        the light's (:meth:`aquaspec.light.sky.SurfaceLight.on_bands`), but for
        a sun above the flat surface with the light-field model, where it also
        holds the water's light the surface mirrors back down
        (:meth:`lightfield_tables`)."""
        if (self.light.sun is not None and self.ms_model == "lightfield"
                and self.surface == "flat"):
            self.lightfield_tables()
            return np.asarray(self.cache.e0, dtype=float)
        return self.light.on_bands(self.bands)

    def sun_inputs(self, caustics: bool = True) -> SunInputs | None:
        """What the sun's terms need per band (:class:`aquaspec.transport.sun_scattering.SunInputs`),
        or None without a sun. Computed on the first call and kept in :attr:`cache`.

        The beam's extinction is the light field's delta-M ``c*`` (its diffuse
        field complements that beam) or ``c`` for the seeds' model; on the way
        to the camera the sun's light has the extinction the surfaces' light
        has (``c - f b`` with the light field's forward cone, else ``c``).
        ``caustics=False``: without the waves' caustic map (None), which is
        then not built if it was not yet (about a minute; the view from above
        does not draw it).
        """
        if self.light.sun is None:
            return None
        if self.cache.sun_inputs is None and (caustics or self.waves is None):
            self.cache.sun_inputs = self._sun_inputs(with_map=True)
        if self.cache.sun_inputs is None:
            return self._sun_inputs(with_map=False)
        if caustics:
            return self.cache.sun_inputs
        return dataclasses.replace(self.cache.sun_inputs, caustics=None)

    def _sun_inputs(self, with_map: bool) -> SunInputs:
        """:meth:`sun_inputs` computed, the caustic map only ``with_map``."""
        sun = self.light.sun
        bw = self.water.on_bands(self.bands)
        a, b = np.asarray(bw.a, dtype=float), np.asarray(bw.b, dtype=float)
        c = a + b
        tables = self.lightfield_tables()
        if tables is None:
            c_sun = c_view = c
        else:
            c_sun = np.asarray(tables.beam_extinction, dtype=float)
            c_view = tables.ray_extinction(a, b)
        caustics = None
        if self.waves is not None and with_map:
            # The pattern carried on into the light scattered through small
            # angles (aquaspec.light.caustic_scatter): one transfer for all bands.
            scatter = ScatterTransfer.for_beam(
                b=b, c=c, c_sun=c_sun, wavelength_nm=self.bands.centers_nm,
                to_sun=sun.to_sun, phase=self.phase, phase_params=self.phase_params)
            caustics = cached_caustic_map(self.waves, sun.elevation_deg, sun.azimuth_deg,
                                          n_water=sun.n_water, scatter=scatter)
        return SunInputs(
            beam0=sun.beam_on(self.bands), c_sun=c_sun, c_view=c_view, b=b,
            log_phase=log_phase_table(self.phase, b=b, wavelength_nm=self.bands.centers_nm,
                                      **dict(self.phase_params)),
            to_sun=sun.to_sun, caustics=caustics)

    def lamp_inputs(self, camera) -> list[LampInputs]:
        """The lamps placed for ``camera`` with what their terms need per band
        (:class:`aquaspec.transport.lamp_scattering.LampInputs`); [] without lamps.

        The lamps' light, from the lamp and on its way to the camera, has the
        extinction surfaces' light has towards the camera: ``c - f b`` with the
        light field's forward cone (scattering within it stays in the beam),
        ``c`` with the seeds' model (``forward`` is that ``f``, for the lamps'
        glow, :mod:`aquaspec.transport.lamp_halo`). (The sun's beam's delta-M ``c*`` on the
        lamp's path left a card lit through Jerlov II with HG 0.92 at 0.41-0.68
        of Mitsuba's all-orders radiance, the forward cone at 1.04-1.07; see
        docs/model.md, Lamps.)
        """
        if not self.lamps:
            return []
        if self.cache.lamp_bands is None:
            bw = self.water.on_bands(self.bands)
            a, b = np.asarray(bw.a, dtype=float), np.asarray(bw.b, dtype=float)
            tables = self.lightfield_tables()
            c_ray = a + b if tables is None else np.asarray(tables.ray_extinction(a, b), float)
            self.cache.lamp_bands = {
                "b": b, "c": c_ray,
                "forward": (None if tables is None
                            else np.asarray(tables.forward_fraction, dtype=float)),
                "log_phase": log_phase_table(self.phase, b=b,
                                             wavelength_nm=self.bands.centers_nm,
                                             **dict(self.phase_params)),
                "intensity": [lamp.intensity_on(self.bands) for lamp in self.lamps]}
        lb = self.cache.lamp_bands
        return [LampInputs(lamp.placed(camera), lb["intensity"][k], lb["c"], lb["c"], lb["b"],
                           lb["log_phase"], forward=lb["forward"])
                for k, lamp in enumerate(self.lamps)]

    def medium(self, materials) -> dict:
        """Keyword arguments of :func:`aquaspec.shading.shade.shade_gbuffer` and the
        shading passes' ``set_medium`` for a scene of ``materials``."""
        bw = self.water.on_bands(self.bands)
        mb = (np.stack([m.on_bands(self.bands) for m in materials]) if materials
              else np.zeros((0, self.bands.n)))
        return dict(a=bw.a, b=bw.b, kd=bw.kd, e0=self.e0_on_bands(),
                    response_weights=self.sensor.band_weights(self.bands, outside=self.outside),
                    material_bands=mb,
                    sigmoid_centers_t=normalised_wavelength(self.bands.centers_nm),
                    ambient=self.ambient)

    def describe(self) -> dict:
        """The setup's parameters, JSON-ready (for a render's metadata)."""
        model_params = ({"ambient_model": self.ambient} if self.ms_model == MONZON2022
                        else {"phase": self.phase, **dict(self.phase_params),
                              "forward_cone_deg": self.cone_deg,
                              "cone_spread": self.cone_spread,
                              "spread_scattering": self.spread_scattering,
                              "ambient_shadow": self.ambient_shadow,
                              "occlusion": self.occlusion,
                              "surface": self.surface,
                              "seabed": None if self.seabed is None
                              else self.seabed.describe()})
        return {"water": self.water.describe(), "sensor": self.sensor.describe(),
                "light": self.light.describe(), "bands": self.bands.describe(),
                "ms_model": self.ms_model, **model_params,
                "sensor_outside_range": self.outside,
                **({} if not self.lamps else {"lamps": [lamp.describe() for lamp in self.lamps],
                                              "lamp_model": LAMP_MODEL}),
                **({} if self.waves is None else {"caustics": self.sun_inputs().caustics
                                                  .describe()})}
