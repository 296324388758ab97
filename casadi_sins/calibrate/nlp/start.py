"""Stage 1 from a start fitted to the data (a session by hand): Gauss-Newton under the noise model, not Ipopt.

Ipopt's quick weights (:func:`.ipopt.quick_weights`) hold the white accelerometer noise alone.  On a unit whose
gyro noise tilts it by a tenth of a degree within a rest (a MEMS unit) the velocities carry that tilt's random
walk, tens of times the quick weights' noise: Gauss-Newton with residuals that large converges linearly, and
Ipopt creeps along for hundreds of iterations.  The generalised least squares whitens with the whole noise model
(angle random walk included, :mod:`noise.kalman`); from rough values fitted to the rests and moves
(:mod:`data.handfit`) its Gauss-Newton steps, halved where they would raise the cost, settle in a few.

A step is a minimum-norm solve: whether the schedule determines every parameter is judged from the information
matrix at the converged point (stage 2), not here.
"""

from __future__ import annotations

import numpy as np

from ...data.recording import Recording
from ...noise.kalman import NoiseSystem
from ...noise.plan import NoisePlan
from .gls import GLS_LINEAR_STEP, line_search
from ...model.parameters import ParameterSet
from .graph import ResidualGraph, variable_scale

#: Most Gauss-Newton steps of the start (each settles a factor of several; 3-8 are typical).
MAX_STEPS = 30
#: Singular values below this share of the largest are left out of a step (a direction the data do not show).
STEP_RCOND = 1e-10
#: Steps (sigma) after which the noise model's whitening is rebuilt along the new attitudes.
RELINEARISE_NOISE = 3.0
#: A Gauss-Newton step of up to this many sigma of which no part lowers the cost ends at a minimum (the quadratic
#: model is off in a weakly determined direction); a longer one is stuck.
STUCK_STEP = 3.0


def start_vector(graph: ResidualGraph, initial: ParameterSet) -> np.ndarray:
    """The decision vector of ``initial`` in ``graph``: 0 for the 21 (the graph's reference) and the start
    attitudes; the extra terms ``initial`` gives (a rough g-sensitivity) as deviations from their prior, which
    stays the reference (the information criterion of ``model="auto"`` tests a group against its prior)."""
    z = np.zeros(graph.n_variables)
    values = initial.aligned(graph.names)
    scale = variable_scale(graph.reference, graph.names)
    known = np.array([n in initial.names for n in graph.names]) & (scale != 0)
    z[:graph.n_params][known] = (values[known] - graph.reference[known]) / scale[known]
    return z


def presolve(rec: Recording, graph: ResidualGraph, noise_plan: NoisePlan, use_rotation_steps: bool,
             max_iterations: int | None, progress, z: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """Gauss-Newton steps under the raw-data noise model from ``z`` (default the graph's reference, all
    variables 0), each halved until the whitened cost does not grow, until a step is under
    :data:`gls.GLS_LINEAR_STEP` sigma or no part of it lowers the cost.

    The noise model's whitening follows the navigated attitude; it is rebuilt only after steps of more than
    :data:`RELINEARISE_NOISE` sigma, so that the cost the steps descend stays put (the heading of a unit that
    does not resolve the Earth rate is weakly determined and moves the whitening a little with it).

    Returns the decision vector and statistics in the form of Ipopt's (``return_status`` ``"Solve_Succeeded"``
    or ``"Gauss_Newton_Not_Settled"``, ``iter_count``, ``success``, ``last_step`` in sigma).
    """
    model = noise_plan.model
    z = np.zeros(graph.n_variables) if z is None else np.array(z, dtype=float)
    limit = MAX_STEPS if max_iterations is None else int(max_iterations)
    system, last, steps, settled = None, np.inf, [], False
    for _ in range(limit):
        r, jac = (np.asarray(m) for m in graph.jacobian(z))
        if system is None or last > RELINEARISE_NOISE:
            system = NoiseSystem(graph.tracks(np.asarray(graph.trajectory(z)), use_rotation_steps, noise_plan.motions),
                                 rec.site.g, rec.site.earth_rate)
        white = system.whiten(np.column_stack([r.ravel(), jac]), model).columns
        rw, jw = white[:, 0], white[:, 1:]
        u, s, vt = np.linalg.svd(jw, full_matrices=False)
        kept = s > STEP_RCOND * s[0]
        step = -vt[kept].T @ ((u[:, kept].T @ rw) / s[kept])
        sigma = np.sqrt(np.sum((vt[kept].T / s[kept]) ** 2, axis=1)) + 1e-300
        full = float(np.max(np.abs(step) / sigma))
        step = line_search(graph, system, model, z, step, float(rw @ rw))
        last = float(np.max(np.abs(step) / sigma))
        steps.append(last)
        z = z + step
        if last < GLS_LINEAR_STEP:
            # settled; or no part of the step lowers the cost: a minimum, unless the model promised a long way
            settled = bool(np.any(step)) or full < STUCK_STEP
            last = last if np.any(step) else full
            break
    if progress:
        progress("nlp: Gauss-Newton from the rough values fitted to the data, steps of "
                 + ", ".join(f"{x:.3g}" for x in steps) + " sigma" + ("" if settled else ": not settled"))
    status = "Solve_Succeeded" if settled else "Gauss_Newton_Not_Settled"
    return z, {"return_status": status, "iter_count": len(steps), "success": settled, "last_step": last}
