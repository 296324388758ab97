"""Calibration on a moving base (issue 38): tapered gyro means, the base's velocity as nuisance, the reference.

Bounds from benchmarks/bench_moving_base.py (20 seeds): on the deck the NLP's RMS errors stay within about 1.2x
the still base's, the largest error of a run about 7e-5 deg/h, 0.3 ug, 0.3 ppm and 0.3 arcsec; the bounds
below are about 2-3x those.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.calibrate.nlp.base import band_basis, base_velocity
from casadi_sins.calibrate.nlp.graph import build_graph
from casadi_sins.calibrate.nlp.pipeline import base_bands
from casadi_sins.core.units import DEG_PER_H
from casadi_sins.data.problem import load_problem
from casadi_sins.model.parameters import natural_errors
from casadi_sins.model.registry import NATURAL_UNITS
from casadi_sins.noise.observations import ObservationKind
from casadi_sins.noise.plan import plan_noise
from casadi_sins.sim import simulate

from ..conftest import PROBLEMS

BOUND = {"deg/h": 2e-4, "ug": 0.8, "ppm": 0.8, "arcsec": 0.6}


def test_a_deck_calibrates_as_a_still_bench_would_and_names_its_motion(deck_nlp, deck_sim):
    result = deck_nlp
    err = natural_errors(result.parameters, deck_sim.truth)
    for e, unit in zip(err, NATURAL_UNITS):
        assert abs(e) < BOUND[unit]
    assert np.abs(err / result.parameters.natural_sigma()).max() < 4.5
    assert not result.distrust and result.linear_motion.moving
    assert any("moved linearly" in w and "mg" in w and "cm" in w for w in result.warnings)
    assert any("sway" in w and "tapered" in w for w in result.warnings)
    assert all(m.taper is not None for m in result.base_motion)
    gyro_sigma = result.parameters.natural_sigma()[9:12]
    assert np.all(gyro_sigma < 1e-4)  # the gyro means count again: the plain ones gave 1.3-1.7e-3 deg/h


def test_a_band_holds_any_line_in_it_and_the_base_variables_come_in_mm_s():
    times = np.arange(0.0, 1290.0, 1.0)
    for band, size in (((0.150, 0.156), 5e-5), ((0.1436, 0.1636), 5e-4)):  # a few bins, and 25
        q = np.linalg.qr(band_basis(times, (0.0, 1290.0), band))[0]
        for f in np.linspace(*band, 7):
            line = np.cos(2 * np.pi * f * times + 0.4)
            assert np.std(line - q @ (q.T @ line)) < size
    outside = np.cos(2 * np.pi * 0.05 * times)
    assert np.std(outside - q @ (q.T @ outside)) > 0.99 * np.std(outside)  # what lies outside stays in the data


@pytest.fixture(scope="module")
def deck_graph(deck_sim):
    rec = deck_sim.recording
    initial = rough_parameters(rec)
    plan = plan_noise(rec, initial.values)
    tapers = {m.segment: m.taper.nw for m in plan.motions if m.taper is not None}
    return build_graph(rec, initial.values, 1.0, 0.04, 0.1, tapers=tapers, base_bands=base_bands(rec, plan))


def test_the_tapered_means_and_the_base_velocity_have_the_jacobian_of_their_residuals(deck_graph):
    graph = deck_graph
    assert graph.tapers and graph.base is not None and graph.n_variables == graph.shape.n_variables + graph.base.size
    z = np.zeros(graph.n_variables)
    z[:21] = np.random.default_rng(0).normal(size=21) * 10
    z[graph.shape.n_variables:] = 5.0
    r, jac = graph.jacobian(z)
    gyro = graph.observations.rows_of(ObservationKind.GYRO_MEAN)
    for k in (9, 12, 18, 21, graph.shape.n_variables + 4):
        step = np.zeros_like(z)
        step[k] = 1e-3
        fd = (graph.residuals(z + step) - graph.residuals(z - step)) / 2e-3
        scale = np.abs(jac[:, k]).max() + 1e-30
        assert np.max(np.abs(fd - jac[:, k])[gyro]) < 1e-5 * scale + 1e-15
        assert np.max(np.abs(fd - jac[:, k])[~gyro]) < 1e-5 * scale + 1e-12


def test_a_tapered_mean_weighs_the_gyro_noise_as_its_residual_does(deck_graph):
    """The noise model's view: a tapered segment's steps carry the gyro noise into its angle with their weights
    (a constant bias reads as itself), and its pulse remainders with the squared coefficients."""
    graph = deck_graph
    trajectory = np.asarray(graph.trajectory(np.zeros(graph.n_variables)))
    track = graph.tracks(trajectory, True)[0]
    gain = track.gyro_gain
    for segment, (steps, weights) in track.segment_taper.items():
        duration = track.segment_duration[segment]
        assert np.sum(gain[steps] * track.step_dt[steps]) / duration == pytest.approx(1.0)
        assert gain[steps][0] == 0.0 and track.quantization_weight(segment) < 2.0 / duration**2
    plain = np.ones(len(gain), bool)
    for steps, _ in track.segment_taper.values():
        plain[steps] = False
    assert np.all(gain[plain] == 1.0)


def test_an_attitude_reference_is_read_where_it_shows_slow_motion_and_left_where_its_noise_would_cost():
    base = load_problem(PROBLEMS / "kang2013-sway.toml")
    slow = base.with_changes(sway_period_s=(150.0, 400.0), sway_components=1, reference_attitude=True,
                             reference_noise_arcsec=0.2)
    rec = simulate(slow, seed=1).recording
    motions = plan_noise(rec, rough_parameters(rec).values).motions
    assert sum(m.uses_reference for m in motions) >= 9
    fast = base.with_changes(reference_attitude=True, reference_noise_arcsec=2.0)
    rec = simulate(fast, seed=1).recording
    motions = plan_noise(rec, rough_parameters(rec).values).motions
    assert all(m.taper is not None for m in motions) and sum(m.uses_reference for m in motions) <= 2
    still = dataclasses.replace(rec, reference=np.zeros_like(rec.reference))
    assert not any(m.uses_reference for m in plan_noise(still, rough_parameters(still).values).motions)


def test_the_report_names_the_base_motion(deck_nlp, deck_sim):
    from casadi_sins.report.calibration import report_data, report_markdown

    data = report_data(deck_nlp, deck_sim.recording)
    linear = data["linear_base_motion"]
    assert linear["moving"] and linear["lines"] and all(3.0 <= line["period_s"] <= 13.5 for line in linear["lines"])
    assert all(m["tapered_mean"]["noise_factor"] < 3.0 for m in data["base_motion"] if m["significant"])
    text = report_markdown(data)
    assert "## Base motion" in text and "moved linearly" in text and "taper_nw" in text
    assert data["distrusted"] == []
