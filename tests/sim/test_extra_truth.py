"""The simulator's extra gyro terms written out by hand from the spec's definitions, not through the
groups' code: at rest gyro ``i`` outputs ``(G f)_i`` more, ``f`` the body specific force (up, ``+g``);
turning, ``A_i |w_i|`` more."""

import dataclasses

import numpy as np

from casadi_sins.model import registry as R
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.model.output import sensor_matrices
from casadi_sins.sim import simulate

GSENS = np.array([[2, -3, 1], [4, -2, 1.5], [-1, 2.5, -3.5]]) * 1e-3 * R.GROUPS["gyro_gsens"].natural_scale
ASYM = np.array([3e-6, -4e-6, 5e-6])


def _unit(short_problem, gsens=GSENS):
    names = R.model_names(("gyro_gsens", "gyro_asym"))
    values = np.concatenate([short_problem.truth.core, gsens.ravel(), ASYM])
    return dataclasses.replace(short_problem, truth=ParameterSet(values, names=names))


def test_at_rest_the_gyros_output_g_sensitivity_times_the_body_specific_force(short_problem):
    sim = simulate(_unit(short_problem), seed=1, noise=False)
    rec, site = sim.recording, short_problem.site
    _, _, _, k_g, s_g, b_g = (np.asarray(m, dtype=float) for m in sensor_matrices(sim.truth.core))
    for seg, c in zip(rec.static_segments, sim.static_attitudes):
        f_b = c.T @ np.array([0.0, 0.0, site.g])  # the reaction to gravity, up
        w_b = c.T @ site.earth_rate
        expected = (k_g @ w_b + b_g.ravel() + GSENS @ f_b + ASYM * np.abs(w_b)) / s_g.ravel()  # pulses per second
        measured = rec.gyro[rec.segment_samples(seg)].mean(axis=0) / rec.dt
        np.testing.assert_allclose(measured, expected, rtol=0, atol=1e-4 * np.abs(GSENS @ f_b / s_g.ravel()).max())


def test_turning_the_gyros_output_asymmetry_times_the_rate_magnitude(short_problem):
    """Over a +90 deg turn the pulse sum of the turning axis' gyro gains ``A_i`` x 90 deg, with ``|w|``."""
    plain = simulate(dataclasses.replace(short_problem, truth=ParameterSet(short_problem.truth.core)), seed=1,
                     noise=False)
    sim = simulate(_unit(short_problem, 0 * GSENS), seed=1, noise=False)
    _, _, _, _, s_g, _ = (np.asarray(m, dtype=float) for m in sensor_matrices(sim.truth.core))
    rec = sim.recording
    for seg in [s for s in rec.segments if not s.is_static]:
        sl = rec.segment_samples(seg)
        extra = (rec.gyro[sl] - plain.recording.gyro[sl]).sum(axis=0) * s_g.ravel()  # rad
        angle = np.abs(plain.recording.gyro[sl].sum(axis=0) * s_g.ravel())
        axis = int(np.argmax(angle))
        np.testing.assert_allclose(extra[axis], ASYM[axis] * angle[axis], rtol=1e-3)
