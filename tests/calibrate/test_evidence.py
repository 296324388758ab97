"""Extra-term alarms judged by what the term would change (:mod:`calibrate.nlp.evidence`)."""

import numpy as np
import pytest

from casadi_sins.calibrate.nlp.evidence import (FAMILY_ALPHA, MOVE_FRACTION, evidence_note, evidence_warning,
                                                family_threshold, judge_groups, moves_of)
from casadi_sins.model.registry import GROUPS, MODELS, NAMES, model_names

NAMES_WITH_TIMING = model_names(MODELS["extended"])


def _fit(correlation: float, wald: float):
    """A fit of the 21 and the timing group: unit variances, the timing term correlated with gyro_scale_z."""
    n = len(NAMES_WITH_TIMING)
    cov = np.eye(n)
    k, t = NAMES.index("gyro_scale_z"), NAMES_WITH_TIMING.index(GROUPS["timing"].names[0])
    cov[k, t] = cov[t, k] = correlation
    z = np.zeros(n)
    z[t] = np.sqrt(wald)
    return z, cov


def test_the_family_threshold_is_bonferroni_over_the_groups():
    from scipy.stats import chi2

    assert family_threshold(1, 6) == pytest.approx(chi2.isf(FAMILY_ALPHA / 6, 1))
    assert family_threshold(3, 1) > family_threshold(1, 1)


def test_the_move_is_the_conditional_shift_in_sigma():
    z, cov = _fit(0.4, 25.0)
    moves = moves_of(list(NAMES_WITH_TIMING), z, cov, "timing", np.ones(len(NAMES)))
    assert moves[NAMES.index("gyro_scale_z")] == pytest.approx(0.4 * 5.0)
    assert np.delete(moves, NAMES.index("gyro_scale_z")).max() == 0.0


@pytest.mark.parametrize("correlation, wald, warned", [(0.4, 25.0, True),    # strong and it moves the 21: warn
                                                       (0.05, 25.0, False),  # strong, moves nothing: a note
                                                       (0.9, 8.51, False)])  # past k ln n only: a note
def test_a_warning_needs_family_wise_evidence_and_a_move(correlation, wald, warned):
    z, cov = _fit(correlation, wald)
    selection = {key: {"statistic": 0.1, "threshold": 24.6, "selected": False, "values_natural": []}
                 for key in MODELS["extended"]}  # every extra group tried; only the timing offset shows
    selection["timing"] = {"statistic": wald, "threshold": 8.2, "selected": wald > 8.2, "values_natural": []}
    judged = judge_groups(selection, NAMES_WITH_TIMING, z, cov, np.ones(len(NAMES)))
    assert judged["timing"]["selected"] is warned
    assert (evidence_warning(judged, "misfit") is not None) is warned
    assert (evidence_note(judged, "misfit") is not None) is (not warned)
    if warned:
        assert judged["timing"]["largest_move"] >= MOVE_FRACTION
