"""A sensor datasheet: noise terms a recording cannot show (TOML, natural units).

::

    gyro_arw_deg_rth = 0.002            # angle random walk, deg/sqrt(h) (one value, or three per axis)
    accel_vrw_ug_rthz = 15              # velocity random walk, ug/sqrt(Hz)
    gyro_bias_instability_deg_h = 0.002 # Gauss-Markov steady-state 1 sigma ...
    gyro_bias_tau_s = 600               # ... and its correlation time

Any subset of :data:`model.noise.NOISE_KEYS`; the terms not given are estimated from the data.
"""

from __future__ import annotations

import math
from pathlib import Path

from ..core.errors import InputError, shown
from ..core.toml import read_toml
from ..model.noise import NOISE_CEILINGS, NOISE_KEYS, SensorNoise


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
