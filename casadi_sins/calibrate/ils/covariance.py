"""Covariance of the paper's equations under the sensor noise model (the ILS's weights), exactly.

The noise of the fitted coefficients is not independent between segments: the gyro noise tilts the
whole group's navigation (angle random walk), bias instability ties the recording together, and the
coarse alignment carries the noise of its own segment into every later one.  The state-space model
of :mod:`noise.kalman` (the same discretisation the NLP whitens with) runs along each group's
navigated attitude at 1 s in static segments, rotations composed into one transition::

    x_t = A_t x_(t-1) + w_t,   w_t ~ N(0, Q_t)

and every equation is a linear functional of the states it visits, ``c = sum_t G_t x_t``: the
polynomial fits of the static velocity, and through the linearised alignment (eq. 15) the noise of
the first segment's mean specific force and rate.  Hence, in one backward pass,

    Cov(c) = sum_t H_t Q_t H_t^T,    H_t = G_t + H_(t+1) A_(t+1).

A counter's pulse remainders (the quantization, ``s_e`` per axis) at the two ends of the alignment
segment enter its mean specific force and rate as ``(e_end - e_start) / T``, independent of the states
and of each other: the alignment's attitude error gains ``M diag(2 s_e^2) M^T / T^2`` (``M`` the
linearised alignment), which every equation sees through its response to that error.  The remainders
at the samples of the polynomial fits are left out: their share of a slope is about 1e-16 (m/s^2)^2.

(Earlier versions estimated this covariance from 3,000 random draws of the same model; those carried
a sampling error that moved the ILS's values by up to about 0.16 sigma between seeds.)
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...data.recording import Recording
from ...model.noise import SensorNoise
from ...model.output import compensate
from ...nav.alignment import alignment_error
from ...nav.navigation import GroupNavigation
from ...noise.kalman import ACC, DV, PHI, Layout, NoiseSystem, gauss_markov_integrals
from ..steps import ROTATION_STEP_S, GroupSteps, group_track, plan_steps
from .equations import Equation, coefficient_operator, equation_segments


class LinearModel:
    """``x_t = A_t x_(t-1) + w_t`` with ``w_t ~ N(0, Q_t)``, and linear functionals ``c = sum_t G_t x_t``.

    Several noise models with the same transitions (``Q_t`` given as one array per model, stacked) share
    one backward pass: ``Cov(c)`` for each.

    Parameters
    ----------
    n : int
        States.
    n_functionals : int
        Rows of ``c``.
    """

    def __init__(self, n: int, n_functionals: int):
        self.n, self.n_functionals = n, n_functionals
        self.a: list[np.ndarray] = []
        self.q: list[np.ndarray] = []  # (models, n, n) per step
        self.g: list[np.ndarray] = []

    def step(self, a: np.ndarray, q: np.ndarray) -> int:
        """Append a step (``q`` (n, n), or (models, n, n)); its index ``t``."""
        self.a.append(a)
        self.q.append(q if q.ndim == 3 else q[None])
        self.g.append(np.zeros((self.n_functionals, self.n)))
        return len(self.a) - 1

    def covariance(self) -> np.ndarray:
        """``Cov(c)`` (models, m, m) by one backward pass (module docstring)."""
        models = self.q[0].shape[0] if self.q else 1
        cov = np.zeros((models, self.n_functionals, self.n_functionals))
        h = np.zeros((self.n_functionals, self.n))
        for t in range(len(self.a) - 1, -1, -1):
            h = self.g[t] + (h @ self.a[t + 1] if t + 1 < len(self.a) else 0.0)
            if self.q[t].any():
                cov += h @ self.q[t] @ h.T
        return 0.5 * (cov + np.swapaxes(cov, 1, 2))


class _GroupSteps:
    """Where one group's static steps sit in the linear model, and what the alignment sees of them."""

    def __init__(self, n_steps: int):
        self.index = np.full(n_steps, -1)  # static step k -> its model step t
        self.v_align = np.zeros((n_steps, 3, 3))  # the velocity's response to an initial attitude error
        self.first: list[tuple[int, int, float]] = []  # first segment: (t before, t after, length)
        self.last_first = -1  # the first segment's last step


def equation_covariance(rec: Recording, params: np.ndarray, navs: list[GroupNavigation], equations: list[Equation],
                        noise: SensorNoise, north_quadratic: bool = True) -> np.ndarray:
    """Covariance (m, m) of the equations' right-hand sides under the sensor noise model (module docstring)."""
    return equation_covariances(rec, params, navs, equations, [noise], north_quadratic)[0]


def equation_covariances(rec: Recording, params: np.ndarray, navs: list[GroupNavigation], equations: list[Equation],
                         noises: list[SensorNoise], north_quadratic: bool = True) -> np.ndarray:
    """The equations' covariance (models, m, m) under each of several noise models in one pass.

    The models must share their transitions: the first sets the state layout and the correlation times,
    the others have the same or none (white noise rides along in a layout with Gauss-Markov biases: its
    biases stay zero); their step covariances are propagated side by side.
    """
    completed = [n.complete() for n in noises]
    model_noise = completed[0]
    layout = Layout.of(model_noise)
    taus = (model_noise.gyro_bias_tau, model_noise.accel_bias_tau)
    if any(Layout.of(n).unmodelled != layout.unmodelled or (Layout.of(n).markov and (
            not layout.markov or (n.gyro_bias_tau, n.accel_bias_tau) != taus)) for n in completed[1:]):
        raise ValueError("noise models with different transitions cannot share one covariance pass")
    if layout.markov:  # a model without instability rides along in the first one's transitions (its biases stay 0)
        completed = [n if Layout.of(n).markov else dataclasses.replace(n, gyro_bias_tau=taus[0], accel_bias_tau=taus[1])
                     for n in completed]
    model = LinearModel(layout.n, len(equations))
    by_group: dict[int, list[int]] = {}
    for i, eq in enumerate(equations):
        by_group.setdefault(eq.group, []).append(i)
    previous_end = None
    remainders = np.zeros((len(completed), len(equations), len(equations)))
    for nav in navs:
        plan = plan_steps(rec, nav.group, 1.0, ROTATION_STEP_S)
        stops = np.cumsum(np.round(plan.step_dt / rec.dt).astype(int)) - 1
        track = group_track(plan, [], nav.initial_attitude, nav.quaternion[stops].T, True)
        system = NoiseSystem([track], rec.site.g, rec.site.earth_rate)
        start = _group_start(model, layout, completed, float(plan.start_time), previous_end)
        first_seg = rec.group_segments(nav.group)[0].number
        steps = _propagate(model, system, track, plan, layout, completed, first_seg, start)
        alignment, m_align, duration = _alignment_functional(rec, params, nav, system, track, plan, steps, layout,
                                                             first_seg)
        rows = by_group.get(nav.group, [])
        with_alignment = any(equations[i].segment == first_seg for i in rows)
        to_alignment = np.zeros((len(equations), 3))  # each equation's response to the alignment's error
        for seg, axes in equation_segments(rec, nav.group, with_alignment):
            _segment_functionals(model, plan, steps, alignment, seg, axes, rows, equations, nav.group,
                                 north_quadratic, to_alignment)
        for k, noise_k in enumerate(completed):
            remainders[k] += to_alignment @ alignment_remainders(m_align, duration, noise_k) @ to_alignment.T
        previous_end = float(plan.start_time + plan.step_dt.sum())
    return model.covariance() + remainders


def alignment_remainders(m_align: np.ndarray, duration: float, noise: SensorNoise) -> np.ndarray:
    """Covariance (3, 3) of the alignment's attitude error from the pulse remainders at the two ends of its
    segment: ``M diag(2 s_e^2) M^T / T^2`` for the means ``(e_end - e_start) / T`` (module docstring).

    ``m_align`` (3, 6) is the alignment's response to its mean specific force and rate (body), ``duration``
    the segment's length ``T``.
    """
    variance = 2.0 * np.concatenate([noise.accel_quantization, noise.gyro_quantization]) ** 2 / duration**2
    return (m_align * variance) @ m_align.T


def _group_start(model: LinearModel, layout: Layout, noises: list[SensorNoise], start: float,
                 previous_end: float | None) -> int:
    """The state at a group's start: zero, but for the biases, which wander on from the previous group (one
    Gauss-Markov process over the recording)."""
    a, q = np.zeros((layout.n, layout.n)), np.zeros((len(noises), layout.n, layout.n))
    if layout.markov:
        for k, noise in enumerate(noises):
            for sl, sigma, tau in ((layout.bg, noise.gyro_bias_instability, noise.gyro_bias_tau),
                                   (layout.ba, noise.accel_bias_instability, noise.accel_bias_tau)):
                beta = (gauss_markov_integrals(max(start - previous_end, 0.0), tau)[0] if previous_end is not None
                        else 0.0)
                a[sl, sl] = np.eye(3) * beta
                q[k, sl, sl] = np.eye(3) * sigma**2 * (1.0 - beta**2)
    return model.step(a, q)


def _propagate(model: LinearModel, system: NoiseSystem, track, plan: GroupSteps, layout: Layout,
               noises: list[SensorNoise], first_seg: int, start: int) -> _GroupSteps:
    """A group's steps into the model: each static step, and the rotation before it as one transition."""
    n = layout.n
    phi, q0 = system.transitions(track, noises[0], layout)
    q = np.stack([q0] + [system.transitions(track, noise, layout)[1] for noise in noises[1:]], axis=1)  # (M, K, n, n)
    restart = np.eye(n)
    restart[ACC, ACC] = 0.0  # a static segment's gyro angle restarts
    response = np.zeros((n, 3))
    response[PHI] = np.eye(3)
    out = _GroupSteps(len(plan.step_dt))
    static = plan.step_segment >= 0
    phi_run, q_run = np.eye(n), np.zeros(q.shape[1:])
    previous = start
    for k in range(len(plan.step_dt)):
        if not static[k]:
            phi_run = phi[k] @ phi_run
            q_run = phi[k] @ q_run @ phi[k].T + q[k]
            continue
        if q_run.any():
            previous = model.step(phi_run, q_run)
            response = phi_run @ response
            phi_run, q_run = np.eye(n), np.zeros(q.shape[1:])
        t = model.step(phi[k] @ restart if plan.segment_start[k] else phi[k], q[k])
        response = phi[k] @ response
        out.index[k], out.v_align[k] = t, response[DV]
        if plan.step_segment[k] == first_seg:
            out.first.append((previous, t, float(plan.step_dt[k])))
            out.last_first = k
        previous = t
    return out


def _alignment_functional(rec: Recording, params, nav: GroupNavigation, system: NoiseSystem, track, plan: GroupSteps,
                          steps: _GroupSteps, layout: Layout, first_seg: int):
    """The alignment's attitude error as ``phi_0 = sum_t P_t x_t`` (eq. 15 linearised): ``{t: P_t (3, n)}``,
    with the linearised alignment ``M`` (3, 6) and the segment's length ``T``.

    The alignment sees the first segment's mean noise: specific force ``C^T (dv - int f x phi) / T`` and
    rate ``a / T`` (the segment's gyro angle).
    """
    duration = float(plan.step_dt[plan.step_segment == first_seg].sum())
    c1 = track.attitude[steps.last_first]
    first = rec.segment_samples(rec.group_segments(nav.group)[0])
    dth, dvel = compensate(rec.gyro[first], rec.accel[first], params, rec.dt)
    m_align = alignment_error(dvel.mean(axis=0) / rec.dt, dth.mean(axis=0) / rec.dt, np.eye(6))  # (3, 6)
    m_accel, m_gyro = m_align[:, :3] @ c1.T / duration, m_align[:, 3:] / duration
    out: dict[int, np.ndarray] = {}

    def add(t: int, block: np.ndarray) -> None:
        out[t] = out.get(t, np.zeros((3, layout.n))) + block

    block = np.zeros((3, layout.n))
    block[:, DV], block[:, ACC] = m_accel, m_gyro
    add(int(steps.index[steps.last_first]), block)
    for before, after, h in steps.first:  # - int f x phi dt, phi at the middle of each step
        block = np.zeros((3, layout.n))
        block[:, PHI] = -m_accel @ system.f_cross * 0.5 * h
        add(before, block)
        add(after, block)
    return out, m_align, duration


def _segment_functionals(model: LinearModel, plan: GroupSteps, steps: _GroupSteps, alignment: dict, seg, axes,
                         rows, equations, group: int, north_quadratic: bool, to_alignment: np.ndarray) -> None:
    """The fitted coefficients of one segment's velocity (the navigation's and the alignment's error) as
    functionals of the states, into their equations' rows of ``G``; their response to the alignment's
    attitude error into the rows of ``to_alignment``."""
    in_segment = np.flatnonzero(plan.step_segment == seg.number)
    tau = np.cumsum(plan.step_dt[in_segment])
    before = in_segment[0] - 1 if in_segment[0] > 0 and plan.step_segment[in_segment[0] - 1] >= 0 else None
    for axis in axes:
        ops, _ = coefficient_operator(tau, 1 if axis == 2 else 2)
        if axis == 1 and not north_quadratic:
            ops = ops[:1]
        for order, weights in enumerate(ops):
            i = next(i for i in rows if equations[i] == Equation(group, seg.number, axis, order + 1))
            for k, w in zip(in_segment, weights):
                model.g[steps.index[k]][i, DV.start + axis] += w
            response = weights @ steps.v_align[in_segment, axis, :]
            if before is not None:  # relative to the velocity before the segment
                model.g[steps.index[before]][i, DV.start + axis] -= weights.sum()
                response = response - weights.sum() * steps.v_align[before, axis]
            to_alignment[i] = response
            for t, block in alignment.items():
                model.g[t][i] += response @ block
