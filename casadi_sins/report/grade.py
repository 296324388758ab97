"""What a unit of this grade, on this schedule, can and cannot determine: a section of the report.

The Earth rate is a reference only when the gyros resolve it: its horizontal part at the site against
the uncertainty of the gyro biases the calibration reaches.  When the biases are known to no better
than :data:`EARTH_RATE_SHARE` of it (a MEMS unit: a bias of degrees per second, noise of degrees per
hour over a rest), the heading is not observed, the gyro biases come from the rests (their mean rates)
and the gyro scale factors and misalignments from the turns only: the attitude a turn leaves, seen by
gravity in the next rest.  A turn about the vertical shows nothing of its angle then, so a gyro axis
never turned while horizontal has its scale factor from the other turns' cross-coupling at best; the
schedule says which axes those are.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.earth import EARTH_RATE
from ..core.orientation import parse_axis
from ..core.units import DEG_PER_H
from ..model.output import compensate
from ..model.registry import GYRO_BIAS, GYRO_SCALE, N_PARAMS

#: The gyro bias sigma, as a share of the horizontal Earth rate, above which the Earth rate is no reference.
EARTH_RATE_SHARE = 0.1
#: A turn faster than this per sample (deg) is navigated with errors beyond the model: the strapdown step's
#: coning and sculling terms and the sensors' own filtering are built for a small angle per sample.
STEP_ANGLE_DEG = 1.0


#: A free move turns a gyro axis while it is horizontal when it turns about it by more than this (deg) and the axis
#: lies within :data:`LEVEL_DEG` of level in the rest before (gravity measured by the calibrated accelerometers).
FREE_TURN_DEG = 45.0
LEVEL_DEG = 45.0


def horizontal_turns(rec, values=None) -> dict[str, int]:
    """Per gyro axis, the rotations about it that start with that axis horizontal: the turns whose angle gravity
    sees.  A turn with letters counts when the letter of the static before is N, S, E or W; a free move (a session
    by hand) by the measured gravity direction of the rest before and the compensated rates of the move
    (``values``: the calibrated parameters), for every axis it turns by more than :data:`FREE_TURN_DEG`."""
    count = {axis: 0 for axis in "xyz"}
    for group in rec.group_ids:
        segs = rec.group_segments(group)
        for before, rotation in zip(segs[0::2], segs[1::2]):
            if before.is_free or rotation.is_free:
                if values is not None:
                    for i in _free_turn_axes(rec, before, rotation, values):
                        count["xyz"[i]] += 1
                continue
            i = int(np.argmax(np.abs(parse_axis(rotation.axis))))
            if before.orientation[i] in "NSEW":
                count["xyz"[i]] += 1
    return count


def _free_turn_axes(rec, before, move, values) -> list[int]:
    """The gyro axes a free move turns by more than :data:`FREE_TURN_DEG` while level within :data:`LEVEL_DEG` in
    the rest before (the body's turn about each axis, from the compensated rates)."""
    rest, sl = rec.segment_samples(before), rec.segment_samples(move)
    _, dv = compensate(rec.gyro[rest], rec.accel[rest], values, rec.dt)
    up = dv.sum(axis=0) / max(float(np.linalg.norm(dv.sum(axis=0))), 1e-300)
    dtheta, _ = compensate(rec.gyro[sl], rec.accel[sl], values, rec.dt)
    turned = np.degrees(np.abs(dtheta.sum(axis=0)))
    return [i for i in range(3) if turned[i] > FREE_TURN_DEG and abs(up[i]) < math.sin(math.radians(LEVEL_DEG))]


def grade_data(params, rec) -> dict:
    """The determinability statement as plain data: the horizontal Earth rate, the gyro bias sigma, whether
    the Earth rate is a reference, the turns each gyro axis has while horizontal, and the sentences."""
    horizontal = EARTH_RATE * math.cos(rec.site.latitude)
    sigma = params.sigma[GYRO_BIAS] if params.sigma is not None else np.full(3, np.nan)
    worst = float(np.nanmax(sigma)) if np.isfinite(sigma).any() else math.nan
    reference = bool(math.isfinite(worst) and worst < EARTH_RATE_SHARE * horizontal)
    turns = horizontal_turns(rec, params.values[:N_PARAMS])
    sentences = []
    if reference:
        sentences.append(f"The gyros resolve the Earth rate ({horizontal / DEG_PER_H:.3g} deg/h horizontal here; gyro "
                         f"bias sigma up to {worst / DEG_PER_H:.3g} deg/h): it is a reference at rest, the heading is "
                         "observed, and the gyro errors show in the static segments as well as in the turns.")
    else:
        sentences.append(
            f"The Earth rate ({horizontal / DEG_PER_H:.3g} deg/h horizontal here) is below what this unit's gyros "
            f"resolve (bias sigma up to {worst / DEG_PER_H:.3g} deg/h): no reference at rest and the heading is not "
            "observed. Gyro biases come from the rests (their mean rates); gyro scale factors and misalignments from "
            "the turns only, through the attitude each turn leaves, seen by gravity in the next rest; the "
            "accelerometers' parameters from gravity in the rests. Turns about the vertical show nothing of their "
            "angle.")
    blind = [axis for axis, n in turns.items() if n == 0]
    if blind and not reference:
        sentences.append(f"Gyro axis {', '.join(blind)} is never turned while horizontal: its scale factor is not "
                         "determined by this schedule beyond what other turns couple into it; turn the unit about it "
                         "with the axis level.")
    step = float(np.degrees(np.max(np.abs(rec.gyro) * params.values[GYRO_SCALE]))) if len(rec.gyro) else 0.0
    if step > STEP_ANGLE_DEG:
        sentences.append(f"The turns reach {step:.3g} deg per sample ({step * rec.rate_hz:.3g} deg/s at "
                         f"{rec.rate_hz:g} Hz): their navigation (coning, the sensors' own filtering) errs beyond the "
                         "model, which weighs on the gyro scale factors and misalignments; turn slower or sample faster.")
    return {"horizontal_earth_rate_deg_h": horizontal / DEG_PER_H, "largest_turn_per_sample_deg": step,
            "gyro_bias_sigma_deg_h": worst / DEG_PER_H if math.isfinite(worst) else None,
            "earth_rate_reference": reference, "horizontal_turns": turns, "sentences": sentences}


def grade_markdown(grade: dict | None) -> list[str]:
    """The section of the Markdown report."""
    if not grade:
        return []
    counts = ", ".join(f"{axis} {n}" for axis, n in grade["horizontal_turns"].items())
    return (["", "## What this unit and schedule determine", ""] + [f"- {s}" for s in grade["sentences"]]
            + [f"- turns about each gyro axis while it is horizontal: {counts}"])
