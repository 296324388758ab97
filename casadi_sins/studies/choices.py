"""The choices the studies' commands offer, light enough for ``casadi-sins --help`` (the studies take them
from here)."""

from __future__ import annotations

#: Criteria of a schedule design (:mod:`studies.design.criteria`): log det of the predicted covariance, its
#: trace, the worst sigma ratio, the navigation error.
DESIGN_CRITERIA = ("d", "a", "worst", "navigation")
#: Criteria of a rotation-scheme design (:mod:`studies.modulation.design`): the largest horizontal position
#: error, the largest horizontal velocity error, the position error at the end.
SCHEME_CRITERIA = ("position", "velocity", "final")
