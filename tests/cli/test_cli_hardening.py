"""Issue 35 in the CLI: bad combinations refused before rendering, warnings on
images a camera would record black, Ctrl-C, non-finite numbers, help texts."""

from __future__ import annotations

import argparse
import json
import re

import pytest

from aquaspec.cli import EXIT_INTERRUPTED, build_parser, main


def run(argv, capsys):
    """``(exit status, stderr)`` of ``aquaspec argv`` in this process (a
    parser error is argparse's SystemExit)."""
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


def assert_refused(code, err, match):
    assert code == 2, err
    assert re.search(match, err), err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert "shading" not in err      # before any rendering


RENDER = ["render", "--size", "8x6", "--bands", "3"]


class TestOutputsAreDistinct:
    @pytest.mark.parametrize("extra", [["--linear", "x.exr", "--layers", "x.exr"],
                                       ["--linear", "sub/../x.exr", "--layers", "x.exr"]])
    def test_linear_and_layers_one_file(self, tmp_path, capsys, monkeypatch, extra):
        monkeypatch.chdir(tmp_path)
        (tmp_path / "sub").mkdir()
        code, err = run([*RENDER, *extra, "-o", "x.png"], capsys)
        assert_refused(code, err, r"--linear and --layers both name .*x\.exr.*different file")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["sub"]

    def test_a_symlink_to_the_same_file(self, tmp_path, capsys):
        (tmp_path / "a.exr").write_bytes(b"old")
        (tmp_path / "b.exr").symlink_to(tmp_path / "a.exr")
        code, err = run([*RENDER, "--linear", str(tmp_path / "a.exr"), "--layers",
                         str(tmp_path / "b.exr"), "-o", str(tmp_path / "x.png")], capsys)
        assert_refused(code, err, "both name")
        assert (tmp_path / "a.exr").read_bytes() == b"old"


class TestSunOptionsNeedTheSun:
    @pytest.mark.parametrize("cmd", [["render", "-o", "x.png"], ["colour", "--water", "IB", "--depth", "5"]])
    @pytest.mark.parametrize("opt", [["--sun-elevation", "30"], ["--sun-azimuth", "90"]])
    def test_sun_placed_without_a_sun(self, tmp_path, capsys, monkeypatch, cmd, opt):
        monkeypatch.chdir(tmp_path)
        code, err = run([*cmd, *opt], capsys)
        assert_refused(code, err, f"{opt[0]} places the sun: it needs --light sun-sky, "
                                  "not --light overcast")

    def test_shadow_map_without_a_sun(self, tmp_path, capsys):
        code, err = run([*RENDER, "--sun-shadow-map", "512", "-o", str(tmp_path / "x.png")],
                        capsys)
        assert_refused(code, err, "--sun-shadow-map .* needs --light sun-sky")

    @pytest.mark.parametrize("size", ["0", "-5", "8"])
    def test_shadow_map_too_small(self, tmp_path, capsys, size):
        code, err = run([*RENDER, "--light", "sun-sky", "--backend", "numpy",
                         "--sun-shadow-map", size, "-o", str(tmp_path / "x.png")], capsys)
        assert_refused(code, err, rf"--sun-shadow-map {size}; accepted: an integer 16 to 8192")
        assert not list(tmp_path.iterdir())

    @pytest.mark.gpu
    def test_shadow_map_beyond_the_device(self, tmp_path, capsys):
        from aquaspec.gpu.device import max_texture_size
        code, err = run([*RENDER, "--light", "sun-sky", "--sun-shadow-map", "100000",
                         "-o", str(tmp_path / "x.png")], capsys)
        assert_refused(code, err, rf"--sun-shadow-map 100000; accepted: an integer 16 to "
                                  rf"\d+ texels; this GPU's largest texture is "
                                  rf"{max_texture_size()} texels")

    def test_sun_elevation_out_of_range(self, tmp_path, capsys):
        code, err = run([*RENDER, "--light", "sun-sky", "--sun-elevation", "95",
                         "-o", str(tmp_path / "x.png")], capsys)
        assert_refused(code, err, "sun elevation 95.0 deg; accepted: 1 to 90")


class TestNonFiniteNumbers:
    @pytest.mark.parametrize("opt", ["--exposure", "--depth", "--sun-elevation",
                                     "--sun-azimuth", "--wind", "--irradiance",
                                     "--forward-cone", "--wave-time", "--wind-azimuth"])
    @pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
    def test_refused_by_the_parser(self, tmp_path, capsys, opt, value):
        # (--opt=-inf: argparse reads a lone "-inf" as an option.)
        code, err = run([*RENDER, f"{opt}={value}", "-o", str(tmp_path / "x.png")], capsys)
        assert_refused(code, err, rf"aquaspec render: error: argument {opt}: .*'{value}'")
        assert not list(tmp_path.iterdir())

    @pytest.mark.parametrize("opt,value", [("--range", "nan-700"), ("--albedo", "nan,1,1"),
                                           ("--exposure", "65")])
    def test_other_numbers(self, tmp_path, capsys, opt, value):
        argv = [*RENDER, opt, value, "-o", str(tmp_path / "x.png")]
        if opt == "--albedo":
            argv[1:1] = ["--mesh", str(tmp_path / "m.ply")]
        code, err = run(argv, capsys)
        assert_refused(code, err, re.escape(value))

    @pytest.mark.parametrize("argv", [["colour", "--water", "IB", "--depth", "nan"],
                                      ["colour", "--water", "IB", "--depth", "5",
                                       "--distance", "inf"],
                                      ["validate", "--g", "nan"], ["bench", "--depth", "inf"],
                                      ["view", "--wind", "nan"]])
    def test_other_commands(self, capsys, argv):
        assert_refused(*run(argv, capsys), "is not accepted; give a finite number|deepest")

    def test_deeper_than_the_ocean(self, tmp_path, capsys):
        code, err = run([*RENDER, "--depth", "1e6", "-o", str(tmp_path / "x.png")], capsys)
        assert_refused(code, err, "depth '1e6' m is deeper than the deepest ocean; accepted: "
                                  "0 to 11000 m")


@pytest.mark.gpu
class TestDarkImagesAreNamed:
    def test_auto_exposure_far_beyond_the_surface(self, tmp_path, capsys):
        code, err = run([*RENDER, "--depth", "1000", "-o", str(tmp_path / "x.png")], capsys)
        assert code == 0, err
        ev = json.loads((tmp_path / "x.png.json").read_text())["display"]["exposure_ev"]
        assert ev > 40
        assert re.search(rf"warning: auto exposure brightened the image by \+{ev:.1f} EV.*"
                         r"at 1000 m in water IB.*--exposure", err), err

    def test_black_image(self, tmp_path, capsys):
        code, err = run([*RENDER, "--water", "9C", "--depth", "200", "--ms-model", "seeds",
                         "-o", str(tmp_path / "x.png")], capsys)
        assert code == 0 and "warning: the image is black: no light reaches the camera at " \
                             "200 m in water 9C" in err, err

    @pytest.mark.parametrize("argv", [["--depth", "5"], ["--depth", "1000", "--exposure", "0"],
                                      ["--water", "9C", "--depth", "20"]])
    def test_no_warning_for_ordinary_images(self, tmp_path, capsys, argv):
        code, err = run([*RENDER, *argv, "-o", str(tmp_path / "x.png")], capsys)
        assert code == 0 and "warning" not in err, err


class TestInterrupted:
    def test_ctrl_c_while_writing(self, tmp_path, capsys, monkeypatch):
        """Ctrl-C in the middle of writing the PNG: one line, status 130,
        none of the image's files (nor a temporary one) left behind."""
        import aquaspec.io.save as save

        def png_writer(image, text):
            def write(tmp):
                with open(tmp, "wb") as f:
                    f.write(b"\x89PNG half")
                raise KeyboardInterrupt
            return write

        monkeypatch.setattr(save, "png_writer", png_writer)
        code, err = run([*RENDER, "--backend", "numpy", "--linear", str(tmp_path / "x.npy"),
                         "-o", str(tmp_path / "x.png")], capsys)
        assert code == EXIT_INTERRUPTED and err.strip().splitlines()[-1] == "aquaspec: interrupted"
        assert "Traceback" not in err
        assert not list(tmp_path.iterdir())

    @pytest.mark.parametrize("argv,target", [
        (["colour", "--water", "IB", "--depth", "5"], "aquaspec.cli.colour_cmd.water_colour"),
        (["list", "waters"], "aquaspec.cli.list_cmd.list_waters")])
    def test_any_command(self, capsys, monkeypatch, argv, target):
        def interrupt(*args, **kwargs):
            raise KeyboardInterrupt
        monkeypatch.setattr(target, interrupt)
        assert run(argv, capsys) == (EXIT_INTERRUPTED, "aquaspec: interrupted\n")


class TestCamspecOrigin:
    @pytest.mark.parametrize("argv", [["list", "sensors"], ["colour", "--water", "IB",
                                                            "--depth", "5", "--sensor", "x"],
                                      ["spectra", "--water", "IB", "--sensor", "x"]])
    def test_missing_camspec_says_where_it_comes_from(self, tmp_path, capsys, argv):
        code, err = run([*argv, "--camspec", str(tmp_path / "camspec_database.txt")], capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert re.search(r"camspec file '.*camspec_database.txt' does not exist; .*Jiang et "
                         r"al\. 2013.*not shipped with aquaspec", err), err

    def test_list_prints_nothing_before_the_error(self, tmp_path, capsys):
        """A bad camspec file is one error, not the built-in sensors and then an error."""
        code = main(["list", "sensors", "--camspec", str(tmp_path / "nope.txt")])
        out = capsys.readouterr().out
        assert code == 2 and out == "", out


class TestHelp:
    def subparsers(self):
        parser = build_parser()
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        return sub.choices

    def test_every_option_has_help(self):
        missing = [f"{name} {'/'.join(a.option_strings) or a.dest}"
                   for name, p in self.subparsers().items() for a in p._actions
                   if not a.help and not isinstance(a, argparse._HelpAction)]
        assert not missing, missing

    def test_no_doubled_percent(self, capsys):
        for name, p in self.subparsers().items():
            p.print_help()
            assert "%%" not in capsys.readouterr().out, name

    def test_view_places_the_sun_as_render_does(self):
        view = self.subparsers()["view"]
        opts = {o: a for a in view._actions for o in a.option_strings}
        assert opts["--light"].choices == ("overcast", "sun-sky")
        assert "overcast" not in opts["--sun-elevation"].help
        assert opts["--sun-elevation"].help.startswith("--light sun-sky")

    def test_view_sun_needs_the_sun(self, capsys):
        assert_refused(*run(["view", "--sun-elevation", "30"], capsys),
                       "--sun-elevation places the sun: it needs --light sun-sky")
