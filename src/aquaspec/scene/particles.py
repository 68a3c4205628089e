"""Marine snow: a seeded set of suspended particles around the camera, drifting with a current.

Marine snow is the aggregates larger than 0.5 mm (detritus, diatom flocs,
faecal pellets, mucus) that hang in the water (Alldredge & Silver,
"Characteristics, dynamics and significance of marine snow", Prog.
Oceanogr. 20, 41-82, 1988). A photograph shows the ones within a few metres
as bright, usually out-of-focus points; farther ones fall under a pixel and
are part of the water's scattering ``b``.

The set (:class:`MarineSnow` describes it, :class:`SnowField` holds it):

- ``density_per_m3`` particles per cubic metre, uniformly in a cube of side
  ``2 range_m`` centred on the camera (metres, y up, surface at y = 0; the
  particles above the surface are dropped). The cube is a periodic tile of
  the water: a particle at world position ``p0 + v t`` (``v`` the current,
  m/s; ``t`` s) is shown at its image in the tile around the camera, so the
  set is fixed in the moving water, and a camera that moves sees particles
  leave on one side and enter on the other. The same ``seed`` gives the same
  particles.
- Diameters ``D`` (m) from a power-law number spectrum
  ``n(D) = a D^-slope`` between ``d_min_mm`` and ``d_max_mm``; the default
  slope 3.0 is what Jackson et al. measured for aggregates in Monterey Bay
  from image diameters (``b1 = 2.96-3.00``; "Particle size spectra between
  1 um and 1 cm at Monterey Bay determined using multiple instruments",
  Deep-Sea Res. I 44, 1739-1767, 1997), 0.5 mm the lower size bound of
  marine snow (Alldredge & Silver 1988), 5 mm a cap of this module's
  choosing (the spectrum has few particles there: with slope 3, 1 % of them
  are larger than 5 mm when the upper bound is infinite).
- Each particle is a Lambertian sphere of spectrally flat ``albedo`` (a
  choice, not a measurement: 0.5, a light grey); its shading is in
  :mod:`aquaspec.shading.particles`.

The number is ``round(density (2 range)^3)``, deterministic; more than
:data:`MAX_PARTICLES` is refused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError

#: The most particles a field holds (a million is ~40 MB of positions and sizes).
MAX_PARTICLES = 2_000_000
#: The side of the cells the particles are sorted by, about, m (:class:`SnowField`).
CELL_M = 1.0
#: Keys of the ``--marine-snow`` spec beyond ``DENSITY[,SEED]``, with their fields.
SPEC_KEYS = {"albedo": "albedo", "range": "range_m", "slope": "slope",
             "dmin": "d_min_mm", "dmax": "d_max_mm", "blur": "blur_px",
             "current": "current_m_s"}


def _number(value, name, lo, hi, *, lo_open=False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise AquaspecError(f"marine snow {name}={value!r}; accepted: a finite number "
                            f"{'>' if lo_open else '>='} {lo:g} and <= {hi:g}")
    if (value <= lo if lo_open else value < lo) or value > hi:
        raise AquaspecError(f"marine snow {name}={value!r}; accepted: "
                            f"{'>' if lo_open else '>='} {lo:g} and <= {hi:g}")
    return float(value)


@dataclass(frozen=True)
class MarineSnow:
    """The marine snow of a render or a live view.

    Parameters
    ----------
    density_per_m3 : float
        Particles per cubic metre (> 0).
    seed : int
        Seed of the positions and sizes (>= 0).
    albedo : float
        The spectrally flat reflectance of the particles' Lambertian
        surface, 0 to 1.
    range_m : float
        Half the side of the cube of particles around the camera, m.
    slope : float
        Power-law exponent of the number spectrum ``n(D) ~ D^-slope``.
    d_min_mm, d_max_mm : float
        Diameter range, mm.
    blur_px : float
        Diameter of the smallest disc a particle is drawn as, pixels (the
        fixed blur without a camera model; at least 1).
    current_m_s : (3,) floats
        The water's velocity (x, y, z), m/s: the particles drift with it
        in a live view (a render is the instant ``t = 0``).
    """

    density_per_m3: float
    seed: int = 0
    albedo: float = 0.5
    range_m: float = 4.0
    slope: float = 3.0
    d_min_mm: float = 0.5
    d_max_mm: float = 5.0
    blur_px: float = 1.5
    current_m_s: tuple = (0.05, -0.002, 0.02)

    def __post_init__(self):
        _number(self.density_per_m3, "density_per_m3", 0.0, 1e6, lo_open=True)
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) \
                or self.seed < 0:
            raise AquaspecError(f"marine snow seed={self.seed!r}; accepted: an integer >= 0")
        _number(self.albedo, "albedo", 0.0, 1.0)
        _number(self.range_m, "range_m", 0.0, 50.0, lo_open=True)
        _number(self.slope, "slope", 0.0, 10.0)
        _number(self.d_min_mm, "d_min_mm", 0.0, 100.0, lo_open=True)
        _number(self.d_max_mm, "d_max_mm", 0.0, 100.0, lo_open=True)
        if self.d_max_mm < self.d_min_mm:
            raise AquaspecError(f"marine snow d_max_mm={self.d_max_mm!r} is below d_min_mm="
                                f"{self.d_min_mm!r}; accepted: d_min_mm <= d_max_mm")
        _number(self.blur_px, "blur_px", 1.0, 64.0)
        current = tuple(self.current_m_s)
        if len(current) != 3:
            raise AquaspecError(f"marine snow current_m_s={self.current_m_s!r}; accepted: "
                                "three velocities (x, y, z) in m/s")
        for v in current:
            _number(v, "current_m_s", -10.0, 10.0)
        object.__setattr__(self, "current_m_s", tuple(float(v) for v in current))
        n = self.count
        if n > MAX_PARTICLES:
            raise AquaspecError(
                f"marine snow of {self.density_per_m3:g} per m^3 in a cube of "
                f"{2 * self.range_m:g} m makes {n} particles; accepted: at most "
                f"{MAX_PARTICLES} (a lower density or range_m)")

    @property
    def count(self) -> int:
        """The number of particles in the cube."""
        return int(round(self.density_per_m3 * (2.0 * self.range_m) ** 3))

    def describe(self) -> dict:
        return {"density_per_m3": self.density_per_m3, "seed": int(self.seed),
                "particles_in_cube": self.count, "cube_side_m": 2.0 * self.range_m,
                "albedo": self.albedo, "size_distribution": {
                    "kind": "power-law number spectrum n(D) ~ D^-slope",
                    "slope": self.slope, "d_min_mm": self.d_min_mm, "d_max_mm": self.d_max_mm,
                    "source": "slope 2.96-3.00: Jackson et al. 1997, Deep-Sea Res. I 44, 1739"},
                "current_m_s": list(self.current_m_s), "min_blur_px": self.blur_px,
                "model": "aquaspec.shading.particles: Lambertian spheres lit by the light "
                         "field, the sun's beam and the lamps, attenuated exp(-c r) to the "
                         "camera, drawn as discs of their image or blur size, depth-tested"}


def parse_marine_snow(spec) -> MarineSnow | None:
    """``render(marine_snow=)`` / ``--marine-snow``: None, a :class:`MarineSnow`,
    a density (number), or ``"DENSITY[,SEED][,key=value...]"`` with keys
    ``albedo``, ``range`` (m), ``slope``, ``dmin``/``dmax`` (mm), ``blur``
    (px), ``current`` (``vx:vy:vz`` m/s)."""
    if spec is None or isinstance(spec, MarineSnow):
        return spec
    if isinstance(spec, (int, float)) and not isinstance(spec, bool):
        return MarineSnow(float(spec))
    if not isinstance(spec, str) or not spec.strip():
        raise AquaspecError(f"marine snow {spec!r}; accepted: None, a density per m^3, "
                            "'DENSITY[,SEED][,key=value...]' or a MarineSnow")
    parts = [p.strip() for p in spec.split(",")]
    kw = {}
    try:
        kw["density_per_m3"] = float(parts[0])
        rest = parts[1:]
        if rest and "=" not in rest[0]:
            kw["seed"] = int(rest[0])
            rest = rest[1:]
        for item in rest:
            key, _, value = item.partition("=")
            if key not in SPEC_KEYS:
                raise AquaspecError(f"marine snow key {key!r} in {spec!r}; accepted: "
                                    f"{', '.join(SPEC_KEYS)}")
            kw[SPEC_KEYS[key]] = (tuple(float(v) for v in value.split(":"))
                                  if key == "current" else float(value))
    except ValueError as exc:
        if isinstance(exc, AquaspecError):
            raise
        raise AquaspecError(f"marine snow {spec!r}; accepted: 'DENSITY[,SEED][,key=value...]' "
                            "with numbers, e.g. '200,7' or '200,7,albedo=0.4,current=0.1:0:0'"
                            ) from None
    return MarineSnow(**kw)


def power_law_diameters(u, d_min, d_max, slope) -> np.ndarray:
    """Diameters with number spectrum ``D^-slope`` on ``[d_min, d_max]`` from
    uniform numbers ``u`` in [0, 1) (inverse of the cumulative distribution)."""
    u = np.asarray(u, dtype=float)
    if d_max == d_min:
        return np.full(u.shape, float(d_min))
    k = 1.0 - slope
    if abs(k) < 1e-12:
        return d_min * (d_max / d_min) ** u
    lo, hi = d_min ** k, d_max ** k
    return (lo + u * (hi - lo)) ** (1.0 / k)


class SnowField:
    """The particles of a :class:`MarineSnow`: positions in the periodic cube
    (drawn once) and diameters, and where they are at an instant.

    The particles are kept sorted by cells of about :data:`CELL_M` of the cube,
    so that :meth:`at` with a camera moves and returns only the particles of
    the cells its view may see (the same particles :meth:`at` without a
    camera gives and a cull to the view keeps, fewer computed)."""

    def __init__(self, snow: MarineSnow):
        self.snow = snow
        rng = np.random.default_rng(snow.seed)
        side = 2.0 * snow.range_m
        origin = rng.uniform(0.0, side, (snow.count, 3))
        diameter = 1e-3 * power_law_diameters(rng.random(snow.count), snow.d_min_mm,
                                              snow.d_max_mm, snow.slope)
        self.cells = max(1, int(round(side / CELL_M)))
        self.cell_m = side / self.cells
        ijk = np.clip((origin / self.cell_m).astype(np.int64), 0, self.cells - 1)
        cell = (ijk[:, 0] * self.cells + ijk[:, 1]) * self.cells + ijk[:, 2]
        order = np.argsort(cell, kind="stable")
        self.origin, self.diameter_m = origin[order], diameter[order]
        self._starts = np.searchsorted(cell[order], np.arange(self.cells ** 3 + 1))

    def _moved(self, index, cam, time_s):
        side = 2.0 * self.snow.range_m
        # (The shift first, one vector: the same sums as origin + drift - cam + side / 2.)
        shift = np.asarray(self.snow.current_m_s) * float(time_s) - cam + 0.5 * side
        pos = self.origin[index] + shift
        np.mod(pos, side, out=pos)
        pos += cam - 0.5 * side
        under = pos[:, 1] < 0.0
        return pos[under], self.diameter_m[index][under]

    def at(self, camera_position, time_s: float = 0.0, *, camera=None,
           margin_px: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """``(positions (N, 3) m, diameters (N,) m)`` at ``time_s``: the water's
        particles moved by the current, each at its image within ``range_m``
        of ``camera_position`` along every axis, those below the surface only.
        With ``camera`` (a :class:`aquaspec.scene.camera.Camera` at that
        position), only the cells whose bounding sphere reaches into its view,
        widened by ``margin_px`` pixels, are returned (a superset of the
        particles in view)."""
        cam = np.asarray(camera_position, dtype=float)
        if camera is None:
            return self._moved(slice(None), cam, time_s)
        return self._moved(self.indices_in_view(cam, time_s, camera, margin_px), cam, time_s)

    def indices_in_view(self, camera_position, time_s, camera, margin_px) -> np.ndarray:
        """Indices into :attr:`origin` of the particles of the cells :meth:`at`
        keeps for ``camera`` (at ``camera_position``) at ``time_s``."""
        cam = np.asarray(camera_position, dtype=float)
        keep = self._cells_in_view(cam, time_s, camera, margin_px)
        lo, hi = self._starts[:-1][keep], self._starts[1:][keep]
        sizes = hi - lo
        return (np.repeat(lo - np.cumsum(sizes) + sizes, sizes)
                + np.arange(int(sizes.sum())))

    def _cells_in_view(self, cam, time_s, camera, margin_px) -> np.ndarray:
        """Which cells (flat index) may hold particles ``camera`` sees."""
        n, s = self.cells, self.cell_m
        side = n * s
        shift = np.mod(np.asarray(self.snow.current_m_s) * float(time_s) - cam + 0.5 * side,
                       side)
        k = np.arange(n)
        # Per axis, each cell's centre in the window around the camera; a cell
        # cut by the window's edge has its other part one side away.
        low = np.mod(k[None, :] * s + shift[:, None], side)          # (3, n)
        centre = cam[:, None] - 0.5 * side + low + 0.5 * s
        other = np.where(low + s > side, centre - side, centre)
        idx = [g.ravel() for g in np.meshgrid(k, k, k, indexing="ij")]
        radius = 0.5 * np.sqrt(3.0) * s
        seen = np.zeros(n ** 3, dtype=bool)
        for mix in range(8):            # every combination of the parts along the axes
            pts = np.stack([(other if (mix >> a) & 1 else centre)[a][idx[a]]
                            for a in range(3)], axis=-1)
            seen |= _sphere_in_view(pts, radius, camera, margin_px)
        return seen


def _sphere_in_view(centres, radius, camera, margin_px) -> np.ndarray:
    """Whether spheres of ``radius`` at ``centres`` (N, 3) reach into the camera's
    view (its four side planes widened by ``margin_px``, in front of it)."""
    p = np.asarray(centres, dtype=float) - camera.position
    x, y, z = p @ camera.right, -(p @ camera.true_up), p @ camera.forward
    ok = z > -radius
    for coord, lo, hi, f in ((x, -camera.cx - margin_px, camera.width - camera.cx + margin_px,
                              camera.fx),
                             (y, -camera.cy - margin_px, camera.height - camera.cy + margin_px,
                              camera.fy)):
        # Planes through the centre: coord f - t z = 0 with t the edge's offset in pixels.
        for t, sign in ((lo, -1.0), (hi, 1.0)):
            norm = np.hypot(f, t)
            ok &= sign * (coord * f - t * z) / norm <= radius
    return ok
