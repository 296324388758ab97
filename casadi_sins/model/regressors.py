"""The regressor layout: per-step sums of the compensated samples that the extra groups' corrections use.

A group names the regressor blocks it reads (:attr:`model.groups.base.ParameterGroup.regressors`); a
parameter model's step data carries the blocks its groups need, in the fixed order of :data:`BLOCKS`
(:func:`layout`).  Per sample ``k`` of length ``dt``, with ``dtheta_k``, ``dv_k`` compensated with
reference parameters, ``w_k = dtheta_k / dt``, ``a_k = dv_k / dt``:

=====  ====  ==========================================================================
block  rows  per-sample value (summed over a step's samples)
=====  ====  ==========================================================================
Q2     3     ``a_k^2 dt`` per axis (quadratic scale)
P2     3     ``a_x a_y dt, a_x a_z dt, a_y a_z dt`` (cross-quadratic terms)
X      3     ``(dtheta_k - w_s dt) x dv_k / dt`` (time offset; ``w_s`` the rate at rest)
DW     3     the rate change over the step, ``w(end) - w(start)`` (boundary rates, not a sum)
M      6     ``(w w^T - |w|^2 I) dt``: xx, yy, zz, xy, xz, yz (centripetal)
=====  ====  ==========================================================================
"""

from __future__ import annotations

import numpy as np

#: The blocks in data order, with their number of rows.
BLOCKS = {"Q2": 3, "P2": 3, "X": 3, "DW": 3, "M": 6}
#: Row of each (i, j) entry of the M block (i <= j).
M_ROW = {(0, 0): 0, (1, 1): 1, (2, 2): 2, (0, 1): 3, (0, 2): 4, (1, 2): 5}
#: Row of each product (j, k) (j < k) of the P2 block.
P2_ROW = {(0, 1): 0, (0, 2): 1, (1, 2): 2}


def layout(blocks) -> dict[str, slice]:
    """Rows of each needed block in a step's regressor array, in the order of :data:`BLOCKS`."""
    out, start = {}, 0
    for name, size in BLOCKS.items():
        if name in blocks:
            out[name] = slice(start, start + size)
            start += size
    return out


def size(blocks) -> int:
    """Number of regressor rows of the given blocks."""
    return sum(BLOCKS[b] for b in BLOCKS if b in blocks)


def sample_rows(dtheta: np.ndarray, dv: np.ndarray, dt: float, blocks, static_rate=None) -> np.ndarray:
    """Per-sample regressors (N, size) of the given blocks (the DW rows zero: they come from boundary rates)."""
    rows = layout(blocks)
    out = np.zeros((len(dtheta), size(blocks)))
    w = dtheta / dt
    if "Q2" in rows:
        out[:, rows["Q2"]] = dv**2 / dt
    if "P2" in rows:
        for (j, k), r in P2_ROW.items():
            out[:, rows["P2"].start + r] = dv[:, j] * dv[:, k] / dt
    if "X" in rows:
        turn = dtheta if static_rate is None else dtheta - static_rate * dt
        out[:, rows["X"]] = np.cross(turn, dv) / dt
    if "M" in rows:
        sq = np.sum(w * w, axis=1)
        for (i, j), r in M_ROW.items():
            out[:, rows["M"].start + r] = (w[:, i] * w[:, j] - (sq if i == j else 0.0)) * dt
    return out


def boundary_rates(dtheta: np.ndarray, dt: float) -> np.ndarray:
    """(N + 1, 3) the rate at the start of each sample (``N``: the end), ``(w_k-1 + w_k) / 2``."""
    w = dtheta / dt
    padded = np.vstack([w[:1], w, w[-1:]])
    return 0.5 * (padded[:-1] + padded[1:])


def step_rows(per_sample: np.ndarray, boundary_rate: np.ndarray, first: np.ndarray, stop: np.ndarray,
              blocks) -> np.ndarray:
    """Regressors (size, M) of steps covering samples ``first[j]:stop[j]``."""
    cumulative = np.vstack([np.zeros(per_sample.shape[1]), np.cumsum(per_sample, axis=0)])
    out = (cumulative[stop] - cumulative[first]).T
    rows = layout(blocks)
    if "DW" in rows:
        out[rows["DW"]] = (boundary_rate[stop] - boundary_rate[first]).T
    return out
