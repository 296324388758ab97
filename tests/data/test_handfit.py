"""The rough sensor models of a session by hand (data.handfit): recovered from the rests and moves alone, and the
one-line refusals of a session that cannot be calibrated."""

import dataclasses

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.data.handfit import (MAX_STEP_DEG, MIN_HAND_RESTS, fit_accelerometers, fit_gsensitivity, fit_gyros,
                                      rough_values)
from casadi_sins.data.handling import fit_session, rest_means, too_fast
from casadi_sins.model.parameters import ParameterSet, natural_errors


def true_spans(rec):
    return [(rec.segment_samples(s).start, rec.segment_samples(s).stop) for s in rec.static_segments]


@pytest.fixture(scope="module")
def exact_fits(hand_sim_exact):
    rec = hand_sim_exact.recording
    spans = true_spans(rec)
    return fit_session(rec.gyro, rec.accel, spans, rec.site.g, rec.dt), spans


def test_the_accelerometers_ellipsoid_recovers_offsets_scales_and_misalignments(exact_fits, hand_sim_exact):
    """Raw counts with mid-scale offsets (biases of 8 g) and no noise: the nine parameters to a few ppm and ug."""
    (accel, _), _ = exact_fits
    truth = hand_sim_exact.truth
    values = np.concatenate([accel.bias, accel.scale, accel.misalignment])
    err = natural_errors(values, truth.core[:9], truth.names[:9])
    assert np.all(np.abs(err[:3]) < 50.0) and np.all(np.abs(err[3:6]) < 5.0) and np.all(np.abs(err[6:]) < 5.0), err


def test_the_gyros_carry_gravity_from_rest_to_rest_with_their_scales_and_misalignments(exact_fits, hand_sim_exact):
    """Scale factors to 0.05 % and misalignments to 0.02 deg from the moves alone (IMU-TK's gyro step)."""
    (accel, gyros), spans = exact_fits
    rec, truth = hand_sim_exact.recording, hand_sim_exact.truth
    rough = ParameterSet.from_dict(rough_values(accel, gyros, rec.dt, *rest_means(rec.gyro, spans)[:1],
                                                accel.force(rest_means(rec.accel, spans)[0], rec.dt),
                                                rest_means(rec.gyro, spans)[1]))
    err = natural_errors(rough.values[:21], truth.core, truth.names[:21])
    assert np.all(np.abs(err[12:15]) < 500.0), err[12:15]  # ppm
    assert np.all(np.abs(err[15:21]) < 72.0), err[15:21]  # arcsec
    assert np.max(gyros.miss_deg) < 0.2 and np.max(gyros.step_deg) < MAX_STEP_DEG


def test_the_rests_rates_give_the_bias_and_g_sensitivity():
    rng = np.random.default_rng(4)
    force = rng.standard_normal((20, 3))
    force *= 9.8 / np.linalg.norm(force, axis=1, keepdims=True)
    g_sens = rng.standard_normal((3, 3)) * 1e-4
    bias = np.array([0.1, -0.2, 0.3])
    bias_fit, g_fit = fit_gsensitivity(bias + force @ g_sens.T, force, np.ones(20))
    assert np.allclose(bias_fit, bias) and np.allclose(g_fit, g_sens)


def test_too_few_rests_are_refused_in_one_line_saying_what_to_add(hand_sim):
    rec = hand_sim.recording
    spans = true_spans(rec)[:MIN_HAND_RESTS - 1]
    with pytest.raises(InputError, match=r"found 11 rest\(s\): a session by hand needs at least 12 .*add rests$"):
        fit_session(rec.gyro, rec.accel, spans, rec.site.g, rec.dt)


def test_rests_in_one_small_cone_are_refused():
    """Twelve rests whose gravity lies within 20 deg: no ellipsoid, in one line naming what to add."""
    rng = np.random.default_rng(5)
    directions = np.array([0.0, 0.0, 1.0]) + 0.15 * rng.standard_normal((12, 3))
    means = 32768.0 + 4000.0 * directions / np.linalg.norm(directions, axis=1, keepdims=True)
    gyro = np.zeros((12 * 200, 3))
    accel = np.repeat(means, 200, axis=0)
    spans = [(200 * k + 20, 200 * k + 180) for k in range(12)]
    with pytest.raises(InputError, match=r"span too few directions.*add rests with each body axis up and down"):
        fit_session(gyro, accel, spans, 9.8, 0.01)
    with pytest.raises(ValueError):
        fit_accelerometers(means, np.ones(12), 9.8, 0.01)


def test_moves_too_fast_for_the_sample_rate_are_named(exact_fits):
    (_, gyros), _ = exact_fits
    step = np.zeros(len(gyros.step_deg))
    step[0] = 20.0
    fast = dataclasses.replace(gyros, step_deg=step)
    reason = too_fast(fast, [(float(k), k + 1.0) for k in range(len(gyros.step_deg))], 100.0)
    assert reason.startswith("1 move(s) turn more than 15 deg in one sample (0.00-1.00 s; up to 20 deg, 2000 deg/s")
    assert "too fast for the sample rate" in reason and "record at a higher rate" in reason
    assert too_fast(gyros, [(0.0, 1.0)] * len(gyros.step_deg), 100.0) is None


def test_the_gyro_fit_needs_motion(hand_sim_exact):
    rec = hand_sim_exact.recording
    with pytest.raises(ValueError, match="no motion"):
        fit_gyros(np.zeros_like(rec.gyro), true_spans(rec), np.tile([0.0, 0.0, 1.0], (len(true_spans(rec)), 1)))


def test_a_move_the_gyros_cannot_carry_is_left_out_and_named(hand_sim):
    """Half a move's gyro pulses lost (a range exceeded): the fit leaves that move out, the others keep the scale
    factors, and the calibration's start names it as a doubt about the segments."""
    from casadi_sins.calibrate.initial import fitted_parameters

    rec = hand_sim.recording
    move = rec.segment_samples(rec.segments[5])
    gyro = rec.gyro.copy()
    gyro[move.start:(move.start + move.stop) // 2] = np.median(gyro[rec.segment_samples(rec.segments[4])], axis=0)
    broken = dataclasses.replace(rec, gyro=gyro, warnings=[])
    rough = fitted_parameters(broken)
    assert np.all(np.abs(rough.values[12:15] / hand_sim.truth.core[12:15] - 1.0) < 0.01)  # a start: 1 %
    assert len(broken.warnings) == 1 and f"at {rec.segments[5].start:.1f}" in broken.warnings[0]
