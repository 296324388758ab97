"""The estimator's graph: built once per schedule shape, its Jacobian from the compiled tangent step."""

import casadi as ca
import numpy as np
import pytest

from casadi_sins.calibrate.initial import rough_parameters
from casadi_sins.calibrate.nlp import shape
from casadi_sins.calibrate.nlp.graph import build_graph
from casadi_sins.calibrate.steps import default_observation_spacing
from casadi_sins.model.registry import EXTRA_GROUPS, NAMES, model_names
from casadi_sins.sim import simulate


@pytest.fixture(scope="module")
def two_recordings(short_problem):
    return [simulate(short_problem, seed=seed).recording for seed in (4, 5)]


def _graph(rec, names=NAMES):
    return build_graph(rec, rough_parameters(rec).aligned(names), default_observation_spacing(rec), names=names)


@pytest.mark.parametrize("names", [NAMES, model_names(EXTRA_GROUPS)], ids=["21", "extended"])
def test_a_second_recording_of_the_shape_reuses_the_graph_with_the_same_residuals(two_recordings, names):
    first, second = two_recordings
    shape._GRAPHS.clear()
    graph_a = _graph(first, names)
    graph_b = _graph(second, names)
    assert graph_b.shape is graph_a.shape  # the pulses are data: one graph for the shape
    shape._GRAPHS.clear()
    fresh = _graph(second, names)
    assert fresh.shape is not graph_a.shape
    rng = np.random.default_rng(0)
    for z in (np.zeros(fresh.n_variables), rng.standard_normal(fresh.n_variables)):
        r_b, j_b = graph_b.jacobian(z)
        r_f, j_f = fresh.jacobian(z)
        assert np.array_equal(r_b, r_f) and np.array_equal(j_b, j_f)
        assert np.array_equal(graph_b.residuals(z + 1e-3), fresh.residuals(z + 1e-3))
        assert np.array_equal(graph_b.trajectory(z), fresh.trajectory(z))
    assert not np.array_equal(graph_a.residuals(np.zeros(fresh.n_variables)), r_f)  # the data differ


@pytest.mark.parametrize("names", [NAMES, model_names(EXTRA_GROUPS)], ids=["21", "extended"])
def test_tangent_jacobian_equals_algorithmic_differentiation(two_recordings, names):
    """The Jacobian carried by the compiled tangent step equals CasADi's algorithmic derivative of the
    residuals on its virtual machine, and the residuals agree, to round-off."""
    graph = _graph(two_recordings[0], names)
    symbolic = shape.ShapeGraph(graph.shape.layouts, graph.names, compiled=False)
    w = ca.MX.sym("w", graph.n_variables)
    r = symbolic.residuals(w, ca.DM(graph.data), ca.DM(graph.ref))
    ad = ca.Function("ad", [w], [r, ca.jacobian(r, w)])
    z = np.random.default_rng(1).standard_normal(graph.n_variables)
    r_ad, j_ad = (np.asarray(m) for m in ad(z))
    r_t, j_t = graph.jacobian(z)
    scale = np.abs(j_ad).max(axis=0)
    assert np.all(np.abs(j_t - j_ad) <= 1e-8 * scale + 1e-300)
    assert np.allclose(r_t, r_ad.ravel(), rtol=0, atol=1e-12 * np.abs(r_ad).max())
    assert np.array_equal(graph.residuals(z + 1e-6), graph.residuals(z + 1e-6))


def test_linearisation_is_kept_for_the_same_point(two_recordings):
    graph = _graph(two_recordings[0])
    z = np.zeros(graph.n_variables)
    graph.jacobian(z)
    graph.jacobian(z.copy())
    graph.trajectory(z)
    assert graph.evaluations["jacobian"] == 1
    r, _ = graph.jacobian(z)
    with pytest.raises(ValueError):
        r[0] = 1.0  # read-only: a shared linearisation cannot be changed by a caller
