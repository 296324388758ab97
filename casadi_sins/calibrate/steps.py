"""How a recording is stepped and observed: the plan both solvers' noise models share.

Static segments are stepped in blocks of summed pulses (exact for the linear output model and a
body at rest; short steps on a swaying base) and observed at regular times; rotations are stepped in
short constant steps (40 ms: the method error grows as rate^2 x step^3, below 0.001 natural units
at 40 ms).  :func:`group_track` turns a plan, its observations and the navigated attitude into the
noise model's view of a group (:class:`noise.kalman.GroupTrack`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.rotations import quat_to_dcm
from ..data.recording import Recording
from ..noise.kalman import GroupTrack
from ..noise.observations import Observation
from ..noise.taper import STEP_S

#: Rotation step and static step on a swaying base (s).
ROTATION_STEP_S = 0.04
SWAY_STATIC_STEP_S = STEP_S


@dataclasses.dataclass
class GroupSteps:
    """How one group is stepped and observed."""

    group: int
    start_time: float  # start of the group's first sample interval, s
    pulses_gyro: np.ndarray  # (3, M) pulse sums per step
    pulses_accel: np.ndarray
    step_dt: np.ndarray  # (M,) step length, s
    previous_scale: np.ndarray  # (M,) 1 where the previous step has the same length, else 0
    step_segment: np.ndarray  # (M,) static segment number of each step, -1 outside static segments
    first: np.ndarray  # (M,) first sample of each step (index into the recording)
    stop: np.ndarray  # (M,) one past the last sample of each step
    observed: np.ndarray  # (K,) indices of steps whose end velocity is observed
    samples_between: np.ndarray  # (K,) samples between consecutive observations (first: since the start)
    after_rotation: np.ndarray  # (K,) True for the first observation after a rotation
    observed_time: np.ndarray  # (K,) time of each observation, s
    segment_of: np.ndarray  # (K,) segment number of each observation

    def middle_step(self, segment: int) -> int:
        """The step whose end attitude a static segment's gyro mean compares the Earth rate in."""
        steps = np.flatnonzero(self.step_segment == segment)
        return int(steps[len(steps) // 2])

    @property
    def segment_start(self) -> np.ndarray:
        """(M,) True at the first step of each static segment."""
        seg = self.step_segment
        return (seg >= 0) & (seg != np.concatenate([[-1], seg[:-1]]))


def plan_steps(rec: Recording, group: int, observe_s: float = 1.0, rotation_step_s: float = 0.0,
               static_step_s: float | None = None) -> GroupSteps:
    """Split a group's samples into navigation steps and choose the observed ones.

    Static segments are stepped in ``static_step_s`` blocks (default ``observe_s``) and observed every
    ``observe_s`` and at their end; rotations in ``rotation_step_s`` steps (0: every sample).
    """
    static_step_s = observe_s if static_step_s is None else static_step_s
    span = rec.group_samples(group)
    block = max(1, int(round(static_step_s * rec.rate_hz)))
    every = max(1, int(round(observe_s / static_step_s)))
    rotation_block = max(1, int(round(rotation_step_s * rec.rate_hz)))
    bounds: list[tuple[int, int, int, bool]] = []  # (first sample, stop, static segment number or -1, observed)
    cursor = span.start
    for seg in rec.group_segments(group):
        sl = rec.segment_samples(seg)
        while cursor < sl.start:  # samples between segments: one step each
            bounds.append((cursor, cursor + 1, -1, False))
            cursor += 1
        size = block if seg.is_static else rotation_block
        n = sl.stop - sl.start
        count = max(1, int(round(n / size)))
        edges = np.round(np.linspace(sl.start, sl.stop, count + 1)).astype(int)
        for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
            observed = seg.is_static and ((k + 1) % every == 0 or k == count - 1)
            bounds.append((a, b, seg.number if seg.is_static else -1, observed))
        cursor = sl.stop
    while cursor < span.stop:
        bounds.append((cursor, cursor + 1, -1, False))
        cursor += 1
    cum_g = np.vstack([np.zeros(3), np.cumsum(rec.gyro, axis=0)])
    cum_a = np.vstack([np.zeros(3), np.cumsum(rec.accel, axis=0)])
    first = np.array([b[0] for b in bounds])
    stop = np.array([b[1] for b in bounds])
    static_of = np.array([b[2] for b in bounds])
    lengths = (stop - first).astype(float)
    observed = np.flatnonzero([b[3] for b in bounds])
    obs_stop = stop[observed]
    between = np.diff(np.concatenate([[span.start], obs_stop]))
    seg_numbers = static_of[observed]
    spans_rotation = np.concatenate([[False], seg_numbers[1:] != seg_numbers[:-1]])
    return GroupSteps(
        group=group,
        start_time=float(rec.time[span.start] - rec.dt),
        pulses_gyro=(cum_g[stop] - cum_g[first]).T,
        pulses_accel=(cum_a[stop] - cum_a[first]).T,
        step_dt=lengths * rec.dt,
        # coning and sculling use the previous increment as a rate estimate: meaningless across a change of
        # step length (a 1 s block after a rotation sample would extrapolate the rotation into rest)
        previous_scale=(lengths == np.concatenate([[lengths[0]], lengths[:-1]])).astype(float),
        step_segment=static_of,
        first=first,
        stop=stop,
        observed=observed,
        samples_between=between.astype(float),
        after_rotation=spans_rotation,
        observed_time=rec.time[obs_stop - 1],
        segment_of=seg_numbers,
    )


def group_track(plan: GroupSteps, observations: list[Observation], start_attitude: np.ndarray, quats: np.ndarray,
                use_rotation_steps: bool, sway: dict | None = None, tapers: dict | None = None) -> GroupTrack:
    """The noise model's view of one group: its steps along the navigated attitude (quaternions at
    every step end, ``(4, M)``), its observations, the sway of its static segments, and the rate weights of
    the segments whose gyro mean is tapered (``tapers``: segment -> weights over its steps,
    :func:`noise.taper.rate_weights`)."""
    sway = sway or {}
    after = quat_to_dcm(quats.T)
    before = np.concatenate([start_attitude[None], after[:-1]])
    attitude = 0.5 * (before + after)
    seg_start = plan.segment_start
    free = np.zeros(len(plan.step_dt), bool)
    if not use_rotation_steps:
        first_static = np.flatnonzero(seg_start)[:1]
        free = seg_start.copy()
        free[first_static] = False
    numbers = np.unique(plan.step_segment[plan.step_segment >= 0])
    durations = {int(s): float(plan.step_dt[plan.step_segment == s].sum()) for s in numbers}
    track = GroupTrack(plan.start_time, plan.step_dt, attitude, seg_start, plan.step_segment >= 0, free, observations,
                       durations, {s: sway[s] for s in durations if s in sway},
                       {int(s): plan.middle_step(int(s)) for s in numbers})
    for segment, weights in (tapers or {}).items():
        steps = np.flatnonzero(plan.step_segment == segment)
        if len(steps):
            track.segment_taper[segment] = (steps, weights)
    return track


#: Static segments longer than this many observations are observed more sparsely (long files).
OBSERVATIONS_PER_SEGMENT = 300


def default_observation_spacing(rec: Recording) -> float:
    """Seconds between static velocity observations: 1 s, or 5 s for integer pulse counters; longer when
    static segments last more than :data:`OBSERVATIONS_PER_SEGMENT` of them.

    Integer pulses add a white velocity noise of about one pulse to every observation (pitfall 8), far
    from white when the pulse is much larger than the sensor noise (a sawtooth); over 5 s the random
    walk of the accelerometer noise dominates it again, and a static base loses nothing by it.  In
    segments of many minutes the slope and curvature the parameters leave are fixed as well by a few
    hundred observations as by thousands (the noise model holds at any spacing), and the graph and the
    filter grow with the observations: a 10 h file is observed every 10 s.
    """
    integral = np.all(rec.accel == np.round(rec.accel)) and np.all(rec.gyro == np.round(rec.gyro))
    base = 5.0 if integral else 1.0
    durations = [s.end - s.start for s in rec.static_segments]
    typical = float(np.median(durations)) if durations else 0.0
    return base * max(1.0, float(np.ceil(typical / (OBSERVATIONS_PER_SEGMENT * base))))
