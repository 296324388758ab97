"""The estimator's symbolic graph: every group navigated by the one strapdown step, and its residuals.

Decision variables
    the parameters as deviations from a reference (the starting values) in natural units (ug, ppm of
    the value, arcsec, deg/h, ...), and per group a small rotation (arcsec, ENU) of the start attitude
    away from the coarse alignment: the positions' deviations from nominal are nuisance variables, the
    alignment (eq. 14) is only the starting guess (physics pitfall 6).
Graph
    the raw pulses of each step (:mod:`calibrate.steps`) enter through the one compensation
    expression (:func:`model.output.compensate_expr`, with the extra groups' corrections), and the one
    strapdown step (:func:`nav.strapdown.step_function`) is chained with ``mapaccum``.
Residuals (:mod:`noise.observations`)
    the navigated velocity at observation times in the static segments (true velocity zero), and per
    static segment the mean compensated gyro rate against the Earth rate seen in the navigated
    attitude at the segment's middle.  The velocity sees gyro errors only through the slow attitude
    drift; the segment mean measures them directly.
"""

from __future__ import annotations

import dataclasses
import time

import casadi as ca
import numpy as np

from ...core.rotations import dcm_to_quat, quat_from_rotvec_expr, quat_multiply_expr, quat_to_dcm_expr
from ...core.units import ARCSEC
from ...data.recording import Recording
from ...model.output import compensate_expr
from ...model.registry import GROUPS, N_PARAMS, NAMES, groups_in, natural_scale_of, relative_mask
from ...nav.navigation import group_alignment, navigation_constants
from ...nav.strapdown import Q, V, step_function
from ...noise.kalman import GroupTrack
from ...noise.observations import Observation, ObservationKind, ObservationTable
from ..steps import ROTATION_STEP_S, GroupSteps, group_track, plan_steps
from .regressors import sample_regressors, static_rates, step_regressors


def variable_scale(reference: np.ndarray, names=NAMES) -> np.ndarray:
    """``d(parameters)/d(natural-unit variables)``: ppm of the value for scale factors, else the natural unit."""
    return np.where(relative_mask(names), reference * 1e-6, natural_scale_of(names))


def natural_to_parameters(z, reference: np.ndarray, names=NAMES):
    """Parameters (SI) from natural-unit deviations ``z`` from ``reference`` (CasADi or NumPy)."""
    scale = variable_scale(reference, names)
    if isinstance(z, (ca.MX, ca.SX)):
        return ca.DM(reference) + ca.diag(ca.DM(scale)) @ z
    return reference + scale * np.asarray(z)


@dataclasses.dataclass
class ResidualGraph:
    """The built NLP: CasADi functions of the decision vector, and what each residual row is.

    Residual rows, in time order per group: three per velocity observation (m/s, ENU) and three per
    static segment's mean gyro rate (rad/s, body), the latter after the segment's last velocity.
    """

    residuals: ca.Function  # w -> r
    jacobian: ca.Function  # w -> (r, J)
    trajectory: ca.Function  # w -> quaternions at every step end, all groups side by side (4, sum M)
    n_variables: int
    observations: ObservationTable
    groups: list[GroupSteps]
    reference: np.ndarray
    start_attitudes: dict[int, np.ndarray]
    build_time: float
    names: tuple[str, ...] = NAMES  # the parameters, in the order of the first variables

    @property
    def n_residuals(self) -> int:
        """Length of the residual vector."""
        return self.observations.n_rows

    @property
    def n_params(self) -> int:
        """Number of parameters (the first variables)."""
        return len(self.names)

    def start_offsets(self, z: np.ndarray) -> dict[int, np.ndarray]:
        """Each group's start-attitude variables (arcsec, ENU) in a decision vector."""
        return {plan.group: z[self.n_params + 3 * i: self.n_params + 3 * i + 3] for i, plan in enumerate(self.groups)}

    def variable_names(self) -> list[str]:
        """Names of the decision variables."""
        return list(self.names) + [f"start attitude of group {p.group} ({axis})" for p in self.groups
                                   for axis in "ENU"]

    def tracks(self, trajectory: np.ndarray, use_rotation_steps: bool, motions=None) -> list[GroupTrack]:
        """The noise model's view of the groups, along the navigated attitude ``trajectory``."""
        sway = {m.segment: m.gyro_mean_variance for m in (motions or [])}
        tracks, offset = [], 0
        for plan in self.groups:
            m = len(plan.step_dt)
            tracks.append(group_track(plan, self.observations.of_group(plan.group), self.start_attitudes[plan.group],
                                      trajectory[:, offset:offset + m], use_rotation_steps, sway))
            offset += m
        return tracks


def _accel_correction(all_params, names, regressors):
    """The extra groups' correction of the accelerometer increments (3 x M), or ``None`` for the 21."""
    present = groups_in(names)
    if not present:
        return None
    values = {name: all_params[i] for i, name in enumerate(names)}
    rows = [ca.DM.zeros(1, regressors.shape[1]) for _ in range(3)]
    for key in present:
        group = GROUPS[key]
        for i, term in enumerate(group.correction({n: values[n] for n in group.names}, regressors)):
            rows[i] = rows[i] + term
    return ca.vertcat(*rows)


def _group_residuals(rec: Recording, plan: GroupSteps, states, dtheta, first_row: int):
    """The residual expressions of one group and their observations."""
    pieces, observations = [], []
    row = first_row
    last_obs_of = {int(s): int(plan.observed[plan.segment_of == s][-1]) for s in np.unique(plan.segment_of)}
    for k, step in enumerate(plan.observed):
        seg_number = int(plan.segment_of[k])
        pieces.append(states[V, int(step)])
        observations.append(Observation(ObservationKind.VELOCITY, row, plan.group, int(step), seg_number,
                                        bool(plan.after_rotation[k]), float(plan.samples_between[k]), k == 0))
        row += 3
        if step == last_obs_of[seg_number]:
            # mean gyro rate of the static segment against the Earth rate seen in the navigated attitude
            in_seg = plan.step_segment == seg_number
            duration = float(plan.step_dt[in_seg].sum())
            mean_rate = ca.sum2(dtheta[:, list(np.flatnonzero(in_seg))]) / duration
            earth_in_body = quat_to_dcm_expr(states[Q, plan.middle_step(seg_number)]).T @ ca.DM(rec.site.earth_rate)
            pieces.append(mean_rate - earth_in_body)
            observations.append(Observation(ObservationKind.GYRO_MEAN, row, plan.group, int(step), seg_number))
            row += 3
    return ca.vertcat(*pieces), observations


def build_graph(rec: Recording, reference: np.ndarray, observe_s: float = 1.0,
                rotation_step_s: float = ROTATION_STEP_S, static_step_s: float | None = None,
                names: tuple[str, ...] = NAMES) -> ResidualGraph:
    """Build the symbolic NLP for a recording around ``reference`` parameters (ordered like ``names``: the
    21, then any extra groups of the registry)."""
    t0 = time.perf_counter()
    n_params = len(names)
    n_var = n_params + 3 * len(rec.group_ids)
    w = ca.MX.sym("w", n_var)
    all_params = natural_to_parameters(w[:n_params], reference, names)
    if n_params > N_PARAMS:
        per_sample, boundary = sample_regressors(rec.gyro, rec.accel, reference, rec.dt, static_rates(rec, reference))
    earth_dt, gravity_dt = navigation_constants(rec)
    parts, trajectories, observations, plans, starts = [], [], [], [], {}
    for gi, group in enumerate(rec.group_ids):
        plan = plan_steps(rec, group, observe_s, rotation_step_s, static_step_s)
        plans.append(plan)
        starts[group] = group_alignment(rec, group, reference)
        correction = (_accel_correction(all_params, names, ca.DM(step_regressors(per_sample, boundary, plan.first,
                                                                                 plan.stop)))
                      if n_params > N_PARAMS else None)
        dtheta, dv = compensate_expr(ca.DM(plan.pulses_gyro), ca.DM(plan.pulses_accel), all_params[:N_PARAMS],
                                     ca.DM(plan.step_dt).T, correction)
        rotvec = w[n_params + 3 * gi: n_params + 3 * gi + 3] * ARCSEC
        x0 = ca.vertcat(quat_multiply_expr(quat_from_rotvec_expr(rotvec), ca.DM(dcm_to_quat(starts[group]))),
                        ca.DM.zeros(3), dtheta[:, 0], dv[:, 0])
        chain = step_function().mapaccum("strapdown_chain", len(plan.step_dt))
        ratio = plan.step_dt[None, :] / rec.dt
        states = chain(x0, dtheta, dv, ca.DM(earth_dt[:, None] * ratio), ca.DM(gravity_dt[:, None] * ratio),
                       ca.DM(plan.previous_scale).T)
        trajectories.append(states[Q, :])
        residual, group_obs = _group_residuals(rec, plan, states, dtheta, 3 * len(observations))
        parts.append(residual)
        observations += group_obs
    r = ca.vertcat(*parts)
    return ResidualGraph(ca.Function("residuals", [w], [r]),
                         ca.Function("residuals_jacobian", [w], [r, ca.jacobian(r, w)]),
                         ca.Function("trajectory", [w], [ca.horzcat(*trajectories)]), n_var,
                         ObservationTable(observations), plans, reference, starts, time.perf_counter() - t0,
                         tuple(names))
