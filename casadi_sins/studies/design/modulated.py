"""The navigation error of a rotation-modulated INS whose sensor errors are what a calibration leaves.

``design --criterion navigation --scheme NAME`` scores a calibration schedule by the navigation it
buys in operation: the unit, calibrated with the schedule's predicted covariance, navigates on a
static base under the rotation scheme ``NAME`` (:mod:`studies.modulation`), aligned at the scheme's
start attitude, for ``hours``.  The value is the largest horizontal position error (1 sigma, m) over
the run, the number ``modulate`` reports as ``max_horizontal_position_error_m``.

The scheme's propagation (transition matrices and noise covariances, :func:`covariance.propagate`)
depends on the scheme, the site and the unit's white noise only, so it is built once; each schedule
then costs one product with a root of its covariance (:func:`designer.criterion_value`).
"""

from __future__ import annotations

import numpy as np

from ...core.errors import InputError
from ...data.problem import Problem
from ...model.registry import NAMES
from ..budget import white_noise_densities
from ..modulation import model as M
from ..modulation.calibrated import parameter_sources
from ..modulation.covariance import propagate
from ..modulation.designer import criterion_value
from ..modulation.schemes import Scheme


class ModulatedNavigation:
    """The largest horizontal position error of a modulated INS over ``hours`` for a calibration covariance.

    Parameters
    ----------
    problem : Problem
        The unit (its white noise) and the site.
    scheme : Scheme
        The rotation scheme the unit runs in operation.
    hours : float
        Length of the navigation run.
    step_deg, max_step_s : float
        Turn sub-step and output interval of the propagation (:func:`covariance.propagate`).

    Raises
    ------
    InputError
        If the site or the run cannot be propagated (a pole, a scheme longer than the run's steps allow).
    """

    def __init__(self, problem: Problem, scheme: Scheme, hours: float, step_deg: float = 5.0,
                 max_step_s: float = 60.0):
        self.site = M.check_site(problem.site)
        self.scheme, self.hours = scheme, hours
        self.gyro_arw, self.accel_vrw = white_noise_densities(problem)
        self.propagation = propagate(scheme, self.site, hours, self.gyro_arw, self.accel_vrw, step_deg, max_step_s,
                                     names=NAMES)

    def __call__(self, nominal: np.ndarray, covariance: np.ndarray) -> float:
        """Largest horizontal position error (m, 1 sigma) with the 21 parameters' ``covariance`` (SI) about
        ``nominal``."""
        n = len(NAMES)
        try:
            sources = parameter_sources(NAMES, np.asarray(nominal)[:n], np.asarray(covariance)[:n, :n],
                                        self.gyro_arw, self.accel_vrw)
        except ValueError as exc:
            raise InputError(None, f"the unit's parameters: {exc}") from None
        return criterion_value(self.propagation, sources.aligned(self.site, self.scheme.start), "position")
