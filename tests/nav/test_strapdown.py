"""Alignment and static navigation."""

import numpy as np

from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.core import earth, rotations
from casadi_sins.core.rotations import dcm_to_quat, quat_to_dcm
from casadi_sins.core.units import ARCSEC
from casadi_sins.model import registry as R
from casadi_sins.model.parameters import natural_errors
from casadi_sins.nav.navigation import group_alignment, navigate
from casadi_sins.nav.strapdown import step_function
from casadi_sins.report.tables import static_velocity_table


def test_quaternion_dcm_round_trip():
    rng = np.random.default_rng(0)
    for _ in range(50):
        v = rng.normal(size=3)
        dcm = rotations.rotation_matrices(v / np.linalg.norm(v) * rng.uniform(0, 3.1))
        np.testing.assert_allclose(quat_to_dcm(dcm_to_quat(dcm)), dcm, atol=1e-14)


def test_static_step_keeps_attitude_and_velocity():
    """With exact static increments one step changes nothing (Earth-rate terms cancel exactly)."""
    lat, g, dt = np.radians(37.5), 9.8, 0.01
    dcm = rotations.rotation_matrices([0.1, -0.2, 0.3])
    w, f = earth.earth_rate_enu(lat), np.array([0.0, 0.0, g])
    dth, dv = dcm.T @ w * dt, dcm.T @ f * dt
    x0 = np.concatenate([dcm_to_quat(dcm), [0.01, 0.02, 0.03], dth, dv])
    x1 = np.asarray(step_function()(x0, dth, dv, w * dt, [0, 0, -g * dt], 1.0)).ravel()
    np.testing.assert_allclose(x1[:7], x0[:7], atol=1e-15)


def test_alignment_recovers_start_attitude_within_the_noise(kang_sim):
    """Tilt noise ~0.1 arcsec (0.5 ug mean accel noise), heading ~2 arcsec (1e-4 deg/h mean gyro noise over
    11.9 deg/h horizontal Earth rate); bounds at about 5 sigma."""
    rec = kang_sim.recording
    for group in rec.group_ids:
        aligned = group_alignment(rec, group, kang_sim.truth.values)
        err = rotations.rotation_vector(aligned @ kang_sim.start_attitudes[group].T) / ARCSEC
        assert np.abs(err[:2]).max() < 1.0
        assert abs(err[2]) < 10.0


def test_navigation_with_truth_stays_at_noise_level_and_rough_values_do_not(kang_sim):
    rec = kang_sim.recording
    truth_navs = navigate(rec, kang_sim.truth.values)
    rough_navs = navigate(rec, rough_parameters(rec).values)
    for nav in truth_navs:
        # 50 ug white noise integrates to ~1e-3 m/s (1 sigma) over 430 s
        assert np.abs(nav.velocity).max() < 6e-3
    assert max(np.abs(n.velocity).max() for n in rough_navs) > 1.0
    table = static_velocity_table(rec, truth_navs)
    horizontal = table[["slope_east_ug", "slope_north_ug"]].abs().to_numpy()
    assert horizontal.max() < 3.0  # a 100 s slope of the noise random walk is ~0.4 ug (1 sigma)


def test_peer_recording_navigates_with_its_truth(peer_recording, peer_truth):
    """Another tool's recording: with its truth the horizontal velocity slopes are the sub-ug effect of
    its extra error terms (extras.md: 0.19-0.79 ug) and the vertical ones its quadratic term (10-30 ug)."""
    rec = peer_recording
    table = static_velocity_table(rec, navigate(rec, peer_truth.values))
    horizontal = table[["slope_east_ug", "slope_north_ug"]].abs().to_numpy()
    assert horizontal.max() < 1.0
    vertical = table["slope_up_ug"].abs().to_numpy() * 9.80665 / 9.7803267715  # in PSINS ug
    assert vertical.max() < 31.0 and vertical.min() > 9.0
    rough = static_velocity_table(rec, navigate(rec, rough_parameters(rec).values))
    assert rough[["slope_east_ug", "slope_north_ug"]].abs().to_numpy().max() > 50.0


def test_rough_initial_values_follow_section_1_3(kang_sim, peer_recording, peer_truth):
    for rec, truth, gyro_ppm in ((kang_sim.recording, kang_sim.truth, 4000.0), (peer_recording, peer_truth, 50.0)):
        rough = rough_parameters(rec).values
        err = natural_errors(rough, truth.values)
        assert np.abs(err[R.ACCEL_SCALE]).max() < 100.0  # 1 g reference: biases up to 3 mg average out
        assert np.abs(err[R.GYRO_SCALE]).max() < gyro_ppm  # 90 deg reference: rate factor 1 +/- 0.4 %
        assert np.all(rough[R.ACCEL_BIAS] == 0) and np.all(rough[R.GYRO_BIAS] == 0)
        assert np.all(rough[R.ACCEL_MISALIGN] == 0) and np.all(rough[R.GYRO_MISALIGN] == 0)
