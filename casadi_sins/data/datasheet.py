"""A sensor datasheet: noise terms a recording cannot show (TOML, natural units).

::

    gyro_arw_deg_rth = 0.002            # angle random walk, deg/sqrt(h) (one value, or three per axis)
    accel_vrw_ug_rthz = 15              # velocity random walk, ug/sqrt(Hz)
    gyro_bias_instability_deg_h = 0.002 # Gauss-Markov steady-state 1 sigma ...
    gyro_bias_tau_s = 600               # ... and its correlation time

Any subset of :data:`model.noise.NOISE_KEYS`; the terms not given are estimated from the data.
``*_bias_instability_*`` is the steady-state 1 sigma of a first-order Gauss-Markov bias, one value per
sensor: not the Allan deviation's floor (a Gauss-Markov bias's Allan deviation peaks at 0.617 sigma at
1.89 times its correlation time; a vendor's "bias instability" is often that floor over 0.664).
:func:`datasheet_toml` writes one (``casadi-sins noise``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.errors import InputError, shown
from ..core.toml import read_toml
from ..model.noise import NOISE_CEILINGS, NOISE_KEYS, SensorNoise

#: What each key is, for the comments of a written datasheet.
KEY_NOTES = {
    "gyro_arw_deg_rth": "angle random walk (white rate noise density), deg/sqrt(h), x y z",
    "accel_vrw_ug_rthz": "velocity random walk (white specific-force noise density), ug/sqrt(Hz), x y z",
    "gyro_quantization_arcsec": "angle quantization (white noise of the accumulated angle), arcsec, x y z",
    "accel_quantization_mm_s": "velocity quantization (white noise of the accumulated velocity), mm/s, x y z",
    "gyro_bias_instability_deg_h": "Gauss-Markov bias: steady-state 1 sigma, deg/h (not the Allan floor)",
    "gyro_bias_tau_s": "its correlation time, s",
    "accel_bias_instability_ug": "Gauss-Markov bias: steady-state 1 sigma, ug (not the Allan floor)",
    "accel_bias_tau_s": "its correlation time, s",
}


def read_datasheet(path: str | Path) -> SensorNoise:
    """Read a sensor datasheet (see the module docstring).

    Raises
    ------
    InputError
        Naming the file and the key at fault.
    """
    path = Path(path)
    doc = read_toml(path, "noise datasheet")
    doc = doc.get("noise", doc)
    if not isinstance(doc, dict):
        raise InputError(path, "[noise] must be a table")
    unknown = sorted(set(doc) - set(NOISE_KEYS))
    if unknown:
        raise InputError(path, f"unknown key(s) {shown(', '.join(unknown))}; known: {', '.join(NOISE_KEYS)}")
    for key, value in doc.items():
        values = value if isinstance(value, list) else [value]
        if (len(values) not in (1, 3) or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in values)
                or not all(math.isfinite(v) and v >= 0 for v in values)
                or (key.endswith("_tau_s") and min(values) <= 0) or (len(values) == 3 and "bias" in key)):
            raise InputError(path, f"{key} must be a non-negative number (or 3 for the white and quantization "
                             f"terms), found {shown(value)}")
        if max(values) > NOISE_CEILINGS[key]:
            raise InputError(path, f"{key} {max(values):g} is beyond any inertial sensor (at most "
                             f"{NOISE_CEILINGS[key]:g}): check the unit")
    return SensorNoise.from_natural(doc)


def datasheet_toml(noise: SensorNoise, comments=()) -> str:
    """A datasheet :func:`read_datasheet` reads back: the terms of ``noise`` that are known (a bias's
    correlation time only with its instability), six significant digits, each key with what it is, the
    ``comments`` first."""
    natural = noise.natural()
    lines = [f"# {line}" for text in comments for line in str(text).splitlines()]
    lines += ["# *_bias_instability_* is a first-order Gauss-Markov bias's steady-state 1 sigma, one per sensor",
              "# (its Allan deviation peaks at 0.617 sigma at 1.89 tau); the other terms are per axis x, y, z", ""]
    for key in NOISE_KEYS:
        value = natural[key]
        sensor = key.split("_")[0]
        if value is None or (key.endswith("_tau_s") and getattr(noise, f"{sensor}_bias_instability") is None):
            continue
        values = np.atleast_1d(np.asarray(value, dtype=float))
        text = (f"{float(values[0]):.6g}" if values.size == 1 or "bias" in key
                else "[" + ", ".join(f"{float(v):.6g}" for v in values) + "]")
        lines.append(f"{key} = {text}   # {KEY_NOTES[key]}")
    return "\n".join(lines) + "\n"
