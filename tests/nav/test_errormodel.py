"""The linear error model (eqs. 13-21) against the navigation it linearises."""

import numpy as np
import pytest

from casadi_sins.model import registry as R
from casadi_sins.nav.errormodel import velocity_sensitivity
from casadi_sins.nav.navigation import navigate_group


def perturbed(values, errors):
    """Parameters whose error state relative to ``values`` is ``errors`` (eqs. 5-12 conventions)."""
    est = values.copy()
    est[~R.SCALE_MASK] -= errors[~R.SCALE_MASK]
    est[R.SCALE_MASK] *= 1 + errors[R.SCALE_MASK]
    return est


@pytest.mark.parametrize("group", [1, 2, 3])
def test_sensitivities_predict_the_navigation_difference(kang_sim_noiseless, group):
    """Each error term (1 natural unit; gyro bias 0.01 deg/h) changes the navigated velocity as the
    linear model predicts: within 1 % for every term whose effect exceeds 1e-3 m/s over the group, within
    5 % above 1e-4 m/s (small net effects of cancelling terms, e.g. a gyro bias against its alignment)."""
    sim = kang_sim_noiseless
    rec, truth = sim.recording, sim.truth.values
    nav = navigate_group(rec, group, truth)
    sens = velocity_sensitivity(rec, nav, truth)
    checked = 0
    for k in range(R.N_PARAMS):
        x = np.zeros(R.N_PARAMS)
        x[k] = R.NATURAL_SCALE[k] * (0.01 if R.NATURAL_UNITS[k] == "deg/h" else 1.0)
        actual = navigate_group(rec, group, perturbed(truth, x)).velocity - nav.velocity
        if np.abs(actual).max() < 1e-4:
            continue
        checked += 1
        bound = 0.01 if np.abs(actual).max() > 1e-3 else 0.05
        assert np.abs(actual - sens[:, :, k] * x[k]).max() < bound * np.abs(actual).max(), R.NAMES[k]
    assert checked >= 10


def numpy_velocity_sensitivity(rec, nav, params):
    """The error model propagated in closed form with NumPy (the package's implementation before it was
    compiled): ``phi_k = R(t_k) (phi_0 - sum_j R(t_j)^T C_j G_j)``, the velocity error summed."""
    from casadi_sins.core.rotations import rotation_matrix
    from casadi_sins.nav.errormodel import error_model_inputs, input_sensitivity

    dt = rec.dt
    dtheta, dv, phi0, c_mid, force_dt = error_model_inputs(rec, nav, params)  # the inputs, shared
    w_ie = rec.site.earth_rate
    t = (np.arange(len(dtheta)) + 1) * dt
    earth_turn = rotation_matrix(w_ie, -np.linalg.norm(w_ie) * t)
    phi = earth_turn @ (phi0[None] - np.cumsum(np.swapaxes(earth_turn, 1, 2) @ (c_mid @ input_sensitivity(
        dtheta, dt, "gyro")), axis=0))
    phi_mid = 0.5 * (np.concatenate([phi0[None], phi[:-1]]) + phi)
    return np.cumsum(np.cross(force_dt[:, :, None], phi_mid, axis=1) + c_mid @ input_sensitivity(dv, dt, "accel"),
                     axis=0)


def test_compiled_recursion_equals_the_closed_form(kang_sim):
    """The compiled per-sample recursion of the error model equals its closed form to round-off."""
    rec = kang_sim.recording
    params = kang_sim.truth.values
    for group in rec.group_ids:
        nav = navigate_group(rec, group, params)
        compiled, closed = velocity_sensitivity(rec, nav, params), numpy_velocity_sensitivity(rec, nav, params)
        assert np.abs(compiled - closed).max() < 1e-10 * np.abs(closed).max()
