"""The simulator's moving base: the deck's linear motion and the attitude reference."""

from __future__ import annotations

import numpy as np
import pytest

from casadi_sins.core.rotations import NED_TO_ENU, enu_to_euler, euler_to_enu
from casadi_sins.data.problem import load_problem
from casadi_sins.sim.motion import Translation

from ..conftest import PROBLEMS


def test_translation_is_bounded_capped_and_its_force_is_its_acceleration_and_coriolis():
    rng = np.random.default_rng(1)
    motion = Translation.draw((0.02, 0.18), (3.0, 13.0), 2, "NU", 15e-3 * 9.8, rng)
    assert np.all(motion.amplitude[0] == 0.0)  # east stays
    assert np.all(np.sum(motion.amplitude * motion.omega**2, axis=1) <= 15e-3 * 9.8 * (1 + 1e-12))
    t = np.linspace(0.0, 60.0, 6001)
    position = motion.position(t)
    assert np.allclose(np.gradient(position, t, axis=0)[5:-5], motion.velocity(t)[5:-5], atol=1e-5)
    earth = np.array([0.0, 5.8e-5, 4.4e-5])
    assert np.allclose(motion.force(t, earth) - motion.acceleration(t), 2 * np.cross(earth, motion.velocity(t)))


def test_euler_angles_round_trip_and_a_heading_turns_the_forward_axis_east():
    angles = np.array([[0.1, -0.2, 2.5], [0.0, 0.0, 0.0], [-1.0, 0.3, -3.0]])
    assert np.allclose(enu_to_euler(euler_to_enu(angles)), angles)
    assert np.allclose(euler_to_enu(np.array([0.0, 0.0, np.pi / 2])) @ [1.0, 0.0, 0.0], [1.0, 0.0, 0.0])
    assert np.allclose(euler_to_enu(np.zeros(3)), NED_TO_ENU)


def test_the_deck_problem_reads_and_a_reference_follows_the_sway():
    from casadi_sins.sim import simulate

    problem = load_problem(PROBLEMS / "kang2013-deck.toml")
    assert problem.deviations.translates and problem.deviations.sways
    short = problem.with_changes(reference_attitude=True, reference_noise_arcsec=0.0, translation_amplitude_m=(0, 0))
    import dataclasses

    short = dataclasses.replace(short, timing=dataclasses.replace(short.timing, static_s=8.0, rotation_s=4.0))
    sim = simulate(short, seed=2, noise=False)
    rec = sim.recording
    turned = euler_to_enu(rec.reference) @ NED_TO_ENU  # the sway's attitude
    expected = sim.sway.attitude(rec.time)
    assert np.max(np.abs(turned - expected)) < 1e-12
    assert rec.reference.shape == (len(rec.time), 3) and np.max(np.abs(rec.reference)) < 1e-3
