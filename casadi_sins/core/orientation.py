"""Orientation letters and body axes: how a recording names positions and turns.

An orientation is three letters, the directions of body x, y, z in the local-level frame
(``"NUE"``: x North, y Up, z East; letters N S E W U D).  A rotation axis is a signed body axis
(``"+X"`` ... ``"-Z"``, right-hand rule).
"""

from __future__ import annotations

import numpy as np

from .rotations import rotation_matrix

DIRECTIONS = {
    "E": np.array([1.0, 0.0, 0.0]),
    "W": np.array([-1.0, 0.0, 0.0]),
    "N": np.array([0.0, 1.0, 0.0]),
    "S": np.array([0.0, -1.0, 0.0]),
    "U": np.array([0.0, 0.0, 1.0]),
    "D": np.array([0.0, 0.0, -1.0]),
}
AXES = {"X": 0, "Y": 1, "Z": 2}
#: The axis strings exactly as the recording format spells them.
AXIS_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")


class OrientationError(ValueError):
    """An orientation or axis string that does not describe a valid frame."""


def orientation_to_dcm(letters: str) -> np.ndarray:
    """Attitude ``C_b^n`` (ENU) of an orientation given as three direction letters.

    Parameters
    ----------
    letters : str
        Directions of body x, y and z, each one of ``N S E W U D``, e.g. ``"NUE"``.

    Returns
    -------
    ndarray, shape (3, 3)
        Columns are the body axes in ENU.

    Raises
    ------
    OrientationError
        Unknown letters, or axes that do not form a right-handed frame.
    """
    if not isinstance(letters, str) or len(letters) != 3:
        raise OrientationError(f"orientation {str(letters)[:40]!r} must be three letters of N S E W U D")
    unknown = [c for c in letters.upper() if c not in DIRECTIONS]
    if unknown:
        raise OrientationError(
            f"orientation {letters!r} has unknown letter(s) {''.join(unknown)!r}; use N S E W U D"
        )
    dcm = np.column_stack([DIRECTIONS[c] for c in letters.upper()])
    det = np.linalg.det(dcm)
    if abs(det - 1.0) > 1e-9:
        kind = "left-handed" if abs(det + 1.0) < 1e-9 else "degenerate (repeated axis)"
        raise OrientationError(f"orientation {letters!r} is not a right-handed frame ({kind})")
    return dcm


def dcm_to_orientation(dcm, tol_deg: float = 20.0) -> str:
    """Nearest orientation letters of an attitude; error if an axis is off by more than ``tol_deg``."""
    letters = []
    for col in np.asarray(dcm).T:
        best = max(DIRECTIONS, key=lambda k: float(DIRECTIONS[k] @ col))
        if DIRECTIONS[best] @ col < np.cos(np.radians(tol_deg)):
            raise OrientationError("attitude is not near any orientation of the letters N S E W U D")
        letters.append(best)
    return "".join(letters)


def parse_axis(axis: str) -> np.ndarray:
    """Unit vector in body coordinates of an axis string ``"+X"`` ... ``"-Z"`` (sign required)."""
    if not isinstance(axis, str) or axis not in AXIS_NAMES:
        raise OrientationError(f"rotation axis {str(axis)[:40]!r} is not one of {' '.join(AXIS_NAMES)}")
    v = np.zeros(3)
    v[AXES[axis[1]]] = -1.0 if axis[0] == "-" else 1.0
    return v


def rotate_body(dcm, axis: str | np.ndarray, angle_rad: float) -> np.ndarray:
    """Attitude after turning the body about its own ``axis`` by ``angle_rad``: ``C R(axis, angle)``."""
    vec = parse_axis(axis) if isinstance(axis, str) else axis
    return np.asarray(dcm) @ rotation_matrix(vec, angle_rad)
