"""What the estimator observes: one record per observation, each owning three residual rows.

The NLP's residuals are, per group in time order, the navigated velocity at observation steps in the
static segments (ENU, m/s) and, per static segment, its mean gyro rate against the Earth rate seen
in the navigated attitude (body, rad/s).  The noise model (:mod:`noise.kalman`) and the checks
(:mod:`calibrate.nlp.diagnostics`) read the same table.
"""

from __future__ import annotations

import dataclasses
import enum
from functools import cached_property

import numpy as np


class ObservationKind(enum.IntEnum):
    """The kind of an observation (three residual rows each)."""

    VELOCITY = 0  #: navigated velocity at the end of a step, ENU, m/s (true value zero)
    GYRO_MEAN = 1  #: a static segment's mean compensated rate minus the Earth rate in the navigated attitude


@dataclasses.dataclass(frozen=True)
class Observation:
    """One observation: three residual rows from ``row``.

    Attributes
    ----------
    kind : ObservationKind
    row : int
        First of its three rows in the residual vector.
    group : int
    step : int
        Index of the navigation step (within the group) at whose end it is made.
    segment : int
        Number of its static segment.
    after_rotation : bool
        A velocity observation that carries the velocity step across a rotation.
    samples_since_previous : float
        Velocity: samples since the group's previous velocity observation (or its start).
    first_of_group : bool
        The group's first velocity observation (known zero velocity before it).
    """

    kind: ObservationKind
    row: int
    group: int
    step: int
    segment: int
    after_rotation: bool = False
    samples_since_previous: float = 0.0
    first_of_group: bool = False


@dataclasses.dataclass
class ObservationTable:
    """The observations of a residual vector, in its row order."""

    observations: list[Observation]

    @property
    def n_rows(self) -> int:
        """Length of the residual vector."""
        return 3 * len(self.observations)

    def _per_row(self, field: str) -> np.ndarray:
        return np.repeat(np.array([getattr(o, field) for o in self.observations]), 3)

    @cached_property
    def kind(self) -> np.ndarray:
        """(rows,) :class:`ObservationKind` value of each row."""
        return self._per_row("kind").astype(int)

    @cached_property
    def group(self) -> np.ndarray:
        """(rows,) group of each row."""
        return self._per_row("group")

    @cached_property
    def segment(self) -> np.ndarray:
        """(rows,) static segment number of each row."""
        return self._per_row("segment")

    @cached_property
    def after_rotation(self) -> np.ndarray:
        """(rows,) velocity rows of the first observation after a rotation."""
        return self._per_row("after_rotation").astype(bool)

    @cached_property
    def samples_since_previous(self) -> np.ndarray:
        """(rows,) samples since the previous velocity observation (0 for gyro rows)."""
        return self._per_row("samples_since_previous").astype(float)

    @cached_property
    def first_of_group(self) -> np.ndarray:
        """(rows,) the group's first velocity observation."""
        return self._per_row("first_of_group").astype(bool)

    def rows_of(self, kind: ObservationKind) -> np.ndarray:
        """(rows,) mask of the rows of one kind."""
        return self.kind == int(kind)

    def of_group(self, group: int) -> list[Observation]:
        """The observations of one group, in order."""
        return [o for o in self.observations if o.group == group]
