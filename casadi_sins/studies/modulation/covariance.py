"""Covariance propagation of the error state along a rotation scheme: the package's one propagator.

The scheme's pieces (:func:`schemes.scheme_pieces`, dwells cut at the output interval) go through
:func:`casadi_sins.nav.propagation.propagate`, which the error budget and the schedule design use too:
each distinct piece (same start attitude, axis, rate and length) is discretised once and reused in every
period (Guan et al. 2023, eqs. 9-19: ``X_k = Phi X_{k-1} + W``): a dwell exactly (``expm`` and Van
Loan's method), a turn by sub-steps of at most ``step_deg`` with the fourth-order Magnus integrator and
Van Loan at each sub-step's middle.  Its result, :class:`Propagation`, holds the sensitivities of
velocity and position to every initial state and the two noise covariances: any source's contribution
is ``S_k P0_source S_k^T`` (Guan et al. 2023, eqs. 20-22 and 26-30).
"""

from __future__ import annotations

import math

import numpy as np

from ...core.earth import Site
from ...core.errors import InputError
from ...nav.propagation import OUT_ROWS, Propagation, discretise as discretise_piece, output_pieces
from ...nav.propagation import propagate as propagate_pieces
from ...nav.propagation import substeps
from ...sim.motion import MotionPiece
from . import model as M
from .schemes import Scheme, check_size, scheme_pieces

__all__ = ["OUT_ROWS", "Propagation", "check_run", "check_turn_step", "discretise", "output_pieces", "propagate",
           "turn_substeps"]

#: Sub-steps per turn below this many per 90 deg are refused (the turn integrals lose accuracy).
MIN_STEPS_PER_90 = 4
#: Sub-steps finer than this (deg) only cost time (1 deg already agrees with 5 deg to 1e-6).
MIN_STEP_DEG = 0.01


def turn_substeps(piece: MotionPiece, step_deg: float) -> int:
    """Sub-steps of a turn of at most ``step_deg`` each (one for a dwell)."""
    return substeps(piece, math.radians(step_deg))


def discretise(piece: MotionPiece, model: M.ErrorModel, gyro_arw, accel_vrw, step_deg: float):
    """``(Phi, Q_gyro, Q_accel)`` of one piece (:func:`casadi_sins.nav.propagation.discretise`)."""
    return discretise_piece(model, piece, gyro_arw, accel_vrw, math.radians(step_deg))


def check_turn_step(step_deg: float, what: str) -> None:
    """Refuse a turn sub-step that is too coarse (fewer than :data:`MIN_STEPS_PER_90` per 90 deg) or
    finer than :data:`MIN_STEP_DEG`.

    Raises
    ------
    InputError
    """
    if not (np.isfinite(step_deg) and step_deg <= 90.0 / MIN_STEPS_PER_90):
        raise InputError(None, f"{what} {step_deg:g} deg gives too few steps per turn "
                         f"(at least {MIN_STEPS_PER_90} per 90 deg: step <= {90 / MIN_STEPS_PER_90:g} deg)")
    if not step_deg >= MIN_STEP_DEG:
        raise InputError(None, f"{what} {step_deg:g} deg is below {MIN_STEP_DEG:g} deg (no more accurate, only slower)")


def check_run(scheme: Scheme, site: Site, hours: float, max_step_s: float) -> None:
    """Refuse a run length, output step or site the propagation cannot take, before any work.

    Raises
    ------
    InputError
        Naming the value (or the scheme file) at fault.
    """
    if not (np.isfinite(hours) and hours > 0):
        raise InputError(None, f"hours must be a positive number (got {hours})")
    if not (np.isfinite(max_step_s) and max_step_s > 0):
        raise InputError(None, f"output step must be a positive number of seconds (got {max_step_s})")
    M.check_site(site)
    check_size(scheme, hours * 3600.0, max_step_s)


def propagate(scheme: Scheme, site: Site, hours: float, gyro_arw, accel_vrw, step_deg: float = 5.0,
              max_step_s: float = 60.0, cache: dict | None = None, names=M.SHEET_NAMES) -> Propagation:
    """Propagate the transition matrix and the noise covariances along ``scheme`` for ``hours``.

    Parameters
    ----------
    gyro_arw, accel_vrw : array (3,)
        White-noise densities, rad/sqrt(s) and m/s/sqrt(s).
    step_deg : float
        Largest integration sub-step of a turn, deg (at least :data:`MIN_STEPS_PER_90` per 90 deg).
    max_step_s : float
        Largest output interval in a dwell, s.
    cache : dict, optional
        The discretised pieces, shared between calls of the same site, noise, ``step_deg`` and ``names``
        (schemes made of the same turns, as a design search's candidates, then cost only their products).
    names : tuple of str
        The parameters whose errors are states (:attr:`sources.Sources.names`).
    """
    check_turn_step(step_deg, "turn integration step")
    check_run(scheme, site, hours, max_step_s)
    pieces = output_pieces(scheme_pieces(scheme, hours * 3600.0), max_step_s)
    return propagate_pieces(M.ErrorModel(site, tuple(names)), pieces, gyro_arw, accel_vrw, math.radians(step_deg),
                            cache)
