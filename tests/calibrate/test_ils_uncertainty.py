"""The ILS's covariance at its last iteration (:mod:`calibrate.ils.uncertainty`, :mod:`calibrate.ils.curvature`)."""

from pathlib import Path

import numpy as np
import pytest

from casadi_sins.calibrate.ils import calibrate_ils
from casadi_sins.calibrate.ils.curvature import with_curvature
from casadi_sins.calibrate.ils.equations import solve_equations
from casadi_sins.calibrate.ils.uncertainty import NoiseTerms, free_levels, sandwich, small_sample_factor
from casadi_sins.data.problem import load_problem
from casadi_sins.model.parameters import joint_chi_square
from casadi_sins.model.registry import N_PARAMS, NATURAL_SCALE, SCALE_MASK
from casadi_sins.sim.simulate import simulate

DESIGN_300S = Path(__file__).resolve().parents[1] / "fixtures" / "design-300s" / "kang2013-design-300s.toml"


def _equations(rng, m):
    """A random design (SI error terms, natural scaling of the columns) and two covariance terms."""
    a = rng.standard_normal((m, N_PARAMS)) / NATURAL_SCALE
    fixed = np.diag(np.full(m, 0.5))
    root = rng.standard_normal((m, m)) / np.sqrt(m)
    unit = root @ root.T + np.eye(m)
    return a, fixed, unit


def test_the_sandwich_is_the_formal_covariance_when_the_weights_are_the_truth():
    rng = np.random.default_rng(1)
    a, fixed, unit = _equations(rng, 60)
    _, formal, _ = solve_equations(a, np.zeros(60), fixed + unit)
    assert np.allclose(sandwich(a, fixed + unit, fixed + unit), formal, rtol=1e-8, atol=0)
    # weights that are wrong give a wider covariance than the formal one of the right weights
    wrong = sandwich(a, fixed + 10.0 * np.diag(np.diag(unit)), fixed + unit)
    assert np.all(np.diag(wrong) >= np.diag(formal) * (1 - 1e-9))


def test_a_free_white_level_is_found_by_the_restricted_likelihood():
    rng = np.random.default_rng(2)
    a, fixed, unit = _equations(rng, 150)
    level = 3e-5  # a velocity random walk's size, m/s/sqrt(s)
    unit = unit * 1e10  # the equations' covariance per unit level: level^2 * unit dominates fixed
    truth = fixed + level**2 * unit
    found = []
    for _ in range(3):
        b = a @ (rng.standard_normal(N_PARAMS) * NATURAL_SCALE) + np.linalg.cholesky(truth) @ rng.standard_normal(150)
        found.append(free_levels(a, b, NoiseTerms(fixed, {"accel_vrw": unit}, {}), {"accel_vrw": 1e-3})["accel_vrw"])
    assert np.all(np.abs(np.array(found) / level - 1.0) < 0.25), found


def test_equations_linear_in_the_step_add_nothing():
    """A right-hand side exactly linear in the step of eqs. 22-25 (scale factors as ``truth / p``), with the
    design that produced it: no curvature, no design error, the covariance comes back as it was."""
    rng = np.random.default_rng(3)
    a, fixed, unit = _equations(rng, 80)
    params = 1.0 + np.abs(rng.standard_normal(N_PARAMS))
    truth = params * (1 + 1e-3 * rng.standard_normal(N_PARAMS))

    def rhs(p):
        return a @ np.where(SCALE_MASK, -truth / p, truth - p)

    design = a * np.where(SCALE_MASK, truth / params, 1.0)
    _, cov, _ = solve_equations(design, np.zeros(80), fixed + unit)
    loose = cov * 1e8  # wide enough to open the gate
    out, share = with_curvature(rhs, params, rhs(params), design, fixed + unit, loose, np.ones(N_PARAMS))
    assert share > -1e-6 and np.allclose(out, loose, rtol=1e-5, atol=0)


@pytest.fixture(scope="module")
def design_300s():
    return load_problem(DESIGN_300S)


def test_the_ils_joint_chi_square_is_honest_on_a_one_group_design(design_300s):
    """A single group of 300 s: the paper's method leaves combinations of thousands of ppm beside tenths of an
    arcsec, and the curvature across the loose ones reached the tight ones (joint chi-square 27-3153 per run).
    With the second order the joint chi-square of 4 runs stays within the chi-square's 99.9 % point."""
    total = 0.0
    for seed in range(50000, 50004):
        sim = simulate(design_300s, seed=seed)
        result = calibrate_ils(sim.recording)
        total += joint_chi_square(result.parameters, sim.truth)
        assert result.ils.curvature > 0.0  # the gate opened
    assert 40.0 < total < 140.0, total  # chi-square with 84 degrees of freedom: 99.9 % within 45-130


def test_the_paper_recording_keeps_its_values_and_paper_sigma(kang_ils):
    """On the paper's schedule the second order stays shut and the values are those of the solve; the paper's
    own sigma is kept beside the final one, which differs by well under a per cent."""
    assert kang_ils.ils.curvature == 0.0
    final = kang_ils.parameters.natural_sigma()
    assert np.all(np.abs(final / kang_ils.ils.paper_sigma_natural - 1.0) < 0.01)


def test_a_level_set_by_the_equations_widens_by_students_t():
    assert small_sample_factor(27, {"accel_vrw": 1e-5}) == pytest.approx(27 / 25)
    assert small_sample_factor(27, {}) == 1.0
