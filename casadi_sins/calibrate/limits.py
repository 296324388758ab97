"""The statistical limits of every check of a fit against its noise model (both solvers).

Under a right noise model the whitened residuals are independent with unit variance; a variance
factor with ``dof`` degrees of freedom then lies below its chi-square 99.9 % point.  The model's own
approximations get a tolerance on top.
"""

from __future__ import annotations

import numpy as np

#: Relative tolerance of the noise model on top of the sampling error of a variance factor.
MODEL_TOLERANCE = 0.15
#: Standard normal quantile of the checks (99.9 %, one-sided).
Z_LIMIT = 3.1


def factor_limit(dof: float) -> float:
    """Upper limit of a variance factor with ``dof`` degrees of freedom (chi-square, 99.9 %, plus the model
    tolerance)."""
    return 1.0 + Z_LIMIT * np.sqrt(2.0 / max(dof, 1.0)) + MODEL_TOLERANCE
