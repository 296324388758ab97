"""Sensor noise from the raw data, base motion, datasheets (issue 9)."""

import numpy as np
import pytest

from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.core.errors import InputError
from casadi_sins.core.units import DEG_PER_H, UG
from casadi_sins.data.datasheet import read_datasheet
from casadi_sins.model.noise import SensorNoise
from casadi_sins.noise.motion import base_motion, describe_motion
from casadi_sins.noise.raw import estimate_sensor_noise
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


def test_coarse_pulses_leave_the_white_noise_to_the_fit_with_an_honest_bound(kang_problem):
    """Integer pulses 70x the accelerometer noise (pitfall 8): sample differences would be wildly too large;
    the raw estimate says the white noise is not determined and bounds it from above."""
    raw, nat, _ = raw_natural(kang_problem.with_changes(quantize=True))
    assert nat["accel_vrw_ug_rthz"] is None
    bounds = raw.upper_bounds().natural()
    assert np.all(bounds["accel_vrw_ug_rthz"] >= 5.0)
    # the pulse remainder is what dominates: about a pulse / sqrt(12) (3.5e-4 m/s pulses)
    assert 0.05 < np.max(nat["accel_quantization_mm_s"]) < 0.15


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
