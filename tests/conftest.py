"""Shared fixtures: the paper's problem, simulations of it, their calibrations, and the peer recording.

The expensive ones (a full calibration takes seconds) are computed once per session and shared by
every test that only reads them.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.calibrate import calibrate_ils, calibrate_nlp
from casadi_sins.data.description import read_recording
from casadi_sins.data.problem import load_problem
from casadi_sins.data.tables import read_table
from casadi_sins.sim import simulate

# Child Pythons (``python -m casadi_sins``, ``python -c``) must import the package the suite tests, the
# installed one, not the checkout they happen to start in: no current folder on their module path.
os.environ["PYTHONSAFEPATH"] = "1"

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
def deck_sim():
    """The paper's experiment on a ship's deck (problems/kang2013-deck.toml: sway and heave/surge), seed 7."""
    return simulate(load_problem(PROBLEMS / "kang2013-deck.toml"), seed=7)


@pytest.fixture(scope="session")
def deck_nlp(deck_sim):
    """The NLP's calibration of :func:`deck_sim` (read-only)."""
    return calibrate_nlp(deck_sim.recording)


@pytest.fixture(scope="session")
def peer_recording():
    """The PSINS 19-position recording."""
    return read_recording(PEER / "psins-19pos.toml")


@pytest.fixture(scope="session")
def peer_truth():
    """Its truth: the 21-parameter part of the generator's errors."""
    return read_table(PEER / "psins-19pos.truth.csv")


def _static_increments(rate_hz, seconds, white, quantization=0.0, sigma=0.0, tau=600.0, seed=0, mean=0.0):
    """Increments of axes at rest, written independently of the package (NumPy and scipy.signal only): white rate
    noise of density ``white`` (unit/sqrt(s)), quantization ``quantization`` of the accumulated angle (each
    increment ``e_k - e_(k-1)``), a first-order Gauss-Markov rate (steady-state ``sigma``, correlation time
    ``tau``; an AR(1) per sample, held over the sample) and a constant rate ``mean``.  Per-axis arrays broadcast;
    returns ``(samples, axes)``."""
    from scipy.signal import lfilter
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    n = int(round(seconds * rate_hz))
    white, quantization, sigma, tau, mean = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float))
                                                                  for v in (white, quantization, sigma, tau, mean)))
    out = np.empty((n, len(white)))
    for k in range(len(white)):
        a = np.exp(-dt / tau[k])
        drive = rng.standard_normal(n) * sigma[k] * np.sqrt(1.0 - a * a)
        bias = lfilter([1.0], [1.0, -a], drive, zi=[a * sigma[k] * rng.standard_normal()])[0]
        remainder = rng.standard_normal(n + 1) * quantization[k]
        out[:, k] = (mean[k] + bias) * dt + white[k] * np.sqrt(dt) * rng.standard_normal(n) + np.diff(remainder)
    return out


@pytest.fixture(scope="session")
def static_increments():
    """The independent generator of a recording at rest (:func:`_static_increments`)."""
    return _static_increments


@pytest.fixture(scope="session")
def hand_problem():
    """A short session by hand (problems/hand-mems.toml with 14 rests of 3-6 s, about 2 minutes): a MEMS unit, raw
    counts with mid-scale offsets, rests at random orientations, free moves, tremor."""
    problem = load_problem(PROBLEMS / "hand-mems.toml")
    return dataclasses.replace(problem, name="hand-short",
                               hand=dataclasses.replace(problem.hand, rests=14, first_rest_s=20.0, rest_s=(3.0, 6.0)))


@pytest.fixture(scope="session")
def hand_sim(hand_problem):
    """That session simulated, seed 3."""
    return simulate(hand_problem, seed=3)


@pytest.fixture(scope="session")
def hand_sim_exact(hand_problem):
    """The same without sensor noise, tremor, settling or clock jitter (what the fits must recover exactly)."""
    hand = dataclasses.replace(hand_problem.hand, tremor_deg=0.0, tremor_mg=0.0, settle_deg=0.0, clock_jitter=0.0)
    return simulate(dataclasses.replace(hand_problem, hand=hand), seed=3, noise=False)


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
