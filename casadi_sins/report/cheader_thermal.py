"""A thermal model (:mod:`model.thermal`) as a C header: compensation at any temperature.

The 21 parameters' polynomials ``p(T) = p_ref + a1 d + a2 d^2``, ``d = T - T_ref``, as ``static const
double`` arrays in table order (shortest exact decimals: the compiler reads back Python's float64),
and two inline functions::

    int casadi_sins_parameters_t(temperature_c, p)      the 21 parameters at T (SI, table order)
    int casadi_sins_compensate_t(dN_g, dN_a, dt, temperature_c, dtheta, dv)

the second the compensation of eq. 1 inverted with the parameters at ``T``::

    dtheta = K_g^-1 (diag(S_g) dN_g - B_g dt),   dv = K_a^-1 (diag(S_a) dN_a - B_a dt)

``K^-1`` applied by Cramer's rule (3 x 3, unit diagonal: never singular for misalignments of
arcseconds).  Extra groups beyond the 21 are not compensated (``CASADI_SINS_EXTRAS_NOT_COMPENSATED``).

**Outside the calibrated range** (``casadi_sins_t_min_c`` .. ``casadi_sins_t_max_c``) the polynomials
are evaluated at the nearest end of the range (clamped: a quadratic extrapolated far beyond its
setpoints runs away, and firmware cannot read a warning), and both functions return 1 (0 within
the range) so that the firmware can flag the sample.  Defining ``CASADI_SINS_THERMAL_EXTRAPOLATE``
before the ``#include`` evaluates them at the temperature itself instead (still returning 1).
``apply --thermal`` evaluates the model as the header does (:meth:`model.thermal.ThermalModel.clamped`).

The comment block carries the provenance as every export does: the model file's and its companion's
SHA-256, when and by which build it was fitted, the versions, and each calibration's temperature,
table and recording SHA-256 and date (:func:`report.provenance.thermal_provenance`).  The header
needs C99 (``static inline``) or C++, and says so with an ``#error`` under an older C standard.
"""

from __future__ import annotations

from ..core.version import build_identity
from ..model.registry import (ACCEL_BIAS, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES, ACCEL_SCALE, GYRO_BIAS,
                              GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES, GYRO_SCALE, N_PARAMS, NAMES)
from ..model.thermal import ThermalModel
from .cheader import C99_CHECK, PREFIX, _c_number, _c_string, comment_lines


def _array(name: str, values) -> str:
    body = ",\n    ".join(_c_number(v) for v in values)
    return f"static const double {PREFIX}_{name}[{N_PARAMS}] = {{\n    {body}}};"


def _sensor(sensor: str, bias: slice, scale: slice, misalign: slice, entries, pulses: str, out: str) -> list[str]:
    """C lines compensating one sensor's triad from the parameters ``p`` at T."""
    lines = [f"    /* {sensor} */",
             "    K[0][0] = 1.0; K[0][1] = 0.0; K[0][2] = 0.0;",
             "    K[1][0] = 0.0; K[1][1] = 1.0; K[1][2] = 0.0;",
             "    K[2][0] = 0.0; K[2][1] = 0.0; K[2][2] = 1.0;"]
    lines += [f"    K[{i}][{j}] = p[{misalign.start + k}];" for k, (i, j) in enumerate(entries)]
    lines += [f"    r[{i}] = p[{scale.start + i}] * {pulses}[{i}] - p[{bias.start + i}] * dt;" for i in range(3)]
    lines += [f"    {PREFIX}_solve3(K, r, {out});"]
    return lines


SOLVE3 = f"""/* x = K^-1 r by Cramer's rule (K: a misalignment matrix, unit diagonal). */
static inline void {PREFIX}_solve3(double K[3][3], const double r[3], double x[3])
{{
    double c00 = K[1][1] * K[2][2] - K[1][2] * K[2][1];
    double c01 = K[1][2] * K[2][0] - K[1][0] * K[2][2];
    double c02 = K[1][0] * K[2][1] - K[1][1] * K[2][0];
    double det = K[0][0] * c00 + K[0][1] * c01 + K[0][2] * c02;
    x[0] = (r[0] * c00 + K[0][1] * (K[1][2] * r[2] - r[1] * K[2][2]) + K[0][2] * (r[1] * K[2][1] - K[1][1] * r[2]))
        / det;
    x[1] = (K[0][0] * (r[1] * K[2][2] - K[1][2] * r[2]) + r[0] * c01 + K[0][2] * (K[1][0] * r[2] - r[1] * K[2][0]))
        / det;
    x[2] = (K[0][0] * (K[1][1] * r[2] - r[1] * K[2][1]) + K[0][1] * (r[1] * K[2][0] - K[1][0] * r[2]) + r[0] * c02)
        / det;
}}"""


def c_header_thermal(model: ThermalModel, metadata: dict | None = None) -> str:
    """The C header text of a thermal model (see the module docstring); ``metadata`` its provenance
    (:func:`report.provenance.thermal_provenance`), one comment line per entry.

    Raises
    ------
    ValueError
        When the model lacks any of the 21 parameters.
    """
    if tuple(model.names[:N_PARAMS]) != NAMES:
        raise ValueError("the thermal model does not have the 21 parameters of eq. 1 in table order")
    metadata = {k: v for k, v in (metadata or {}).items() if v is not None}
    extras = model.names[N_PARAMS:]
    guard = "CASADI_SINS_THERMAL_COMPENSATION_H"
    lines = ["/* Temperature-dependent compensation of a strapdown IMU,"]
    lines += comment_lines(f"written by {build_identity()}.")
    lines += [" * Needs C99 or later (static inline functions), or C++.",
             " *",
             " * Each of the 21 parameters of the output model (Kang et al. 2013, eq. 1), SI, table order:",
             f" *     p(T) = p_ref + a1 d + a2 d^2,   d = T - {model.reference_c!r} degC",
             f" * calibrated from {model.range_c[0]:g} to {model.range_c[1]:g} degC: outside that range p is evaluated at",
             " * the nearest end of it (clamped; define CASADI_SINS_THERMAL_EXTRAPOLATE to extrapolate instead)",
             " * and the functions return 1 (0 within the range).",
             " * Per sample interval dt (s) from the raw pulses dN_g, dN_a at the unit's temperature T (degC):",
             " *     dtheta = K_g^-1 (diag(S_g) dN_g - B_g dt)   (rad)",
             " *     dv     = K_a^-1 (diag(S_a) dN_a - B_a dt)   (m/s)"]
    lines += comment_lines("Parameters (the index of p, a1, a2): " + ", ".join(f"{i} {n}" for i, n in enumerate(NAMES))
                           + ".")
    lines += [" *"]
    for key, value in metadata.items():
        lines += comment_lines(f"{key}: {value}")
    if extras:
        lines += [" *"] + comment_lines("NOT compensated here: " + ", ".join(extras) + ".")
    lines += [" */", f"#ifndef {guard}", f"#define {guard}", "", C99_CHECK, ""]
    if extras:
        lines += ["#define CASADI_SINS_EXTRAS_NOT_COMPENSATED 1", ""]
    c = model.coefficients[:N_PARAMS]
    lines += [f"static const char {PREFIX}_unit_id[] = {_c_string(metadata.get('unit_id', ''))};",
              f"static const char {PREFIX}_thermal_model_sha256[] = "
              f"{_c_string(metadata.get('thermal_model_sha256', ''))};",
              f"static const double {PREFIX}_t_ref_c = {_c_number(model.reference_c)};",
              f"static const double {PREFIX}_t_min_c = {_c_number(model.range_c[0])};",
              f"static const double {PREFIX}_t_max_c = {_c_number(model.range_c[1])};", "",
              _array("p_ref", c[:, 0]), _array("a1", c[:, 1]), _array("a2", c[:, 2]), "",
              "/* The 21 parameters at temperature_c (degC), SI, table order; returns 1 when temperature_c lies",
              " * outside the calibrated range (then clamped to it, unless CASADI_SINS_THERMAL_EXTRAPOLATE), else 0. */",
              f"static inline int {PREFIX}_parameters_t(double temperature_c, double p[{N_PARAMS}])",
              "{", "    double d;", "    int i, outside = 0;",
              f"    if (temperature_c < {PREFIX}_t_min_c || temperature_c > {PREFIX}_t_max_c) {{",
              "        outside = 1;",
              "#ifndef CASADI_SINS_THERMAL_EXTRAPOLATE",
              f"        temperature_c = temperature_c < {PREFIX}_t_min_c ? {PREFIX}_t_min_c : {PREFIX}_t_max_c;",
              "#endif",
              "    }",
              f"    d = temperature_c - {PREFIX}_t_ref_c;",
              f"    for (i = 0; i < {N_PARAMS}; ++i) {{",
              f"        p[i] = {PREFIX}_p_ref[i] + d * {PREFIX}_a1[i] + d * d * {PREFIX}_a2[i];", "    }",
              "    return outside;", "}", "",
              SOLVE3, "",
              "/* Compensated increments of one sample interval at temperature_c: dtheta (rad) and dv (m/s); returns 1",
              " * when temperature_c lies outside the calibrated range (see casadi_sins_parameters_t), else 0. */",
              f"static inline int {PREFIX}_compensate_t(const double dN_g[3], const double dN_a[3], double dt,",
              "                                        double temperature_c, double dtheta[3], double dv[3])",
              "{", f"    double p[{N_PARAMS}], K[3][3], r[3];",
              f"    int outside = {PREFIX}_parameters_t(temperature_c, p);"]
    lines += _sensor("gyros", GYRO_BIAS, GYRO_SCALE, GYRO_MISALIGN, GYRO_MISALIGN_ENTRIES, "dN_g", "dtheta")
    lines += _sensor("accelerometers", ACCEL_BIAS, ACCEL_SCALE, ACCEL_MISALIGN, ACCEL_MISALIGN_ENTRIES, "dN_a", "dv")
    lines += ["    return outside;", "}", "", f"#endif /* {guard} */"]
    return "\n".join(lines) + "\n"
