"""Matrix functions of SciPy, imported when first used (SciPy's import costs 0.2 s that a calibration
does not need)."""

from __future__ import annotations

import numpy as np


def expm(matrix: np.ndarray) -> np.ndarray:
    """The matrix exponential (``scipy.linalg.expm``)."""
    from scipy.linalg import expm as scipy_expm

    return scipy_expm(matrix)
