"""The estimator's graph: every group navigated by the one strapdown step, and its residuals.

Decision variables
    the parameters as deviations from a reference (the starting values) in natural units (ug, ppm of
    the value, arcsec, deg/h, ...), and per group a small rotation (arcsec, ENU) of the start attitude
    away from the coarse alignment: the positions' deviations from nominal are nuisance variables, the
    alignment (eq. 14) is only the starting guess (physics pitfall 6).
Graph
    the raw pulses of each step (:mod:`calibrate.steps`) enter through the one compensation
    expression (:func:`model.output.compensate_expr`, with the extra groups' corrections), and the one
    strapdown step (:func:`nav.strapdown.step_expr`) is chained in compiled blocks with its forward
    derivative (:mod:`nav.tangent`).  The graph belongs to the schedule's *shape* and is built once per
    shape (:mod:`.shape`); a recording binds its pulses to it as data.
Residuals (:mod:`noise.observations`)
    the navigated velocity at observation times in the static segments (true velocity zero), and per
    static segment the mean compensated gyro rate against the Earth rate seen in the navigated
    attitude at the segment's middle (on a swaying segment its tapered mean, :mod:`noise.taper`).
    The velocity sees gyro errors only through the slow attitude drift; the segment mean measures
    them directly.
"""

from __future__ import annotations

import dataclasses
import time

import casadi as ca
import numpy as np

from ...core.compiled import Buffered
from ...core.rotations import dcm_to_quat, euler_to_enu, small_rotations
from ...data.recording import Recording
from ...model.registry import N_PARAMS, NAMES, natural_scale_of, regressor_blocks, relative_mask
from ...model.regressors import step_rows
from ...nav.navigation import group_alignment
from ...noise.kalman import GroupTrack
from ...noise.observations import Observation, ObservationKind, ObservationTable
from ...noise.taper import point_coefficients, rate_weights
from ..steps import ROTATION_STEP_S, GroupSteps, group_track, plan_steps
from .base import BaseVelocity, base_velocity
from .regressors import sample_regressors, static_rates
from .shape import ShapeGraph, group_data, group_layout, shape_graph


def variable_scale(reference: np.ndarray, names=NAMES) -> np.ndarray:
    """``d(parameters)/d(natural-unit variables)``: ppm of the value for scale factors, else the natural unit."""
    return np.where(relative_mask(names), reference * 1e-6, natural_scale_of(names))


def natural_to_parameters(z, reference: np.ndarray, names=NAMES):
    """Parameters (SI) from natural-unit deviations ``z`` from ``reference`` (CasADi or NumPy)."""
    scale = variable_scale(reference, names)
    if isinstance(z, (ca.MX, ca.SX)):
        return ca.DM(reference) + ca.diag(ca.DM(scale)) @ z
    return reference + scale * np.asarray(z)


class Linearisation:
    """The residuals ``r`` (n,), their Jacobian ``J`` (n, variables) and the trajectory (4, steps) at ``z``
    (read-only arrays)."""

    def __init__(self, z: np.ndarray, r: np.ndarray, jac: np.ndarray, trajectory: np.ndarray):
        self.z = z.copy()
        self.r, self.jac, self.trajectory = r.ravel(), jac, trajectory
        for array in (self.r, self.jac, self.trajectory):
            array.flags.writeable = False

    def at(self, z: np.ndarray) -> bool:
        """Whether this is the linearisation at ``z`` (exactly)."""
        return self.z.shape == np.shape(z) and bool(np.all(self.z == z))


@dataclasses.dataclass
class ResidualGraph:
    """The built NLP of one recording: its schedule shape's graph with the recording's data bound, and what
    each residual row is.

    Residual rows, in time order per group: three per velocity observation (m/s, ENU) and three per
    static segment's mean gyro rate (rad/s, body), the latter after the segment's last velocity.
    ``jacobian(z)`` keeps its linearisation: Ipopt's gradient and Hessian at one point, and the
    generalised least squares at Ipopt's solution, share one evaluation.  On a moving base the base's
    velocity adds nuisance variables after the shape's (:mod:`.base`): ``r = r_shape - B z_base``.
    """

    shape: ShapeGraph
    data: np.ndarray
    ref: np.ndarray  # the reference parameters, then their natural scales
    observations: ObservationTable
    groups: list[GroupSteps]
    reference: np.ndarray
    start_attitudes: dict[int, np.ndarray]
    build_time: float
    names: tuple[str, ...] = NAMES  # the parameters, in the order of the first variables
    evaluations: dict = dataclasses.field(default_factory=lambda: {"jacobian": 0, "residuals": 0})
    tapers: dict = dataclasses.field(default_factory=dict)  # segment -> its tapered mean's rate weights (steps)
    base: BaseVelocity | None = None  # the base's velocity on a moving base (nuisance variables)

    def __post_init__(self):
        self._calls = {}
        self._last: Linearisation | None = None

    def _call(self, name: str, z) -> list[np.ndarray]:
        if name not in self._calls:
            self._calls[name] = _buffered(self.shape, name)
        z = np.asarray(z, dtype=float)
        out = self._calls[name](z[:self.shape.n_variables], self.data, self.ref)
        if self.base is None or name == "trajectory":
            return out
        nuisance = self.base.matrix @ z[self.shape.n_variables:]
        if name == "residuals":
            return [out[0].ravel() - nuisance]
        r, jac, trajectory = out
        return [r.ravel() - nuisance, np.hstack([jac, -self.base.matrix]), trajectory]

    def linearise(self, z) -> Linearisation:
        """Residuals, Jacobian and trajectory at ``z`` (the last one is kept)."""
        z = np.asarray(z, dtype=float)
        if self._last is None or not self._last.at(z):
            self.evaluations["jacobian"] += 1
            self._last = Linearisation(z, *self._call("jacobian", z))
        return self._last

    def jacobian(self, z) -> tuple[np.ndarray, np.ndarray]:
        """``(r, J)`` at ``z``: residuals (n,) and Jacobian (n, variables)."""
        lin = self.linearise(z)
        return lin.r, lin.jac

    def residuals(self, z) -> np.ndarray:
        """Residuals (n,) at ``z``."""
        if self._last is not None and self._last.at(np.asarray(z, dtype=float)):
            return self._last.r
        self.evaluations["residuals"] += 1
        return self._call("residuals", z)[0].ravel()

    def trajectory(self, z) -> np.ndarray:
        """Quaternions at every step end, all groups side by side (4, sum M)."""
        if self._last is not None and self._last.at(np.asarray(z, dtype=float)):
            return self._last.trajectory
        return self._call("trajectory", z)[0]

    @property
    def n_variables(self) -> int:
        """Number of decision variables."""
        return self.shape.n_variables + (self.base.size if self.base is not None else 0)

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
                                   for axis in "ENU"] + (self.base.names if self.base is not None else [])

    def tracks(self, trajectory: np.ndarray, use_rotation_steps: bool, motions=None) -> list[GroupTrack]:
        """The noise model's view of the groups, along the navigated attitude ``trajectory``."""
        sway = {m.segment: m.added_variance for m in (motions or [])}
        tracks, offset = [], 0
        for plan in self.groups:
            m = len(plan.step_dt)
            tracks.append(group_track(plan, self.observations.of_group(plan.group), self.start_attitudes[plan.group],
                                      trajectory[:, offset:offset + m], use_rotation_steps, sway, self.tapers))
            offset += m
        return tracks


def _buffered(shape: ShapeGraph, name: str) -> Buffered:
    """One buffered caller per shape function (shared by the recordings of the shape)."""
    calls = shape.buffered
    if name not in calls:
        calls[name] = Buffered(getattr(shape, name))
    return calls[name]


def _group_observations(plan: GroupSteps, first_row: int) -> list[Observation]:
    """The observations of one group, in residual order (:mod:`.shape`)."""
    observations = []
    row = first_row
    last_obs_of = {int(s): int(plan.observed[plan.segment_of == s][-1]) for s in np.unique(plan.segment_of)}
    for k, step in enumerate(plan.observed):
        seg_number = int(plan.segment_of[k])
        observations.append(Observation(ObservationKind.VELOCITY, row, plan.group, int(step), seg_number,
                                        bool(plan.after_rotation[k]), float(plan.samples_between[k]), k == 0))
        row += 3
        if step == last_obs_of[seg_number]:
            observations.append(Observation(ObservationKind.GYRO_MEAN, row, plan.group, int(step), seg_number))
            row += 3
    return observations


def build_graph(rec: Recording, reference: np.ndarray, observe_s: float = 1.0,
                rotation_step_s: float = ROTATION_STEP_S, static_step_s: float | None = None,
                names: tuple[str, ...] = NAMES, tapers: dict[int, float] | None = None,
                base_bands: list[tuple[float, float, str]] | None = None, referenced=frozenset()) -> ResidualGraph:
    """The NLP of a recording around ``reference`` parameters (ordered like ``names``: the 21, then any
    extra groups of the registry): its shape's graph (built once per shape) and the recording's data.
    ``tapers``: static segment -> the time-half-bandwidth of its tapered gyro mean (:mod:`noise.taper`);
    ``base_bands``: the frequency bands (Hz) of a base's linear motion and the ENU axes each moves, whose velocity
    becomes nuisance variables (:mod:`.base`); ``referenced``: the tapered segments whose mean reads the gyros' attitude
    against the recording's attitude reference (:attr:`data.recording.Recording.reference`)."""
    t0 = time.perf_counter()
    names = tuple(names)
    extended = len(names) > N_PARAMS
    blocks = regressor_blocks(names)
    if extended:
        rest = static_rates(rec, reference) if "X" in blocks else None
        per_sample, boundary = sample_regressors(rec.gyro, rec.accel, reference, rec.dt, blocks, rest)
    tapers = tapers or {}
    layouts, data, observations, plans, starts, weights = [], [], [], [], {}, {}
    for group in rec.group_ids:
        plan = plan_steps(rec, group, observe_s, rotation_step_s, static_step_s)
        plans.append(plan)
        starts[group] = group_alignment(rec, group, reference)
        layout, segments = group_layout(plan, names, {s for s in segments_of(plan) if s in tapers})
        layouts.append(layout)
        regressors = step_rows(per_sample, boundary, plan.first, plan.stop, blocks) if extended else None
        references = {}
        for segment in segments:
            if segment in tapers:
                weights[segment] = rate_weights(plan.step_dt[plan.step_segment == segment], tapers[segment])
            if segment in tapers and segment in referenced:
                references[segment] = reference_turns(rec, plan, segment, point_coefficients(weights[segment]))
        data.append(group_data(rec.site, plan, segments, dcm_to_quat(starts[group]), regressors,
                               {s: point_coefficients(weights[s]) for s in segments if s in weights}, references))
        observations += _group_observations(plan, 3 * len(observations))
    shape, _ = shape_graph(layouts, names)
    ref = np.concatenate([reference, variable_scale(reference, names)])
    table = ObservationTable(observations)
    base = base_velocity(table, plans, base_bands) if base_bands else None
    return ResidualGraph(shape, np.concatenate(data), ref, table, plans, reference, starts,
                         time.perf_counter() - t0, names, tapers=weights, base=base)


def reference_turns(rec: Recording, plan: GroupSteps, segment: int, coefficients: np.ndarray) -> np.ndarray:
    """The tapered mean (ENU, rad/s) of the recording's attitude reference over a segment's steps: its rotation
    after each step against the middle one, weighed by the mean's ``coefficients``."""
    steps = np.flatnonzero(plan.step_segment == segment)
    attitude = euler_to_enu(rec.reference[plan.stop[steps] - 1])
    return coefficients @ small_rotations(attitude, attitude[len(steps) // 2])


def segments_of(plan: GroupSteps) -> list[int]:
    """The static segments of a group's plan."""
    return [int(s) for s in np.unique(plan.step_segment[plan.step_segment >= 0])]
