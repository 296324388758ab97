"""Shared fixtures: the paper's problem, simulations of it, and the peer recording."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from casadi_sins.problem import load_problem
from casadi_sins.recording import read_recording
from casadi_sins.simulate import simulate

PEER = Path(__file__).resolve().parents[1].parent / "shared" / "peer" / "psins-19pos"


@pytest.fixture(scope="session")
def kang_problem():
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
    return simulate(kang_problem, seed=5, noise=False)


@pytest.fixture(scope="session")
def peer_recording():
    path = PEER / "psins-19pos.toml"
    if not path.exists():
        pytest.skip("shared/peer/psins-19pos is not beside this checkout")
    return read_recording(path)


@pytest.fixture(scope="session")
def peer_truth():
    from casadi_sins.parameters import read_table

    return read_table(PEER / "psins-19pos.truth.csv")
