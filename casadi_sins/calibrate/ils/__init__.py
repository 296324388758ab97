"""The paper's reference solver: iterative linear least squares (Kang et al. 2013, section 1)."""

from .solver import calibrate_ils

__all__ = ["calibrate_ils"]
