"""Stage 1 of the estimator: Ipopt with quick weights, and the rank check of every stage.

The quick weighting is white accelerometer noise alone: consecutive velocity observations of a
group are differenced and divided by the random walk over the samples between them (physics
pitfall 7); gyro means are divided by their white noise and sway.  Quick, and near the answer; the
full noise model follows in the generalised least squares (:mod:`calibrate.nlp.gls`).
"""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Callable

import casadi as ca
import numpy as np
import scipy.sparse as sp

from ...model.noise import ACCEL_VRW_FLOOR, GYRO_ARW_FLOOR, SensorNoise
from ...model.registry import N_PARAMS, NAMES
from ...noise.observations import ObservationKind
from ..result import CalibrationError
from .graph import ResidualGraph

#: Relative singular values below this count as zero (healthy schedules: >= 7e-6).
RANK_TOLERANCE = 1e-7


def quick_weights(graph: ResidualGraph, noise: SensorNoise, dt: float, use_rotation_steps: bool,
                  motions=()) -> sp.csr_matrix:
    """The quick weighting of stage 1: white accelerometer noise alone.

    Consecutive velocity observations of a group are differenced and divided by the random walk over
    the samples between them (pitfall 7); a difference across a rotation is dropped when the steps are
    not used.  Gyro means are divided by the white gyro noise of a segment and its sway.
    """
    sway = {m.segment: m.gyro_mean_variance for m in motions}
    model = noise.complete()
    vrw = max(float(np.mean(model.accel_vrw)), ACCEL_VRW_FLOOR)
    arw = max(float(np.mean(model.gyro_arw)), GYRO_ARW_FLOOR)
    rows, cols, vals = [], [], []
    out = 0
    observations = graph.observations.observations
    previous = {}
    for obs in (o for o in observations if o.kind == ObservationKind.VELOCITY):
        i, group = obs.row, obs.group
        keep = use_rotation_steps or not obs.after_rotation
        weight = 1.0 / (vrw * np.sqrt(obs.samples_since_previous * dt))
        if keep:
            for axis in range(3):
                rows.append(out + axis), cols.append(i + axis), vals.append(weight)
                if group in previous:
                    rows.append(out + axis), cols.append(previous[group] + axis), vals.append(-weight)
            out += 3
        previous[group] = i
    for obs in (o for o in observations if o.kind == ObservationKind.GYRO_MEAN):
        i, seg = obs.row, obs.segment
        plan = next(p for p in graph.groups if p.group == obs.group)
        duration = float(plan.step_dt[plan.step_segment == seg].sum())
        variance = arw**2 / duration + sway.get(seg, np.zeros(3))
        for axis in range(3):
            rows.append(out + axis), cols.append(i + axis), vals.append(1.0 / np.sqrt(variance[axis]))
        out += 3
    return sp.csr_matrix((vals, (rows, cols)), shape=(out, graph.n_residuals))


def solve_ipopt(graph: ResidualGraph, weights: sp.csr_matrix, hessian: str, tolerance: float, max_iterations: int,
                 progress: Callable[[str], None] | None):
    """Stage 1: Ipopt from the reference (all variables 0) with the ``weights`` of :func:`quick_weights`.

    Algorithmic derivatives, the Gauss-Newton Hessian ``J^T W J`` (``hessian="gauss-newton"``, as in
    CasADi's system-identification example), or ``"exact"`` / ``"limited-memory"``.  Returns the
    decision vector and Ipopt's statistics.
    """
    w = ca.MX.sym("w", graph.n_variables)
    d = ca.DM(weights.tocsc())
    r = ca.mtimes(d, graph.residuals(w))  # not the jacobian function's r: its derivative would hold J's
    scale = 1.0 / weights.shape[0]  # mean square: the tolerance does not depend on the recording's length
    nlp = {"x": w, "f": 0.5 * scale * ca.dot(r, r)}
    # The variables are in natural units already: Ipopt's gradient scaling at the (far-off) rough start
    # would shrink the objective by ~1e-6 and stall the line search at round-off.  The gradient of the
    # chained navigation has a round-off floor near 1e-8; a gradient of 1e-7 moves the estimate by
    # ~1e-4 of its sigma.  Also stop when the objective stalls: with noise-free data or very unequal
    # weights the gradient's round-off floor can exceed any fixed tolerance although Gauss-Newton has
    # converged.
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": tolerance,
            "ipopt.acceptable_tol": 1e20, "ipopt.acceptable_obj_change_tol": 1e-12, "ipopt.acceptable_iter": 2,
            "ipopt.max_iter": max_iterations, "ipopt.sb": "yes", "ipopt.nlp_scaling_method": "none"}
    if hessian == "gauss-newton":
        jw = ca.mtimes(d, graph.jacobian(w)[1])
        sigma = ca.MX.sym("sigma")
        opts["hess_lag"] = ca.Function("nlp_hess_l", [w, ca.MX.sym("p", 0, 1), sigma, ca.MX.sym("lam_g", 0, 1)],
                                       [sigma * scale * ca.triu(jw.T @ jw)], ["x", "p", "lam_f", "lam_g"],
                                       ["triu_hess_gamma_x_x"])
    elif hessian == "limited-memory":
        opts["ipopt.hessian_approximation"] = "limited-memory"
    elif hessian != "exact":
        raise ValueError(f"unknown hessian {hessian!r}")
    solver = ca.nlpsol("calibration", "ipopt", nlp, opts)
    with interruptions() as interrupted:
        sol = solver(x0=np.zeros(graph.n_variables))
    if interrupted:  # CasADi stops Ipopt on Ctrl-C and reports an exception: it is an interruption
        raise KeyboardInterrupt
    stats = solver.stats()
    if progress:
        progress(f"nlp: ipopt {stats['return_status']} after {stats['iter_count']} iterations, "
                 f"cost {float(sol['f']):.6g}")
    return np.asarray(sol["x"]).ravel(), stats


@contextlib.contextmanager
def interruptions():
    """Record a Ctrl-C that arrives while C++ code runs (CasADi turns it into a failed solve)."""
    seen: list[bool] = []
    if threading.current_thread() is not threading.main_thread():
        yield seen
        return

    def handler(signum, frame):
        seen.append(True)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, previous)


def check_rank(jac: np.ndarray, names: list[str] | None = None, svd=None) -> None:
    """Raise naming the unobservable variables when the Jacobian is (numerically) rank deficient.

    Relative singular values below :data:`RANK_TOLERANCE` count as zero: on the paper's schedule and
    the peer's 19 positions the smallest is 7e-6, on a one-group schedule 7e-9.
    """
    m, n = jac.shape
    u, s, vt = svd if svd is not None else np.linalg.svd(jac, full_matrices=False)
    null = s < RANK_TOLERANCE * s[0]
    if m <= n or null.any():
        weak = np.abs(vt[null]).max(axis=0) > 0.3 if null.any() else np.ones(n, bool)
        names = names or [NAMES[i] if i < N_PARAMS else f"start attitude of group {(i - N_PARAMS) // 3 + 1}"
                          for i in range(n)]
        raise CalibrationError(f"the residuals do not determine all parameters (condition "
                               f"{s[0] / max(s[-1], 1e-300):.2g}); not observable from this schedule: "
                               f"{', '.join(names[i] for i in np.flatnonzero(weak))}")
