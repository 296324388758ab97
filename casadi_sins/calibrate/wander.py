"""Bias instability without a datasheet: what both solvers decide from the restricted likelihood.

A Gauss-Markov bias whose correlation time is minutes moves the static segments' slopes against each
other; its mean over the recording is a constant bias and cannot be told from one.  When no datasheet
gives a sensor's instability, the solvers measure the wander the static data show (:mod:`noise.wander`)
and decide here:

* the correlation time is half the recording's span (:data:`TAU_FRACTION`: a recording cannot show
  its own correlation time; in issue 16's Monte Carlo, with half the span the mean's variance the
  observed wander implies matched the simulated process within 6 %, a quarter under-covered, the
  whole span over-covered);
* a sensor's term enters the noise model when its likelihood ratio against none exceeds
  :data:`INCLUDE_LR`: one-sided p = 0.005 per sensor (the ratio of a size on the boundary of its range is
  half zero, half chi-square with one degree of freedom), so that a white-noise unit gets a term for either
  sensor in about 1 % of its recordings (:data:`FAMILY_P`).  At p = 0.05 for the accelerometers (issue 16)
  one good unit in twenty had its bias sigmas widened 2.3-6.3 times, a false FAIL against a tolerance sheet's
  sigma limits; a wander that matters for the bias sigma shows with a ratio far above either threshold;
* a warning names the size and the assumed correlation time and asks for the datasheet when the
  ratio exceeds :data:`WARN_LR` (p = 0.0005 per sensor, no warning in 99.9 % of recordings without
  instability: at p = 0.005 the paper's white-noise world gave a warning in 2 of 50 recordings and
  navigation-grade white noise in 1 of 50, where no instability was simulated; an included term below
  the warning is still stated in the report, with its size and ratio).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.units import DEG_PER_H, UG
from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..noise.plan import NoisePlan
from ..noise.wander import SensorWander

#: Static segments are cut into pieces of PIECE_S seconds, or span / MAX_PIECES when that is longer (the
#: wander is slow against span / 40 anyway); every static segment has at least one piece.  Pieces of 50, 75, 100 or 150 s give the restricted
#: likelihood within 1 in ln L of the exact one (the Kalman model with Gauss-Markov states) near its optimum,
#: none of them closer on every recording, and 100 s pieces the same decisions as 50 s ones in 20
#: navigation-grade recordings; 100 s keep a group of the paper's schedule within one compiled filter pass.
PIECE_S = 100.0
MAX_PIECES = 40
TAU_FRACTION = 0.5
#: :data:`TAU_FRACTION` in the words of the warning and the report.
TAU_WORDS = "half the recording"
INCLUDE_LR = {"accel": 6.63, "gyro": 6.63}
#: The probability that a unit without instability gets a term for either sensor (two tests at one-sided 0.005).
FAMILY_P = 0.01
WARN_LR = 10.83
#: The wander is taken for model mismatch when an acceleration constant in each static segment (independent
#: between segments) fits better by this likelihood ratio (the lever arms, quadratic scale factor and time
#: offset of the 19-position peer recording: 41; a true wander, 20 navigation-grade recordings: -6.5 to 2.2).
MISMATCH_LR = 6.63
#: The noise source of an included term.
SOURCE = "static data (restricted likelihood)"


def span_s(rec: Recording) -> float:
    """The recording's span, s."""
    return float(rec.time[-1] - rec.time[0] + rec.dt)


def wander_tau(rec: Recording) -> float:
    """The correlation time assumed for a wander the static data show, s."""
    return TAU_FRACTION * span_s(rec)


def piece_s(rec: Recording) -> float:
    """Longest piece of a static segment in the wander's random effects, s."""
    return max(PIECE_S, span_s(rec) / MAX_PIECES)


def unknown_sensors(noise_plan: NoisePlan) -> list[str]:
    """The sensors whose bias instability no datasheet gives."""
    return [s for s in ("accel", "gyro") if noise_plan.source[f"{s}_bias_instability"] == "not modelled"]


def decide(estimates: dict[str, SensorWander], mismatch: bool = False) -> dict[str, SensorWander]:
    """Mark the terms that enter the noise model (:data:`INCLUDE_LR`; none when ``mismatch``)."""
    for sensor, wander in estimates.items():
        strong = wander.sigma > 0.0 and wander.lr > INCLUDE_LR[sensor]
        wander.included = strong and not mismatch
        wander.mismatch = strong and mismatch
    return estimates


def p_value(lr: float) -> float:
    """One-sided p-value of a wander's likelihood ratio against none: half the chi-square (1 degree of freedom)
    tail, the size being on the boundary of its range under the null (``erfc(sqrt(lr / 2)) / 2``)."""
    return 0.5 * math.erfc(math.sqrt(max(lr, 0.0) / 2.0))


def bias_cost(before: np.ndarray, after: np.ndarray, names, sensor: str) -> float:
    """What an included wander cost: the largest factor by which it widened a bias sigma of ``sensor``
    (``before``/``after`` the covariances of the parameters ``names``, any consistent units)."""
    idx = [list(names).index(f"{sensor}_bias_{axis}") for axis in "xyz"]
    return float(np.max(np.sqrt(np.diag(after)[idx] / np.diag(before)[idx])))


def with_wander(model: SensorNoise, estimates: dict[str, SensorWander]) -> SensorNoise | None:
    """``model`` with the included terms as Gauss-Markov biases (``None`` when none is included)."""
    included = {s: w for s, w in estimates.items() if w.included}
    if not included:
        return None
    out = dataclasses.replace(model)
    for sensor, wander in included.items():
        setattr(out, f"{sensor}_bias_instability", wander.sigma)
        setattr(out, f"{sensor}_bias_tau", wander.tau)
    return out


def record(noise_plan: NoisePlan, estimates: dict[str, SensorWander]) -> None:
    """The included terms' source in the noise plan."""
    for sensor, wander in estimates.items():
        if wander.included:
            noise_plan.source[f"{sensor}_bias_instability"] = SOURCE


#: Per sensor: its name in a sentence, and the natural unit of its bias and wander with the SI size of one.
SENSOR_WORDS = {"accel": ("accelerometers", "ug", UG), "gyro": ("gyros", "deg/h", DEG_PER_H)}


def natural_size(sensor: str, value: float) -> str:
    """A wander's size in natural units (ug, deg/h)."""
    _, unit, scale = SENSOR_WORDS[sensor]
    return f"{value / scale:.3g} {unit}"


def describe(estimates: dict[str, SensorWander]) -> str | None:
    """The warning when the static data show bias instability without a datasheet (``None`` when not)."""
    parts = [f"{SENSOR_WORDS[s][0]} {natural_size(s, w.sigma)} (likelihood ratio "
             f"{w.lr:.3g}{'; at the ceiling of the search: not bounded by the data' if w.at_ceiling else ''})"
             for s, w in estimates.items() if w.included and w.lr > WARN_LR]
    if not parts:
        return None
    tau = next(iter(estimates.values())).tau
    cost = max(w.cost for w in estimates.values() if w.included)
    widened = f" (up to {cost:.3g} times wider)" if cost > 1.0 else ""
    return (f"the static data show bias instability beyond the white noise and no datasheet gives it: "
            f"{', '.join(parts)}, modelled as a Gauss-Markov wander with an assumed correlation time of {tau:.0f} s "
            f"({TAU_WORDS}, which cannot show its own); the bias sigmas include it{widened}. Give the datasheet's "
            "bias instability (--noise) for a founded value")
