"""A parameter table as a C header for the unit's firmware.

The header holds the compensation of eq. 1 inverted, per sensor, in ``static const double`` arrays
(every number written in its shortest exact decimal form: the C compiler reads back the very
float64 that Python used) and one inline function::

    dtheta = M_g dN_g + c_g dt        M = K^-1 diag(S),  c = -K^-1 B
    dv     = M_a dN_a + c_a dt

with ``dN`` the raw pulses of one sample interval, ``dt`` its length (s), ``dtheta`` in rad and ``dv``
in m/s (:func:`model.output.compensation_matrices`, the same numbers as the JSON export).  The unit
id, the table's provenance (recording hash, date, software) are in the comment block and in string
constants.  The gyro's extra groups of a table (g-sensitivity, scale asymmetry: each group's
``c_terms``, :mod:`model.groups`) are per-sample terms after the affine part::

    dtheta -= G_g dv + A_g |dtheta|

The accelerometers' extra terms (quadratic scale, lever arms, time offset) are not in a per-sample
form: when a table has them, the header says so and defines ``CASADI_SINS_EXTRAS_NOT_COMPENSATED``.
"""

from __future__ import annotations

import hashlib
import re
import textwrap

import numpy as np

from ..core.text import code_comment
from ..core.version import build_identity
from ..model.output import compensation_matrices, sensor_matrices
from ..model.parameters import ParameterSet
from ..model.registry import GROUPS

PREFIX = "casadi_sins"


def _c_number(x: float) -> str:
    text = repr(float(x) + 0.0)  # no -0; repr is the shortest string that reads back exactly
    return text if any(c in text for c in ".en") else text + ".0"


def _c_string(text: str) -> str:
    """A C string literal of printable ASCII (anything else becomes ``?``, escaped: no trigraph)."""
    clean = "".join(c if 32 <= ord(c) < 127 else "?" for c in str(text))
    return '"' + clean.replace("\\", "\\\\").replace('"', '\\"').replace("?", "\\?") + '"'  # no trigraphs


def _comment(text: str) -> str:
    return "".join(c if 32 <= ord(c) < 127 else "?" for c in code_comment(text))


#: The preprocessor check that a header is compiled as C99 or later (``static inline``), or as C++.
C99_CHECK = """#if !defined(__cplusplus) && (!defined(__STDC_VERSION__) || __STDC_VERSION__ < 199901L)
#error "this header needs C99 or later (static inline functions): compile with -std=c99 or newer"
#endif"""
#: The width of a comment line of a header.
COMMENT_WIDTH = 100


def comment_lines(text: str) -> list[str]:
    """``text`` as whole lines of a C block comment (`` * ...``), wrapped at :data:`COMMENT_WIDTH`, nothing cut
    off (each line made safe by :func:`_comment`)."""
    clean = "".join(c if 32 <= ord(c) < 127 else "?" for c in str(text).replace("\n", " "))
    clean = clean.replace("*/", "* /").replace("/*", "/ *")
    return [f" * {line}" for line in textwrap.wrap(clean, COMMENT_WIDTH - 3, break_long_words=True,
                                                    subsequent_indent="    ")] or [" *"]


def _matrix(name: str, m: np.ndarray) -> str:
    rows = ",\n    ".join("{" + ", ".join(_c_number(x) for x in row) + "}" for row in m)
    return f"static const double {PREFIX}_{name}[3][3] = {{\n    {rows}}};"


def _vector(name: str, v: np.ndarray) -> str:
    return f"static const double {PREFIX}_{name}[3] = {{" + ", ".join(_c_number(x) for x in v) + "};"


def c_header(params: ParameterSet, metadata: dict | None = None) -> str:
    """The C header text of a parameter set (see the module docstring)."""
    metadata = {k: v for k, v in (metadata or {}).items() if v is not None}
    mats = compensation_matrices(params.core)
    (m_g, c_g), (m_a, c_a) = mats["gyro"], mats["accel"]
    unit = str(metadata.get("unit_id", ""))
    tag = hashlib.sha256(unit.encode("utf-8", "surrogatepass")).hexdigest()[:8].upper()  # SN-1 and SN_1 differ
    guard = f"CASADI_SINS_COMPENSATION_{re.sub(r'[^A-Z0-9]', '_', unit.upper())[:60]}_{tag}_H"
    lines = ["/* Sensor compensation of a strapdown IMU, written by " + build_identity() + ".",
             " * Needs C99 or later (static inline functions), or C++.",
             " *",
             " * Per sample interval of length dt (s), from the raw pulses dN_g, dN_a of the three gyros and",
             " * three accelerometers (body axes x, y, z):",
             " *",
             " *     dtheta = M_g dN_g + c_g dt   (rad)      M = K^-1 diag(S),  c = -K^-1 B",
             " *     dv     = M_a dN_a + c_a dt   (m/s)",
             " *",
             " * the exact inverse of the output model dN = diag(S)^-1 (K x + B dt) (Kang et al. 2013, eq. 1):",
             " * S scale factors (rad or m/s per pulse), K misalignment matrices (unit diagonal), B biases",
             " * (rad/s, m/s^2). All numbers float64, SI; M in rad/pulse and m/s/pulse, c in rad/s and m/s^2.",
             " *"]
    lines += [f" * {_comment(k)}: {_comment(v)}" for k, v in metadata.items()]
    terms = _extra_terms(params)
    left = [k for k in params.extras if GROUPS[k].c_terms is None]
    lines += [f" * {name}: {_comment(meaning)}" for name, _, meaning in terms]
    if left:
        lines += [" *", " * NOT compensated here: the extra terms of this table (" + _comment(", ".join(left))
                  + "); see the JSON export."]
    lines += [" */", f"#ifndef {guard}", f"#define {guard}", "", C99_CHECK, ""]
    if left:
        lines += ["#define CASADI_SINS_EXTRAS_NOT_COMPENSATED 1", ""]
    if terms:
        lines += ["#include <math.h>", ""]
    lines += [f"static const char {PREFIX}_unit_id[] = {_c_string(metadata.get('unit_id', ''))};",
              f"static const char {PREFIX}_recording_sha256[] = {_c_string(metadata.get('recording_sha256', ''))};",
              f"static const char {PREFIX}_table_sha256[] = {_c_string(metadata.get('table_sha256', ''))};", "",
              _matrix("M_g", m_g), _vector("c_g", c_g), _matrix("M_a", m_a), _vector("c_a", c_a)]
    lines += [_matrix(name, m) for name, m, _ in terms]
    lines += ["",
              "/* Compensated increments of one sample interval: dtheta (rad) and dv (m/s). */",
              f"static inline void {PREFIX}_compensate(const double dN_g[3], const double dN_a[3], double dt,",
              "                                         double dtheta[3], double dv[3])",
              "{",
              "    int i;",
              "    for (i = 0; i < 3; ++i) {",
              f"        dtheta[i] = {PREFIX}_M_g[i][0] * dN_g[0] + {PREFIX}_M_g[i][1] * dN_g[1]"
              f" + {PREFIX}_M_g[i][2] * dN_g[2] + {PREFIX}_c_g[i] * dt;",
              f"        dv[i] = {PREFIX}_M_a[i][0] * dN_a[0] + {PREFIX}_M_a[i][1] * dN_a[1]"
              f" + {PREFIX}_M_a[i][2] * dN_a[2] + {PREFIX}_c_a[i] * dt;",
              "    }"]
    lines += _extra_code(terms)
    lines += ["}", "", f"#endif /* {guard} */"]
    return "\n".join(lines) + "\n"


def _extra_terms(params: ParameterSet) -> list:
    """``(C name, 3 x 3 matrix, meaning)`` of the table's extra groups with a per-sample form."""
    k_g = np.asarray(sensor_matrices(params.core)[3], dtype=float)
    values = params.as_dict()
    out = []
    for key in params.extras:
        group = GROUPS[key]
        if group.c_terms is not None:
            out += group.c_terms({n: values[n] for n in group.names if n in values}, np.linalg.inv(k_g))
    return out


def _extra_code(terms) -> list[str]:
    """The loop subtracting the gyro's extra terms (``G_g dv``, ``A_g |dtheta|``) from ``dtheta``."""
    if not terms:
        return []
    sources = {"G_g": "dv[j]", "A_g": "fabs(first[j])"}
    lines = ["    {", "        double first[3];", "        int j;",
             "        for (i = 0; i < 3; ++i) first[i] = dtheta[i];",
             "        for (i = 0; i < 3; ++i) {", "            for (j = 0; j < 3; ++j) {"]
    lines += [f"                dtheta[i] -= {PREFIX}_{name}[i][j] * {sources[name]};" for name, _, _ in terms]
    return lines + ["            }", "        }", "    }"]
