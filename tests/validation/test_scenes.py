"""The occluded validation scenes (issue 36): geometry, masks, the study's
plumbing per scene, the per-scene report, the CLI's --scene and --occlusion."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.scene.mesh import face_normals
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.validation.scenes import (BOARD_DISTANCE_M, OCCLUDED_SCENES, SCENES,
                                        SEABED_BELOW_M, board_scene, cuboid, masks)

DEPTH = 5.0


def mesh_named(scene, name):
    (mesh,) = [m for m in scene.meshes if m.name == name]
    return mesh


def board_box(scene):
    """(lo, hi) corners of the board's backing."""
    v = mesh_named(scene, "backing").vertices
    return v.min(axis=0), v.max(axis=0)


def closed_and_outward(mesh):
    """Every edge (vertices merged by position) is used once in each direction
    (a closed, consistently wound surface), the divergence theorem gives a
    positive volume (the winding faces outwards), and the given normals are
    the winding's."""
    v = np.round(mesh.vertices, 9)
    _, ids = np.unique(v, axis=0, return_inverse=True)
    f = ids.reshape(-1)[mesh.faces]
    directed = [(a, b) for tri in f for a, b in ((tri[0], tri[1]), (tri[1], tri[2]),
                                                    (tri[2], tri[0]))]
    closed = sorted(directed) == sorted((b, a) for a, b in directed) and \
        len(set(directed)) == len(directed)
    tri = mesh.vertices[mesh.faces]
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    given = mesh.normals[mesh.faces].mean(axis=1)
    same = np.allclose(face_normals(mesh.vertices, mesh.faces), given, atol=1e-12)
    return closed, volume, same


class TestGeometry:
    def test_cuboid_is_closed_and_faces_out(self):
        box = cuboid([0.0, -1.0, 2.0], [1.0, 0.5, 2.5], 0, "box")
        closed, volume, same = closed_and_outward(box)
        assert closed and same
        assert volume == pytest.approx(1.0 * 1.5 * 0.5)
        # Each face's normal points away from the box's centre.
        centre = box.vertices.mean(axis=0)
        tri = box.vertices[box.faces]
        out = np.einsum("ij,ij->i", face_normals(box.vertices, box.faces),
                        tri.mean(axis=1) - centre)
        assert np.all(out > 0)
        with pytest.raises(AquaspecError, match="box 'flat'.*accepted: finite corners"):
            cuboid([0, 0, 0], [1, 0, 1], 0, "flat")

    @pytest.mark.parametrize("name", OCCLUDED_SCENES)
    def test_every_mesh_faces_where_it_is_seen_from(self, name):
        """The occluder is closed with outward normals; the board's quads face
        the camera and the seabed faces up (Mitsuba's surfaces are one-sided)."""
        scene, cam = board_scene(DEPTH, scene=name)
        assert scene.seabed.depth_m == pytest.approx(DEPTH + SEABED_BELOW_M)
        for mesh in scene.meshes:
            n = face_normals(mesh.vertices, mesh.faces)
            if mesh.name == name:
                closed, volume, same = closed_and_outward(mesh)
                assert closed and volume > 0 and same, name
            elif mesh.name == "seabed":
                np.testing.assert_allclose(n, [[0.0, 1.0, 0.0]] * 2)
                assert mesh.vertices[0, 1] == pytest.approx(-DEPTH - SEABED_BELOW_M)
            else:
                np.testing.assert_allclose(n, np.tile(-cam.forward, (len(n), 1)), atol=1e-12)
        assert (name == "open") == (len(scene.meshes) == 26)

    def test_ledge_over_the_board(self):
        scene, _ = board_scene(DEPTH, scene="ledge")
        lo, hi = board_box(scene)
        v = mesh_named(scene, "ledge").vertices
        # Its underside 0.3 m above the board's top edge, 0.2 m thick.
        assert v[:, 1].min() == pytest.approx(hi[1] + 0.3)
        assert v[:, 1].max() - v[:, 1].min() == pytest.approx(0.2)
        # Wider than the board, from behind it to well in front of it.
        assert v[:, 0].min() < lo[0] and v[:, 0].max() > hi[0]
        assert v[:, 2].min() < lo[2] - 0.4 and v[:, 2].max() > hi[2] + 1.0
        assert scene.materials[mesh_named(scene, "ledge").material].values.max() <= 0.05

    def test_wall_behind_the_board(self):
        scene, cam = board_scene(DEPTH, scene="wall")
        lo, hi = board_box(scene)
        v = mesh_named(scene, "wall").vertices
        gap = lo[2] - v[:, 2].max()
        assert 0.3 <= gap <= 0.5
        assert v[:, 1].min() < -DEPTH - SEABED_BELOW_M and v[:, 1].max() > hi[1] + 1.0
        assert v[:, 0].max() - v[:, 0].min() >= 4.0
        m = masks(raycast_gbuffer(scene, cam), scene="wall")
        # It fills the view behind the board: no open water is seen.
        assert not m["background"].any() and m["occluder"].sum() > 1000

    def test_box_on_the_seabed_in_view(self):
        scene, cam = board_scene(DEPTH, scene="box")
        v = mesh_named(scene, "box").vertices
        bed = -DEPTH - SEABED_BELOW_M
        assert v[:, 1].min() < bed < v[:, 1].min() + 0.05
        assert np.ptp(v, axis=0) == pytest.approx([1.0, 1.01, 1.0])
        m = masks(raycast_gbuffer(scene, cam), scene="box")
        assert m["occluder"].sum() > 100 and m["seabed"].sum() > 500

    def test_bad_scene(self):
        with pytest.raises(AquaspecError, match="scene='cave'; accepted: board, open, ledge"):
            board_scene(DEPTH, scene="cave")
        with pytest.raises(AquaspecError, match="view='down'; accepted: the occluded scenes "
                                                "in the level view only"):
            board_scene(DEPTH, scene="ledge", view="down")
        with pytest.raises(AquaspecError, match="seabed_below_m=2.0 with scene='box'"):
            board_scene(DEPTH, scene="box", seabed_below_m=2.0)


class TestMasks:
    @staticmethod
    def hits(name):
        scene, cam = board_scene(DEPTH, scene=name)
        gb = raycast_gbuffer(scene, cam)
        return scene, gb, masks(gb, scene=name)

    def test_shaded_seabed_lies_under_the_ledge(self):
        scene, gb, m = self.hits("ledge")
        shaded = m["shaded_seabed"]
        assert shaded.sum() > 200
        p = gb.positions()[shaded]
        v = mesh_named(scene, "ledge").vertices
        lo, hi = v.min(axis=0), v.max(axis=0)
        assert np.all((p[:, 0] >= lo[0]) & (p[:, 0] <= hi[0]))
        assert np.all((p[:, 2] >= lo[2]) & (p[:, 2] <= hi[2]))
        np.testing.assert_allclose(p[:, 1], -DEPTH - SEABED_BELOW_M, atol=1e-6)
        # Seabed outside the footprint is seen too (beyond the ledge's back).
        assert (m["seabed"] & ~shaded).sum() > 100
        # The ledge's underside is in view; part of the board's patches too.
        assert m["occluder"].sum() > 200 and m["grey"].sum() >= 9
        assert all(p.sum() >= 9 for p in m["patches"])

    def test_open_compares_the_same_seabed(self):
        """"open" marks the ledge's footprint: the same pixels with and without the ledge."""
        _, _, ledge = self.hits("ledge")
        _, _, open_ = self.hits("open")
        np.testing.assert_array_equal(ledge["shaded_seabed"], open_["shaded_seabed"])
        assert not open_["occluder"].any()
        # The ledge hides open water, not the seabed or the board.
        np.testing.assert_array_equal(ledge["seabed"], open_["seabed"])
        assert ledge["background"].sum() < open_["background"].sum()

    def test_shaded_seabed_beside_the_box(self):
        scene, gb, m = self.hits("box")
        p = gb.positions()[m["shaded_seabed"]]
        assert len(p) >= 30
        v = mesh_named(scene, "box").vertices
        lo, hi = v.min(axis=0), v.max(axis=0)
        dx = np.maximum(np.maximum(lo[0] - p[:, 0], p[:, 0] - hi[0]), 0)
        dz = np.maximum(np.maximum(lo[2] - p[:, 2], p[:, 2] - hi[2]), 0)
        d = np.hypot(dx, dz)
        assert np.all((d > 0) & (d <= 0.3 + 1e-9))
        assert d.max() > 0.2                     # the whole 0.3 m strip, not only its edge

    def test_shaded_seabed_before_the_wall(self):
        scene, gb, m = self.hits("wall")
        p = gb.positions()[m["shaded_seabed"]]
        assert len(p) >= 50
        face = mesh_named(scene, "wall").vertices[:, 2].max()
        assert np.all((p[:, 2] >= face) & (p[:, 2] <= -BOARD_DISTANCE_M))

    def test_the_thesis_board_is_unchanged(self):
        scene, gb, m = self.hits("board")
        assert scene.seabed is None and len(scene.meshes) == 25
        for r in ("seabed", "occluder", "shaded_seabed"):
            assert not m[r].any()
        assert m["background"].sum() > 4000


def fake_reference(monkeypatch, calls):
    """Replace the path tracer in the study by a constant image and fixed Kd."""
    import aquaspec.validation.study as study

    def render(scene, cam, water, light, **kw):
        calls.append(len(scene.meshes))
        return {"band_radiance": np.full((cam.height, cam.width, 30), 0.01), "seconds": 1.0}
    monkeypatch.setattr(study, "render_reference", render)
    monkeypatch.setattr(study, "preflight", lambda *a, **kw: None)
    monkeypatch.setattr(study, "measure_kd", lambda *a, **kw: {
        "kd": np.full(30, 0.1), "kd_stderr": np.full(30, 0.01)})
    return study


class TestStudy:
    kw = dict(waters=("IB",), depths=(5.0,), size=(48, 36), band_counts=(8,),
              ms_models=("lightfield",), kd_modes=("database",))

    def test_scenes_in_rows_keys_and_images(self, monkeypatch, tmp_path):
        from aquaspec.colour.sensors import get_sensor
        calls = []
        study = fake_reference(monkeypatch, calls)
        res = study.run_study(sensors={"human": get_sensor("human")}, cache_dir=tmp_path,
                              scene_names=("board", "ledge", "box"), **self.kw)
        # One reference per scene, each its own cache file (the scene is in the key).
        assert calls == [25, 27, 27] and len(list(tmp_path.glob("*.npz"))) == 4
        again = []
        fake_reference(monkeypatch, again)
        study.run_study(sensors={"human": get_sensor("human")}, cache_dir=tmp_path,
                        scene_names=("ledge",), **self.kw)
        assert again == []                       # from the cache
        assert [sc["scene"] for sc in res["scenes"]] == ["board", "ledge", "box"]
        assert res["params"]["scenes"] == ["board", "ledge", "box"]
        regions = {s: {r["region"] for r in res["rows"] if r["scene"] == s}
                   for s in ("board", "ledge", "box")}
        assert "shaded_seabed" not in regions["board"] and "occluder" not in regions["board"]
        assert {"seabed", "shaded_seabed", "occluder", "grey"} <= regions["ledge"]
        assert ("ledge", "IB", 5.0, "reference", "-") in res["images"]
        # The regions' mean colours, from the images and the scene's own masks.
        scene, cam = board_scene(5.0, scene="ledge", width=48, height=36)
        mask = masks(raycast_gbuffer(scene, cam), scene="ledge")["shaded_seabed"]
        ref = res["images"][("ledge", "IB", 5.0, "reference", "-")][mask].mean(axis=0)
        ours = res["images"][("ledge", "IB", 5.0, "lightfield-n8", "database")][mask].mean(axis=0)
        (row,) = [r for r in res["rows"] if r["scene"] == "ledge"
                  and r["region"] == "shaded_seabed" and r["method"] == "lightfield-n8"]
        np.testing.assert_allclose([row[f"ratio_{c}"] for c in "rgb"], ours / ref, rtol=1e-12)
        assert row["mean_ratio"] == pytest.approx(ours.sum() / ref.sum(), rel=1e-12)
        (pm,) = [r for r in res["rows"] if r["scene"] == "ledge"
                 and r["region"] == "patch_means" and r["method"] == "lightfield-n8"]
        assert pm["mean_abs_error"] >= abs(pm["mean_ratio"] - 1) - 1e-12
        # The convergence check includes the shaded seabed.
        ledge = res["scenes"][1]
        assert set(ledge["reference_stderr"]) == {"grey", "background", "shaded_seabed"}

    def test_occlusion_not_available(self, monkeypatch, tmp_path):
        from aquaspec.colour.sensors import get_sensor
        study = fake_reference(monkeypatch, [])
        monkeypatch.setitem(sys.modules, "aquaspec.scene.occlusion", None)
        with pytest.raises(AquaspecError, match="--occlusion: the light field's occlusion "
                                                "model .* is not available yet"):
            study.run_study(sensors={"human": get_sensor("human")}, cache_dir=tmp_path,
                            scene_names=("ledge",), occlusion=True, **self.kw)
        with pytest.raises(AquaspecError, match="occlusion is part of the light-field model"):
            study.run_study(sensors={"human": get_sensor("human")}, cache_dir=tmp_path,
                            occlusion=True, **{**self.kw, "ms_models": ("seeds",)})

    def test_occlusion_maps_reach_the_light_field_only(self, monkeypatch, tmp_path):
        """With an occlusion model (here a stand-in) the study computes the scene's
        maps once and hands them to the light field's shading, not to the seeds'."""
        from aquaspec.colour.sensors import get_sensor
        study = fake_reference(monkeypatch, [])
        made, seen = [], []
        fake = types.ModuleType("aquaspec.scene.occlusion")
        fake.occlusion_maps = lambda scene, cam: made.append(scene) or f"maps {len(made)}"
        monkeypatch.setitem(sys.modules, "aquaspec.scene.occlusion", fake)
        real = study.shade_gbuffer

        def shade(gb, *, occlusion=None, **kw):
            seen.append((kw.get("lightfield") is not None, occlusion))
            return real(gb, **kw)
        monkeypatch.setattr(study, "shade_gbuffer", shade)
        res = study.run_study(sensors={"human": get_sensor("human")}, cache_dir=tmp_path,
                              scene_names=("ledge",), occlusion=True,
                              **{**self.kw, "ms_models": ("seeds", "lightfield")})
        assert res["params"]["occlusion"] is True
        assert len(made) == 1                    # once for the scene, for every band count
        assert {occ for lf, occ in seen if lf} == {"maps 1"}
        assert {occ for lf, occ in seen if not lf} == {None}


class TestReport:
    def rows(self):
        out = []
        for cam, (grey, bed, p1, p2) in {"a": (1.2, 0.9, 1.1, 0.8),
                                         "b": (1.4, 0.7, 1.3, 1.0)}.items():
            base = {"scene": "ledge", "water": "IB", "depth_m": 5.0, "camera": cam,
                    "method": "lightfield-n16", "kd": "database", "rmse_rel": 0.0, "hsv": 0.0,
                    "hue_deg": 2.0, "ciede2000": 0.0}
            out.append({**base, "region": "grey", "mean_ratio": grey, "mean_hue_deg": 1.0,
                        "ratio_r": grey, "ratio_g": grey, "ratio_b": grey})
            out.append({**base, "region": "shaded_seabed", "mean_ratio": bed,
                        "mean_hue_deg": 3.0, "ratio_r": 1, "ratio_g": 1, "ratio_b": 1})
            out.append({**base, "region": "patch_means", "mean_ratio": (p1 + p2) / 2,
                        "mean_abs_error": (abs(p1 - 1) + abs(p2 - 1)) / 2})
        return out

    def test_scene_errors(self):
        from aquaspec.validation.report import format_scenes, scene_errors
        scenes = [{"scene": "ledge", "water": "IB", "depth_m": 5.0, "converged": False}]
        (r,) = scene_errors(self.rows(), scenes, method="lightfield-n16")
        assert r["grey"]["error"] == pytest.approx(0.3)
        assert (r["grey"]["min"], r["grey"]["max"]) == pytest.approx((0.2, 0.4))
        assert r["grey"]["rgb_ratio"] == pytest.approx([1.3] * 3)
        assert r["shaded_seabed"]["error"] == pytest.approx(-0.2)
        assert r["shaded_seabed"]["hue_deg"] == pytest.approx(3.0)
        assert r["patch_means"]["error"] == pytest.approx(0.15)
        assert r["patch_means"]["hue_deg"] == pytest.approx(2.0)
        text = format_scenes(self.rows(), scenes, ["lightfield-n16"])
        assert "ledge IB 5 m *" in text and "+30.0%" in text and "-20.0%" in text


class TestCli:
    @pytest.mark.parametrize("argv, match", [
        (["--scene", "cave"], "--scene 'cave'; accepted: a comma-separated list of board, "
                              "open, ledge, wall, box"),
        (["--scene", "ledge,ledge"], "--scene 'ledge,ledge'; accepted"),
        (["--scene", ","], "--scene ','; accepted"),
        (["--scene", "ledge", "--seabed-below", "2"], "--seabed-below with --scene ledge; "
                                                     "accepted: --scene board only"),
        (["--scene", "open,wall", "--view", "down"], "--view down with --scene open,wall"),
    ])
    def test_bad_scene(self, argv, match, capsys, tmp_path, monkeypatch):
        # Refused before Mitsuba is imported and anything is rendered.
        import aquaspec.validation.study as study
        monkeypatch.setattr(study, "run_study", lambda **kw: pytest.fail("study ran"))
        assert main(["validate", *argv, "-o", str(tmp_path)]) == 2
        err = capsys.readouterr().err
        assert match in err, err

    def test_scene_and_occlusion_reach_the_study(self, tmp_path, monkeypatch):
        pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
        import aquaspec.validation.study as study
        got = {}

        class Stop(Exception):
            pass

        def run(**kw):
            got.update(kw)
            raise Stop
        monkeypatch.setattr(study, "run_study", run)
        with pytest.raises(Stop):
            main(["validate", "--scene", "open, ledge", "--occlusion", "-o", str(tmp_path)])
        assert got["scene_names"] == ("open", "ledge") and got["occlusion"] is True
        with pytest.raises(Stop):
            main(["validate", "-o", str(tmp_path)])
        assert got["scene_names"] == ("board",) and got["occlusion"] is False


def test_reference_sees_the_ledge(tmp_path):
    """Mitsuba renders the same geometry: in the path tracer the ledge darkens
    the board and the seabed under it, and its own pixels are dark."""
    pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import load_water
    from aquaspec.validation.reference import render_reference
    water, light = load_water("IB"), surface_light("overcast")
    out = {}
    for name in ("open", "ledge"):
        scene, cam = board_scene(3.0, scene=name, width=32, height=24)
        gb = raycast_gbuffer(scene, cam)
        m = masks(gb, scene=name)
        m["board"] = gb.hit & (gb.material <= 24)
        img = render_reference(scene, cam, water, light, spp=32)["band_radiance"].sum(axis=-1)
        out[name] = (img, m)
    (img_o, m_o), (img_l, m_l) = out["open"], out["ledge"]
    board = m_o["board"]
    assert board.sum() > 50 and np.array_equal(board, m_l["board"])
    assert img_l[board].mean() < 0.85 * img_o[board].mean()
    assert img_l[m_l["shaded_seabed"]].mean() < 0.9 * img_o[m_o["shaded_seabed"]].mean()
    # Where aquaspec's G-buffer sees the ledge, Mitsuba sees something far
    # darker than the open water there in the open scene.
    assert img_l[m_l["occluder"]].mean() < 0.5 * img_o[m_l["occluder"]].mean()
    assert set(SCENES) == {"board", *OCCLUDED_SCENES}
