"""The bias-wander decision without a datasheet (:mod:`calibrate.wander`): a family-wise 1 % for white noise."""

import numpy as np
import pytest

from casadi_sins.calibrate.wander import FAMILY_P, INCLUDE_LR, bias_cost, decide, p_value
from casadi_sins.model.registry import NAMES
from casadi_sins.noise.wander import BiasWander, SensorWander


def test_the_p_value_is_half_the_chi_square_tail():
    from scipy.stats import chi2

    for lr in (0.5, 2.71, 6.63, 10.83):
        assert p_value(lr) == pytest.approx(0.5 * chi2.sf(lr, 1), rel=1e-9)
    assert p_value(0.0) == 0.5


def test_two_sensors_at_their_thresholds_make_the_family_wise_level():
    total = 1.0 - np.prod([1.0 - p_value(lr) for lr in INCLUDE_LR.values()])
    assert total == pytest.approx(FAMILY_P, rel=0.01)


def test_weak_evidence_includes_nothing():
    estimates = {"accel": SensorWander(2e-5, 5.0, 1e-4, 600.0), "gyro": SensorWander(1e-9, 7.0, 1e-8, 600.0)}
    out = decide(estimates)
    assert not out["accel"].included and out["gyro"].included


def test_white_noise_contrasts_rarely_include_a_term():
    """Restricted likelihood on white contrasts (no wander at all): the share of draws that include a term for
    either sensor is near the family-wise 1 % (0.2-2.5 % over 1200 draws)."""
    rng = np.random.default_rng(40)
    k = 30
    scale = {"accel": 1e5, "gyro": 1e9}  # a unit size in SI moves the contrasts by this much: sizes mid-range
    roots = {s: rng.standard_normal((k, 6)) * scale[s] for s in ("accel", "gyro")}
    gram = {s: r @ r.T for s, r in roots.items()}
    hits = 0
    for _ in range(1200):
        estimates = decide(BiasWander(rng.standard_normal(k), gram, 600.0).estimate(["accel", "gyro"]))
        hits += any(w.included for w in estimates.values())
    assert 0.002 < hits / 1200 < 0.025, hits


def test_the_cost_is_the_widest_bias_sigma_ratio():
    before = np.eye(len(NAMES))
    after = before.copy()
    after[NAMES.index("accel_bias_y"), NAMES.index("accel_bias_y")] = 9.0
    assert bias_cost(before, after, NAMES, "accel") == pytest.approx(3.0)
    assert bias_cost(before, after, NAMES, "gyro") == pytest.approx(1.0)
