"""The estimator's graph of a schedule *shape*, with the recording's pulses as inputs.

One CasADi graph per shape (the steps of each group, the observation layout, the parameter names)
serves every recording of that shape (a Monte Carlo, a repeated calibration): the pulses, step
lengths, start attitudes and site enter as one data vector ``d``, the reference parameters and their
natural scales as ``ref``.  Each group's chain is a handful of calls of compiled blocks of the
strapdown step (:func:`nav.tangent.step_blocks`), so the graph is small and built in milliseconds:

``jacobian(w, d, ref) -> (r, J, trajectory)``
    the residuals and their Jacobian from the tangent step (the state and its derivatives along the
    parameters and the group's start attitude, carried through the chain);
``residuals(w, d, ref) -> r``
    the residuals alone, from the nominal step;
``trajectory(w, d, ref)``
    the quaternion after every step, all groups side by side.

Residual rows per group, in time order: the velocity at each observed step, and after each static
segment's last observation its mean compensated gyro rate minus the Earth rate seen in the navigated
attitude at the segment's middle step (:mod:`noise.observations`).  On a swaying segment the gyro mean
is tapered (:mod:`noise.taper`): the navigated attitude after each of the segment's steps against the
middle one (its rotation vector, ENU), weighed by the window's coefficients, in body axes at the middle,
``C_mid^T sum_k c_k 2 vec(q_k q_mid^-1)``: the rate at which the navigation turns away from the Earth,
which is the gyros' error rate plus ``C_mid^T [w_ie x] phi`` (what the plain mean measures, without the
sway's angle change).
"""

from __future__ import annotations

import collections
import dataclasses
import functools

import casadi as ca
import numpy as np

from ...core.rotations import quat_from_rotvec_expr, quat_multiply_expr, quat_to_dcm_expr
from ...core.units import ARCSEC
from ...model.output import compensate_expr
from ...model.registry import N_PARAMS
from ...nav.strapdown import STATE_SIZE, V
from ...nav.tangent import packed_sizes, step_blocks


@dataclasses.dataclass(frozen=True)
class GroupLayout:
    """The shape of one group: its steps, observations and residual order.

    Attributes
    ----------
    steps : int
    observed : tuple of int
        Steps whose end velocity is observed.
    mids : tuple of int
        Per static segment with a gyro mean, its middle step.
    order : tuple of int
        Residual order: indices into the velocity rows (3 per observation) followed by the gyro rows.
    n_data : int
        Packed data rows of a step (:func:`nav.tangent.packed_sizes`).
    tapered : tuple of (int, int)
        Per static segment with a gyro mean, its first step and number of steps when its mean is tapered,
        else ``(0, 0)``.
    """

    steps: int
    observed: tuple[int, ...]
    mids: tuple[int, ...]
    order: tuple[int, ...]
    n_data: int
    tapered: tuple[tuple[int, int], ...] = ()

    def sizes(self) -> list[tuple[str, int]]:
        """``(field, length)`` of the group's part of the data vector, in order."""
        s = len(self.mids)
        return [("steps", self.n_data * self.steps), ("q_start", 4), ("earth", 3), ("gravity", 1),
                ("segment_gyro", 3 * s), ("segment_accel", 3 * s), ("segment_dt", s),
                ("taper", sum(count for _, count in self.tapered)),
                ("taper_reference", 3 * sum(1 for _, count in self.tapered if count))]

    @property
    def size(self) -> int:
        """Length of the group's part of the data vector."""
        return sum(n for _, n in self.sizes())


def group_layout(plan, names, tapered: set | frozenset = frozenset()) -> tuple[GroupLayout, list[int]]:
    """The layout of one group (a :class:`calibrate.steps.GroupSteps`) and its static segments with a gyro
    mean, in residual order; the segments numbered in ``tapered`` get a tapered mean."""
    last_observation = {int(s): int(plan.observed[plan.segment_of == s][-1]) for s in np.unique(plan.segment_of)}
    order, segments = [], []
    n_velocity = 3 * len(plan.observed)
    for k, step in enumerate(plan.observed):
        order += [3 * k + a for a in range(3)]
        segment = int(plan.segment_of[k])
        if step == last_observation[segment]:
            order += [n_velocity + 3 * len(segments) + a for a in range(3)]
            segments.append(segment)
    spans = []
    for segment in segments:
        steps = np.flatnonzero(plan.step_segment == segment)
        spans.append((int(steps[0]), len(steps)) if segment in tapered else (0, 0))
    layout = GroupLayout(len(plan.step_dt), tuple(int(i) for i in plan.observed),
                         tuple(plan.middle_step(s) for s in segments), tuple(order), packed_sizes(names)[1],
                         tuple(spans) if tapered else ())
    return layout, segments


def group_data(site, plan, segments: list[int], q_start: np.ndarray, regressors=None,
               taper_coefficients: dict | None = None, taper_references: dict | None = None) -> np.ndarray:
    """The data vector of one group (:meth:`GroupLayout.sizes`), matrices column-major; ``taper_coefficients``:
    segment -> the coefficients of its tapered mean on the attitudes after its steps
    (:func:`noise.taper.point_coefficients`); ``taper_references``: segment -> the same mean of an attitude
    reference's turns (ENU, rad/s; zero where none is read)."""
    steps = [plan.pulses_gyro, plan.pulses_accel, plan.step_dt[None], plan.previous_scale[None]]
    if regressors is not None:
        steps.append(regressors)
    masks = [plan.step_segment == s for s in segments]
    segment_gyro = np.array([plan.pulses_gyro[:, m].sum(axis=1) for m in masks]).reshape(-1, 3)
    segment_accel = np.array([plan.pulses_accel[:, m].sum(axis=1) for m in masks]).reshape(-1, 3)
    segment_dt = np.array([plan.step_dt[m].sum() for m in masks])
    tapers, references = taper_coefficients or {}, taper_references or {}
    parts = [np.vstack(steps).ravel(order="F"), q_start, site.earth_rate, [site.g], segment_gyro.ravel(),
             segment_accel.ravel(), segment_dt] + [tapers[s] for s in segments if s in tapers] + [
        references.get(s, np.zeros(3)) for s in segments if s in tapers]
    return np.concatenate([np.asarray(x, dtype=float).ravel() for x in parts])


@functools.lru_cache(maxsize=None)
def _earth_in_body(nd: int) -> ca.Function:
    """``(q, Q, w) -> (C(q)^T w, d(C(q)^T w)/dq Q)`` for a quaternion and its tangents (4 x nd)."""
    q, tangents, w = ca.SX.sym("q", 4), ca.SX.sym("Q", 4, nd), ca.SX.sym("w", 3)
    e = quat_to_dcm_expr(q).T @ w
    return ca.Function("earth_in_body", [q, tangents, w], [e, ca.jtimes(e, q, tangents)])


@functools.lru_cache(maxsize=None)
def _tapered_in_body(nd: int) -> ca.Function:
    """``(q_mid, Q_mid, p, P, s) -> (r, R)``: the tapered mean ``r = C(q_mid)^T (2 vec(p q_mid^-1) - s)`` of the
    weighted sum ``p = sum_k c_k q_k`` of a segment's attitudes (less ``s``, an attitude reference's turns
    over the same window), and its tangents along the directions of ``Q_mid`` and ``P`` (4 x nd each).

    ``2 vec(q_k q_mid^-1)`` is the rotation vector of ``q_k`` against the middle attitude to third order in
    its angle (sway and drift within a segment are small), and linear in ``q_k``: the weighted sum of the
    attitudes is taken first.
    """
    q_mid, mid_tangents = ca.SX.sym("q_mid", 4), ca.SX.sym("Q_mid", 4, nd)
    p, p_tangents, reference = ca.SX.sym("p", 4), ca.SX.sym("P", 4, nd), ca.SX.sym("s", 3)
    conjugate = ca.vertcat(q_mid[0], -q_mid[1:4])
    r = quat_to_dcm_expr(q_mid).T @ (2 * quat_multiply_expr(p, conjugate)[1:4] - reference)
    return ca.Function("tapered_in_body", [q_mid, mid_tangents, p, p_tangents, reference],
                       [r, ca.jtimes(r, q_mid, mid_tangents) + ca.jtimes(r, p, p_tangents)])


class _Chain:
    """The states of a group's chain, one call of a compiled block per :data:`nav.tangent.STEP_BLOCK` steps
    (the last block padded with zero steps after the group's end, where nothing is observed).

    The blocks' outputs are kept apart and only the states used are taken from them: one matrix of every
    state would be large (13 x 35 rows x the steps), and CasADi builds large matrices slowly.
    """

    def __init__(self, block: ca.Function, x0, const, data, steps: int):
        self.size = block.size2_in(2)
        self.outputs = []
        x = x0
        for start in range(0, steps, self.size):
            piece = data[:, start:min(start + self.size, steps)]
            if piece.shape[1] < self.size:
                piece = ca.horzcat(piece, ca.DM.zeros(data.shape[0], self.size - piece.shape[1]))
            x, _, states = block(x, const, piece)
            self.outputs.append(states)

    def take(self, rows, steps) -> ca.MX:
        """``states[rows, steps]`` (rows of a state column; step ``k``: the state after step ``k``)."""
        steps = np.asarray(steps, dtype=int)
        order = np.argsort(steps, kind="stable")
        ordered, pieces = steps[order], []
        for b in np.unique(ordered // self.size):
            local = ordered[ordered // self.size == b] - b * self.size
            pieces.append(self.outputs[b][list(rows), local.tolist()])
        taken = ca.horzcat(*pieces)
        return taken if np.all(order == np.arange(len(order))) else taken[:, np.argsort(order).tolist()]

    def weighted(self, rows, first: int, weights) -> ca.MX:
        """``sum_k weights[k] states[rows, first + k]`` over consecutive steps: each block's columns times its share
        of the weights (a product per block, not a slice per state)."""
        count = weights.shape[0]
        total = 0
        for b in range(first // self.size, (first + count - 1) // self.size + 1):
            low, high = max(first, b * self.size), min(first + count, (b + 1) * self.size)
            padded = ca.vertcat(ca.DM.zeros(low - b * self.size, 1), weights[low - first:high - first],
                                ca.DM.zeros((b + 1) * self.size - high, 1))
            total = total + self.outputs[b] @ padded
        return total[list(rows)]


def _interleave(per_axis):
    """(3 K x nd), row ``3 k + a``, from three (nd x K) blocks (axis ``a``: direction, observation ``k``)."""
    k = per_axis[0].shape[1]
    stacked = ca.vertcat(*[block.T for block in per_axis])  # row a K + k
    return stacked[(np.arange(3)[None, :] * k + np.arange(k)[:, None]).ravel().tolist(), :]


class _Symbols:
    """The graph's inputs and what every group shares: decision vector, data, reference, parameters."""

    def __init__(self, layouts: list[GroupLayout], names: tuple[str, ...]):
        self.names, self.n_params = names, len(names)
        self.n_variables = self.n_params + 3 * len(layouts)
        self.w = ca.MX.sym("w", self.n_variables)
        self.d = ca.MX.sym("d", sum(layout.size for layout in layouts))
        self.ref = ca.MX.sym("ref", 2 * self.n_params)  # reference values, then their natural scales
        self.scale = self.ref[self.n_params:]
        self.all_params = self.w[:self.n_params] * self.scale + self.ref[:self.n_params]
        self.params = self.all_params[:N_PARAMS]

    def fields(self, layout: GroupLayout, offset: int) -> dict:
        out = {}
        for name, size in layout.sizes():
            out[name] = self.d[offset:offset + size]
            offset += size
        out["steps"] = ca.reshape(out["steps"], layout.n_data, layout.steps)
        return out

    def const(self, fields: dict):
        return ca.vertcat(self.params, self.scale[:N_PARAMS], self.all_params[N_PARAMS:], self.scale[N_PARAMS:],
                          fields["earth"], fields["gravity"])

    def start_state(self, fields: dict, group_index: int):
        """The state before the first step: the alignment turned by the group's variables, and the first
        step's increments (for its coning and sculling terms)."""
        first = fields["steps"][:, 0]
        dtheta, dv = compensate_expr(first[0:3], first[3:6], self.params, first[6], self.extras(first[8:]))
        rotation = self.w[self.n_params + 3 * group_index:self.n_params + 3 * group_index + 3] * ARCSEC
        q0 = quat_multiply_expr(quat_from_rotvec_expr(rotation), fields["q_start"])
        return ca.vertcat(q0, ca.DM.zeros(3), dtheta, dv)

    def mean_rates(self, fields: dict, segments: int):
        """Each static segment's mean compensated gyro rate (3 x S)."""
        seg_dt = fields["segment_dt"].T
        rows = packed_sizes(self.names)[1] - 8  # the gyro groups read no regressor; the accelerometers' are unused
        dtheta, _ = compensate_expr(ca.reshape(fields["segment_gyro"], 3, segments),
                                    ca.reshape(fields["segment_accel"], 3, segments), self.params, seg_dt,
                                    self.extras(ca.DM.zeros(rows, segments)))
        return dtheta / ca.repmat(seg_dt, 3, 1)

    def extras(self, regressors):
        """The extra groups' part of :func:`model.output.compensate_expr` (``None`` for the 21)."""
        if self.n_params == N_PARAMS:
            return None
        return self.all_params[N_PARAMS:], self.names[N_PARAMS:], regressors

    def columns(self, group_index: int) -> list[int]:
        """The group's directions among the variables: the parameters, then its start attitude."""
        start = self.n_params + 3 * group_index
        return list(range(self.n_params)) + list(range(start, start + 3))


class ShapeGraph:
    """The graph of one schedule shape (module docstring).

    Parameters
    ----------
    layouts : list of GroupLayout
    names : tuple of str
        The parameters (the first variables).
    compiled : bool
        The compiled step blocks (default), or the same on CasADi's virtual machine, which CasADi can
        differentiate (an exact Hessian).
    """

    def __init__(self, layouts: list[GroupLayout], names: tuple[str, ...], compiled: bool = True):
        self.layouts, self.names = list(layouts), tuple(names)
        self.buffered: dict = {}  # the buffered callers of its functions (calibrate.nlp.graph), shared by recordings
        tangent, nominal = step_blocks(tuple(names), compiled)
        sym = _Symbols(layouts, tuple(names))
        self.n_variables = sym.n_variables
        rows_r, rows_j, rows_nominal, trajectories, tangent_trajectories = [], [], [], [], []
        offset = 0
        for gi, layout in enumerate(layouts):
            fields = sym.fields(layout, offset)
            offset += layout.size
            x0, const = sym.start_state(fields, gi), sym.const(fields)
            r, jac, quats = self._tangent_rows(sym, tangent, layout, fields, x0, const, gi)
            rows_r.append(r)
            rows_j.append(jac)
            tangent_trajectories.append(quats)
            r_nominal, quats = self._nominal_rows(sym, nominal, layout, fields, x0, const)
            rows_nominal.append(r_nominal)
            trajectories.append(quats)
        r = ca.vertcat(*rows_r)
        self.n_residuals = r.shape[0]
        inputs, labels = [sym.w, sym.d, sym.ref], ["w", "d", "ref"]
        self.jacobian = ca.Function("residuals_jacobian", inputs, [r, ca.vertcat(*rows_j),
                                    ca.horzcat(*tangent_trajectories)], labels, ["r", "J", "trajectory"])
        self.residuals = ca.Function("residuals", inputs, [ca.vertcat(*rows_nominal)], labels, ["r"])
        self.trajectory = ca.Function("trajectory", inputs, [ca.horzcat(*trajectories)], labels, ["trajectory"])

    @staticmethod
    def _tangent_rows(sym: _Symbols, block, layout: GroupLayout, fields, x0, const, gi: int):
        """A group's residuals, their Jacobian (all variables) and its trajectory, from the tangent chain."""
        columns = sym.columns(gi)
        nd = len(columns)
        x0_tangents = ca.jacobian(x0, sym.w)[:, columns]
        # a state column: the state after the step, then its tangents along the directions
        chain = _Chain(block, ca.horzcat(x0, x0_tangents), const, fields["steps"], layout.steps)
        observed = list(layout.observed)
        r = ca.vec(chain.take(range(V.start, V.stop), observed))  # row 3 k + a
        jac = _interleave([chain.take(STATE_SIZE * (1 + np.arange(nd)) + V.start + a, observed) for a in range(3)])
        segments = len(layout.mids)
        if segments:
            mids = list(layout.mids)
            mean_rate = sym.mean_rates(fields, segments)
            rows_q = (STATE_SIZE * (1 + np.arange(nd))[:, None] + np.arange(4)[None, :]).ravel()  # 4 i + b
            q_tangents = ca.reshape(chain.take(rows_q, mids), 4, nd * segments)  # column i + nd j
            earth, earth_tangents = _earth_in_body(nd).map(segments)(chain.take(range(4), mids), q_tangents,
                                                                     fields["earth"])
            per_direction = ca.reshape(earth_tangents, 3 * nd, segments)  # row 3 i + a, column j
            gyro_jac = ca.jacobian(ca.vec(mean_rate), sym.w)[:, columns] - _interleave(
                [per_direction[(3 * np.arange(nd) + a).tolist(), :] for a in range(3)])
            gyro_r = ca.vec(mean_rate - earth)
            if any(count for _, count in layout.tapered):
                gyro_r, gyro_jac = _tapered_rows(chain, layout, fields, rows_q, nd, gyro_r, gyro_jac)
            r = ca.vertcat(r, gyro_r)
            jac = ca.vertcat(jac, gyro_jac)
        order = list(layout.order)
        r, jac = r[order], jac[order, :]
        n_groups = (sym.n_variables - sym.n_params) // 3
        rows = jac.shape[0]
        jac = ca.horzcat(jac[:, :sym.n_params], ca.MX(rows, 3 * gi), jac[:, sym.n_params:],
                         ca.MX(rows, 3 * (n_groups - gi - 1)))
        return r, jac, chain.take(range(4), range(layout.steps))

    @staticmethod
    def _nominal_rows(sym: _Symbols, block, layout: GroupLayout, fields, x0, const):
        """A group's residuals and trajectory from the nominal chain."""
        chain = _Chain(block, x0, const, fields["steps"], layout.steps)
        r = ca.vec(chain.take(range(V.start, V.stop), layout.observed))
        segments = len(layout.mids)
        if segments:
            earth = _earth_in_body(1).map(segments)(chain.take(range(4), layout.mids), ca.DM.zeros(4, segments),
                                                    fields["earth"])[0]
            gyro_r = ca.vec(sym.mean_rates(fields, segments) - earth)
            if any(count for _, count in layout.tapered):
                gyro_r = _tapered_rows(chain, layout, fields, None, 0, gyro_r, None)[0]
            r = ca.vertcat(r, gyro_r)
        return r[list(layout.order)], chain.take(range(4), range(layout.steps))


def _tapered_rows(chain: _Chain, layout: GroupLayout, fields: dict, rows_q, nd: int, gyro_r, gyro_jac):
    """The gyro rows ``(r, J)`` (3 per segment) with the tapered segments' rows replaced by their tapered means
    (module docstring, :func:`_tapered_in_body`); ``rows_q`` ``None``: the residuals alone (no tangents)."""
    rows, blocks, offset, tapered = [], [], 0, 0
    coefficients, references = fields["taper"], fields["taper_reference"]
    for j, ((first, count), mid) in enumerate(zip(layout.tapered, layout.mids)):
        if not count:
            rows.append(gyro_r[3 * j:3 * j + 3])
            blocks.append(gyro_jac[3 * j:3 * j + 3, :] if gyro_jac is not None else None)
            continue
        c = coefficients[offset:offset + count]
        reference = references[3 * tapered:3 * tapered + 3]
        offset, tapered = offset + count, tapered + 1
        q_mid, weighted = chain.take(range(4), [mid]), chain.weighted(range(4), first, c)
        if rows_q is None:
            rows.append(_tapered_in_body(1)(q_mid, ca.DM.zeros(4, 1), weighted, ca.DM.zeros(4, 1), reference)[0])
            continue
        mid_tangents = ca.reshape(chain.take(rows_q, [mid]), 4, nd)  # rows 4 i + b
        weighted_tangents = ca.reshape(chain.weighted(rows_q, first, c), 4, nd)
        body, body_tangents = _tapered_in_body(nd)(q_mid, mid_tangents, weighted, weighted_tangents, reference)
        rows.append(body)
        blocks.append(body_tangents)
    return ca.vertcat(*rows), (ca.vertcat(*blocks) if gyro_jac is not None else None)


_GRAPHS: collections.OrderedDict = collections.OrderedDict()
#: Shapes kept per process.
CACHED_SHAPES = 8


def shape_graph(layouts: list[GroupLayout], names: tuple[str, ...]) -> tuple[ShapeGraph, bool]:
    """The graph of a shape, built once per process: ``(graph, whether it was built before)``."""
    key = (tuple(layouts), tuple(names))
    if key in _GRAPHS:
        _GRAPHS.move_to_end(key)
        return _GRAPHS[key], True
    graph = ShapeGraph(layouts, tuple(names))
    _GRAPHS[key] = graph
    while len(_GRAPHS) > CACHED_SHAPES:
        _GRAPHS.popitem(last=False)
    return graph, False
