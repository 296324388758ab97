"""Exports of a parameter table in the forms units load: compensation matrices, and the PSINS layout.

Compensation form (JSON or YAML), per sensor: the increments from the raw pulses of one sample,

    dtheta = M_g dN_g + c_g dt,    M = K^-1 diag(S),   c = -K^-1 B          (eq. 1 inverted)
    dv     = M_a dN_a + c_a dt

with ``K^-1``, ``S`` and ``B`` also given separately (SI: rad, m/s, per pulse; rad/s, m/s^2), the
sigma of every parameter, the extra terms when estimated, and a metadata block (unit id, date,
software, the recording's hash).

C header (:mod:`report.cheader`): the same matrices as ``static const double`` arrays and an inline
compensation function, for the unit's firmware.  Every export carries the provenance of its table
(:mod:`report.provenance`) and is written with every number in full float64 precision.

PSINS layout (text): the fields of the toolbox's ``clbt`` struct as MATLAB assignments, such that
its compensation ``wm' = Kg*wm - eb*ts``, ``vm' = Ka*vm - db*ts`` applied to increments in rad and
m/s made with the nominal pulse sizes (``wm = p_g dN_g``) gives our compensated increments:
``Kg = K_g^-1 diag(S_g) / p_g``, ``eb = K_g^-1 B_g`` (likewise Ka, db).  The extra terms follow the
toolbox's signs, each group's own (:mod:`model.groups`: ``Ka2 = -k2``; lever arms ``rx, ry`` are
compensation values, minus the accelerometers' positions; ``tGA`` the time offset; ``gSens = K_g^-1 G``)
as worked out for the PSINS 19-position peer recording (``docs/recording-format.md``).
"""

from __future__ import annotations

import datetime
import json
from pathlib import Path

import numpy as np

from ..core.text import code_comment
from ..core.version import build_identity
from ..model.output import sensor_matrices
from ..model.parameters import ParameterSet
from ..model.registry import EXTRA_GROUPS, GROUPS, N_PARAMS, unit_of
from .cheader import c_header
from .export_formats import EXPORT_FORMATS


def compensation(params: ParameterSet, metadata: dict | None = None) -> dict:
    """The compensation form of a parameter set as plain data."""
    k_a, s_a, b_a, k_g, s_g, b_g = (np.asarray(m, dtype=float) for m in sensor_matrices(params.core))
    sigma = dict(zip(params.names, params.sigma)) if params.sigma is not None else {}
    out = {"format": "casadi-sins-compensation/1",
           "metadata": {"software": build_identity(),
                        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                        **(metadata or {})},
           "model": "dtheta = M_g dN_g + c_g dt, dv = M_a dN_a + c_a dt; M = K^-1 diag(S), c = -K^-1 B "
                    "(Kang et al. 2013, eq. 1 inverted); SI units"}
    for sensor, k, s, b, unit, rate in (("gyro", k_g, s_g, b_g, "rad", "rad/s"),
                                        ("accel", k_a, s_a, b_a, "m/s", "m/s^2")):
        k_inv = np.linalg.inv(k)
        out[sensor] = {"M": (k_inv @ np.diag(s.ravel())).tolist(), "c": (-k_inv @ b.ravel()).tolist(),
                       "K_inverse": k_inv.tolist(), "scale": s.ravel().tolist(), "bias": b.ravel().tolist(),
                       "units": {"M": f"{unit}/pulse", "c": rate, "scale": f"{unit}/pulse", "bias": rate}}
    out["parameters"] = [{"parameter": n, "unit": unit_of(n), "value": float(v),
                          "sigma": None if n not in sigma or not np.isfinite(sigma[n]) else float(sigma[n])}
                         for n, v in zip(params.names, params.values)]
    if params.extras:
        out["extras"] = {n: float(v) for n, v in zip(params.names[N_PARAMS:], params.values[N_PARAMS:])}
    return out


def to_json(data: dict) -> str:
    """The compensation form as JSON text."""
    return json.dumps(data, indent=2) + "\n"


def to_yaml(data, indent: int = 0) -> str:
    """Plain YAML of nested dicts, lists and numbers (no dependency; lists of numbers in flow style)."""
    pad = "  " * indent
    lines = []
    if isinstance(data, dict):
        for key, value in data.items():
            if isinstance(value, (dict, list)) and not _flat(value):
                lines.append(f"{pad}{key}:")
                lines.append(to_yaml(value, indent + 1).rstrip("\n"))
            else:
                lines.append(f"{pad}{key}: {_scalar(value)}")
    else:
        for item in data:
            if isinstance(item, dict):
                first = True
                for key, value in item.items():
                    lines.append(f"{pad}{'- ' if first else '  '}{key}: {_scalar(value)}")
                    first = False
            else:
                lines.append(f"{pad}- {_scalar(item)}")
    return "\n".join(lines) + "\n"


def _flat(value) -> bool:
    return isinstance(value, list) and all(not isinstance(v, dict) for v in value)


def _scalar(value) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(_scalar(v) for v in value) + "]"
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, np.floating)):
        return repr(float(value))
    return json.dumps(str(value))


def psins_clbt(params: ParameterSet, pulse_gyro: float | None = None, pulse_accel: float | None = None,
               metadata: dict | None = None) -> str:
    """The PSINS ``clbt`` struct as MATLAB text (see the module docstring for the convention)."""
    k_a, s_a, b_a, k_g, s_g, b_g = (np.asarray(m, dtype=float) for m in sensor_matrices(params.core))
    p_g = float(pulse_gyro or np.mean(s_g))
    p_a = float(pulse_accel or np.mean(s_a))

    def mat(m):
        m = np.atleast_2d(m)
        return "[" + "; ".join(" ".join(repr(float(x) + 0.0) for x in row) for row in m) + "]"  # no -0

    k_g_inv, k_a_inv = np.linalg.inv(k_g), np.linalg.inv(k_a)
    lines = [f"% PSINS clbt struct from {build_identity()}",
             f"% wm = {p_g!r} * dN_g (rad), vm = {p_a!r} * dN_a (m/s); then wm' = Kg*wm - eb*ts, "
             "vm' = Ka*vm - db*ts"]
    lines += [f"% {code_comment(k)}: {code_comment(v)}" for k, v in (metadata or {}).items()]
    lines += [f"clbt.Kg = {mat(k_g_inv @ np.diag(s_g.ravel()) / p_g)};",
              f"clbt.eb = {mat((k_g_inv @ b_g.ravel())[:, None])};",
              f"clbt.Ka = {mat(k_a_inv @ np.diag(s_a.ravel()) / p_a)};",
              f"clbt.db = {mat((k_a_inv @ b_a.ravel())[:, None])};"]
    for field, (value, unit) in psins_extra_fields(params.as_dict(), k_g_inv).items():
        value = np.asarray(value, dtype=float)
        text = repr(float(value) + 0.0) if value.ndim == 0 else mat(value[:, None] if value.ndim == 1 else value)
        lines.append(f"clbt.{field} = {text};  % {unit}")
    left = [GROUPS[k].label for k in params.extras if GROUPS[k].psins is None]
    if left:
        lines.append(f"% not in the clbt struct (no such field): {', '.join(left)}")
    return "\n".join(lines) + "\n"


def psins_extra_fields(values: dict, k_g_inv: np.ndarray) -> dict:
    """The extra groups' ``clbt`` fields (every group of the registry, 0 when absent from ``values``):
    ``{field: (value, unit)}``; groups filling parts of one field (lever arms) add up."""
    out: dict = {}
    for key in EXTRA_GROUPS:
        group = GROUPS[key]
        if group.psins is None:
            continue
        for field, (value, unit) in group.psins({n: values[n] for n in group.names if n in values}, k_g_inv).items():
            out[field] = (out[field][0] + value, unit) if field in out else (value, unit)
    return out


_WRITERS = {"json": lambda p, meta: to_json(compensation(p, meta)),
            "yaml": lambda p, meta: to_yaml(compensation(p, meta)),
            "psins": lambda p, meta: psins_clbt(p, metadata=meta),
            "c": c_header}
#: Export format -> (suffix of its file beside the table, writer ``(params, metadata) -> text``), in the order
#: of :data:`report.export_formats.EXPORT_FORMATS`.
EXPORTS = {fmt: (suffix, _WRITERS[fmt]) for fmt, (suffix, _) in EXPORT_FORMATS.items()}


def export_path(table_path, fmt: str) -> Path:
    """``NAME.compensation.json`` ... : the file of the export ``fmt`` beside a table ``NAME.csv``."""
    stem = Path(table_path).with_suffix("")
    return stem.with_name(f"{stem.name}.{EXPORTS[fmt][0]}")


def export_files(params: ParameterSet, table_path, formats, metadata: dict) -> dict:
    """``{path: content}`` of the exports beside a table ``NAME.csv``: ``NAME.compensation.json`` ..."""
    meta = {k: v for k, v in metadata.items() if v is not None}
    return {export_path(table_path, f): EXPORTS[f][1](params, meta).encode() for f in formats}
