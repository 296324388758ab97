"""Sensor noise from the raw data, base motion, datasheets (issue 9), a counter's quantization (issue 16)."""

import dataclasses

import numpy as np
import pytest

from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.core.errors import InputError
from casadi_sins.core.units import ARCSEC, ARW_UNIT, DEG_PER_H, UG, VRW_UNIT
from casadi_sins.data.datasheet import read_datasheet
from casadi_sins.model.noise import SensorNoise
from casadi_sins.noise.motion import base_motion, describe_motion
from casadi_sins.noise.raw import block_mean_variances, estimate_sensor_noise
from casadi_sins.sim import simulate

REALISTIC = dict(accel_noise_ug=0.0, gyro_noise_deg_h=0.0, accel_vrw_ug_rthz=15.0, gyro_arw_deg_rth=0.002)
SWAY = dict(sway_amplitude_arcsec=(20.0, 120.0), sway_period_s=(2.0, 20.0))


def raw_natural(problem, seed=1):
    rec = simulate(problem, seed=seed).recording
    raw = estimate_sensor_noise(rec, rough_parameters(rec).values)
    return raw, raw.model().natural(), rec


@pytest.mark.parametrize("changes, arw, vrw", [({}, 0.01 * 0.1 / 60, 50 * 0.1), (REALISTIC, 0.002, 15.0),
                                               (dict(REALISTIC, **SWAY), 0.002, 15.0)])
def test_raw_estimate_is_within_10_percent_of_the_simulated_noise(kang_problem, changes, arw, vrw):
    """Third differences of block sums: the paper's noise, navigation-grade noise, and the same on a
    swaying base (the sway does not reach third differences of short blocks, pitfall 9)."""
    _, nat, _ = raw_natural(kang_problem.with_changes(**changes))
    np.testing.assert_allclose(nat["gyro_arw_deg_rth"], arw, rtol=0.1)
    np.testing.assert_allclose(nat["accel_vrw_ug_rthz"], vrw, rtol=0.1)


def test_block_means_of_the_accumulated_increments_follow_their_formula():
    """Fourth differences of block means: white noise gives (25 m^2 + 35) / (3 m) s^2, independent errors of the
    accumulated increments 70 s_e^2 / m (600,000 samples: sampling errors of 2-3 % at m = 64, bounds 10 %)."""
    rng = np.random.default_rng(0)
    n, blocks = 600_000, [1, 4, 16, 64]
    m = np.array(blocks, dtype=float)[:, None]
    white, count = block_mean_variances([rng.standard_normal((n, 3))], blocks)
    np.testing.assert_allclose(white, (25 * m**2 + 35) / (3 * m) * np.ones((1, 3)), rtol=0.1)
    assert np.all(count[:, 0] == [n // b - 4 for b in blocks])
    errors = rng.standard_normal((n + 1, 3))
    remainder, _ = block_mean_variances([np.diff(errors, axis=0)], blocks)  # increments e_k - e_(k-1)
    np.testing.assert_allclose(remainder, 70.0 / m * np.ones((1, 3)), rtol=0.1)


COARSE_COUNTER = dict(quantize=True, accel_noise_ug=30.0, gyro_noise_deg_h=0.02)


@pytest.mark.parametrize("changes, rate_hz, vrw, arw", [
    (dict(quantize=True), 100.0, 50 * 0.1, 0.01 * 0.1 / 60),  # the paper's noise, integer pulses
    # issue 16's coarse counter: a pulse of 144 per 200 Hz sample, 0.004 pulse of white noise
    (COARSE_COUNTER, 200.0, 30 * 200**-0.5, 0.02 * 200**-0.5 / 60)])
def test_a_carried_counter_is_told_apart_from_white_noise(kang_problem, changes, rate_hz, vrw, arw):
    """Integer pulses carrying their remainder (pitfall 8): the remainder is one pulse / sqrt(12), known; the white
    noise beneath pulses 70-1000 times larger shows in block means of the accumulated increments (block sums never
    show it: they see the remainder at two instants).  The raw data determine it, and its standard error covers it."""
    problem = dataclasses.replace(kang_problem.with_changes(**changes), rate_hz=rate_hz)
    raw, nat, rec = raw_natural(problem)
    assert raw.counter == {"gyro": True, "accel": True}
    np.testing.assert_allclose(nat["accel_vrw_ug_rthz"], vrw, rtol=0.2)
    np.testing.assert_allclose(nat["gyro_arw_deg_rth"], arw, rtol=0.25)
    for sensor, truth in (("accel", vrw * VRW_UNIT), ("gyro", arw * ARW_UNIT)):
        for term in raw.white[sensor]:
            assert abs(term.value - truth) < 4.0 * term.standard_error
    pulse = rough_parameters(rec).values
    np.testing.assert_allclose(nat["accel_quantization_mm_s"], pulse[3:6] / np.sqrt(12) * 1e3, rtol=1e-12)
    np.testing.assert_allclose(nat["gyro_quantization_arcsec"], pulse[12:15] / np.sqrt(12) / ARCSEC, rtol=1e-12)


def test_a_counter_on_a_swaying_base_leaves_the_white_noise_undetermined_rather_than_wrong(kang_problem):
    """Pulses hide the white noise in short blocks and the sway in long ones: the raw data must not claim it (the
    fit sets it within the bound); what they do claim is within 25 %."""
    raw, _, _ = raw_natural(kang_problem.with_changes(quantize=True, **SWAY), seed=2)
    truth = {"gyro": 0.01 * DEG_PER_H * 0.1, "accel": 50 * UG * 0.1}  # per sqrt(s), at 100 Hz
    claimed = [(t.value, truth[s]) for s in truth for t in raw.white[s] if t.determined]
    assert all(abs(value / true - 1.0) < 0.25 for value, true in claimed)
    assert len(claimed) < 6


def test_sway_is_detected_and_sized_and_a_still_base_is_not(kang_problem):
    _, nat, rec = raw_natural(kang_problem.with_changes(**SWAY))
    motions = base_motion(rec, rough_parameters(rec).values, SensorNoise.from_natural(nat))
    text = describe_motion(motions)
    assert text and "sway" in text and all(m.significant for m in motions)
    assert 20.0 < max(m.amplitude_arcsec for m in motions) < 400.0
    _, nat, rec = raw_natural(kang_problem.with_changes(**REALISTIC))
    assert describe_motion(base_motion(rec, rough_parameters(rec).values, SensorNoise.from_natural(nat))) is None


def test_datasheet_reads_natural_units_and_names_bad_keys(tmp_path):

    path = tmp_path / "unit.toml"
    path.write_text("gyro_arw_deg_rth = 0.002\naccel_bias_instability_ug = 3\naccel_bias_tau_s = 900\n")
    spec = read_datasheet(path)
    assert spec.gyro_arw == pytest.approx(np.full(3, 0.002 * np.pi / 180 / 60))
    assert spec.accel_bias_instability == pytest.approx(3 * UG) and spec.accel_vrw is None
    assert SensorNoise.from_natural(spec.natural()).gyro_arw[0] == pytest.approx(spec.gyro_arw[0])
    assert spec.natural()["accel_bias_instability_ug"] == pytest.approx(3.0)
    assert DEG_PER_H > 0
    path.write_text("gyro_arw = 0.002\n")
    with pytest.raises(InputError, match=r"unit\.toml: unknown key\(s\) 'gyro_arw'"):
        read_datasheet(path)
    path.write_text("gyro_arw_deg_rth = -1\n")
    with pytest.raises(InputError, match="gyro_arw_deg_rth must be a non-negative number"):
        read_datasheet(path)
