"""The restricted likelihood of bias instability in closed form (issue 16) against the likelihood in full."""

import numpy as np

from casadi_sins.noise.pieces import BiasPiece
from casadi_sins.noise.wander import BiasWander, exponential_kernel


def brute_force_nll(rw, jw, cov):
    """REML of ``rw ~ N(J b, cov)``: ``0.5 (ln det S + ln det J^T S^-1 J + r^T P r)``."""
    inv = np.linalg.inv(cov)
    info = jw.T @ inv @ jw
    proj = inv - inv @ jw @ np.linalg.solve(info, jw.T @ inv)
    return 0.5 * (np.linalg.slogdet(cov)[1] + np.linalg.slogdet(info)[1] + rw @ proj @ rw)


def test_closed_form_from_responses_equals_the_brute_force_likelihood():
    """Two pieces per sensor axis, Gauss-Markov correlated in time: the Gram matrix of the projected responses and
    the kernels give the restricted likelihood exactly (up to a constant), and each profile is its difference."""
    rng = np.random.default_rng(3)
    m, p, tau = 80, 4, 30.0
    pieces = [BiasPiece(sensor, axis, time, 0, 0) for sensor in ("accel", "gyro") for time in (10.0, 40.0)
              for axis in range(3)]
    jw, rw = rng.standard_normal((m, p)), rng.standard_normal(m)
    zw = rng.standard_normal((m, len(pieces))) * np.where([x.sensor == "gyro" for x in pieces], 1e5, 1.0)
    basis = np.linalg.qr(jw)[0]
    wander = BiasWander.from_responses(rw, basis, zw, pieces, tau)

    def cov(sigma):
        out = np.eye(m)
        for sensor, size in sigma.items():
            for axis in range(3):
                sel = [i for i, x in enumerate(pieces) if x.sensor == sensor and x.axis == axis]
                kernel = exponential_kernel(np.array([pieces[i].time for i in sel]), tau)
                out += size**2 * zw[:, sel] @ kernel @ zw[:, sel].T
        return out

    zero = {"accel": 0.0, "gyro": 0.0}
    offset = brute_force_nll(rw, jw, cov(zero)) - wander.nll(zero)
    for sigma in ({"accel": 0.7, "gyro": 0.0}, {"accel": 0.0, "gyro": 2e-5}, {"accel": 0.3, "gyro": 1e-5}):
        assert abs(brute_force_nll(rw, jw, cov(sigma)) - wander.nll(sigma) - offset) < 1e-9
    profile = wander.profile("gyro", {"accel": 0.3})
    held = wander.nll({"accel": 0.3, "gyro": 0.0})
    assert abs(float(profile.delta(1e-5)) - (wander.nll({"accel": 0.3, "gyro": 1e-5}) - held)) < 1e-9


def test_closed_form_from_covariances_and_the_search_find_the_brute_force_optimum():
    """The ILS's form (whitened equations and unit covariances): the estimate is the brute-force REML's minimum,
    its likelihood ratio and 95 % bound follow the brute-force curve."""
    rng = np.random.default_rng(7)
    m, p = 40, 6
    jw = rng.standard_normal((m, p))
    unit = rng.standard_normal((m, 5))
    unit = unit @ unit.T * 1e8  # a unit instability that moves the equations a lot (SI)
    truth = 2e-4
    rw = jw @ rng.standard_normal(p) + np.linalg.cholesky(np.eye(m) + truth**2 * unit) @ rng.standard_normal(m)
    wander = BiasWander.from_covariances(jw, rw, {"accel": unit}, tau=100.0)
    estimate = wander.estimate(["accel"])["accel"]
    sizes = np.exp(np.linspace(np.log(1e-7), np.log(1e-1), 4001))
    curve = np.array([brute_force_nll(rw, jw, np.eye(m) + s**2 * unit) for s in sizes])
    best = sizes[np.argmin(curve)]
    none = brute_force_nll(rw, jw, np.eye(m))
    assert abs(np.log(estimate.sigma / best)) < 0.02
    assert abs(estimate.lr - 2.0 * (none - curve.min())) < 1e-3
    beyond = sizes > best
    upper = sizes[beyond][np.argmax(curve[beyond] - curve.min() > 2.71 / 2.0)]
    assert abs(np.log(estimate.upper / upper)) < 0.02 and estimate.tau == 100.0
