"""Stage 2 of the estimator: generalised least squares under the full noise model.

Gauss-Newton steps on the Kalman-whitened residuals and Jacobian (:mod:`noise.kalman`: angle and
velocity random walk, the gyro noise shared by the gyro means and the velocity, pulse quantization,
bias instability, base sway), re-linearised, with a line search outside the linear region; every
step is reported.  ``sigma`` is ``(J_w^T J_w)^-1`` at the final point.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...data.recording import Recording
from ...model.noise import SensorNoise
from ...noise.kalman import NoiseSystem
from ...noise.observations import ObservationKind
from ...noise.plan import NoisePlan
from ..result import CalibrationError
from .graph import ResidualGraph
from .ipopt import OBJECTIVE_CHANGE, RANK_TOLERANCE, check_rank, quick_weights, solve_ipopt
from .likelihood import estimate_free_terms

#: A step this small (in sigma) is taken as the last: the next is smaller by a factor ~1e-4 x step
#: (measured: steps of 2.2, 0.11 and 20 sigma were followed by 0.001, 6e-7 and 0.017), so the residuals
#: are updated linearly instead of evaluating the graph again.
GLS_LINEAR_STEP = 0.5
GLS_MAX_STEPS = 6
#: Steps above this (sigma) move the attitudes enough to rebuild the noise model along them.
GLS_RELINEARISE_NOISE = 0.3


@dataclasses.dataclass
class Fit:
    """A finished fit: the solution, the whitened problem at it, and how it got there.

    Attributes
    ----------
    z : ndarray
        Decision vector (natural units: parameters, then start attitudes in arcsec).
    noise : SensorNoise
        The noise model the residuals were whitened with.
    whitened_residuals, whitened_jacobian : ndarray
    residuals, jacobian : ndarray
        Unwhitened, linearised at ``z``.
    leverage : ndarray
        Diagonal of the hat matrix of each whitened row.
    left_singular_vectors : ndarray
        ``U`` of the whitened Jacobian.
    covariance_natural : ndarray
        ``(J_w^T J_w)^-1`` of the decision vector.
    gls_steps : list of float
        Largest step of each Gauss-Newton iteration, in sigma.
    rotation_step_ratio : float
        Mean square of the whitened residuals after rotations over that of the others.
    use_rotation_steps : bool
    system : NoiseSystem
    ipopt_stats : dict
    """

    z: np.ndarray
    noise: SensorNoise
    whitened_residuals: np.ndarray
    whitened_jacobian: np.ndarray
    residuals: np.ndarray
    jacobian: np.ndarray
    leverage: np.ndarray
    left_singular_vectors: np.ndarray
    covariance_natural: np.ndarray
    gls_steps: list[float]
    rotation_step_ratio: float
    use_rotation_steps: bool
    system: NoiseSystem
    ipopt_stats: dict = dataclasses.field(default_factory=dict)


def fit_graph(rec: Recording, graph: ResidualGraph, noise_plan: NoisePlan, use_rotation_steps: bool, hessian: str,
              tolerance: float, max_iterations: int, progress, presolved: tuple | None = None,
              x0: np.ndarray | None = None, relinearise: float = None,
              objective_change: float = OBJECTIVE_CHANGE) -> Fit:
    """Stage 1 (Ipopt, quick weights; or ``presolved``, ``(z, stats)`` of :func:`.start.presolve`: Gauss-Newton
    under the noise model from a start fitted to the data) and stage 2 (generalised least squares under the noise
    model).

    Raises
    ------
    CalibrationError
        Stage 1 did not converge: it stopped at its iteration limit or diverged (saying so, and what to try);
        or, at the converged point, the Jacobian is rank deficient (naming the unobservable variables).
    KeyboardInterrupt
        Ctrl-C inside Ipopt.
    """
    if presolved is not None:
        z, stats = presolved
    else:
        weights = quick_weights(graph, noise_plan.model, rec.dt, use_rotation_steps, noise_plan.motions)
        z, stats = solve_ipopt(graph, weights, hessian, tolerance, max_iterations, progress, x0, objective_change)
    if stats["return_status"] in ("User_Requested_Stop", "Interrupted_By_User"):
        raise KeyboardInterrupt  # Ctrl-C inside Ipopt: an interruption, not a failure to converge
    if not stats["success"] and stalled(stats):
        progress and progress(f"nlp: Ipopt's objective changed by less than {STALL_CHANGE:g} (relative) over its last "
                              f"{STALL_ITERATIONS} iterations: a flat valley of a misfit outside the model; the "
                              "generalised least squares takes it from there")
    elif not stats["success"]:
        # only what was tested: the solver stopped, and says so.  A rank-deficient problem leaves Ipopt wandering
        # along what the data do not determine: "not observable" is said only when Gauss-Newton steps in the
        # directions they do determine settle, from the information matrix at that converged point
        weights = quick_weights(graph, noise_plan.model, rec.dt, use_rotation_steps, noise_plan.motions)
        settled, converged = settle_in_range(graph, weights, z)
        if converged:
            check_rank(np.asarray(graph.jacobian(settled)[1]), graph.variable_names())
        raise CalibrationError(not_converged(stats, max_iterations))
    fit = generalised_least_squares(rec, graph, noise_plan, dataclasses.replace(noise_plan.model), z,
                                    use_rotation_steps, progress, relinearise=relinearise)
    fit.ipopt_stats = stats
    return fit


#: A point is converged when the Gauss-Newton step in the directions the data determine would lower the weighted
#: sum of squares by less than this (one unit of chi-square is what noise makes of it).
CONVERGED_DECREASE = 1.0


#: Gauss-Newton steps tried after a stage-1 solver stopped, before it is said not to have converged.
SETTLE_STEPS = 10


def settle_in_range(graph: ResidualGraph, weights, z: np.ndarray) -> tuple[np.ndarray, bool]:
    """Gauss-Newton steps within the range of the weighted Jacobian (singular values above
    :data:`ipopt.RANK_TOLERANCE` of the largest; a rank-deficient problem leaves a solver wandering along the
    others), each halved until the weighted sum of squares does not grow, from where a solver stopped:
    ``(z, converged)``, converged when no such step would lower the sum by :data:`CONVERGED_DECREASE` or more."""
    for _ in range(SETTLE_STEPS):
        r, jac = graph.jacobian(z)
        rw, jw = weights @ np.asarray(r).ravel(), weights @ np.asarray(jac)
        u, s, vt = np.linalg.svd(jw, full_matrices=False)
        kept = s > RANK_TOLERANCE * s[0]
        projected = u[:, kept].T @ rw
        if float(projected @ projected) < CONVERGED_DECREASE:
            return z, True
        step = -vt[kept].T @ (projected / s[kept])
        cost = float(rw @ rw)
        for _ in range(30):
            trial = weights @ np.asarray(graph.residuals(z + step)).ravel()
            if float(trial @ trial) < cost:
                break
            step = step / 2.0
        else:
            return z, False
        z = z + step
    return z, False


def not_converged(stats: dict, max_iterations: int) -> str:
    """What a stage-1 solver that did not converge did, and what to try (no judgement of the schedule: that needs a
    converged point)."""
    status, count = stats["return_status"], int(stats["iter_count"])
    if status == "Maximum_Iterations_Exceeded":
        return (f"Ipopt did not converge: it stopped at its iteration limit ({count} of {max_iterations}) still "
                "moving: start nearer the answer (--initial P.csv: a table of this unit, or `casadi-sins rough`'s "
                "values edited) or allow more (--max-iterations)")
    if status == "Gauss_Newton_Not_Settled":
        return (f"the Gauss-Newton steps from the rough values fitted to the data did not settle in {count} steps "
                f"(the last {stats.get('last_step', float('nan')):.3g} sigma): the start is too far from the answer "
                "or the segments hold motion as rest; check the segments (casadi-sins segment), start nearer "
                "(--initial P.csv) or allow more (--max-iterations)")
    return (f"Ipopt did not converge: {status} after {count} iterations (the iterates diverged or the steps "
            "failed): start nearer the answer (--initial P.csv), check the segment times against the data "
            "(casadi-sins validate, segment)")


#: Ipopt at its iteration cap has converged for our purpose when the objective moved less than this (relative)
#: over its last iterations: a large misfit outside the model makes Gauss-Newton creep along a flat valley (a
#: hand-turned MEMS session), and the generalised least squares after it checks its own convergence.
STALL_CHANGE = 1e-6
STALL_ITERATIONS = 20


def stalled(stats: dict) -> bool:
    """Whether Ipopt stopped at its iteration cap with a stalled objective (see :data:`STALL_CHANGE`)."""
    if stats.get("return_status") != "Maximum_Iterations_Exceeded":
        return False
    objective = np.asarray((stats.get("iterations") or {}).get("obj") or [], dtype=float)
    if len(objective) <= STALL_ITERATIONS:
        return False
    recent = objective[-STALL_ITERATIONS - 1:]
    return bool(np.all(np.isfinite(recent)) and np.ptp(recent) <= STALL_CHANGE * abs(recent[-1]))


def generalised_least_squares(rec: Recording, graph: ResidualGraph, noise_plan: NoisePlan, model: SensorNoise,
                              z: np.ndarray, use_rotation_steps: bool, progress, update_free: bool = True,
                              relinearise: float | None = None) -> Fit:
    """Gauss-Newton on the Kalman-whitened residuals from ``z`` until a step is in the linear region.

    With ``update_free`` the noise terms the raw data did not determine are set by restricted maximum
    likelihood at the first linearisation (:func:`likelihood.estimate_free_terms`).  The noise model is rebuilt
    along the attitudes after a step of more than ``relinearise`` sigma (default :data:`GLS_RELINEARISE_NOISE`;
    a unit whose heading is weakly determined, a MEMS unit by hand, would chase its own whitening otherwise).
    """
    relinearise = GLS_RELINEARISE_NOISE if relinearise is None else relinearise
    gls_steps: list[float] = []
    system = None
    for _ in range(GLS_MAX_STEPS):
        r, jac = (np.asarray(m) for m in graph.jacobian(z))
        r = r.ravel()
        if system is None or gls_steps[-1] > relinearise:  # the attitudes barely move near the answer
            system = NoiseSystem(graph.tracks(np.asarray(graph.trajectory(z)), use_rotation_steps,
                                              noise_plan.motions), rec.site.g, rec.site.earth_rate)
        white = system.whiten(np.column_stack([r, jac]), model).columns
        rw, jw = white[:, 0], white[:, 1:]
        u, s, vt = np.linalg.svd(jw, full_matrices=False) if graph.base is None else gram_svd(jw)
        check_rank(jw, graph.variable_names(), (u, s, vt))
        step = -vt.T @ ((u.T @ rw) / s)
        sigma = np.sqrt(np.sum((vt.T / s) ** 2, axis=1))
        if np.max(np.abs(step) / sigma) > 1.0:  # outside the linear region a full step may overshoot
            step = line_search(graph, system, model, z, step, float(rw @ rw))
        gls_steps.append(float(np.max(np.abs(step) / sigma)))
        z = z + step
        rw = rw + jw @ step
        if update_free and any(noise_plan.free_terms().values()):
            # the terms the raw data did not determine, once, at the first linearisation; then solve again
            model = estimate_free_terms(model, noise_plan, system, np.column_stack([r + jac @ step, jac]))
            update_free = False
            continue
        if gls_steps[-1] < GLS_LINEAR_STEP:
            break
    if progress:
        progress("nlp: generalised least squares under the noise model, steps of "
                 + ", ".join(f"{s:.3g}" for s in gls_steps) + " sigma")
    return Fit(z, model, rw, jw, r + jac @ step, jac, np.sum(u**2, axis=1), u, (vt.T / s**2) @ vt, gls_steps,
               rotation_step_ratio(graph, rw, use_rotation_steps), use_rotation_steps, system)


def gram_svd(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The thin SVD ``(u, s, vt)`` of a tall matrix from the eigenvectors of its Gram matrix: several times faster
    than LAPACK's for the hundreds of columns a moving base's velocity adds, and within 1e-8 of it for the
    condition numbers of a calibration (1e5); singular values below 1e-7 of the largest are found as such."""
    w, v = np.linalg.eigh(a.T @ a)
    w, v = w[::-1], v[:, ::-1]
    s = np.sqrt(np.clip(w, 0.0, None))
    return a @ v / np.where(s > 0.0, s, 1.0), s, v.T


def rotation_step_ratio(graph: ResidualGraph, rw: np.ndarray, use_rotation_steps: bool) -> float:
    """Mean square of the whitened velocity residuals just after rotations over that of the others (1 when
    the steps across rotations are not used)."""
    table = graph.observations
    velocity = table.rows_of(ObservationKind.VELOCITY)
    steps = table.after_rotation & velocity
    plain = velocity & ~steps & ~table.first_of_group
    if use_rotation_steps and steps.any() and plain.any():
        return float(np.mean(rw[steps] ** 2) / np.mean(rw[plain] ** 2))
    return 1.0


def line_search(graph: ResidualGraph, system: NoiseSystem, model: SensorNoise, z: np.ndarray, step: np.ndarray,
                 cost: float, halvings: int = 8) -> np.ndarray:
    """The Gauss-Newton step, halved until the whitened cost does not grow (far from the linear region:
    residuals much larger than the noise model, as with unmodelled errors)."""
    for _ in range(halvings):
        if np.max(np.abs(step)) < 1e-9:
            return step
        trial = np.asarray(graph.residuals(z + step)).ravel()
        new_cost = float(np.sum(system.whiten(trial, model).columns ** 2))
        if new_cost <= cost * (1.0 + 1e-9) + 1e-12:
            return step
        step = step / 2.0
    return np.zeros_like(step)
