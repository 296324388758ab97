"""The paper's rough initial values (section 1.3), computed from the recording itself.

* Accelerometer scale factors from the 1 g reference of the static positions:
  in every static segment ``|diag(S_a) n_bar| = g dt`` for the mean pulses
  per sample ``n_bar``; with ``u_i = S_i^2`` this is linear,
  ``sum_i n_bar_i^2 u_i = (g dt)^2``, and is solved by least squares over
  all static segments (insensitive to the positions' deviations from nominal).
* Gyro scale factors from the 90 deg reference of the rotations: the pulses
  accumulated over a rotation about axis i, less the static rate of the
  segment before it (Earth rate plus bias: the rotation-axis component of
  Earth rate does not change while turning about that axis), correspond to
  the nominal angle.  Averaged over the rotations about each axis.  An axis
  that is never turned falls back to the Earth-rate magnitude of the static
  segments.
* ``K = I``, ``B = 0`` -- except the gyro biases of a unit whose resting gyros read far more than the
  Earth rate, the same in every orientation (a MEMS unit, :func:`data.segmentation.bias_ratio`): their
  rough values are the rests' mean rate (the Earth rate, below their noise, is left in), so that the
  solver does not start degrees per second away.  A navigation-grade unit keeps the paper's ``B = 0``.

A session by hand (rests without orientation letters, moves without a nominal angle), or one whose
accelerometers at rest do not read one magnitude (an offset, as of raw counts), has no nominal angles and no
zero bias to start from: its rough values are fitted to its own rests and moves instead
(:mod:`data.handfit`: the accelerometers' ellipsoid, the rests' mean rate, the gyros that carry each rest's
gravity direction into the next's), so that the solver starts near the answer whatever the offsets.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..core.earth import EARTH_RATE
from ..core.errors import Caution, InputError
from ..core.orientation import parse_axis
from ..data.handfit import BIAS_EARTH_RATIO, rough_values
from ..data.handling import MAX_MISS_DEG, fit_session, rest_means, too_fast
from ..data.recording import Recording
from ..data.segmentation import BIAS_RATIO_LIMIT, bias_ratio
from ..model.parameters import ParameterSet
from ..model.registry import ACCEL_SCALE, GYRO_BIAS, GYRO_SCALE, N_PARAMS


#: A rotation whose pulses off its nominal axis exceed this share of those on it is a move by hand about
#: several axes: its nominal angle sets no rough scale factor while other turns about the axis do.
HANDLING_SHARE = 0.3


def _static_means(rec: Recording, pulses: np.ndarray) -> np.ndarray:
    return np.array([pulses[rec.segment_samples(s)].mean(axis=0) for s in rec.static_segments])


def _magnitude_scale(means: np.ndarray, magnitude: float, what: str, rec: Recording) -> np.ndarray:
    """Scale factors ``S`` with ``|S * n_bar_k| = magnitude`` in the least-squares sense."""
    design = means**2
    strength = np.abs(means).max(axis=0)
    weak = strength < 0.2 * strength.max()
    if weak.any():
        axes = ", ".join("xyz"[i] for i in np.flatnonzero(weak))
        raise InputError(rec.label, f"the {what} axis {axes} never sees a large reference in any static "
                             "segment; its scale factor cannot be set from this schedule")
    u, *_ = np.linalg.lstsq(design, np.full(len(means), magnitude**2), rcond=None)
    if (u <= 0).any():
        raise InputError(rec.label, f"the static segments give no consistent {what} scale factor")
    return np.sqrt(u)


#: Rests whose specific force under the paper's rough accelerometer scale factors (no bias) spreads by more than
#: this share of gravity carry an offset: the rough values are fitted to the data instead.
OFFSET_SPREAD = 0.02


def rough_parameters(rec: Recording) -> ParameterSet:
    """The paper's rough initial values from a recording (section 1.3); a session by hand's, or one with offsets,
    fitted to its rests and moves (module docstring).

    Raises
    ------
    InputError
        A session by hand that cannot be calibrated: too few rests, rests that span too few directions, moves too
        fast for the sample rate (one line saying what to add).
    """
    dt = rec.dt
    means = _static_means(rec, rec.accel)
    if starts_from_the_data(rec):
        return fitted_parameters(rec)
    values = np.zeros(N_PARAMS)
    values[ACCEL_SCALE] = _magnitude_scale(means, rec.site.g * dt, "accelerometer", rec)

    estimates: list[list[float]] = [[], [], []]
    handled: list[list[float]] = [[], [], []]
    for group in rec.group_ids:
        segs = rec.group_segments(group)
        for before, rotation in zip(segs[0::2], segs[1::2]):
            axis = parse_axis(rotation.axis)
            i = int(np.argmax(np.abs(axis)))
            samples = rec.segment_samples(rotation)
            static_rate = rec.gyro[rec.segment_samples(before), i].mean()
            net = rec.gyro[samples, i].sum() - static_rate * (samples.stop - samples.start)
            static = rec.gyro[rec.segment_samples(before)].mean(axis=0)
            nets = rec.gyro[samples].sum(axis=0) - static * (samples.stop - samples.start)  # for the other axes
            if net == 0.0:
                raise InputError(rec.label, f"{rotation.describe()} shows no rotation on gyro {'xyz'[i]}")
            estimate = math.radians(abs(rotation.angle_deg)) / abs(net)
            # a move by hand about several axes, written as its nominal single-axis turn, says little of a scale
            handling = np.linalg.norm(np.delete(nets, i)) > HANDLING_SHARE * abs(net)
            (handled if handling else estimates)[i].append(estimate)
    for i in range(3):
        estimates[i] = estimates[i] or handled[i]
    missing = [i for i in range(3) if not estimates[i]]
    gyro_scale = np.array([np.mean(e) if e else np.nan for e in estimates])
    if missing:
        warnings.warn(f"{rec.label}: no rotation about gyro axis {', '.join('xyz'[i] for i in missing)}; "
                      "its rough scale factor comes from the Earth-rate magnitude (about 1 % accurate)",
                      Caution, stacklevel=2)
        means = _static_means(rec, rec.gyro)
        known = np.nansum((means * np.nan_to_num(gyro_scale)) ** 2, axis=1)
        rest = (EARTH_RATE * dt) ** 2 - known
        for i in missing:
            weight = means[:, i] ** 2
            gyro_scale[i] = math.sqrt(max(np.sum(rest * weight) / np.sum(weight**2), 0.0)) or np.nan
        if np.isnan(gyro_scale).any():
            raise InputError(rec.label, "gyro scale factors cannot be set from this schedule")
    values[GYRO_SCALE] = gyro_scale
    values[GYRO_BIAS] = _large_gyro_bias(rec, gyro_scale)
    return ParameterSet(values)


#: The rests' mean gyro rate known to this share of the horizontal Earth rate or better (their white noise) shows the
#: Earth rate; a unit whose rests read more than :data:`data.handfit.BIAS_EARTH_RATIO` Earth rates, or whose
#: rests' means are noisier, does not resolve it (a MEMS unit).
EARTH_RATE_NOISE_SHARE = 0.1


def resolves_earth_rate(rec: Recording, values: np.ndarray) -> bool:
    """Whether the unit's gyros resolve the Earth rate at rest (navigation grade): the rests' mean rate is of its
    size, and known to a tenth of it over a rest (from the rests' own sample scatter); with ``values`` the rough
    gyro scale factors.  A MEMS unit does not: its g-sensitivity and noise call for another model and start."""
    scale = np.asarray(values)[GYRO_SCALE]
    rates, noise = [], []
    for seg in rec.static_segments:
        part = rec.gyro[rec.segment_samples(seg)] * scale / rec.dt
        rates.append(float(np.linalg.norm(part.mean(axis=0))))
        if len(part) > 2:
            noise.append(float(np.linalg.norm(np.std(np.diff(part, axis=0), axis=0))) / np.sqrt(2.0 * len(part)))
    horizontal = EARTH_RATE * max(math.cos(rec.site.latitude), 0.1)
    return bool(np.median(rates) <= BIAS_EARTH_RATIO * EARTH_RATE
                and (not noise or np.median(noise) <= EARTH_RATE_NOISE_SHARE * horizontal))


def starts_from_the_data(rec: Recording) -> bool:
    """Whether the rough values are fitted to the data (:func:`fitted_parameters`) rather than the paper's: a
    session by hand (a rest without letters or a move without a nominal angle), or accelerometers whose rests read
    no common magnitude (an offset)."""
    return any(s.is_free for s in rec.segments) or _offset(_static_means(rec, rec.accel), rec)


def _offset(means: np.ndarray, rec: Recording) -> bool:
    """Whether the rests' specific force under the paper's rough scale factors spreads by more than
    :data:`OFFSET_SPREAD` of gravity (an offset in the pulses)."""
    design = means**2
    if len(means) < 3 or np.linalg.matrix_rank(design) < 3:
        return False
    u = np.linalg.lstsq(design, np.full(len(means), 1.0), rcond=None)[0]
    if np.any(u <= 0):
        return True
    magnitude = np.sqrt(design @ u)
    return bool(np.ptp(magnitude) > OFFSET_SPREAD)


def fitted_parameters(rec: Recording) -> ParameterSet:
    """Rough values fitted to the recording's own rests and moves (:mod:`data.handfit`); a move whose gravity the
    gyros miss by more than :data:`data.handling.MAX_MISS_DEG` (the chain by measured gravity) is a doubt added to
    ``rec.warnings``.

    Raises
    ------
    InputError
        Naming the recording: too few rests, rests that span too few directions, moves too fast.
    """
    statics = [rec.segment_samples(s) for s in rec.static_segments]
    spans = [(sl.start, sl.stop) for sl in statics]
    try:
        accel_fit, gyro_fit = fit_session(rec.gyro, rec.accel, spans, rec.site.g, rec.dt)
    except InputError as exc:
        raise InputError(rec.label, exc.reason) from None
    moves = [(rec.time[a - 1], rec.time[b] - rec.dt) for (_, a), (b, _) in zip(spans[:-1], spans[1:])]
    reason = too_fast(gyro_fit, moves, rec.rate_hz)
    if reason:
        raise InputError(rec.label, reason)
    missed = [f"{a:.2f}-{b:.2f} s ({m:.3g} deg)" for (a, b), m in zip(moves, gyro_fit.miss_deg) if m > MAX_MISS_DEG]
    if missed:  # the chain by measured gravity: a move the gyros do not carry into the next rest (a doubt, reported)
        doubt = (f"{rec.label}: the gyros carry gravity off the next rest's measured direction in the move(s) at "
                 f"{', '.join(missed[:4])}{', ...' if len(missed) > 4 else ''} (a jolt, the sensor's range exceeded, a "
                 "rest that was none?): check the segments there (casadi-sins segment starts a new group at such a "
                 "move)")
        if doubt not in rec.warnings:
            rec.warnings.append(doubt)
    rest_gyro, weights = rest_means(rec.gyro, spans)
    rest_force = accel_fit.force(rest_means(rec.accel, spans)[0], rec.dt)
    return ParameterSet.from_dict(rough_values(accel_fit, gyro_fit, rec.dt, rest_gyro, rest_force, weights))


def _large_gyro_bias(rec: Recording, gyro_scale: np.ndarray) -> np.ndarray:
    """The rests' length-weighted mean gyro rate (rad/s) when it dwarfs the Earth rate, else zeros."""
    gyro_means, accel_means = _static_means(rec, rec.gyro), _static_means(rec, rec.accel)
    if bias_ratio(gyro_means, accel_means) <= BIAS_RATIO_LIMIT:
        return np.zeros(3)
    lengths = np.array([s.end - s.start for s in rec.static_segments])
    return gyro_scale * (lengths @ gyro_means) / lengths.sum() / rec.dt
