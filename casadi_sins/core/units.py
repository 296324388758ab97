"""Natural units at the edges (ug, deg/h, ppm, arcsec, ...) and their size in SI.

Everything inside the package is SI (rad, rad/s, m/s^2); these constants convert at the edges:
reports, tables, plots, and the scaling of decision variables.
"""

from __future__ import annotations

import numpy as np

from .earth import G0

ARCSEC = np.pi / (180.0 * 3600.0)
DEG = np.pi / 180.0
DEG_PER_H = DEG / 3600.0
UG = 1e-6 * G0
MG = 1e-3 * G0
PPM = 1e-6
#: 1 deg/sqrt(h) (angle random walk) in rad/sqrt(s).
ARW_UNIT = DEG / 60.0
#: 1 ug/sqrt(Hz) (velocity random walk) in m/s/sqrt(s).
VRW_UNIT = UG

#: Multipliers from a unit name to SI, for every unit a table or problem file may use, and its dimension.
UNITS = {
    "m/s^2": (1.0, "acceleration"), "ug": (UG, "acceleration"), "mg": (MG, "acceleration"),
    "rad/s": (1.0, "rate"), "deg/h": (DEG_PER_H, "rate"), "deg/s": (DEG, "rate"),
    "rad": (1.0, "angle"), "arcsec": (ARCSEC, "angle"), "deg": (DEG, "angle"),
    "m/s/pulse": (1.0, "velocity per pulse"),
    "rad/pulse": (1.0, "angle per pulse"), "deg/pulse": (DEG, "angle per pulse"),
    "arcsec/pulse": (ARCSEC, "angle per pulse"),
    "s^2/m": (1.0, "quadratic scale"), "ug/g^2": (1e-6 / G0, "quadratic scale"),
    "m": (1.0, "length"), "mm": (1e-3, "length"), "cm": (1e-2, "length"),
    "s": (1.0, "time"), "ms": (1e-3, "time"),
    "rad/s/(m/s^2)": (1.0, "g-sensitivity"), "deg/h/g": (DEG_PER_H / G0, "g-sensitivity"),
    "ratio": (1.0, "ratio"), "ppm": (PPM, "ratio"),
}  # fmt: skip
#: Multiplier from a unit name to SI.
TO_SI = {name: factor for name, (factor, _) in UNITS.items()}


def dimension_of(unit: str) -> str:
    """The physical dimension of a unit name (``"ug"`` -> ``"acceleration"``); ``KeyError`` if unknown."""
    return UNITS[unit][1]
