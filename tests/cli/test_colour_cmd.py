"""`aquaspec colour`: the text and JSON answers and bad input."""

from __future__ import annotations

import json

import pytest

from aquaspec.cli import main


class TestCli:
    def test_colour_json(self, capsys):
        assert main(["colour", "--water", "IB", "--depth", "5", "--distance", "3",
                     "--sensor", "human", "--bands", "16", "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        assert len(out["water_rgb"]) == 3 and len(out["grey_card_rgb"]) == 3
        assert out["water"]["name"] == "IB" and out["depth_m"] == 5 and out["bands"]["n"] == 16
        assert out["ms_model"] == "lightfield" and out["phase"] == "petzold"   # the default

    def test_colour_text_names_the_model(self, capsys):
        for argv, name in [([], "light field (petzold phase function)"),
                           (["--ms-model", "seeds"], "monzon2022 model (the seeds' model)")]:
            assert main(["colour", "--water", "IB", "--depth", "5", "--bands", "4", *argv]) == 0
            assert capsys.readouterr().out.splitlines()[0].endswith(name)

    def test_colour_camspec(self, capsys, camspec_path):
        assert main(["colour", "--water", "3C", "--depth", "9", "--sensor", "Nikon D90",
                     "--camspec", str(camspec_path), "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["sensor"]["name"] == "Nikon D90"

    @pytest.mark.parametrize("argv,match", [
        (["--water", "XI", "--depth", "5"], "unknown water type 'XI'"),
        (["--water", "IB", "--depth", "-2"], "depth -2.0 m is not accepted; give metres below"),
        (["--water", "IB", "--depth", "5", "--distance", "-1"],
         "distance -1.0 m is not accepted; give metres from the camera"),
        (["--water", "IB", "--depth", "5", "--bands", "0"], "'0' bands; accepted: 1 to 1024"),
        (["--water", "IB", "--depth", "5", "--sensor", "leica"], "unknown sensor 'leica'"),
        (["--water", "IB", "--depth", "5", "--range", "350-700"], "sensor 'human' covers 360-830"),
        (["--water", "IB", "--depth", "5", "--range", "400-800"], "covers 300-700 nm"),
    ])
    def test_errors(self, capsys, argv, match):
        try:
            code = main(["colour", *argv])
        except SystemExit as exc:      # refused by the parser
            code = exc.code
        err = capsys.readouterr().err
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert "error:" in err
        import re
        assert re.search(match, err), err

    def test_list(self, capsys):
        assert main(["list", "waters"]) == 0
        out = capsys.readouterr().out
        assert "9C" in out and "williamson2022" in out
        assert main(["list", "sensors"]) == 0
        assert "nikon-5100-npl" in capsys.readouterr().out

    def test_help(self, capsys):
        with pytest.raises(SystemExit):
            main(["--help"])
        assert "aquaspec colour" in capsys.readouterr().out
