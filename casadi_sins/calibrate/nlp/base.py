"""The base's velocity on a moving base: free, band-limited nuisance variables of the velocity residuals.

The navigated velocity of a unit on a deck carries the deck's velocity: ``v_base(t) - v_base(t_0)``,
``t_0`` the group's start.  The first term is bounded and band-limited, at the periods the specific
force shows (:mod:`noise.translation`); the second is a constant of the group.  Both are given to the
base as nuisance variables, estimated with the parameters and projected out of their information:

* per group, a constant velocity (ENU, three variables);
* per ENU axis and band of the motion ``[f_c - W, f_c + W]``, the band's signals over the recording:
  the first Slepian sequences of half-bandwidth ``W`` over the recording's time (:func:`slepians`,
  ``2 W T +`` :data:`EXTRA_SEQUENCES` of them: any signal of the band, a line anywhere in it included,
  lies in their span to 2e-5 of its size), times ``cos`` and ``sin`` of ``2 pi f_c t``, read at the
  velocity observations.

A bounded motion at those periods then leaves no trace in the parameters (a plain fit of the
velocity leaks about 9 ug of a deck's heave into every static's tilt): what it costs is the
velocity's information within the bands, a narrow share of it.  The variables are in mm/s.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ...noise.observations import ObservationKind

#: The nuisance variables' unit (m/s): mm/s.
NUISANCE_UNIT = 1e-3
#: Slepian sequences per band beyond ``2 W T``: then a line anywhere in a band of a few of the recording's
#: frequency bins lies in their span to 2e-5 of its size (a line of 0.15 m/s leaves 3 um/s, far below the
#: velocity noise), at the edge of a band of 25 bins to 3e-4 (6 more instead of 8 left 3e-3).
EXTRA_SEQUENCES = 8
#: Grid of the Slepian sequences over the recording (s), interpolated at the observations.
SEQUENCE_STEP_S = 0.5


@functools.lru_cache(maxsize=64)
def slepians(n: int, nw: float, count: int) -> np.ndarray:
    """The first ``count`` discrete prolate spheroidal sequences of ``n`` points and time-half-bandwidth ``nw``
    (n, count), unit norm (read-only): the eigenvectors of their tridiagonal form (Percival and Walden,
    section 8.3)."""
    from scipy.linalg import eigh_tridiagonal  # imported here: only a moving base needs it

    k = np.arange(n)
    diagonal = ((n - 1 - 2.0 * k) / 2.0) ** 2 * np.cos(2.0 * np.pi * nw / n)
    off = k[1:] * (n - k[1:]) / 2.0
    count = min(count, n)
    vectors = eigh_tridiagonal(diagonal, off, select="i", select_range=(n - count, n - 1))[1][:, ::-1]
    vectors = np.ascontiguousarray(vectors)
    vectors.flags.writeable = False
    return vectors


def band_basis(times: np.ndarray, span: tuple[float, float], band: tuple[float, float]) -> np.ndarray:
    """The signals of a frequency band (Hz) over the time ``span`` (s), read at ``times`` (s), (len(times), 2 K):
    Slepian sequences of the band's half-width times ``cos`` and ``sin`` of its centre (module docstring)."""
    start, end = span
    n = max(int(np.ceil((end - start) / SEQUENCE_STEP_S)) + 1, 2)
    grid = np.linspace(start, end, n)
    low, high = band
    centre, half = 0.5 * (low + high), 0.5 * (high - low)
    nw = half * (end - start)
    count = min(int(np.ceil(2.0 * nw)) + EXTRA_SEQUENCES, n // 2)
    sequences = slepians(n, float(nw * n / max(n - 1, 1)), count) * np.sqrt(n)  # of unit mean square
    values = np.column_stack([np.interp(times, grid, sequence) for sequence in sequences.T])
    phase = 2.0 * np.pi * centre * (times - 0.5 * (start + end))
    return np.hstack([values * np.cos(phase)[:, None], values * np.sin(phase)[:, None]])


@dataclasses.dataclass
class BaseVelocity:
    """The nuisance variables of a moving base: their columns in the residuals (``r -= matrix @ z_nuisance``,
    the matrix already in m/s per variable) and their names."""

    matrix: np.ndarray  # (residual rows, variables)
    names: list[str]

    @property
    def size(self) -> int:
        """Number of variables."""
        return self.matrix.shape[1]


def base_velocity(observations, plans, bands: list[tuple[float, float, str]]) -> BaseVelocity:
    """The nuisance variables of the base's velocity for a graph's velocity observations (module docstring):
    ``observations`` its :class:`noise.observations.ObservationTable`, ``plans`` its groups'
    :class:`calibrate.steps.GroupSteps`, ``bands`` the motion's frequency bands (Hz) with the ENU axes each moves
    (``"U"``, ``"EN"`` or ``"ENU"``)."""
    rows = observations.n_rows
    columns, names, all_rows, all_times = [], [], [], []
    for plan in plans:
        velocity = [o for o in observations.of_group(plan.group) if o.kind == ObservationKind.VELOCITY]
        first = np.array([o.row for o in velocity], dtype=int)
        for axis, label in enumerate("ENU"):
            column = np.zeros(rows)
            column[first + axis] = 1.0
            columns.append(column)
            names.append(f"base velocity of group {plan.group} at its start ({label})")
        all_rows.append(first)
        all_times.append(plan.observed_time)
    first, times = np.concatenate(all_rows), np.concatenate(all_times)
    span = (float(min(p.start_time for p in plans)), float(times.max()))
    for low, high, axes in bands:
        basis = band_basis(times, span, (low, high))
        for axis, label in ((a, label) for a, label in enumerate("ENU") if label in axes):
            block = np.zeros((rows, basis.shape[1]))
            block[first + axis] = basis
            columns += list(block.T)
            names += [f"base velocity in {low:.3g}-{high:.3g} Hz ({label}, signal {j + 1})"
                      for j in range(basis.shape[1])]
    return BaseVelocity(np.column_stack(columns) * NUISANCE_UNIT, names)
