"""Bad input to the command line: broken, forged and oversized model files, values no phone records, a port out of
range, a manifest that is not text. Each is refused with exit status 2 and one line, before any large read."""

import io
import json
import tracemalloc
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.model import DictionaryModel

runner = CliRunner()


@pytest.fixture(scope="module")
def model_bytes(tmp_path_factory):
    """A small valid model file's bytes."""
    path = tmp_path_factory.mktemp("m") / "model.npz"
    DictionaryModel(classes=["a", "b"], channels=["x"], rate=20.0, window=4, step=1, normalisation="l2",
                    scale=np.ones(1), dictionary=np.arange(12.0).reshape(4, 3), column_class=np.array([0, 1, 0]),
                    features="channels").save(path)
    return path.read_bytes()


def _npz(members: dict[str, bytes], compression=zipfile.ZIP_DEFLATED) -> bytes:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return out.getvalue()


def _npy(array: np.ndarray) -> bytes:
    out = io.BytesIO()
    np.lib.format.write_array(out, array, allow_pickle=True)
    return out.getvalue()


def _members(model_bytes: bytes) -> dict[str, bytes]:
    with zipfile.ZipFile(io.BytesIO(model_bytes)) as archive:
        return {name: archive.read(name) for name in archive.namelist()}


def _with(model_bytes, **replaced) -> bytes:
    return _npz({**_members(model_bytes), **{f"{k}.npy": v for k, v in replaced.items()}})


def _declares(shape) -> bytes:
    """An ``.npy`` whose header declares ``shape`` of float64 but holds 16 bytes of data."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": shape})
    return header.getvalue() + bytes(16)


def _metadata(model_bytes, edit) -> bytes:
    with zipfile.ZipFile(io.BytesIO(model_bytes)) as archive:
        meta = json.loads(str(np.load(io.BytesIO(archive.read("metadata.npy")))))
    edited = edit(meta)
    return _with(model_bytes, metadata=_npy(np.array(edited if isinstance(edited, str) else json.dumps(edited))))


BROKEN = {
    "empty": lambda b: b"",
    "truncated": lambda b: b[: len(b) // 2],
    "one byte changed": lambda b: b[:200] + bytes([b[200] ^ 0xFF]) + b[201:],
    "text": lambda b: b"classes: a, b\n",
    "object array": lambda b: _with(b, scale=_npy(np.array([{"x": 1}], dtype=object))),
    "declares 2 GiB": lambda b: _with(b, dictionary=_declares((1 << 14, 1 << 14))),
    "metadata not JSON": lambda b: _metadata(b, lambda m: "{classes: [a]"),
    "metadata a list": lambda b: _metadata(b, lambda m: [1, 2]),
    "window is text": lambda b: _metadata(b, lambda m: {**m, "window": "4"}),
    "no channels": lambda b: _metadata(b, lambda m: {k: v for k, v in m.items() if k != "channels"}),
    "negative rate": lambda b: _metadata(b, lambda m: {**m, "rate": -20}),
    "not an array": lambda b: _npz({**_members(b), "notes.txt": b"hello"}),
    "rate 1e300": lambda b: _metadata(b, lambda m: {**m, "rate": 1e300}),
    "100k duplicate classes": lambda b: _metadata(b, lambda m: {**m, "classes": ["a"] * 100_000}),
    "NaN dictionary": lambda b: _with(b, dictionary=_npy(np.full((4, 3), np.nan))),
    "infinite scale": lambda b: _with(b, scale=_npy(np.array([np.inf]))),
}


@pytest.mark.parametrize("name", BROKEN)
def test_a_broken_model_file_exits_2_with_one_line(tmp_path, model_bytes, name):
    path = tmp_path / "model.npz"
    path.write_bytes(BROKEN[name](model_bytes))
    result = runner.invoke(app, ["classify", str(path), str(tmp_path / "in.csv"), "-o", str(tmp_path / "o.csv")])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "model file" in lines[0] and "pickle" not in lines[0], result.output


def test_a_zip_bomb_is_refused_from_its_directory(tmp_path, model_bytes):
    """1 GiB and a bit of zeros, declared by the zip directory: refused before a byte of it is inflated."""
    members = _members(model_bytes)
    path = tmp_path / "bomb.npz"
    chunk = bytes(1 << 20)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
        with archive.open("causal_dictionary.npy", "w", force_zip64=True) as member:
            member.write(_declares((1 << 27, 1))[:-16])
            for _ in range(1025):
                member.write(chunk)
    assert path.stat().st_size < 4 << 20
    tracemalloc.start()
    with pytest.raises(InputError, match="declares"):
        DictionaryModel.load(path)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 64 << 20


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.data())
def test_any_altered_model_file_loads_or_says_why(tmp_path, model_bytes, data):
    """Hypothesis alters bytes of a valid model file (or cuts it): loading either gives a model or InputError."""
    raw = bytearray(model_bytes)
    for _ in range(data.draw(st.integers(1, 4))):
        raw[data.draw(st.integers(0, len(raw) - 1))] = data.draw(st.integers(0, 255))
    raw = raw[: data.draw(st.integers(0, len(raw)))]
    path = tmp_path / "fuzzed.npz"
    path.write_bytes(bytes(raw))
    try:
        DictionaryModel.load(path)
    except InputError as exc:
        assert "\n" not in str(exc)


@pytest.mark.parametrize("port", ["70000", "-1"])
def test_serve_refuses_a_port_out_of_range(tmp_path, port):
    result = runner.invoke(app, ["serve", "--port", port, "--database", str(tmp_path / "r.db")])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
    assert not (tmp_path / "r.db").exists()


def test_fleet_ingest_of_a_binary_manifest_exits_2(tmp_path):
    manifest = tmp_path / "rides.csv"
    manifest.write_bytes(bytes(range(256)) * 40)
    riders = tmp_path / "riders.csv"
    riders.write_text("rider_id,age_band,gender,skill\nr1,30-39,f,novice\n")
    result = runner.invoke(app, ["fleet", "ingest", "--store", str(tmp_path / "s.db"), "--manifest", str(manifest),
                                 "--riders", str(riders)])
    assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output


@pytest.mark.parametrize("column, value", [("ax", 1e300), ("lon", 500.0), ("gz", -1e9), ("speed", -5.0)])
def test_values_no_phone_records_exit_2(tmp_path, column, value):
    n = 200
    table = {"time": np.arange(n) / 20, "ax": np.zeros(n), "ay": np.zeros(n), "az": np.full(n, 9.81),
             "gx": np.zeros(n), "gy": np.zeros(n), "gz": np.zeros(n), "lat": np.full(n, 35.0),
             "lon": np.full(n, 139.0), "speed": np.full(n, 3.0)}
    table[column][50] = value
    path = tmp_path / "ride.csv"
    header = ",".join(table)
    rows = np.column_stack(list(table.values()))
    path.write_text(header + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    result = runner.invoke(app, ["features", str(path), "-o", str(tmp_path / "f.csv")])
    assert result.exit_code == 2, result.output
    assert column in result.output and len(result.output.strip().splitlines()) == 1, result.output
