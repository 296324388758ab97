"""Unit conversions at the edges: natural units (ug, deg/h, ppm, arcsec) <-> SI."""

from __future__ import annotations

import numpy as np

from .frames import G0

ARCSEC = np.pi / (180.0 * 3600.0)
DEG = np.pi / 180.0
DEG_PER_H = DEG / 3600.0
UG = 1e-6 * G0
MG = 1e-3 * G0
PPM = 1e-6

#: Multipliers from a unit name to SI, for every unit a table or problem file may use.
TO_SI = {
    "m/s^2": 1.0,
    "ug": UG,
    "mg": MG,
    "rad/s": 1.0,
    "deg/h": DEG_PER_H,
    "deg/s": DEG,
    "rad": 1.0,
    "arcsec": ARCSEC,
    "deg": DEG,
    "m/s/pulse": 1.0,
    "rad/pulse": 1.0,
    "deg/pulse": DEG,
    "arcsec/pulse": ARCSEC,
    "s^2/m": 1.0,
    "ug/g^2": 1e-6 / G0,
    "m": 1.0,
    "mm": 1e-3,
    "cm": 1e-2,
    "s": 1.0,
    "ms": 1e-3,
}


def to_si(value, unit: str):
    """Convert ``value`` given in ``unit`` to SI; ``KeyError`` names unknown units."""
    try:
        return np.asarray(value, dtype=float) * TO_SI[unit]
    except KeyError:
        raise KeyError(f"unknown unit {unit!r}; known: {', '.join(TO_SI)}") from None
