"""Bias instability as random effects (issue 16): the pieces and the residuals' response to a bias held over each."""

import numpy as np

from casadi_sins.model.noise import SensorNoise
from casadi_sins.noise.pieces import bias_responses, track_pieces, whitened_bias_responses

from .test_kalman import G, one_segment


def test_bias_responses_of_the_pieces_add_up_to_a_constant_bias():
    """A unit offset held over each piece; over all pieces together the response of a constant bias, written by hand
    (body = ENU, no Earth rate): accelerometer ``v = t``, gyro ``v_N = -g t^2 / 2`` (``phi' = -b``, ``v' = f x phi``)
    and a gyro mean of 1."""
    n = 12
    system = one_segment(n)
    responses, pieces = bias_responses(system, piece_s=4.0)
    assert len(pieces) == responses.shape[1] == 6 * 3  # 12 s in pieces of 4 s, 3 axes, 2 sensors
    t = np.arange(1, n + 1, dtype=float)
    accel = [i for i, p in enumerate(pieces) if p.sensor == "accel" and p.axis == 0]
    gyro = [i for i, p in enumerate(pieces) if p.sensor == "gyro" and p.axis == 0]
    east, north = slice(0, 3 * n, 3), slice(1, 3 * n, 3)
    np.testing.assert_allclose(responses[east][:, accel].sum(axis=1), t, rtol=1e-12)
    np.testing.assert_allclose(responses[east][:, accel[0]], np.minimum(t, 4.0), rtol=1e-12)  # held, then carried
    np.testing.assert_allclose(responses[north][:, gyro].sum(axis=1), -G * t**2 / 2, rtol=1e-12)
    np.testing.assert_allclose(responses[3 * n, gyro].sum(), 1.0, rtol=1e-12)
    assert [p.time for p in pieces[:9:3]] == [2.0, 6.0, 10.0] and {p.segment for p in pieces} == {0}


def test_pieces_cut_static_segments_and_join_rotations_to_the_piece_before():
    system = one_segment(10)
    track = system.tracks[0]
    track.static[6:8] = False  # two steps of a "rotation", then a new segment at step 8
    track.segment_start[8] = True
    piece, mids, segments = track_pieces(track, piece_s=4.0)
    np.testing.assert_array_equal(piece, [0, 0, 0, 1, 1, 1, 1, 1, 2, 2])  # 6 s in two pieces of 3 s
    np.testing.assert_allclose(mids, [1.5, 4.5, 9.0])
    np.testing.assert_array_equal(segments, [0, 0, 1])


def test_groups_whitened_together_are_the_groups_whitened_alone():
    """Without Gauss-Markov states no state crosses a group: one filter column carries a column of every group."""
    first, second = one_segment(8), one_segment(6)
    shifted = second.tracks[0]
    shifted.start_time = 20.0
    shifted.observations = [type(o)(o.kind, o.row + 27, 2, o.step, 2) for o in shifted.observations]
    shifted.segment_duration, shifted.segment_mid_of = {2: 6.0}, {2: 3}
    system = type(first)([first.tracks[0], shifted], G, np.zeros(3))
    noise = SensorNoise(gyro_arw=1e-6, accel_vrw=2e-4, gyro_quantization=1e-7, accel_quantization=1e-5)
    packed, pieces = whitened_bias_responses(system, noise, piece_s=4.0)
    assert {p.group for p in pieces} == {0, 1}
    np.testing.assert_allclose(packed, system.whiten(bias_responses(system, 4.0)[0], noise).columns,
                               rtol=1e-9, atol=1e-9 * np.abs(packed).max())
