"""Hostile files of other tools (issue 35): ``import`` writes only what its own reader accepts, refuses what is not
an array of real numbers, never follows an HDF5 link out of the file, and judges declared sizes before it
allocates; each case one line, exit 2, its input unchanged and nothing written."""

import subprocess
import sys

import numpy as np
import pytest

from casadi_sins.data.description import read_recording
from casadi_sins.sim import simulate, write_simulation

KEYS = ("time", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")


@pytest.fixture(scope="module")
def samples(short_problem, tmp_path_factory):
    """Time and pulses of a short recording, and the recording itself (a description to take segments from)."""
    folder = tmp_path_factory.mktemp("foreign")
    write_simulation(simulate(short_problem, seed=3, name="orig"), folder)
    rec = read_recording(folder / "orig.toml")
    return rec.time, np.column_stack([rec.gyro, rec.accel]), folder / "orig.toml"


def savemat(path, **arrays):
    scipy_io = pytest.importorskip("scipy.io")
    scipy_io.savemat(path, arrays)
    return path


def mat_of(samples, path, **extra):
    time, pulses, _ = samples
    return savemat(path, **{"time": time, "gyro": pulses[:, :3], "accel": pulses[:, 3:], **extra})


def nothing_written(folder, *keep):
    assert sorted(p.name for p in folder.iterdir()) == sorted(keep)


def test_out_naming_the_data_file_is_refused(samples, tmp_path, cli_keeps_inputs):
    src = mat_of(samples, tmp_path / "imu.mat")
    cli_keeps_inputs(["import", "mat", src, "--segments", samples[2], "--out", tmp_path / "rec.csv"], [src], 2,
                     "rec.csv", "NAME.toml")
    nothing_written(tmp_path, "imu.mat")


@pytest.mark.parametrize("case, needle", [
    ({"temperature": "nan"}, "not a finite number"),
    ({"temperature": 1e308}, "temperature 1e+308 is outside"),
    ({"pulse": 1e300}, "not a pulse count"),
])
def test_values_the_reader_refuses_are_never_written(samples, tmp_path, cli_keeps_inputs, case, needle):
    time, pulses, description = samples
    pulses = pulses.copy()
    extra = {}
    if "temperature" in case:
        extra["temperature"] = np.full(len(time), float(case["temperature"]))
    else:
        pulses[7, 4] = case["pulse"]
    src = savemat(tmp_path / "imu.mat", time=time, gyro=pulses[:, :3], accel=pulses[:, 3:], **extra)
    cli_keeps_inputs(["import", "mat", src, "--segments", description, "--out", tmp_path / "rec.toml"], [src], 2,
                     "imu.mat", needle)
    nothing_written(tmp_path, "imu.mat")


@pytest.mark.parametrize("options, needle", [
    (["--name", "a\nb"], "--name"), (["--name", "x" * 10_000], "--name"), (["--height", "1e9"], "--height"),
    (["--height", "nan"], "--height"), (["--rate", "nan"], "--rate"), (["--latitude", "nan"], "--latitude"),
])
def test_options_the_reader_would_refuse_are_one_line(samples, tmp_path, cli_keeps_inputs, options, needle):
    src = mat_of(samples, tmp_path / "imu.mat")
    err = cli_keeps_inputs(["import", "mat", src, "--latitude", "37.5", "--out", tmp_path / "rec.toml", *options]
                           if "--latitude" not in options else
                           ["import", "mat", src, "--out", tmp_path / "rec.toml", *options], [src], 2, needle)
    assert len(err) < 400
    nothing_written(tmp_path, "imu.mat")


def test_an_accepted_import_reads_back_as_written(samples, tmp_path, cli_keeps_inputs):
    src = mat_of(samples, tmp_path / "imu.mat", temperature=np.full(len(samples[0]), 24.5))
    cli_keeps_inputs(["import", "mat", src, "--segments", samples[2], "--out", tmp_path / "rec.toml"], [src], 0)
    back = read_recording(tmp_path / "rec.toml")
    np.testing.assert_array_equal(np.column_stack([back.gyro, back.accel]), samples[1])
    assert np.all(back.temperature == 24.5)


def _mat_cases(samples, folder):
    time, pulses, _ = samples
    (folder / "zero.mat").write_bytes(b"")
    return {
        "zero.mat": ("truncated", folder / "zero.mat"),
        "none.mat": ("no time", savemat(folder / "none.mat")),
        "text.mat": ("holds text", savemat(folder / "text.mat", time="abc", gyro=pulses[:, :3], accel=pulses[:, 3:])),
        "cell.mat": ("cell array", savemat(folder / "cell.mat", time=np.array([[1, "a"]], dtype=object))),
        "struct.mat": ("a struct", savemat(folder / "struct.mat", time={"a": 1.0})),
        "complex.mat": ("complex", savemat(folder / "complex.mat", time=time + 1j, gyro=pulses[:, :3],
                                           accel=pulses[:, 3:])),
        "empty.mat": ("empty", savemat(folder / "empty.mat", time=np.zeros((0, 1)), gyro=pulses[:, :3],
                                       accel=pulses[:, 3:])),
        "ten.mat": ("'temperature' 10 rows", savemat(folder / "ten.mat", time=time, gyro=pulses[:, :3],
                                                     accel=pulses[:, 3:], temperature=np.arange(10.0))),
    }


@pytest.mark.parametrize("name", ["zero.mat", "none.mat", "text.mat", "cell.mat", "struct.mat", "complex.mat",
                                  "empty.mat", "ten.mat"])
def test_mat_files_that_hold_no_samples_are_one_line(samples, tmp_path, cli_keeps_inputs, name):
    needle, src = _mat_cases(samples, tmp_path)[name]
    cli_keeps_inputs(["import", "mat", src, "--segments", samples[2], "--out", tmp_path / "out" / "rec.toml"], [src],
                     2, name, needle)
    assert not (tmp_path / "out").exists()


def _hdf5_cases(samples, folder):
    h5py = pytest.importorskip("h5py")
    time, pulses, _ = samples

    def make(name, fill):
        with h5py.File(folder / name, "w") as handle:
            fill(handle)
        return folder / name

    outside = folder / "outside.h5"
    with h5py.File(outside, "w") as handle:
        handle["time"] = time
    return {
        "text.h5": ("holds text", make("text.h5", lambda h: h.create_dataset("time", data=np.array([b"a", b"b"])))),
        "compound.h5": ("compound", make("compound.h5", lambda h: h.create_dataset(
            "time", data=np.zeros(3, dtype=[("a", "f8"), ("b", "i4")])))),
        "null.h5": ("null dataspace", make("null.h5", lambda h: h.create_dataset("time", data=h5py.Empty("f8")))),
        "loop.h5": ("loop", make("loop.h5", lambda h: h.__setitem__("time", h5py.SoftLink("/time")))),
        "external.h5": ("link to another file", make("external.h5", lambda h: h.__setitem__(
            "time", h5py.ExternalLink(str(outside), "/time")))),
        "group.h5": ("is a group", make("group.h5", lambda h: h.create_group("time"))),
        "scalar.h5": ("no samples", make("scalar.h5", lambda h: h.create_dataset("time", data=1.0))),
    }


@pytest.mark.parametrize("name", ["text.h5", "compound.h5", "null.h5", "loop.h5", "external.h5", "group.h5",
                                  "scalar.h5"])
def test_hdf5_files_that_hold_no_samples_are_one_line(samples, tmp_path, cli_keeps_inputs, name):
    needle, src = _hdf5_cases(samples, tmp_path)[name]
    cli_keeps_inputs(["import", "hdf5", src, "--segments", samples[2], "--out", tmp_path / "out" / "rec.toml"],
                     [src, tmp_path / "outside.h5"], 2, name, needle)
    assert not (tmp_path / "out").exists()


def test_an_external_link_inside_a_group_path_is_not_followed(samples, tmp_path, cli_keeps_inputs):
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "other.h5", "w") as handle:
        handle["imu/time"] = samples[0]
    with h5py.File(tmp_path / "src.h5", "w") as handle:
        handle["imu"] = h5py.ExternalLink(str(tmp_path / "other.h5"), "/imu")
        handle["alias"] = h5py.SoftLink("/imu")
    for name in ("imu/time", "alias/time"):
        cli_keeps_inputs(["import", "hdf5", tmp_path / "src.h5", "--map", f"time={name}", "--segments", samples[2],
                          "--out", tmp_path / "out" / "rec.toml"], [tmp_path / "src.h5", tmp_path / "other.h5"], 2,
                         "link to another file")


def test_junk_in_a_parquet_file_and_a_folder_or_device_are_named(samples, tmp_path, cli_keeps_inputs):
    pytest.importorskip("pyarrow")
    junk = tmp_path / "junk.parquet"
    junk.write_bytes(bytes(range(256)) * 4)
    cli_keeps_inputs(["import", "parquet", junk, "--latitude", "37.5", "--out", tmp_path / "o" / "r.toml"], [junk], 2,
                     "junk.parquet", "not a Parquet file")
    cli_keeps_inputs(["import", "mat", tmp_path, "--latitude", "37.5", "--out", tmp_path / "o" / "r.toml"], [junk], 2,
                     "is a folder")
    cli_keeps_inputs(["import", "mat", "/dev/zero", "--latitude", "37.5", "--out", tmp_path / "o" / "r.toml"], [junk],
                     2, "/dev/zero", "not a regular file")


#: The child's own peak: Linux carries a parent's peak RSS into ``ru_maxrss`` across fork and exec (a test suite
#: of 1 GB made every child read 1 GB), not into the new process image's ``VmHWM``.
PEAK_MB = ("def peak_mb():\n"
           "    try:\n"
           "        with open('/proc/self/status') as status:\n"
           "            return next(float(l.split()[1]) / 1024 for l in status if l.startswith('VmHWM:'))\n"
           "    except (OSError, StopIteration):\n"
           "        import resource\n"
           "        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0\n")


def _peak(args) -> tuple[int, str, float]:
    """Exit status, standard error and peak memory (MB) of the command line in a child process."""
    code = (PEAK_MB + "import sys\nfrom casadi_sins.cli import main\nstatus = main(sys.argv[1:])\n"
            "print(peak_mb(), file=sys.stderr)\nsys.exit(status)")
    done = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True, timeout=300)
    lines = done.stderr.strip().splitlines()
    return done.returncode, "\n".join(lines[:-1]), float(lines[-1])


def test_an_hdf5_file_of_3_kb_declaring_3e8_rows_stays_small(tmp_path):
    h5py = pytest.importorskip("h5py")
    src = tmp_path / "bomb.h5"
    with h5py.File(src, "w") as handle:
        for key in KEYS:
            handle.create_dataset(key, shape=(300_000_000,), dtype="f8", chunks=(1 << 20,), compression="gzip")
    assert src.stat().st_size < 10_000
    status, err, peak_mb = _peak(["import", "hdf5", src, "--latitude", "37.5", "--out", tmp_path / "o" / "r.toml"])
    assert status == 2 and len(err.splitlines()) == 1 and "bomb.h5" in err, err
    assert "declares" in err or "does not increase" in err, err
    assert peak_mb < 1000 and not (tmp_path / "o").exists()


def test_a_parquet_file_of_constant_rows_is_judged_on_its_size_or_first_block(tmp_path):
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    batch = pa.table({key: np.ones(1 << 20) for key in KEYS})
    src = tmp_path / "constant.parquet"
    with pq.ParquetWriter(src, batch.schema, compression="zstd") as writer:
        for _ in range(128):  # 1.3e8 rows in a few MB
            writer.write_table(batch)
    status, err, peak_mb = _peak(["import", "parquet", src, "--latitude", "37.5", "--out", tmp_path / "o" / "r.toml"])
    assert status == 2 and len(err.splitlines()) == 1 and "not a Parquet file" not in err, err
    assert "declares" in err or "does not increase" in err, err
    assert peak_mb < 1000


def test_a_declared_size_that_fits_is_still_judged_on_the_first_block(tmp_path, monkeypatch):
    """With memory to spare for the declared rows, the reader stops at the first block's fault, allocating one
    block (not the 2.4 GB per column the file declares)."""
    import tracemalloc

    from casadi_sins.core import inputs
    from casadi_sins.core.errors import InputError
    from casadi_sins.data.importers import import_samples

    h5py = pytest.importorskip("h5py")
    src = tmp_path / "bomb.h5"
    with h5py.File(src, "w") as handle:
        for key in KEYS:
            handle.create_dataset(key, shape=(300_000_000,), dtype="f8", chunks=(1 << 20,), compression="gzip")
    monkeypatch.setattr(inputs, "memory_available", lambda: 1e15)
    tracemalloc.start()
    try:
        with pytest.raises(InputError, match=r"time at row 2 \(0\) does not increase"):
            import_samples("hdf5", src)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 200e6


def test_an_hdf5_chunk_too_large_to_decompress_is_refused_before_reading(tmp_path, monkeypatch):
    """A few MB of zeros compressed into one chunk of 800 MB: any row would need the whole chunk in memory."""
    from casadi_sins.core import inputs
    from casadi_sins.core.errors import InputError
    from casadi_sins.data.importers import import_samples

    h5py = pytest.importorskip("h5py")
    src = tmp_path / "chunk.h5"
    with h5py.File(src, "w") as handle:
        for key in KEYS:
            handle.create_dataset(key, shape=(100_000_000,), dtype="f8", chunks=(100_000_000,), compression="gzip")
    monkeypatch.setattr(inputs, "memory_available", lambda: 1e15)  # the declared size passes: the chunk decides
    with pytest.raises(InputError, match="chunks of 800 MB"):
        import_samples("hdf5", src)
