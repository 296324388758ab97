"""Gyro g-sensitivity and scale-factor asymmetry (issue 26): the 19-position schedule (turns of both senses
about every axis), recovered within sigma by the gyro groups in the strapdown step; the 21 alone name them."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.calibrate import calibrate_nlp
from casadi_sins.data.problem import load_problem
from casadi_sins.model.parameters import natural_errors
from casadi_sins.sim import simulate

PROBLEM = Path(__file__).resolve().parents[2] / "problems" / "extended-gsens.toml"


@pytest.fixture(scope="module")
def gsens_sim():
    """The problem with 30 s static segments (the schedule, not the duration, separates the terms)."""
    problem = load_problem(PROBLEM)
    return simulate(dataclasses.replace(problem, timing=dataclasses.replace(problem.timing, static_s=30.0)), seed=2)


def test_the_gyro_groups_are_recovered_with_honest_sigma(gsens_sim):
    result = calibrate_nlp(gsens_sim.recording, model=("gyro_gsens", "gyro_asym"))
    params = result.parameters
    z = natural_errors(params, gsens_sim.truth) / params.natural_sigma()
    assert len(params.names) == 33 and np.all(np.abs(z) < 4.5)
    assert np.sum(z**2) < 63.9  # chi-square, 33 degrees of freedom, 1 %
    bias = np.abs(params.values[9:12] - gsens_sim.truth.core[9:12]) / (np.pi / 180 / 3600)
    assert bias.max() < 5e-4  # deg/h


def test_the_21_name_the_groups_that_explain_their_misfit(gsens_sim):
    result = calibrate_nlp(gsens_sim.recording)
    named = [w for w in result.warnings if "--model auto" in w]
    assert len(named) == 1 and "gyro_gsens" in named[0]
    assert not any("bias instability beyond the white noise" in w for w in result.warnings)
