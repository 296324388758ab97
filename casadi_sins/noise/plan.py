"""The noise model of one calibration and where each of its terms came from.

Terms come from a datasheet when given, else from the raw data when they determine them, else from
the fit (white noise hidden under coarse pulses, bounded by the raw data).  A counter's quantization
is known: its integer pulses carry the remainder, one pulse / sqrt(12).  Bias instability comes
from a datasheet; without one the solvers measure the wander the static data show
(:mod:`calibrate.wander`) and the report says what they found.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.units import ARW_UNIT, VRW_UNIT
from ..data.recording import Recording
from ..model.noise import ACCEL_VRW_FLOOR, GYRO_ARW_FLOOR, SensorNoise
from .motion import SegmentMotion, base_motion, static_increments
from .raw import RawNoise, estimate_sensor_noise
from .translation import LinearMotion, linear_motion

#: The source of a counter's quantization: its integer pulses carry the remainder, one pulse / sqrt(12).
COUNTER_SOURCE = "integer pulses (1 pulse / sqrt(12))"


@dataclasses.dataclass
class NoisePlan:
    """The noise model of a calibration and where each term came from."""

    raw: RawNoise
    given: SensorNoise  # datasheet terms (None where not given)
    model: SensorNoise  # in use: given, else raw where determined, else fitted
    source: dict[str, str]  # term -> "datasheet" | "raw data" | COUNTER_SOURCE | "fit" | "not modelled"
    motions: list[SegmentMotion]
    warnings: list[str] = dataclasses.field(default_factory=list)  # a datasheet the data contradict
    linear: LinearMotion | None = None  # the base's linear motion (a deck's heave and surge)

    def free_terms(self) -> dict[str, list[str]]:
        """Terms the fit must set, by residual kind they show in most."""
        return {"velocity": [t for t in ("accel_vrw",) if self.source[t] == "fit"],
                "gyro": [t for t in ("gyro_arw",) if self.source[t] == "fit"]}


def plan_noise(rec: Recording, reference: np.ndarray, given: SensorNoise | None = None) -> NoisePlan:
    """Raw-data noise estimate, merged with a datasheet; base motion (sway and linear motion)."""
    raw = estimate_sensor_noise(rec, reference)
    given = given or SensorNoise()
    determined = raw.model()
    given, warnings = _check_datasheet(given, determined, raw)
    bounds = raw.upper_bounds()
    model = SensorNoise(
        gyro_arw=_first(given.gyro_arw, determined.gyro_arw, np.maximum(bounds.gyro_arw, GYRO_ARW_FLOOR)),
        accel_vrw=_first(given.accel_vrw, determined.accel_vrw, np.maximum(bounds.accel_vrw, ACCEL_VRW_FLOOR)),
        gyro_quantization=_first(given.gyro_quantization, determined.gyro_quantization),
        accel_quantization=_first(given.accel_quantization, determined.accel_quantization),
        gyro_bias_instability=given.gyro_bias_instability or 0.0, gyro_bias_tau=given.gyro_bias_tau,
        accel_bias_instability=given.accel_bias_instability or 0.0, accel_bias_tau=given.accel_bias_tau)
    model.gyro_arw = np.maximum(model.gyro_arw, GYRO_ARW_FLOOR)
    model.accel_vrw = np.maximum(model.accel_vrw, ACCEL_VRW_FLOOR)

    def source(given_value, determined_value):
        return "datasheet" if given_value is not None else ("raw data" if determined_value is not None else "fit")

    sources = {"gyro_arw": source(given.gyro_arw, determined.gyro_arw),
               "accel_vrw": source(given.accel_vrw, determined.accel_vrw),
               "gyro_quantization": _quantization_source(given.gyro_quantization, raw.counter.get("gyro", False)),
               "accel_quantization": _quantization_source(given.accel_quantization, raw.counter.get("accel", False)),
               "gyro_bias_instability": "datasheet" if given.gyro_bias_instability is not None else "not modelled",
               "accel_bias_instability": "datasheet" if given.accel_bias_instability is not None else "not modelled"}
    increments = static_increments(rec, reference)
    motions = base_motion(rec, reference, model, increments)
    return NoisePlan(raw, given, model, sources, motions, warnings, linear_motion(rec, reference, model, increments))


def _quantization_source(given_value, counter: bool) -> str:
    """Where a quantization term came from: a datasheet, a counter's pulse (known), or the raw data's fit."""
    if given_value is not None:
        return "datasheet"
    return COUNTER_SOURCE if counter else "raw data"


#: A datasheet's white-noise density more than this factor away from the raw data's determined estimate
#: contradicts the data (the estimate is within a few per cent; datasheets round, units differ by 60).
DATASHEET_TOLERANCE = 2.0


def _check_datasheet(given: SensorNoise, determined: SensorNoise, raw: RawNoise) -> tuple[SensorNoise, list[str]]:
    """Datasheet white-noise terms the raw data contradict are replaced by the data's, with a warning naming both."""
    warnings = []
    given = dataclasses.replace(given)
    for term, label, unit, scale in (("gyro_arw", "angle random walk", "deg/sqrt(h)", ARW_UNIT),
                                     ("accel_vrw", "velocity random walk", "ug/sqrt(Hz)", VRW_UNIT)):
        stated, measured = getattr(given, term), getattr(determined, term)
        if stated is None or measured is None or not np.all(measured > 0):
            continue
        ratio = float(np.max(np.maximum(stated / measured, measured / np.maximum(stated, 1e-300))))
        if ratio > DATASHEET_TOLERANCE:
            warnings.append(f"the datasheet's {label} {np.mean(stated) / scale:.3g} {unit} contradicts the "
                            f"{np.mean(measured) / scale:.3g} {unit} measured in the raw data ({ratio:.3g} times): "
                            "the measured value is used (check the datasheet's units and the unit)")
            setattr(given, term, None)
    return given, warnings


def _first(*values):
    for value in values:
        if value is not None:
            return np.asarray(value, dtype=float).copy()
    return None
