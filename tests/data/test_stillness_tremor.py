"""Rests under a hand's tremor keep clear of the moves (data.stillness, issue 37).

A trembling hand (tones of 3-10 Hz, hundredths of a degree) hides the first tenths of a degree of a minimum-jerk
move, which starts like ``t^3``; a rest that reaches into the move by a quarter second holds a degree of it and
spoils the calibration.  The session is written here with NumPy alone: gyro pulses in raw counts (a mid-scale
offset, 16-bit resolution), the rests' true spans known.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from casadi_sins.data.handling import shortest_hand_rest
from casadi_sins.data.stillness import find_rests

RATE = 200.0
COUNT_DEG = 1.0 / 65.536 / RATE  # deg per gyro count per sample (+/-500 deg/s over 16 bits)
#: The largest angle of a move a found rest may hold (deg): a twentieth of a degree, about the tremor's rms.
MOVE_INSIDE_DEG = 0.05


def minimum_jerk(tau):
    tau = np.clip(tau, 0.0, 1.0)
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def trembling_session(seed, tremor_deg=0.045):
    """``(gyro, accel, rests, moves)``: raw counts, and the true rests and moves as ``(start_s, end_s)``."""
    rng = np.random.default_rng(seed)
    t, rests, moves = 30.0, [(0.0, 30.0)], []
    for _ in range(12):
        duration, angle = rng.uniform(1.0, 3.0), rng.uniform(30.0, 120.0)
        moves.append((t, t + duration, angle, rng.normal(size=3)))
        t += duration
        rest = rng.uniform(3.0, 8.0)
        rests.append((t, t + rest))
        t += rest
    time = np.arange(1, int(t * RATE) + 1) / RATE
    angle = np.zeros((len(time), 3))  # each move about a fixed body axis: the angles add up, the attitudes chain
    attitude = Rotation.random(random_state=seed)
    up = np.tile(attitude.inv().apply([0.0, 0.0, 1.0]), (len(time), 1))
    for start, end, size, axis in moves:
        turn = np.outer(minimum_jerk((time - start) / (end - start)), size * axis / np.linalg.norm(axis))
        angle += turn
        after = time > start
        up[after] = (attitude * Rotation.from_rotvec(np.radians(turn[after]))).inv().apply([0.0, 0.0, 1.0])
        attitude = attitude * Rotation.from_rotvec(np.radians(size * axis / np.linalg.norm(axis)))
    hz = rng.uniform(3.0, 10.0, (4, 3))
    phase = rng.uniform(0.0, 2.0 * np.pi, (4, 3))
    angle += tremor_deg * np.sqrt(2.0 / 4) * np.sin(2.0 * np.pi * hz[None] * time[:, None, None] + phase).sum(axis=1)
    steps = np.diff(np.vstack([np.zeros((1, 3)), angle]), axis=0) / COUNT_DEG
    gyro = np.round(steps + 32768.0 + 40.0 + 0.5 * rng.standard_normal(steps.shape))
    accel = np.round(4096.0 * up + 32768.0 + 3.0 * rng.standard_normal(steps.shape))  # +/-8 g over 16 bits
    return gyro, accel, rests, [(a, b, size) for a, b, size, _ in moves]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_rests_under_tremor_hold_no_move(seed):
    """Every true rest holds one found rest, at least half as long; none holds more than :data:`MOVE_INSIDE_DEG` of
    the moves beside it (the slow start and end of each, hidden in the tremor)."""
    gyro, accel, rests, moves = trembling_session(seed)
    found = [(a / RATE, b / RATE) for a, b in find_rests(gyro, accel, RATE, shortest_hand_rest(RATE)).spans]
    assert len(found) == len(rests)
    for (first, stop), (start, end) in zip(found, rests):
        assert stop - first > 0.5 * (end - start)
    for (start, end, size), (_, stop), (first, _) in zip(moves, found[:-1], found[1:]):
        inside_before = size * minimum_jerk((stop - start) / (end - start))
        inside_after = size * (1.0 - minimum_jerk((first - start) / (end - start)))
        assert inside_before <= MOVE_INSIDE_DEG and inside_after <= MOVE_INSIDE_DEG, (start, stop, first, end)
