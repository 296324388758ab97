"""``noise`` on the package's own simulator: a problem with one long static segment and a bias instability,
simulated (integer pulses, remainder carried) and identified with its truth table, gives back the problem's noise,
and a datasheet that ``calibrate --noise`` reads."""

import dataclasses
import math

import numpy as np
import pytest

from casadi_sins.core.units import ARW_UNIT, DEG_PER_H, UG, VRW_UNIT
from casadi_sins.data.datasheet import read_datasheet
from casadi_sins.data.description import write_recording
from casadi_sins.data.problem import GroupPlan
from casadi_sins.data.tables import write_table
from casadi_sins.sim import simulate
from casadi_sins.studies.static_noise import noise_files, run_noise, scale_from

Z = 4.0  # standard errors


@pytest.fixture(scope="module")
def rest(kang_problem, tmp_path_factory):
    """Two hours at rest at 10 Hz: ARW 0.002 deg/sqrt(h), VRW 15 ug/sqrt(Hz), bias instability 0.05 deg/h and
    10 ug over 100 s, integer pulses."""
    problem = dataclasses.replace(
        kang_problem, name="rest", rate_hz=10.0, groups=(GroupPlan("NUE", ()),),
        timing=dataclasses.replace(kang_problem.timing, static_s=7200.0),
        deviations=dataclasses.replace(kang_problem.deviations, accel_noise_ug=0.0, gyro_noise_deg_h=0.0,
                                       accel_vrw_ug_rthz=15.0, gyro_arw_deg_rth=0.002, quantize=True,
                                       gyro_bias_instability_deg_h=0.05, gyro_bias_tau_s=100.0,
                                       accel_bias_instability_ug=10.0, accel_bias_tau_s=100.0))
    sim = simulate(problem, seed=4)
    folder = tmp_path_factory.mktemp("rest")
    toml = write_recording(sim.recording, folder / "rest.toml")
    write_table(folder / "truth.csv", sim.truth)
    return toml, folder / "truth.csv", sim.truth


def test_the_simulators_noise_comes_back(rest):
    toml, truth_path, truth = rest
    study = run_noise(toml, scale=scale_from(str(truth_path)))
    fits = study.identification.fits
    assert study.integer.all()  # a counter
    for i, fit in enumerate(fits):
        white = 0.002 * ARW_UNIT if i < 3 else 15.0 * VRW_UNIT
        sigma = 0.05 * DEG_PER_H if i < 3 else 10.0 * UG
        assert abs(fit.white.value - white) <= Z * fit.white.sigma
        assert fit.status == "determined"
        assert abs(math.log(fit.gm_sigma.value / sigma)) <= Z * fit.gm_sigma.sigma / fit.gm_sigma.value
        assert abs(math.log(fit.gm_tau.value / 100.0)) <= Z * fit.gm_tau.sigma / fit.gm_tau.value
    # a counter's quantization is known, one pulse / sqrt(12); its white noise is fitted where the sawtooth of the
    # remainder stays below it (taken as white, the remainder had pulled the VRW 9 % low)
    for i, name in enumerate(("gyro_scale_x", "accel_scale_x")):
        pulse = abs(truth.values[truth.names.index(name)])
        assert fits[3 * i].quantization.value == pytest.approx(pulse / math.sqrt(12.0), rel=1e-9)


def test_its_datasheet_reads_back_as_the_calibrator_takes_it(rest, tmp_path):
    toml, truth_path, _ = rest
    study = run_noise(toml, scale=scale_from(str(truth_path)))
    files = noise_files(study, tmp_path, plots=False)
    (tmp_path / "datasheet.toml").write_bytes(files[tmp_path / "datasheet.toml"])
    sheet = read_datasheet(tmp_path / "datasheet.toml")
    noise, _ = study.datasheet()
    np.testing.assert_allclose(sheet.gyro_arw, noise.gyro_arw, rtol=1e-5)
    np.testing.assert_allclose(sheet.accel_vrw, noise.accel_vrw, rtol=1e-5)
    assert sheet.gyro_bias_instability == pytest.approx(noise.gyro_bias_instability, rel=1e-5)
    assert sheet.accel_bias_tau == pytest.approx(noise.accel_bias_tau, rel=1e-5)
    # one bias instability per sensor: the RMS of the axes' Gauss-Markov sigma, here near the simulated one
    assert sheet.gyro_bias_instability == pytest.approx(0.05 * DEG_PER_H, rel=0.3)
    assert sheet.accel_bias_instability == pytest.approx(10.0 * UG, rel=0.3)
