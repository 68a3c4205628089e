"""Fuzzing the file readers (hypothesis, bounded; issue 35).

Water, sensor and reflectance CSVs, camspec text, meshes (OBJ and ASCII PLY)
and RGB-D inputs (PNG images, PNG and NPY depth maps) get random bytes,
truncations of a valid file and numeric junk. Each reader either returns
its object or raises :class:`AquaspecError` with a one-line message: no
other exception type. Two of them are also driven through
:func:`aquaspec.cli.main` in-process: exit status 2 and one line on stderr
(or 0 when the junk happens to be a valid file). ``EXAMPLES`` per reader
keeps the file to about half a minute.
"""

from __future__ import annotations

import contextlib
import io
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from PIL import Image

from aquaspec.cli import main
from aquaspec.colour.reflectance import reflectance_from_csv
from aquaspec.colour.sensors import load_camspec, sensor_from_csv
from aquaspec.errors import AquaspecError
from aquaspec.medium.water import water_from_csv
from aquaspec.scene.load import load_mesh
from aquaspec.scene.rgbd import load_rgbd

#: Examples per reader (and half as many through the CLI).
EXAMPLES = 150
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

ROW33 = " ".join(f"{0.1 * (k % 10):g}" for k in range(33))
VALID = {
    "water": b"wavelength_nm,a,b,Kd\n400,0.1,0.2,0.15\n550,0.06,0.1,0.08\n700,0.6,0.1,0.7\n",
    "sensor": b"wavelength_nm,r,g,b\n400,0,0.1,1\n550,0.1,1,0.1\n700,1,0.1,0\n",
    "reflectance": b"wavelength_nm,reflectance\n400,0.1\n550,0.5\n700,0.9\n",
    "camspec": (f"400nm-720nm, step 10nm\n---------\n\nCam A\n{ROW33}\n{ROW33}\n{ROW33}\n"
                f"Cam B\n{ROW33}\n{ROW33}\n{ROW33}\n").encode(),
    "obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 2 4\n",
    "ply": (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
            b"property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
            b"end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
}
CSV_READERS = {"water": water_from_csv, "sensor": sensor_from_csv,
               "reflectance": reflectance_from_csv}

#: Numbers a file might hold: ordinary, extreme, not finite, not numbers.
NUMBER = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10 ** 6, 10 ** 6).map(str),
    st.sampled_from(["", "-", "1e999", "-0", "nan", "inf", "0x1F", "1,5", "é", "\t", "\"",
                     "9" * 400, "1e-400"]))


def truncations(kind):
    """The valid file of ``kind`` cut anywhere, possibly with junk appended."""
    data = VALID[kind]
    return st.tuples(st.integers(0, len(data)), st.binary(max_size=20)).map(
        lambda t: data[:t[0]] + t[1])


def numeric_junk(header: bytes, sep: str = ","):
    """A header, then rows of a random number of random numbers."""
    row = st.lists(NUMBER, min_size=0, max_size=5).map(lambda xs: sep.join(xs))
    return st.lists(row, max_size=8).map(lambda rows: header + "\n".join(rows).encode())


def inputs(kind, header: bytes, sep: str = ","):
    return st.one_of(st.binary(max_size=300), truncations(kind), numeric_junk(header, sep))


def load_or_refuse(reader, path):
    """``reader(path)``'s object, or None after a one-line AquaspecError."""
    try:
        out = reader(path)
    except AquaspecError as exc:
        msg = str(exc)
        assert msg and "\n" not in msg, f"not one line: {msg!r}"
        event("refused")
        return None
    event("loaded")
    return out


@contextlib.contextmanager
def file_of(data: bytes, name: str):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / name
        p.write_bytes(data)
        yield p


@pytest.mark.parametrize("kind", sorted(CSV_READERS))
def test_csv_readers(kind):
    header = VALID[kind].split(b"\n", 1)[0] + b"\n"

    @FUZZ
    @given(data=inputs(kind, header))
    def check(data):
        with file_of(data, f"{kind}.csv") as p:
            load_or_refuse(CSV_READERS[kind], p)
    check()


@FUZZ
@given(data=inputs("camspec", b"400nm-720nm, step 10nm\nCam\n", sep=" "))
def test_camspec(data):
    with file_of(data, "cams.txt") as p:
        cams = load_or_refuse(load_camspec, p)
    assert cams is None or all(s.response.shape[0] == 3 for s in cams.values())


@pytest.mark.parametrize("kind", ["obj", "ply"])
def test_meshes(kind):
    pytest.importorskip("trimesh")
    junk = numeric_junk(b"", sep=" ").map(
        lambda b: b"\n".join((b"v " if k % 2 else b"f ") + line
                             for k, line in enumerate(b.split(b"\n"))))

    @FUZZ
    @given(data=st.one_of(st.binary(max_size=300), truncations(kind), junk))
    def check(data):
        with file_of(data, f"m.{kind}") as p:
            scene = load_or_refuse(load_mesh, p)
        assert scene is None or scene.n_triangles > 0
    check()


def _png(array) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(array).save(buf, format="PNG")
    return buf.getvalue()


GOOD_RGB = _png(np.full((4, 5, 3), 120, np.uint8))
GOOD_DEPTH = _png(np.full((4, 5), 1500, np.uint16))


def _npy(array) -> bytes:
    buf = io.BytesIO()
    np.save(buf, array)
    return buf.getvalue()


def _array(shape, dtype, value):
    if dtype in ("U3", "M8[s]"):
        return np.zeros(shape, dtype=dtype)
    with np.errstate(all="ignore"):   # 1e308 as float16, nan as int: whatever comes out
        return np.full(shape, value).astype(dtype)


#: Depth arrays of odd shapes, dtypes and values.
ODD_ARRAYS = st.one_of(
    st.builds(_array, st.lists(st.integers(0, 6), max_size=4),
              st.sampled_from(["f8", "f4", "f2", "i4", "u1", "?", "c16", "U3", "M8[s]"]),
              st.sampled_from([1.5, 0.0, -1.0, np.nan, np.inf, 1e308])),
    st.just(np.ones((4, 5, 1))), st.just(np.ones((4, 5, 2))))


@FUZZ
@given(depth=st.one_of(ODD_ARRAYS.map(_npy), st.binary(max_size=200),
                       st.integers(0, 200).map(lambda n: _npy(np.ones((4, 5)))[:n])))
def test_rgbd_npy_depth(depth):
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "c.png").write_bytes(GOOD_RGB)
        (Path(d) / "d.npy").write_bytes(depth)
        out = load_or_refuse(lambda p: load_rgbd(Path(d) / "c.png", p), Path(d) / "d.npy")
    assert out is None or (out[1].shape == (4, 5) and np.all(out[1] > 0))


@FUZZ
@given(image=st.one_of(st.binary(max_size=200),
                       st.integers(0, len(GOOD_RGB)).map(lambda n: GOOD_RGB[:n])),
       depth=st.one_of(st.binary(max_size=200),
                       st.integers(0, len(GOOD_DEPTH)).map(lambda n: GOOD_DEPTH[:n]),
                       st.sampled_from([_png(np.zeros((4, 5), np.uint16)),
                                        _png(np.full((5, 4), 9, np.uint16)),
                                        _png(np.full((4, 5, 3), 9, np.uint8))])))
def test_rgbd_png(image, depth):
    with tempfile.TemporaryDirectory() as d:
        (Path(d) / "c.png").write_bytes(image)
        (Path(d) / "d.png").write_bytes(depth)
        load_or_refuse(lambda p: load_rgbd(p, Path(d) / "d.png"), Path(d) / "c.png")


def run_cli(argv):
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main(argv)
    return code, err.getvalue()


def _assert_cli(code, err, command):
    assert code in (0, 2), code
    event(f"exit {code}")
    if code == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"aquaspec {command}: error: "), err
        assert "Traceback" not in err


@settings(max_examples=EXAMPLES // 2, deadline=None, derandomize=True)
@given(data=inputs("camspec", b"400nm-720nm, step 10nm\nCam\n", sep=" "))
@example(data=VALID["camspec"])
def test_cli_camspec(data):
    with file_of(data, "cams.txt") as p:
        code, err = run_cli(["list", "sensors", "--camspec", str(p)])
    _assert_cli(code, err, "list")


@settings(max_examples=EXAMPLES // 2, deadline=None, derandomize=True)
@given(data=inputs("water", b"wavelength_nm,a,b\n"))
@example(data=VALID["water"])
def test_cli_water_csv(data):
    with file_of(data, "w.csv") as p:
        code, err = run_cli(["spectra", "--water", str(p), "--bands", "2", "--range",
                             "400-700"])
    _assert_cli(code, err, "spectra")
