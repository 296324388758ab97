"""Stage 1 of the estimator: Ipopt with quick weights, and the rank check of every stage.

The quick weighting is white accelerometer noise alone: consecutive velocity observations of a
group are differenced and divided by the random walk over the samples between them (physics
pitfall 7); gyro means are divided by their white noise and sway.  Quick, and near the answer; the
full noise model follows in the generalised least squares (:mod:`calibrate.nlp.gls`).

Ipopt minimises ``f = |W r|^2 / 2n`` over the decision vector.  Its gradient ``J^T W^T W r / n`` and
the Gauss-Newton Hessian ``J^T W^T W J / n`` come from the graph's compiled Jacobian (the forward
derivative carried along the chain, :mod:`nav.tangent`), evaluated once per point: Ipopt's
gradient and Hessian at one iterate, and the generalised least squares at the solution, share it
(:meth:`graph.ResidualGraph.linearise`).  The objective at trial points needs the residuals alone.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Callable

import casadi as ca
import numpy as np

from ...model.noise import ACCEL_VRW_FLOOR, GYRO_ARW_FLOOR, SensorNoise
from ...model.registry import N_PARAMS, NAMES
from ...noise.observations import ObservationKind
from ..result import CalibrationError
from .graph import ResidualGraph

#: Relative singular values below this count as zero (healthy schedules: >= 7e-6).
RANK_TOLERANCE = 1e-7


class RowWeights:
    """A sparse weighting matrix ``W`` (rows of the weighted residuals x residuals), as triplets.

    Parameters
    ----------
    rows, cols : ndarray of int
    values : ndarray
    shape : tuple of int
    """

    def __init__(self, rows, cols, values, shape: tuple[int, int]):
        self.rows, self.cols = np.asarray(rows, dtype=np.int64), np.asarray(cols, dtype=np.int64)
        self.values, self.shape = np.asarray(values, dtype=float), shape

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        out = np.zeros((self.shape[0],) + x.shape[1:])
        np.add.at(out, self.rows, self.values.reshape((-1,) + (1,) * (x.ndim - 1)) * x[self.cols])
        return out

    def to_casadi(self) -> ca.DM:
        """The matrix as a sparse CasADi ``DM`` (the triplets are unique)."""
        return ca.DM.triplet(self.rows.tolist(), self.cols.tolist(), self.values.tolist(), *self.shape)


def quick_weights(graph: ResidualGraph, noise: SensorNoise, dt: float, use_rotation_steps: bool,
                  motions=()) -> RowWeights:
    """The quick weighting of stage 1: white accelerometer noise alone.

    Consecutive velocity observations of a group are differenced and divided by the random walk over
    the samples between them (pitfall 7); a difference across a rotation is dropped when the steps are
    not used.  Gyro means are divided by the white gyro noise of a segment (a tapered mean's: its weights'
    share, :mod:`noise.taper`) and its sway.
    """
    sway = {m.segment: m.added_variance for m in motions}
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
        step_dt = plan.step_dt[plan.step_segment == seg]
        white = (arw**2 * float(np.sum(graph.tapers[seg] ** 2 * step_dt)) if seg in graph.tapers
                 else arw**2 / float(step_dt.sum()))
        variance = white + sway.get(seg, np.zeros(3))
        for axis in range(3):
            rows.append(out + axis), cols.append(i + axis), vals.append(1.0 / np.sqrt(variance[axis]))
        out += 3
    return RowWeights(rows, cols, vals, (out, graph.n_residuals))


class _Oracle(ca.Callback):
    """A NumPy function of the decision vector as a CasADi function, for Ipopt."""

    def __init__(self, name: str, n: int, outputs: list[ca.Sparsity], evaluate: Callable):
        ca.Callback.__init__(self)
        self.n, self.outputs, self.evaluate = n, outputs, evaluate
        self.construct(name, {})

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return len(self.outputs)

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self.n, 1)

    def get_sparsity_out(self, i):
        return self.outputs[i]

    def eval(self, arg):
        return self.evaluate(np.asarray(arg[0]).ravel())


class WeightedLeastSquares:
    """``f = |W r|^2 / 2n``, its gradient and Gauss-Newton Hessian, from the graph's residuals and Jacobian.

    Parameters
    ----------
    graph : ResidualGraph
    weights : RowWeights
        ``W`` (n rows).
    """

    def __init__(self, graph: ResidualGraph, weights: RowWeights):
        self.graph, self.weights = graph, weights
        self.scale = 1.0 / weights.shape[0]  # mean square: the tolerance does not depend on the recording's length
        self._weighted = (None, None)
        self._base_columns = None

    def _linear(self, z: np.ndarray):
        """``(W r, W J)`` at ``z``, one Jacobian evaluation per point (the base's velocity columns, constant, weighed
        once)."""
        lin = self.graph.linearise(z)
        if self._weighted[0] is not lin:
            if self.graph.base is None:
                weighted_jac = self.weights @ lin.jac
            else:
                n = self.graph.shape.n_variables
                if self._base_columns is None:
                    self._base_columns = self.weights @ lin.jac[:, n:]
                weighted_jac = np.hstack([self.weights @ lin.jac[:, :n], self._base_columns])
            self._weighted = (lin, (self.weights @ lin.r, weighted_jac))
        return self._weighted[1]

    def cost(self, z: np.ndarray) -> list:
        """``[f]`` at ``z`` (the residuals alone, unless the point is linearised already)."""
        rw = self.weights @ self.graph.residuals(z)
        return [0.5 * self.scale * float(rw @ rw)]

    def gradient(self, z: np.ndarray) -> list:
        """``[f, grad f]`` at ``z``."""
        rw, jw = self._linear(z)
        return [0.5 * self.scale * float(rw @ rw), self.scale * (jw.T @ rw)]

    def hessian(self, z: np.ndarray) -> list:
        """``[triu(J^T W^T W J) / n]`` at ``z``."""
        _, jw = self._linear(z)
        return [ca.triu(ca.DM(self.scale * (jw.T @ jw)))]

    def problem(self, hessian: str) -> tuple[dict, dict, list]:
        """The NLP of ``ca.nlpsol`` and its options (gradient and, for ``"gauss-newton"``, Hessian given),
        and the callbacks (to be kept alive while the solver is)."""
        n = self.graph.n_variables
        scalar, column = ca.Sparsity.dense(1, 1), ca.Sparsity.dense(n, 1)
        cost = _Oracle("weighted_cost", n, [scalar], self.cost)
        gradient = _Oracle("weighted_gradient", n, [scalar, column], self.gradient)
        keep = [cost, gradient]
        w, p = ca.MX.sym("x", n), ca.MX.sym("p", 0, 1)
        opts = {"grad_f": ca.Function("nlp_grad_f", [w, p], gradient(w), ["x", "p"], ["f", "grad_f_x"]),
                "calc_lam_p": False, "no_nlp_grad": True}
        if hessian == "gauss-newton":
            gauss_newton = _Oracle("gauss_newton_hessian", n, [ca.Sparsity.upper(n)], self.hessian)
            keep.append(gauss_newton)
            sigma, lam_g = ca.MX.sym("sigma"), ca.MX.sym("lam_g", 0, 1)
            opts["hess_lag"] = ca.Function("nlp_hess_l", [w, p, sigma, lam_g], [sigma * gauss_newton(w)],
                                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
        elif hessian == "limited-memory":
            opts["ipopt.hessian_approximation"] = "limited-memory"
        else:
            raise ValueError(f"unknown hessian {hessian!r}")
        x = ca.MX.sym("w", n)
        return {"x": x, "f": cost(x)}, opts, keep


#: Ipopt stops when the objective changes less than this (relative) over two iterations; on a moving base when it
#: changes less than :data:`MOVING_OBJECTIVE_CHANGE` once: the tapered gyro means' weights raise the objective's
#: round-off to 1e-9, and the generalised least squares after Ipopt takes its last step.
OBJECTIVE_CHANGE = 1e-12
MOVING_OBJECTIVE_CHANGE = 1e-8


def solve_ipopt(graph: ResidualGraph, weights: RowWeights, hessian: str, tolerance: float, max_iterations: int,
                progress: Callable[[str], None] | None, x0: np.ndarray | None = None,
                objective_change: float = OBJECTIVE_CHANGE):
    """Stage 1: Ipopt from ``x0`` (default the reference, all variables 0) with the ``weights`` of
    :func:`quick_weights`.

    The Gauss-Newton Hessian ``J^T W J`` (``hessian="gauss-newton"``, as in CasADi's system-identification
    example) or Ipopt's ``"limited-memory"`` approximation, with the gradient from the compiled Jacobian
    (module docstring); ``"exact"``: CasADi's algorithmic derivatives of the whole chain on its virtual
    machine (slow; for comparison).  ``objective_change``: the relative change of the objective over two
    iterations below which Ipopt has converged (:data:`OBJECTIVE_CHANGE`).  Returns the decision vector and
    Ipopt's statistics.
    """
    if hessian == "exact":
        nlp, opts, keep = _exact_problem(graph, weights), {}, []
    else:
        nlp, opts, keep = WeightedLeastSquares(graph, weights).problem(hessian)
    # The variables are in natural units already: Ipopt's gradient scaling at the (far-off) rough start
    # would shrink the objective by ~1e-6 and stall the line search at round-off.  The gradient of the
    # chained navigation has a round-off floor near 1e-8; a gradient of 1e-7 moves the estimate by
    # ~1e-4 of its sigma.  Also stop when the objective stalls: with noise-free data or very unequal
    # weights the gradient's round-off floor can exceed any fixed tolerance although Gauss-Newton has
    # converged.
    opts.update({"ipopt.print_level": 0, "print_time": False, "ipopt.tol": tolerance,
                 "ipopt.acceptable_tol": 1e20, "ipopt.acceptable_obj_change_tol": objective_change,
                 "ipopt.acceptable_iter": 2 if objective_change == OBJECTIVE_CHANGE else 1,
                 "ipopt.max_iter": max_iterations, "ipopt.sb": "yes", "ipopt.nlp_scaling_method": "none"})
    solver = ca.nlpsol("calibration", "ipopt", nlp, opts)
    with interruptions() as interrupted:
        try:
            sol = solver(x0=np.zeros(graph.n_variables) if x0 is None else x0)
        except RuntimeError:
            if interrupted:
                raise KeyboardInterrupt from None
            raise
    if interrupted:  # CasADi stops Ipopt on Ctrl-C and reports an exception: it is an interruption
        raise KeyboardInterrupt
    del keep
    stats = solver.stats()
    if progress:
        progress(f"nlp: ipopt {stats['return_status']} after {stats['iter_count']} iterations, "
                 f"cost {float(sol['f']):.6g}")
    return np.asarray(sol["x"]).ravel(), stats


def _exact_problem(graph: ResidualGraph, weights: RowWeights) -> dict:
    """The objective as a CasADi expression of the shape's graph on the virtual machine (differentiable)."""
    from .shape import ShapeGraph

    symbolic = ShapeGraph(graph.shape.layouts, graph.names, compiled=False)
    w = ca.MX.sym("w", graph.n_variables)
    n = graph.shape.n_variables
    r = symbolic.residuals(w[:n], ca.DM(graph.data), ca.DM(graph.ref))
    if graph.base is not None:
        r = r - ca.mtimes(ca.DM(graph.base.matrix), w[n:])
    r = ca.mtimes(weights.to_casadi(), r)
    return {"x": w, "f": 0.5 / weights.shape[0] * ca.dot(r, r)}


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
