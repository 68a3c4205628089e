"""Bathymetry grids: reading them, refusing bad ones, the height-field mesh
and renders over it from below and from above (issue 30)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import aquaspec
from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.scene.bathymetry import (Bathymetry, bathymetry_mesh, bathymetry_scene,
                                       check_camera_over, load_bathymetry)
from aquaspec.scene.camera import Camera, camera_above

GRID = 4.0 + 0.5 * np.arange(6)[:, None] + 0.25 * np.arange(5)[None, :]   # 6 rows x 5 cols


def _write_asc(path, depth, nodata=None, cellsize=0.5):
    rows, cols = depth.shape
    lines = [f"ncols {cols}", f"nrows {rows}", "xllcorner 0", "yllcorner 0",
             f"cellsize {cellsize}"] + ([f"NODATA_value {nodata}"] if nodata is not None else [])
    lines += [" ".join(f"{-v:g}" for v in row) for row in depth]
    path.write_text("\n".join(lines) + "\n")


def test_every_format_reads_the_same_grid(tmp_path):
    from PIL import Image
    np.save(tmp_path / "g.npy", GRID)
    np.savetxt(tmp_path / "g.csv", GRID, delimiter=",")
    _write_asc(tmp_path / "g.asc", GRID)
    Image.fromarray(np.round(GRID * 1000).astype(np.uint16)).save(tmp_path / "g.png")
    for name in ("g.npy", "g.csv", "g.png"):
        b = load_bathymetry(tmp_path / name, spacing_m=0.5)
        np.testing.assert_allclose(b.depth_m, GRID, atol=1e-3)
    asc = load_bathymetry(tmp_path / "g.asc")                # elevations, its cellsize
    np.testing.assert_allclose(asc.depth_m, GRID)
    assert asc.spacing_m == 0.5


@pytest.mark.parametrize("case,match", [
    ("garbage.npy", "could not read bathymetry file"),
    ("nan.npy", "2 samples are NaN or infinite .*row 1, column 2"),
    ("nodata.asc", "1 samples are NaN or infinite .*row 0, column 1"),
    ("land.npy", "row 2, column 0 is -1 m deep, at or above the surface"),
    ("nospacing.csv", "has no sample spacing"),
    ("x.tif", r"has suffix .\.tif.; accepted: \.asc, \.npy"),
    ("missing.npy", "does not exist"),
    ("short.asc", "the header says 6 x 5 samples, the file holds 5 x 5"),
])
def test_bad_grids_are_refused_with_the_reason(tmp_path, case, match):
    grid = GRID.copy()
    path = tmp_path / case
    if case == "garbage.npy":
        path.write_bytes(b"not a numpy file")
    elif case == "nan.npy":
        grid[1, 2] = grid[3, 3] = np.nan
        np.save(path, grid)
    elif case == "nodata.asc":
        grid[0, 1] = 9999.0
        _write_asc(path, grid, nodata=-9999)
    elif case == "land.npy":
        grid[2, 0] = -1.0
        np.save(path, grid)
    elif case == "nospacing.csv":
        np.savetxt(path, grid, delimiter=",")
    elif case == "x.tif":
        path.write_bytes(b"")
    elif case == "short.asc":
        _write_asc(path, grid)
        text = path.read_text().splitlines()
        path.write_text("\n".join(text[:-1]) + "\n")
    with pytest.raises(AquaspecError, match=match):
        load_bathymetry(path, spacing_m=0.5 if case not in ("nospacing.csv",) else None)


def test_bad_values_in_the_api():
    with pytest.raises(AquaspecError, match="spacing 0; accepted"):
        Bathymetry(GRID, 0)
    with pytest.raises(AquaspecError, match="shape \\(5,\\)"):
        Bathymetry(np.ones(5), 1.0)


def test_the_mesh_is_the_grid_and_depth_at_interpolates_it():
    """Vertices at y = -depth on the grid (centred), faces up; on a plane
    (depth linear in x and z) depth_at is exact anywhere inside."""
    b = Bathymetry(GRID, 0.5)
    mesh = bathymetry_mesh(b)
    assert len(mesh.faces) == 2 * 5 * 4
    np.testing.assert_allclose(np.sort(-mesh.vertices[:, 1]), np.sort(GRID.reshape(-1)))
    # y = -(4 + z' + x' / 2) on the grid's plane: the normal is (0.5, 1, 1) / 1.5.
    np.testing.assert_allclose(mesh.normals, np.tile([1 / 3, 2 / 3, 2 / 3], (30, 1)), atol=1e-12)
    np.testing.assert_allclose(mesh.vertices[:, [0, 2]].mean(axis=0), 0.0, atol=1e-12)
    rng = np.random.default_rng(1)
    x, z = rng.uniform(-1.0, 1.0, 20), rng.uniform(-1.2, 1.2, 20)
    x0, z0 = b.origin()
    expect = 4.0 + 0.5 * (z - z0) / 0.5 + 0.25 * (x - x0) / 0.5
    np.testing.assert_allclose(b.depth_at(x, z), expect, rtol=1e-12)
    assert b.seabed().depth_m == pytest.approx(GRID.mean())


def test_a_camera_below_the_bottom_is_refused():
    b = Bathymetry(GRID, 0.5)
    cam = Camera.look_at([0.0, -6.0, 0.0], [0.0, -6.0, -1.0], width=8, height=6)
    with pytest.raises(AquaspecError, match="not below the camera at 6 m"):
        check_camera_over(b, cam)
    check_camera_over(b, camera_above(2.0, width=8, height=6))


def test_render_over_a_flat_bathymetry_sees_the_bottom_where_it_is():
    """From below, a flat 6 m bottom under a camera at 2 m: every ray going
    down meets it at 4 / -v_y (the G-buffer's distance)."""
    b = Bathymetry(np.full((81, 81), 6.0), 0.5)
    cam = Camera.look_at([0.0, -2.0, 0.0], [0.0, -3.0, -0.7], width=24, height=16)
    res = aquaspec.render(scene=bathymetry_scene(b, cam), size=(24, 16), bands=4,
                          backend="numpy")
    v = cam.ray_directions()
    np.testing.assert_allclose(res.gbuffer.distance, 4.0 / -v[..., 1], rtol=1e-5)
    assert res.params["scene"]["bathymetry"]["depth_range_m"] == [6.0, 6.0]
    assert res.params["seabed"]["depth_m"] == 6.0


def test_cli_bathymetry_from_above_and_below(tmp_path, capsys):
    grid = tmp_path / "bed.npy"
    np.save(grid, 3.0 + np.random.default_rng(0).uniform(0, 1, (24, 24)))
    out = tmp_path / "above.png"
    assert main(["render", "--bathymetry", f"{grid},0.5", "--camera-height", "3",
                 "--size", "20x12", "--bands", "4", "--backend", "numpy", "-o", str(out)]) == 0
    meta = json.loads((tmp_path / "above.png.json").read_text())
    assert meta["scene"]["bathymetry"]["rows"] == 24 and "above_water" in meta
    assert main(["render", "--bathymetry", f"{grid},0.5", "--depth", "5", "--size", "20x12",
                 "-o", str(out)]) == 2
    assert "not below the camera at 5 m" in capsys.readouterr().err
    assert main(["render", "--bathymetry", f"{grid},x", "-o", str(out)]) == 2
    assert "spacing 'x' is not a number" in capsys.readouterr().err
