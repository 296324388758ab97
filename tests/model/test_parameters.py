"""Errors against a truth, and the joint chi-square of an estimate's errors under its own covariance."""

import numpy as np
from scipy import stats

from casadi_sins.model.parameters import ParameterSet, joint_chi_square, parameter_errors
from casadi_sins.model.registry import NAMES, relative_mask


def _truth() -> ParameterSet:
    rng = np.random.default_rng(1)
    values = rng.normal(0.0, 1e-4, len(NAMES))
    values[relative_mask(NAMES)] = np.abs(values[relative_mask(NAMES)]) + 3e-4  # scale factors: pulse sizes
    return ParameterSet(values, names=NAMES)


def test_joint_chi_square_of_draws_from_the_covariance_follows_its_distribution():
    truth = _truth()
    rng = np.random.default_rng(2)
    a = rng.normal(size=(21, 21)) * 1e-7
    relative = a @ a.T + np.diag(np.full(21, 1e-12))  # correlated, in the units of parameter_errors
    mask = relative_mask(NAMES)
    factor = np.linalg.cholesky(relative)
    values = []
    for _ in range(400):
        err = factor @ rng.normal(size=21)
        estimate = truth.values + err * np.where(mask, truth.values, 1.0)  # scale factors: S_hat = S (1 + t)
        scale = np.where(mask, np.abs(estimate), 1.0)  # the table's covariance is in SI
        cov = relative * np.outer(scale, scale)
        values.append(joint_chi_square(ParameterSet(estimate, covariance=cov, names=NAMES), truth))
    values = np.array(values)
    # mean 21, and the distribution as a whole (Kolmogorov-Smirnov against chi-square with 21 dof)
    assert abs(values.mean() - 21.0) < 3 * np.sqrt(2 * 21 / len(values))
    assert stats.kstest(values, stats.chi2(21).cdf).pvalue > 0.001


def test_joint_chi_square_is_the_sum_of_squared_z_for_a_diagonal_covariance_and_nan_without_one():
    truth = _truth()
    sigma = np.full(21, 2e-6)
    estimate_values = truth.values.copy()
    estimate_values[0] += 3 * sigma[0]
    estimate = ParameterSet(estimate_values, covariance=np.diag(sigma**2), names=NAMES)
    z = parameter_errors(estimate.values, truth.values) / np.sqrt(np.diag(estimate.relative_covariance()))
    assert np.isclose(joint_chi_square(estimate, truth), float(z @ z), rtol=1e-12)
    assert np.isclose(z[0], 3.0)
    assert np.isnan(joint_chi_square(ParameterSet(estimate_values, names=NAMES), truth))


def test_relative_covariance_and_natural_size_agree_with_the_errors_of_a_draw():
    """One conversion of the registry: an SI draw of a table's covariance, divided by the natural size, has the
    natural sigma of the table; the relative covariance is the covariance of :func:`parameter_errors`."""
    from casadi_sins.model.registry import model_names, natural_size, natural_scale_of, relative_covariance

    names = model_names(("gyro_asym", "quadratic"))
    truth = ParameterSet(np.concatenate([_truth().values, [3e-6, -2e-6, 1e-6, 1e-6, 2e-6, 3e-6]]), names=names)
    rng = np.random.default_rng(3)
    a = rng.normal(size=(len(names), len(names)))
    size = natural_size(names, truth.values)
    cov = (a @ a.T + np.eye(len(names))) * np.outer(size, size)
    params = ParameterSet(truth.values, covariance=cov, names=names)
    draws = truth.values + rng.multivariate_normal(np.zeros(len(names)), cov, size=4000)
    errors = np.array([parameter_errors(d, truth.values, names) for d in draws])
    rel = relative_covariance(names, truth.values, cov)
    np.testing.assert_allclose(np.sqrt(np.diag(rel)) / natural_scale_of(names), params.natural_sigma(), rtol=1e-12)
    np.testing.assert_allclose(errors.std(axis=0) / np.sqrt(np.diag(rel)), 1.0, atol=0.05)
    scale = relative_mask(names)
    np.testing.assert_allclose(natural_size(names, truth.values)[scale], 1e-6 * np.abs(truth.values[scale]))
