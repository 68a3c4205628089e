"""The light-field GPU pass as its tests make it: a setup and a pass on a G-buffer.

Used by tests/gpu/passes/test_lightfield_pass.py and test_watertable_pass.py.
"""

from __future__ import annotations

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup


def setup_of(water, n, phase, cone=0.0, sensor="nikon-5100-npl", cone_spread=False):
    return SpectralSetup(load_water(water), get_sensor(sensor), surface_light("overcast"),
                         Bands(n), ms_model="lightfield", phase=phase, forward_cone_deg=cone,
                         cone_spread=cone_spread)


def gpu_pass(gb, setup, e0_scale=1.0, filtering=None, tables=None):
    from aquaspec.gpu.device import get_device
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.gpu.passes.lightfield import LightfieldPass
    g = GBufferTextures(get_device()[1], gb.camera.width, gb.camera.height)
    g.upload(gb)
    lp = LightfieldPass(g, filtering=filtering)
    medium = setup.medium(gb.materials)
    medium["e0"] = medium["e0"] * e0_scale
    lp.set_medium(**medium, tables=setup.lightfield_tables() if tables is None else tables)
    return lp
