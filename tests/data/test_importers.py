"""Importers: a recording written as PSINS [wm vm t], MATLAB .mat, HDF5 and Parquet, imported back, gives the
same samples bit for bit and the same calibration (to 1e-9 sigma); a missing reader names its extra."""

import sys

import numpy as np
import pytest

from casadi_sins.calibrate import calibrate
from casadi_sins.cli import main
from casadi_sins.core.errors import InputError
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.data.importers import import_samples
from casadi_sins.sim import simulate


@pytest.fixture(scope="module")
def original(short_problem, tmp_path_factory):
    folder = tmp_path_factory.mktemp("orig")
    rec = simulate(short_problem, seed=9).recording
    return write_recording(rec, folder / "orig.toml")


def _write(kind: str, rec, folder):
    """The recording's samples in another tool's file."""
    if kind == "psins":
        path = folder / "imu.txt"
        np.savetxt(path, np.column_stack([rec.gyro, rec.accel, rec.time]), fmt="%.17g")
    elif kind == "mat":
        scipy_io = pytest.importorskip("scipy.io")
        path = folder / "imu.mat"
        scipy_io.savemat(path, {"t": rec.time, "wm": rec.gyro, "accel_x": rec.accel[:, 0], "accel_y": rec.accel[:, 1],
                                "accel_z": rec.accel[:, 2]})
    elif kind == "hdf5":
        h5py = pytest.importorskip("h5py")
        path = folder / "imu.h5"
        with h5py.File(path, "w") as handle:
            handle["imu/time"], handle["imu/gyro"], handle["imu/accel"] = rec.time, rec.gyro, rec.accel
    else:
        pa = pytest.importorskip("pyarrow")
        pq = pytest.importorskip("pyarrow.parquet")
        path = folder / "imu.parquet"
        columns = {"time": rec.time, **{f"{s}_{a}": v[:, i] for s, v in (("gyro", rec.gyro), ("accel", rec.accel))
                                        for i, a in enumerate("xyz")}}
        pq.write_table(pa.table(columns), path)
    return path


MAPS = {"psins": [], "mat": ["--map", "time=t", "gyro=wm"], "hdf5": ["--map", "time=imu/time", "gyro=imu/gyro",
                                                                      "accel=imu/accel"], "parquet": []}


@pytest.mark.parametrize("kind", list(MAPS))
def test_each_format_imports_the_same_samples(kind, original, tmp_path):
    rec = read_recording(original)
    src = _write(kind, rec, tmp_path)
    out = tmp_path / "imported.toml"
    assert main(["import", kind, str(src), "--segments", str(original), "--out", str(out)] + MAPS[kind]) == 0
    back = read_recording(out)
    np.testing.assert_array_equal(back.gyro, rec.gyro)
    np.testing.assert_array_equal(back.accel, rec.accel)
    np.testing.assert_allclose(back.time, rec.time, rtol=0, atol=1e-12)
    assert back.segments == rec.segments and back.rate_hz == rec.rate_hz


def test_an_import_calibrates_like_the_original_to_1e_9_sigma(original, tmp_path):
    rec = read_recording(original)
    out = tmp_path / "psins.toml"
    assert main(["import", "psins", str(_write("psins", rec, tmp_path)), "--segments", str(original),
                 "--out", str(out)]) == 0
    first, second = calibrate(rec).parameters, calibrate(read_recording(out)).parameters
    assert np.max(np.abs(first.values - second.values) / first.sigma) <= 1e-9


def test_a_missing_reader_names_its_extra(original, tmp_path, monkeypatch):
    src = tmp_path / "imu.h5"
    src.write_bytes(b"\x89HDF\r\n\x1a\n")
    monkeypatch.setitem(sys.modules, "h5py", None)
    both = r'pip install "casadi-sins\[hdf5\]" \(from a checkout of the source: pip install "\.\[hdf5\]"\)'
    with pytest.raises(InputError, match=both):
        import_samples("hdf5", src)


def test_a_missing_column_is_named_with_the_option_that_maps_it(original, tmp_path):
    pytest.importorskip("pyarrow")
    rec = read_recording(original)
    src = _write("parquet", rec, tmp_path)
    with pytest.raises(InputError, match=r"no time \(looked for 'timestamp'; --map time=NAME"):
        import_samples("parquet", src, {"time": "timestamp"})
