"""Rests from the changes of the signals (data.stillness): any offset, the slow ends of moves left out, tremor."""

import numpy as np

from casadi_sins.data.handling import shortest_hand_rest
from casadi_sins.data.stillness import find_rests, rest_baseline, sure_motion


def true_rests(rec):
    return [(rec.segment_samples(s).start, rec.segment_samples(s).stop) for s in rec.static_segments]


def test_every_rest_is_found_inside_its_true_span(hand_sim):
    """Each true rest holds one found rest that covers most of it; a found rest reaches beyond its true span by a
    fraction of a second at most (the slowest start of a move, under the tremor)."""
    rec = hand_sim.recording
    found = find_rests(rec.gyro, rec.accel, rec.rate_hz, shortest_hand_rest(rec.rate_hz)).spans
    truth = true_rests(rec)
    assert len(found) == len(truth)
    for (a, b), (p, q) in zip(truth, found):
        assert p < b and q > a
        assert (a - p) / rec.rate_hz < 0.3 and (q - b) / rec.rate_hz < 0.3
        assert (min(b, q) - max(a, p)) > 0.5 * (b - a)


def test_an_offset_changes_nothing(hand_sim):
    """Raw counts with any mid-scale offset: the rests are the same."""
    rec = hand_sim.recording
    shortest = shortest_hand_rest(rec.rate_hz)
    plain = find_rests(rec.gyro, rec.accel, rec.rate_hz, shortest).spans
    shifted = find_rests(rec.gyro + 12345.0, rec.accel - 30000.0, rec.rate_hz, shortest).spans
    assert shifted == plain


def test_the_settling_hand_is_left_out(hand_sim):
    """The simulated hand creeps the last degree of each move into the rest (a quarter-second time constant):
    the found rests start after most of it."""
    rec = hand_sim.recording
    found = find_rests(rec.gyro, rec.accel, rec.rate_hz, shortest_hand_rest(rec.rate_hz)).spans
    late = [(p - a) / rec.rate_hz for (a, _), (p, _) in zip(true_rests(rec)[1:], found[1:])]
    assert np.median(late) > 0.5


def test_nothing_moves_in_noise_alone():
    rng = np.random.default_rng(1)
    rests = find_rests(rng.standard_normal((3000, 3)) + 32768.0, rng.standard_normal((3000, 3)), 100.0, 1.0)
    assert not rests.moves


def test_sure_motion_splits_rest_from_moves_whatever_their_levels():
    rng = np.random.default_rng(2)
    for rest, move in ((1.0, 60.0), (6.0, 60.0), (1.0, 1e6)):
        act = np.concatenate([rest * np.exp(0.2 * rng.standard_normal(6000)),
                              move * np.exp(0.5 * rng.standard_normal(4000))])
        assert 3.0 * rest < sure_motion(act) < move / 3.0 or sure_motion(act) == 8.0 and 3.0 * rest < 8.0


def test_the_rest_baseline_is_each_rests_level_and_a_line_between():
    pulses = np.zeros((100, 1))
    pulses[10:20] = 5.0
    pulses[60:80] = 25.0
    base = rest_baseline(pulses, [(10, 20), (60, 80)])
    assert np.all(base[10:20] == 5.0) and np.all(base[60:80] == 25.0) and np.all(base[:10] == 5.0)
    assert base[40, 0] == np.interp(40, [14.5, 69.5], [5.0, 25.0])
