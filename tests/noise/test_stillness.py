"""A record at rest is checked for motion: a turn, a bump to another attitude and a counter glitch are found and
told by time and axis; noise and a strong slow wander are not motion."""

import numpy as np
import pytest

from casadi_sins.noise.rest import rest_record
from casadi_sins.noise.stillness import find_motion


def _windows(static_increments, seconds=1800.0, seed=0):
    rate = 20.0
    # navigation-grade sizes in pulses: gyro 0.02 pulse per sample, accelerometer gravity 580 pulses
    x = static_increments(rate, seconds, [0.09, 0.09, 0.09, 0.09, 0.09, 0.09], 0.0, [0.0, 0.0, 0.01, 0.0, 0.0, 0.01],
                          100.0, seed=seed, mean=[0.8, 0.2, 0.6, 2.0, 1.0, 11600.0])
    return x, rate


def _motion(x, rate):
    record = rest_record(x, rate)
    return find_motion(record.window_means, record.window_s, record.window_samples)


def test_noise_and_a_strong_wander_are_not_motion(static_increments):
    x, rate = _windows(static_increments)
    assert _motion(x, rate) is None


@pytest.mark.parametrize("kind", ["turn", "bump", "glitch"])
def test_motion_is_found_where_it_is(static_increments, kind):
    x, rate = _windows(static_increments, seed=1)
    at = int(900.0 * rate)
    if kind == "turn":  # 90 deg about z in 10 s at 5.6e-6 deg per pulse: 1.6e6 pulses per second
        x[at:at + 200, 2] += 8000.0
    elif kind == "bump":  # set down 0.1 deg off: gravity moves 1.7e-3 of 580 pulses onto x
        x[at:, 3] += 1.0
        x[at:, 5] -= 0.001
    else:
        x[at, 4] += 65536.0
    motion = _motion(x, rate)
    assert motion is not None
    assert motion.axis == {"turn": "gyro_z", "bump": "accel_x", "glitch": "accel_y"}[kind]
    assert abs(motion.start_s - 900.0) <= 2.0
