"""Shared fixtures: the paper's problem, simulations of it, their calibrations, and the peer recording.

The expensive ones (a full calibration takes seconds) are computed once per session and shared by
every test that only reads them.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from casadi_sins.calibrate import calibrate_ils, calibrate_nlp
from casadi_sins.data.description import read_recording
from casadi_sins.data.problem import load_problem
from casadi_sins.data.tables import read_table
from casadi_sins.sim import simulate

#: The PSINS 19-position recording, converted to our format (see its README).
PEER = Path(__file__).resolve().parent / "fixtures" / "psins-19pos"
PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


@pytest.fixture(scope="session")
def kang_problem():
    """The paper's experiment (problems/kang2013.toml)."""
    return load_problem()


@pytest.fixture(scope="session")
def short_problem(kang_problem):
    """The paper's schedule with short segments: fast, for format and CLI tests."""
    timing = dataclasses.replace(kang_problem.timing, static_s=8.0, rotation_s=4.0)
    return dataclasses.replace(kang_problem, timing=timing, name="short")


@pytest.fixture(scope="session")
def kang_sim(kang_problem):
    """The paper's experiment with noise, seed 11."""
    return simulate(kang_problem, seed=11)


@pytest.fixture(scope="session")
def kang_sim_noiseless(kang_problem):
    """The paper's experiment without sensor noise, seed 5."""
    return simulate(kang_problem, seed=5, noise=False)


@pytest.fixture(scope="session")
def kang_nlp(kang_sim):
    """The NLP's calibration of :func:`kang_sim` (read-only)."""
    return calibrate_nlp(kang_sim.recording)


@pytest.fixture(scope="session")
def kang_ils(kang_sim):
    """The ILS's calibration of :func:`kang_sim` (read-only)."""
    return calibrate_ils(kang_sim.recording)


@pytest.fixture(scope="session")
def peer_recording():
    """The PSINS 19-position recording."""
    return read_recording(PEER / "psins-19pos.toml")


@pytest.fixture(scope="session")
def peer_truth():
    """Its truth: the 21-parameter part of the generator's errors."""
    return read_table(PEER / "psins-19pos.truth.csv")


@pytest.fixture()
def cli_keeps_inputs(capsys):
    """Run the command line on ``args``: its exit status is ``status``, standard error one line (no traceback)
    holding every ``needle`` (for a failure, status 2; ``lines=0``: nothing, as a batch whose units failed
    reports them in its fleet table), and every file of ``inputs`` still there with the same SHA-256.  Returns
    the standard error.  ``cli_keeps_inputs(args, inputs, status=2, *needles, lines=1)``."""
    import hashlib

    from casadi_sins.cli import main

    def digest(path):
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()

    def run(args, inputs, status=2, *needles, lines=1):
        before = {Path(p): digest(p) for p in inputs}
        capsys.readouterr()
        got = main([str(a) for a in args])
        err = capsys.readouterr().err.strip()
        assert got == status, (got, err)
        assert "Traceback" not in err and "internal error" not in err, err
        if status == 2:
            assert len(err.splitlines()) == lines, err
        for needle in needles:
            assert needle in err, (needle, err)
        assert {p: digest(p) for p in before} == before, "an input changed"
        return err

    return run
