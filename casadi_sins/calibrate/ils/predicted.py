"""What the ILS will reach on a schedule, before any data: the covariance of :mod:`.uncertainty` on a noise-free
recording at the truth, with the second order of :mod:`.curvature`."""

from __future__ import annotations

import numpy as np

from ...model.noise import SensorNoise
from .covariance import equation_covariances
from .curvature import dimensionless_of, with_curvature
from .equations import build_equations
from .uncertainty import sandwich


def predicted_covariance(rec, params: np.ndarray, noise: SensorNoise, north_quadratic: bool = True,
                         alignment_up: bool = True) -> np.ndarray:
    """The covariance (SI error terms, scale factors relative) the ILS reaches on ``rec``'s schedule at the
    values ``params`` under ``noise``, before any data: its equations' generalised least squares under their
    exact covariance, with the second order of :mod:`.curvature` (a noise-free recording at the truth, as
    :func:`studies.prediction.predict_problem` makes it)."""
    a, b, equations, navs = build_equations(rec, params, north_quadratic, alignment_up)
    sigma = equation_covariances(rec, params, navs, equations, [noise], north_quadratic)[0]
    cov = sandwich(a, sigma, sigma)
    cov, _ = with_curvature(lambda p: build_equations(rec, p, north_quadratic, alignment_up, False)[1], params, b, a,
                            sigma, cov, dimensionless_of(rec))
    return cov
