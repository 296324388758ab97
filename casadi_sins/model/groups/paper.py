"""The six groups of the paper's 21 parameters (Kang et al. 2013, eq. 1)::

    dN_g = diag(S_g)^-1 (K_g dtheta + B_g dt)
    dN_a = diag(S_a)^-1 (K_a dv     + B_a dt)

``K_g`` unit-diagonal with six off-diagonal misalignments, ``K_a`` unit-lower-triangular with three.
Their physics is eq. 1 itself (:mod:`model.output`).
"""

from __future__ import annotations

from ...core.units import ARCSEC, DEG_PER_H, PPM, UG
from ..catalog import GROUP_LABELS
from .base import ParameterGroup, axes

GROUPS = (
    ParameterGroup("accel_bias", GROUP_LABELS["accel_bias"], axes("accel_bias"), "m/s^2", "ug", UG,
                   meaning="B_a: accelerometer bias"),
    ParameterGroup("accel_scale", GROUP_LABELS["accel_scale"], axes("accel_scale"), "m/s/pulse", "ppm", PPM,
                   relative=True, value_unit="m/s/pulse", value_scale=1.0, meaning="S_a: accelerometer pulse weight"),
    ParameterGroup("accel_misalign", GROUP_LABELS["accel_misalign"], axes("accel_misalign", ("yx", "zx", "zy")), "rad",
                   "arcsec", ARCSEC, meaning="K_a lower off-diagonal (row = sensor axis, column)"),
    ParameterGroup("gyro_bias", GROUP_LABELS["gyro_bias"], axes("gyro_bias"), "rad/s", "deg/h", DEG_PER_H,
                   sensor="gyro", weak_level=0.01, meaning="B_g: gyro bias"),
    ParameterGroup("gyro_scale", GROUP_LABELS["gyro_scale"], axes("gyro_scale"), "rad/pulse", "ppm", PPM, sensor="gyro",
                   relative=True, value_unit="arcsec/pulse", value_scale=ARCSEC, meaning="S_g: gyro pulse weight"),
    ParameterGroup("gyro_misalign", GROUP_LABELS["gyro_misalign"],
                   axes("gyro_misalign", ("xy", "xz", "yx", "yz", "zx", "zy")), "rad", "arcsec", ARCSEC,
                   sensor="gyro", meaning="K_g off-diagonal (row = sensor axis, column)"),
)
