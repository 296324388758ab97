"""Each extra group's physics: its compensation undoes its simulator truth (to second order), for every
group of the registry, so that a new group is tested by its registry line."""

import casadi as ca
import numpy as np
import pytest

from casadi_sins.core.rotations import rotation_matrices
from casadi_sins.core.units import TO_SI, dimension_of
from casadi_sins.model import registry as R
from casadi_sins.model.groups.physics import Nodes, sensed_outputs
from casadi_sins.model.output import compensate_expr
from casadi_sins.model.regressors import boundary_rates, sample_rows, step_rows

G = 9.8
DT = 0.01
N = 300


def _kinematics(rate, start):
    """A body turning at a constant ``rate`` (body frame) from ``start`` (C_b^n), at rest otherwise."""
    def kinematics(t):
        c = start @ rotation_matrices(np.asarray(t)[..., None] * rate)
        w = np.broadcast_to(rate, c.shape[:-1]).copy()
        f = np.einsum("...ji,j->...i", c, [0.0, 0.0, G])
        return c, w, np.zeros_like(w), f
    return kinematics


#: Natural units of a large value of a group (a navigation-grade unit's worst); default 100.
LARGE = {"timing": 2.0, "lever": 30.0, "lever_along": 30.0}


def _values(key, rng):
    """Values of a group of about the size :data:`LARGE` says, random signs."""
    group = R.GROUPS[key]
    size = LARGE.get(key, 100.0) * group.natural_scale
    return {n: float(rng.uniform(1, 3) * rng.choice([-1, 1]) * size) for n in group.names}


@pytest.mark.parametrize("key", R.EXTRA_GROUPS)
def test_a_groups_compensation_undoes_its_simulated_truth(key):
    """Sensor outputs with the group's true term, compensated with its correction: the true increments come
    back to a small fraction of the term (the corrections are first order in the extras)."""
    rng = np.random.default_rng(len(key))
    group, values = R.GROUPS[key], _values(key, rng)
    kinematics = _kinematics(np.array([0.1, -0.15, 0.2]), rotation_matrices(rng.normal(size=(1, 3)))[0])
    t0 = np.arange(N) * DT
    dv_f, gyro_extra, accel_extra = sensed_outputs(kinematics, t0, t0 + DT, values, [group])
    plain = sensed_outputs(kinematics, t0, t0 + DT, {}, [])[0]  # the true specific-force increments
    dtheta = np.tile(np.array([0.1, -0.15, 0.2]) * DT, (N, 1))
    out_g, out_a = dtheta + gyro_extra, dv_f + accel_extra
    blocks = R.regressor_blocks(group.names)
    regs = step_rows(sample_rows(out_g, out_a, DT, blocks), boundary_rates(out_g, DT), np.arange(N),
                     np.arange(1, N + 1), blocks)
    p = np.zeros(R.N_PARAMS)
    p[R.ACCEL_SCALE], p[R.GYRO_SCALE] = 1.0, 1.0  # pulses = increments
    names = R.model_names((key,))[R.N_PARAMS:]
    back_g, back_a = compensate_expr(ca.DM(out_g.T), ca.DM(out_a.T), ca.DM(p), ca.DM(np.full((1, N), DT)),
                                     (ca.DM([values[n] for n in names]), names, ca.DM(regs)))
    effect = np.abs(np.vstack([gyro_extra, out_a - plain])).max()
    assert effect > 0
    np.testing.assert_allclose(np.asarray(back_g).T, dtheta, rtol=0, atol=1e-3 * effect)
    np.testing.assert_allclose(np.asarray(back_a).T, plain, rtol=0, atol=1e-3 * effect)


def test_the_registry_lists_groups_with_known_units_and_one_owner_per_name():
    names = [n for g in R.GROUPS.values() for n in g.names]
    assert len(names) == len(set(names))
    for group in R.GROUPS.values():
        assert group.sensor in ("gyro", "accel")
        assert group.unit in TO_SI
        if not group.relative:
            assert dimension_of(group.natural_unit) == dimension_of(group.unit)
            assert TO_SI[group.natural_unit] == pytest.approx(group.natural_scale)
        assert set(group.regressors) <= {"Q2", "P2", "X", "DW", "M"}
        assert group.core == (group.correction is None)


def test_nodes_integrate_exactly_a_polynomial():
    x, w = np.polynomial.legendre.leggauss(6)
    t0 = np.array([0.0, 1.0])
    points = t0[:, None] + (1.0 + x[None, :]) / 2.0
    nodes = Nodes((np.ones(2)[:, None] * w[None, :] / 2.0), points, points, points, points)
    np.testing.assert_allclose(nodes.integral(points**3), [0.25, (16 - 1) / 4])
