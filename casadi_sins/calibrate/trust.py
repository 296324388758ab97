"""Whether a calibration's own checks trust its table: the reasons they do not.

A warning is a doubt the user weighs; some findings mean the table is not a calibration of the unit
at all, and it is then not handed over as one (the command line refuses it with exit status 2, or
writes it marked under ``--accept-distrusted``, :mod:`cli.commands`):

* errors outside the model beyond what the model can represent (an unmodelled term at the top of
  its search range, :func:`calibrate.nlp.likelihood.unmodelled_at_bounds`): the sigma does not
  cover them;
* values no unit has: a scale factor that moved more than :data:`SCALE_CHANGE_LIMIT` from its
  start (the 1 g and 90 deg references are good to a few tenths of a per cent), a misalignment
  beyond :data:`MISALIGNMENT_LIMIT`, a value or sigma that is not finite.
"""

from __future__ import annotations

import numpy as np

from ..model.parameters import ParameterSet
from ..model.registry import relative_mask

#: A scale factor further than this (relative) from its starting value is no unit's.
SCALE_CHANGE_LIMIT = 0.1
#: A misalignment beyond this (rad, 5.7 deg) is no unit's: the axes would be mislabelled, not misaligned.
MISALIGNMENT_LIMIT = 0.1


def implausible(params: ParameterSet, initial: ParameterSet) -> list[str]:
    """Reasons a table's values are no unit's (module docstring), one per kind."""
    out = []
    values, names = np.asarray(params.values, dtype=float), list(params.names)
    sigma = params.sigma if params.covariance is not None else np.zeros(len(names))
    bad = [n for n, v, s in zip(names, values, sigma) if not (np.isfinite(v) and np.isfinite(s))]
    if bad:
        out.append(f"not finite: {', '.join(bad)}")
    start = np.asarray(initial.aligned(names), dtype=float)
    scale = relative_mask(names)
    with np.errstate(divide="ignore", invalid="ignore"):
        change = np.where(scale, np.abs(values / start - 1.0), 0.0)
    moved = [f"{n} {c:.3g}" for n, c, s in zip(names, change, scale) if s and c > SCALE_CHANGE_LIMIT]
    if moved:
        out.append(f"scale factors moved from their 1 g / 90 deg starting values by more than "
                   f"{SCALE_CHANGE_LIMIT:g} (relative: {', '.join(moved)}): no unit's")
    misaligned = [f"{n} {abs(v):.3g} rad" for n, v in zip(names, values)
                  if "misalign" in n and abs(v) > MISALIGNMENT_LIMIT]
    if misaligned:
        out.append(f"misalignments beyond {MISALIGNMENT_LIMIT:g} rad ({', '.join(misaligned)}): no unit's")
    return out

