"""What a scheme leaves of the gyro errors: the navigation-frame gyro error integrated over time.

Yu and Ruan (2014, eqs. 5-7) project the gyro output error onto the geographic frame,
``d_w^n(t) = C(t) d_w(t)``, ``d_w = T_g (C^T w_ie + w_table) + eps (+ dK* |w|)``; during one 180 deg turn
it takes five forms (constant, sin a, cos a, sin 2a, cos 2a) of which only the constant and the sin a
terms survive the integral over the half turn (eq. 8).  The part left over a whole period acts as a
constant "equivalent drift" ``(1/T) int_period d_w^n dt``; the rest only oscillates (its integral is
their Fig. 6).  Guan et al. (2023, eqs. 32-35) list which terms a rotation about the azimuth cancels.

Everything here is linear in the sensor states (the parameters ``names`` of the error state, :mod:`.model`;
the extra groups, the asymmetry's ``|w|`` among them, enter only the total), so the functions return
``(3, n)`` matrices whose columns act on the sensor part of the error state.  The gyro error is the
package's one sensor-error model (:func:`casadi_sins.nav.errorinputs.error_columns`).
Integrals are by 6-point Gauss-Legendre quadrature on sub-intervals of at most 5 deg of a turn:
the integrands are trigonometric polynomials of the angle, integrated to round-off.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.earth import Site
from ...model.registry import GYRO_BIAS, N_PARAMS
from ...nav.errorinputs import body_motion, error_columns
from ...sim.motion import MotionPiece
from . import model as M
from .schemes import Scheme, period_pieces, scheme_pieces, still

_GX, _GW = np.polynomial.legendre.leggauss(6)
#: The parts of the gyro error: all of it, the biases, the scale and misalignment terms of the Earth rate
#: and those of the table rate.
PARTS = ("total", "bias", "earth", "table")


def _integrand(piece: MotionPiece, site: Site, tau: np.ndarray, part: str, names) -> np.ndarray:
    """``C(t) d(d_w)/dx`` (N, 3, n) at times ``tau`` into the piece, for one part of the error."""
    times = piece.t0 + tau
    c = piece.attitude_at(times)
    table = piece.turn_rate(times)
    rate, force, rest = body_motion(c, site.earth_rate, site.g, table)
    if part == "bias":
        j = np.zeros((len(tau), 3, len(names)))
        j[:, :, GYRO_BIAS] = np.eye(3)
    else:
        j = error_columns(names, {"total": rate, "earth": rest, "table": table}[part], force, rest)[0]
        if part != "total":  # bias and the extra groups only in their own part / the total
            j[:, :, GYRO_BIAS] = 0.0
            j[:, :, N_PARAMS:] = 0.0
    return c @ j


def nav_frame_error(piece: MotionPiece, site: Site, tau: np.ndarray, part: str = "total",
                    names=M.SHEET_NAMES) -> np.ndarray:
    """``C(t) d(d_w)/dx`` (N, 3, n) at times ``tau`` into a piece: the gyro error in the navigation frame."""
    return _integrand(piece, site, np.atleast_1d(np.asarray(tau, dtype=float)), part, names)


def quadrature(piece: MotionPiece, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights over ``[0, length]`` of a piece: 6-point Gauss-Legendre on at most 5 deg of a turn."""
    n = 1 if piece.axis is None else max(1, math.ceil(abs(piece.angle) / piece.duration * length / math.radians(5.0)))
    edges = np.linspace(0.0, length, n + 1)
    a, b = edges[:-1, None], edges[1:, None]
    return ((a + b) / 2 + (b - a) / 2 * _GX[None]).ravel(), ((b - a) / 2 * _GW[None]).ravel()


def piece_integral(piece: MotionPiece, site: Site, part: str = "total", upto: float | None = None,
                   names=M.SHEET_NAMES) -> np.ndarray:
    """``int_0^upto C(t) d(d_w)/dx dt`` over a piece (3, n), s * (rad/s per unit state)."""
    length = piece.duration if upto is None else upto
    if length <= 0:
        return np.zeros((3, len(names)))
    tau, weights = quadrature(piece, length)
    return np.einsum("n,nij->ij", weights, _integrand(piece, site, tau, part, names))


def period_integral(scheme: Scheme, site: Site, part: str = "total", names=M.SHEET_NAMES) -> np.ndarray:
    """``int_period C d(d_w)/dx dt`` (3, n) over one period from the start attitude."""
    return sum(piece_integral(p, site, part, names=names) for p in period_pieces(scheme, scheme.start))


def equivalent_drift(scheme: Scheme, site: Site, part: str = "total", names=M.SHEET_NAMES) -> np.ndarray:
    """The constant navigation-frame drift a period leaves per unit of each sensor state (3, n), rad/s.

    Multiply by the sensor part of an error state (the parameters ``names``) for the drift of given errors.
    A strapdown scheme has no period: its drift is the integrand itself.
    """
    if not scheme.steps:
        return _integrand(still(0.0, 1.0, scheme.start), site, np.zeros(1), part, names)[0]
    return period_integral(scheme, site, part, names) / scheme.period


def integrated_error(scheme: Scheme, site: Site, sensor_errors: np.ndarray, hours: float,
                     step_s: float = 1.0, names=M.SHEET_NAMES) -> tuple[np.ndarray, np.ndarray]:
    """``theta^n(t) = int_0^t C d_w dt`` (rad) of given sensor errors (n,): Yu and Ruan's Fig. 6.

    Sampled every ``step_s`` inside each piece and at every piece end.
    """
    times, values, acc = [0.0], [np.zeros(3)], np.zeros(3)
    for piece in scheme_pieces(scheme, hours * 3600.0):
        for tau in np.append(np.arange(step_s, piece.duration, step_s), piece.duration):
            times.append(piece.t0 + tau)
            values.append(acc + piece_integral(piece, site, "total", tau, names) @ sensor_errors)
        acc = values[-1]
    return np.array(times), np.array(values)


def turn_forms(piece: MotionPiece, site: Site, sensor_errors: np.ndarray, samples: int = 64,
               names=M.SHEET_NAMES) -> dict[str, np.ndarray]:
    """Least-squares coefficients of the five forms of Yu and Ruan's eq. 7 in ``C d_w`` over one turn.

    Returns ``{"const", "sin", "cos", "sin2", "cos2"}`` -> (3,) and ``"misfit"`` (largest residual of
    the fit): the error of a turn about a body axis is exactly these five forms of the turned angle.
    """
    tau = np.linspace(0.0, piece.duration, samples)
    alpha = abs(piece.angle) / piece.duration * tau
    y = _integrand(piece, site, tau, "total", names) @ sensor_errors  # (N, 3)
    basis = np.column_stack([np.ones_like(alpha), np.sin(alpha), np.cos(alpha), np.sin(2 * alpha),
                             np.cos(2 * alpha)])
    coef, *_ = np.linalg.lstsq(basis, y, rcond=None)
    out = dict(zip(("const", "sin", "cos", "sin2", "cos2"), coef))
    out["misfit"] = np.abs(basis @ coef - y).max(axis=0)
    return out


def sensor_vector(names=M.SHEET_NAMES, **errors: float) -> np.ndarray:
    """The sensor states of the parameters ``names`` from keyword errors in SI, e.g.
    ``sensor_vector(gyro_scale_x=1e-5)``."""
    x = np.zeros(len(names))
    for name, value in errors.items():
        x[tuple(names).index(name)] = value
    return x
