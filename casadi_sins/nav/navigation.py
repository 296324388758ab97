"""Navigation of a recording's groups: compensate, align (eq. 14), chain the strapdown step.

Each group is navigated from its own coarse alignment on its first static segment (or a given start
attitude) with a parameter vector; the numbers come from the same step ``Function`` the estimator
differentiates, compiled (:mod:`core.compiled`).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from ..core.compiled import StepChain
from ..core.rotations import dcm_to_quat, quat_to_dcm
from ..data.recording import Recording
from ..model.output import compensate
from .alignment import align
from .strapdown import Q, V, sample_step_function


@dataclasses.dataclass
class GroupNavigation:
    """Navigation of one group: state after each sample of the group's span."""

    group: int
    samples: slice  # indices into the recording
    time: np.ndarray
    velocity: np.ndarray  # (N, 3) ENU, m/s
    quaternion: np.ndarray  # (N, 4) q_b^n
    initial_attitude: np.ndarray  # C_b^n at the start of the span

    def attitude(self, k: int) -> np.ndarray:
        """``C_b^n`` after sample ``k`` of the span."""
        return quat_to_dcm(self.quaternion[k])


def static_velocities(rec: Recording, navs: list[GroupNavigation]):
    """``(segment, time, velocity)`` of every static segment of the navigated groups, in schedule order."""
    for nav in navs:
        for seg in rec.group_segments(nav.group):
            if seg.is_static:
                sl = rec.segment_samples(seg)
                local = slice(sl.start - nav.samples.start, sl.stop - nav.samples.start)
                yield seg, nav.time[local], nav.velocity[local]


def navigation_constants(rec: Recording) -> tuple[np.ndarray, np.ndarray]:
    """``(earth_rate_dt, gravity_dt)`` in ENU for one sample interval."""
    return rec.site.earth_rate * rec.dt, np.array([0.0, 0.0, -rec.site.g]) * rec.dt


def compensated_increments(rec: Recording, params, samples: slice | None = None):
    """Compensated ``(dtheta, dv)`` of a recording (or a range of its samples), eq. 1 inverted."""
    samples = samples if samples is not None else slice(None)
    return compensate(rec.gyro[samples], rec.accel[samples], params, rec.dt)


def group_alignment(rec: Recording, group: int, params) -> np.ndarray:
    """Coarse alignment (eq. 14) of a group on its first static segment."""
    first = rec.group_segments(group)[0]
    dth, dv = compensated_increments(rec, params, rec.segment_samples(first))
    return align(dth, dv, rec.dt)


def navigate_group(rec: Recording, group: int, params, initial_attitude: np.ndarray | None = None
                   ) -> GroupNavigation:
    """Navigate one group from its alignment (or a given start attitude) with parameters ``params``."""
    params = np.asarray(params, dtype=float)
    span = rec.group_samples(group)
    dth, dv = compensated_increments(rec, params, span)
    if initial_attitude is None:
        first = rec.segment_samples(rec.group_segments(group)[0])
        local = slice(first.start - span.start, first.stop - span.start)
        initial_attitude = align(dth[local], dv[local], rec.dt)
    x0 = np.concatenate([dcm_to_quat(initial_attitude), np.zeros(3), dth[0], dv[0]])
    wdt, gdt = navigation_constants(rec)
    states, _ = navigation_chain()(x0, np.concatenate([wdt, gdt]), np.hstack([dth, dv]))
    return GroupNavigation(group, span, rec.time[span], states[:, V], states[:, Q], np.asarray(initial_attitude))


@functools.lru_cache(maxsize=None)
def navigation_chain() -> StepChain:
    """The strapdown step per sample (:func:`strapdown.sample_step_function`), compiled, as a chain over rows of
    ``(dtheta, dv)`` with ``(earth_rate_dt, gravity_dt)`` constant; every state (N, 13) out."""
    return StepChain("navigation", "sample step", sample_step_function)


def navigate(rec: Recording, params, initial_attitudes: dict[int, np.ndarray] | None = None
             ) -> list[GroupNavigation]:
    """Navigate every group of a recording; one :class:`GroupNavigation` per group."""
    initial_attitudes = initial_attitudes or {}
    return [navigate_group(rec, g, params, initial_attitudes.get(g)) for g in rec.group_ids]
