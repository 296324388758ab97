"""The names of the parameter groups and models, light enough for ``casadi-sins --help``.

The command line lists them in its help before any physics is loaded, so their one home imports nothing:
each group module (:mod:`model.groups`) takes its label from :data:`GROUP_LABELS`, and the registry
(:mod:`model.registry`) refuses to load unless its groups are these, in this order.
"""

from __future__ import annotations

#: Every group of the registry, in table order: key -> label (its name in reports and help).
GROUP_LABELS = {
    "accel_bias": "accel bias",
    "accel_scale": "accel scale",
    "accel_misalign": "accel misalignment",
    "gyro_bias": "gyro bias",
    "gyro_scale": "gyro scale",
    "gyro_misalign": "gyro misalignment",
    "quadratic": "accel quadratic scale",
    "lever": "accel lever arms across the sensing axes (size effect)",
    "lever_along": "accel lever arms along the sensing axes",
    "timing": "gyro/accel time offset",
    "gyro_gsens": "gyro g-sensitivity",
    "gyro_asym": "gyro scale-factor asymmetry",
    "cross_quadratic": "accel cross-quadratic terms",
}
#: The paper's six groups (Kang et al. 2013, eq. 1), the 21 parameters; the others are the extra groups.
PAPER_GROUPS = ("accel_bias", "accel_scale", "accel_misalign", "gyro_bias", "gyro_scale", "gyro_misalign")
#: The parameter models of a fixed parameter list (:data:`model.registry.MODELS`): the paper's 21, and with
#: every extra group the schedule determines; what a prediction or a design can be made for.
FIXED_MODELS = ("21", "extended")
#: The parameter models a calibration takes: the fixed ones, or the extra groups the data support (``auto``, a
#: search: NLP only).
MODELS = FIXED_MODELS + ("auto",)


def extra_group_labels() -> list[str]:
    """The labels of the extra groups, in table order."""
    return [label for key, label in GROUP_LABELS.items() if key not in PAPER_GROUPS]
