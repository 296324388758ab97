"""How long a rest must last: from what a static segment must determine, given the measured noise and rate.

A static segment of a description is checked against the data (:func:`data.segmentation.refine`): its
edges are trimmed to the fitted onset of the motion beside them, and what is left must still serve.
What it must determine:

* its **edges**: the onset fit (:mod:`data.edges`) needs :data:`~data.edges.ONSET_REST_S` of rest on
  each side of the line it fits, and a few samples besides;
* its **level**: the mean specific force over the rest gives the attitude the navigation is checked
  against; its noise, ``sigma_dv / sqrt(N)`` (``sigma_dv`` the accelerometer noise per sample measured
  in the rests, from second differences: a sway does not enter), must fix the level within
  :data:`LEVEL_RESOLUTION` of 1 g.

The shortest rest is the larger of the two, or what the user states (``--min-rest-s``).  The report
states the rule and the shortest rest of the recording (the check "shortest rest" of :func:`calibrate.calibrate`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.errors import InputError
from .edges import ONSET_REST_S

#: The level a rest's mean specific force must fix (rad, relative to 1 g): 1 arcmin, a good bubble level's;
#: a rest that averages its noise to less is no reference position at all.
LEVEL_RESOLUTION = math.radians(1.0 / 60.0)
#: Samples a rest needs besides the onset windows (a mean and a spread).
MIN_REST_SAMPLES = 3


@dataclasses.dataclass(frozen=True)
class RestRule:
    """The shortest rest accepted, and why.

    Attributes
    ----------
    seconds : float
        The shortest rest, s.
    reason : str
        One sentence: where the number comes from.
    stated : bool
        Whether the user stated it (an option) rather than the data.
    """

    seconds: float
    reason: str
    stated: bool = False


def accel_noise_per_sample(accel: np.ndarray, slices) -> float:
    """The accelerometer's white noise per sample relative to the resting specific force (1 g): the median
    over the rests of ``std(second difference) / sqrt(6)`` over ``|mean|``; nan without rests."""
    ratios = []
    for sl in slices:
        part = accel[sl]
        if len(part) < 5:
            continue
        level = float(np.linalg.norm(part.mean(axis=0)))
        if level > 0:
            ratios.append(float(np.linalg.norm(np.std(np.diff(part, 2, axis=0), axis=0))) / math.sqrt(6.0) / level)
    return float(np.median(ratios)) if ratios else math.nan


def minimum_rest(rec, stated_s: float | None = None) -> RestRule:
    """The shortest rest a static segment of ``rec`` must keep after trimming (see the module docstring).

    Raises
    ------
    InputError
        When ``stated_s`` is not a positive number.
    """
    if stated_s is not None:
        if not (math.isfinite(stated_s) and stated_s > 0.0):
            raise InputError(None, f"the shortest rest must be a positive number of seconds, found {stated_s!r}")
        return RestRule(float(stated_s), f"{stated_s:g} s as stated (--min-rest-s)", stated=True)
    edges_s = 2.0 * ONSET_REST_S + MIN_REST_SAMPLES * rec.dt
    noise = accel_noise_per_sample(rec.accel, [rec.segment_samples(s) for s in rec.static_segments])
    level_s = (noise / LEVEL_RESOLUTION) ** 2 * rec.dt if math.isfinite(noise) else 0.0
    seconds = max(edges_s, level_s)
    reason = (f"{seconds:.3g} s: the larger of the edges' onset fit ({edges_s:.3g} s at {rec.rate_hz:g} Hz) and the "
              f"level to {math.degrees(LEVEL_RESOLUTION) * 60:.0f} arcmin under the measured accelerometer noise "
              f"({noise * 1e6:.3g} ppm of 1 g per sample: {level_s:.3g} s); --min-rest-s states another")
    return RestRule(seconds, reason)
