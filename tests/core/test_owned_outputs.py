"""A run owns its output set (core.files.claim_outputs, write_files(stale=...)); inputs are registered as they
are found (core.guard) and are never written over or removed; held signals arrive after the step."""

import os
import signal
import time

import pytest

from casadi_sins.core import files
from casadi_sins.core.errors import InputError, OutputError
from casadi_sins.core.files import claim_outputs, gathered_writes, write_files
from casadi_sins.core.guard import guarded_inputs, register_input
from casadi_sins.core.inputs import check_input_file
from casadi_sins.core.signals import signals_held


def test_the_files_of_the_set_not_written_again_are_removed_with_the_writes(tmp_path):
    table, certificate, other = tmp_path / "SN.csv", tmp_path / "SN.certificate.html", tmp_path / "SN.notes.txt"
    for path in (table, certificate, other):
        path.write_text("earlier run")
    with guarded_inputs(), gathered_writes():
        claim_outputs([table, certificate])
        write_files({table: b"new table"})
        assert certificate.read_text() == "earlier run"  # nothing happens before the command ends well
    assert table.read_text() == "new table" and not certificate.exists()
    assert other.read_text() == "earlier run"  # not of the set: left alone
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left


def test_a_failing_command_removes_nothing_and_writes_nothing(tmp_path):
    table, certificate = tmp_path / "SN.csv", tmp_path / "SN.certificate.html"
    table.write_text("earlier")
    certificate.write_text("PASS")
    with pytest.raises(InputError), guarded_inputs(), gathered_writes():
        claim_outputs([table, certificate])
        write_files({table: b"new"})
        raise InputError(None, "the calibration failed")
    assert table.read_text() == "earlier" and certificate.read_text() == "PASS"


def test_an_input_in_the_set_is_refused_before_anything_and_never_removed(tmp_path):
    data, certificate = tmp_path / "SN.csv", tmp_path / "SN.certificate.html"
    data.write_text("samples")
    certificate.write_text("x")
    with guarded_inputs([(str(data), "the samples of SN.toml")]):
        with pytest.raises(OutputError, match="samples of SN.toml"):
            claim_outputs([data, certificate])
        with pytest.raises(OutputError, match="refusing to remove it"):
            write_files({}, stale=[data])
        os.link(data, tmp_path / "alias.csv")  # the same file by another name
        with pytest.raises(OutputError, match="input"):
            write_files({}, stale=[tmp_path / "alias.csv"])
    assert data.read_text() == "samples" and (tmp_path / "alias.csv").exists()


def test_every_file_a_reader_checks_becomes_an_input(tmp_path):
    report = tmp_path / "P.report.json"
    report.write_text("{}")
    with guarded_inputs():
        check_input_file(report, "calibration report")
        with pytest.raises(OutputError, match="read as a calibration report"):
            write_files({report: b"{}"})
        with pytest.raises(OutputError, match="input"):
            write_files({}, stale=[report])
    assert report.read_text() == "{}"


def test_a_folder_or_a_device_in_the_set_is_refused_not_removed(tmp_path):
    folder = tmp_path / "SN.report.md"
    folder.mkdir()
    with guarded_inputs():
        with pytest.raises(OutputError, match="is a folder.*refusing to remove it"):
            write_files({}, stale=[folder])
        link = tmp_path / "SN.clbt.m"
        link.symlink_to(os.devnull)
        with pytest.raises(OutputError, match="not a regular file"):
            claim_outputs([link])
    assert folder.is_dir() and os.readlink(link) == os.devnull


def test_a_failed_write_puts_the_earlier_files_back(tmp_path, monkeypatch):
    keep, written = tmp_path / "SN.certificate.html", tmp_path / "SN.csv"
    keep.write_text("PASS")
    real = os.replace

    def failing(src, dst):
        if str(dst) == str(written):
            raise OSError(28, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(files.os, "replace", failing)
    with guarded_inputs(), pytest.raises(OutputError, match="No space left"):
        write_files({written: b"table"}, stale=[keep])
    assert keep.read_text() == "PASS" and not written.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["SN.certificate.html"]


def test_a_signal_during_the_held_step_arrives_after_it(tmp_path):
    seen, done = [], []
    previous = signal.signal(signal.SIGHUP, lambda signum, frame: seen.append(list(done)))
    try:
        with signals_held():
            os.kill(os.getpid(), signal.SIGHUP)
            time.sleep(0.05)
            done.append("whole")
        assert seen == [["whole"]]  # delivered once, after the step
    finally:
        signal.signal(signal.SIGHUP, previous)


def test_registering_outside_a_command_does_nothing(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("x")
    register_input(path)  # no command runs: nothing to guard
    write_files({path: b"y"})
    assert path.read_text() == "y"
