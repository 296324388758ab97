"""Error sources: an error sheet (TOML, natural units) -> the SI covariance of the initial error state.

Error sheet (``format = "casadi-sins-errors/1"``)::

    format = "casadi-sins-errors/1"
    name = "guan2023-table1"
    sigma_level = 1            # the values are 1-sigma (3: 3-sigma bounds, divided by 3 here)
    [initial]
    level_arcsec = 10.0        # east and north tilt, each
    heading_arcmin = 1.5
    [gyro]
    bias_deg_h = 0.01          # scalar (every axis) or [x, y, z]
    scale_ppm = 10.0
    misalignment_arcsec = 3.0  # scalar or the 6 of T_g: [xy, xz, yx, yz, zx, zy]
    noise_deg_sqrt_h = 0.002   # angle random walk
    asymmetry_ppm = 0.0        # optional: scale-factor asymmetry dK* (Guan et al. 2023, eq. 33)
    [accel]
    bias_ug = 30.0
    scale_ppm = 30.0
    misalignment_arcsec = 3.0  # scalar or the 3 of T_a: [yx, zx, zy]
    noise_ug_sqrt_hz = 5.0     # velocity random walk

Every value is the sigma of a zero-mean error, independent of every other one.  The sheet's terms are the
registry's groups (:mod:`casadi_sins.model.registry`, their natural units): the 21 and the gyro scale
asymmetry (``gyro_scale_asym_*``).  The sources of the split (:meth:`Sources.groups`) are the initial
attitude and every registry group the errors hold; a calibrated table (:mod:`.calibrated`) brings its own
groups, its sigma and, when known, its full covariance (then correlated across groups: kept in the total,
Guan et al. 2023, eqs. 20-30).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ...core import units
from ...core.earth import Site
from ...core.errors import InputError, shown
from ...model import registry
from .model import N_NAV, NAV_NAMES, PHI, SHEET_NAMES, ErrorModel
from . import shipped

#: The ``format`` key of an error sheet.
FORMAT = "casadi-sins-errors/1"
#: The sources of the initial attitude: their states.
INITIAL = {"initial level": [0, 1], "initial heading": [2]}
NOISES = ("gyro noise", "accel noise")
#: (section, key) of a sheet -> the registry group it gives, or (states of the initial attitude or noise
#: count, SI per natural unit).
SHEET_KEYS = {
    ("initial", "level_arcsec"): (INITIAL["initial level"], units.ARCSEC),
    ("initial", "heading_arcmin"): (INITIAL["initial heading"], 60 * units.ARCSEC),
    ("gyro", "bias_deg_h"): "gyro_bias",
    ("gyro", "scale_ppm"): "gyro_scale",
    ("gyro", "misalignment_arcsec"): "gyro_misalign",
    ("gyro", "asymmetry_ppm"): "gyro_asym",
    ("accel", "bias_ug"): "accel_bias",
    ("accel", "scale_ppm"): "accel_scale",
    ("accel", "misalignment_arcsec"): "accel_misalign",
    ("gyro", "noise_deg_sqrt_h"): (3, units.ARW_UNIT),
    ("accel", "noise_ug_sqrt_hz"): (3, units.VRW_UNIT),
}


def _states(names, key: str) -> list[int]:
    """The states of a registry group's parameters among ``names`` (after the navigation errors)."""
    return [N_NAV + i for i, n in enumerate(names) if n in registry.GROUPS[key].names]


def source_groups(names) -> dict[str, list[int]]:
    """The independent sources of an error state of the parameters ``names`` and their states: the initial
    attitude, then each registry group present, the gyro's before the accelerometer's (registry order)."""
    out = dict(INITIAL)
    for sensor in ("gyro", "accel"):
        for key, group in registry.GROUPS.items():
            if group.sensor == sensor and _states(names, key):
                out[group.label] = _states(names, key)
    return out


@dataclasses.dataclass
class Sources:
    """Covariance of the independent initial errors (SI), the white-noise densities, and optionally the map
    of an alignment: the initial state is ``transform @ x`` (``x ~ p0``).

    Attributes
    ----------
    name : str
    p0 : ndarray (n, n)
        Covariance of the independent initial errors of the state of :class:`model.ErrorModel` with the
        parameters ``names``, SI (scale factors relative).
    gyro_arw, accel_vrw : ndarray (3,)
        White-noise densities, rad/sqrt(s) and m/s/sqrt(s).
    correlated : bool
        ``p0`` has terms between groups (a calibrated table's full covariance).
    origin : str
        Where the errors came from (files), for the report.
    transform : ndarray (n, n) or None
        None: the initial errors as given; else the map of an alignment (:meth:`Sources.aligned`).
    names : tuple of str
        The parameters whose errors are states (the 21, then extra groups; a sheet's: :data:`model.SHEET_NAMES`).
    """

    name: str
    p0: np.ndarray
    gyro_arw: np.ndarray
    accel_vrw: np.ndarray
    correlated: bool = False
    origin: str = ""
    transform: np.ndarray | None = None
    names: tuple[str, ...] = SHEET_NAMES

    def model(self, site: Site) -> ErrorModel:
        """The error model of these sources' state at ``site``."""
        return ErrorModel(site, self.names)

    @property
    def state_names(self) -> tuple[str, ...]:
        """The names of the state's entries (navigation errors, then ``names``)."""
        return NAV_NAMES + tuple(self.names)

    def groups(self) -> dict[str, list[int]]:
        """The independent sources and their states (:func:`source_groups`)."""
        return source_groups(self.names)

    def initial_map(self) -> np.ndarray:
        """The map from the independent errors to the initial error state (identity unless aligned)."""
        return np.eye(len(self.p0)) if self.transform is None else self.transform

    @property
    def initial_covariance(self) -> np.ndarray:
        """Covariance of the initial error state (with the alignment's correlations, when aligned)."""
        t = self.initial_map()
        return t @ self.p0 @ t.T

    def group_covariance(self, group: str) -> np.ndarray:
        """The initial covariance of one source alone (its block, through the alignment if aligned)."""
        idx = self.groups()[group]
        p = np.zeros_like(self.p0)
        p[np.ix_(idx, idx)] = self.p0[np.ix_(idx, idx)]
        t = self.initial_map()
        return t @ p @ t.T

    def values(self) -> np.ndarray:
        """Every sigma as an error value (+1 sigma on every state): the papers' deterministic runs."""
        return self.initial_map() @ np.sqrt(np.clip(np.diag(self.p0), 0.0, None))

    def aligned(self, site: Site, attitude: np.ndarray) -> "Sources":
        """The same errors with the initial attitude error of a static alignment at ``attitude`` added:
        ``phi_0 = A x_sensor`` (:meth:`ErrorModel.alignment_map`, eq. 15) plus the sheet's own initial errors."""
        model = self.model(site)
        t = np.eye(model.n_state)
        t[PHI, model.sensor] = model.alignment_map(attitude)
        return dataclasses.replace(self, transform=t, name=f"{self.name} (aligned)")


def _values(raw, count: int, source: str, where: str) -> np.ndarray:
    """One sheet entry: a number for every axis, or ``count`` numbers; finite, >= 0."""
    items = raw if isinstance(raw, list) else [raw]
    if len(items) not in (1, count):
        raise InputError(source, f"{where}: give one number or {count}")
    if any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in items):
        raise InputError(source, f"{where}: not a number ({shown(raw)})")
    vals = np.array(items, dtype=float)
    if not np.all(np.isfinite(vals)):
        raise InputError(source, f"{where}: not finite ({shown(raw)})")
    if np.any(vals < 0):
        raise InputError(source, f"{where}: a sigma cannot be negative ({shown(raw)})")
    return np.broadcast_to(vals, (count,)).copy()


def parse_sheet(data: dict, source: str) -> Sources:
    """An error sheet's TOML table -> :class:`Sources` (``format`` is not required here).

    Raises
    ------
    InputError
        Naming ``source`` and the section and key at fault.
    """
    if "sigma_level" not in data:
        raise InputError(source, "the sheet does not say what its values are: add sigma_level = 1 "
                         "(values are 1-sigma) or 3 (3-sigma bounds)")
    level = data["sigma_level"]
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not math.isfinite(level) or level <= 0:
        raise InputError(source, f"sigma_level must be a positive number (got {shown(level)})")
    known_sections = ("initial", "gyro", "accel")
    extra = set(data) - set(known_sections) - {"format", "name", "sigma_level", "description", "reference",
                                               "meaning", "note"}
    if extra:
        raise InputError(source, f"unknown key(s) {shown(', '.join(sorted(extra)))}")
    n_state = N_NAV + len(SHEET_NAMES)
    p0 = np.zeros((n_state, n_state))
    noise = {}
    for section in known_sections:
        table = data.get(section, {})
        if not isinstance(table, dict):
            raise InputError(source, f"[{section}] must be a table")
        unknown = {k for k in table if (section, k) not in SHEET_KEYS}
        if unknown:
            allowed = ", ".join(k for s, k in SHEET_KEYS if s == section)
            raise InputError(source, f"[{section}] unknown key(s) {shown(', '.join(sorted(unknown)))} ({allowed})")
        for key, raw in table.items():
            entry = SHEET_KEYS[(section, key)]
            states, size = ((_states(SHEET_NAMES, entry), registry.GROUPS[entry].natural_scale)
                            if isinstance(entry, str) else entry)
            count = states if isinstance(states, int) else len(states)
            sig = _values(raw, count, source, f"[{section}] {key}") * size / float(level)
            if isinstance(states, int):
                noise[key] = sig
            else:
                p0[states, states] = sig**2
    name = data.get("name", Path(source).stem)
    return Sources(name if isinstance(name, str) else Path(source).stem, p0, noise.get("noise_deg_sqrt_h", np.zeros(3)),
                   noise.get("noise_ug_sqrt_hz", np.zeros(3)), origin=source)


def load_sheet(name_or_path) -> Sources:
    """An error sheet file, or the name of a shipped one (``guan2023-table1``, ``yu-ruan2014-sim``).

    Raises
    ------
    InputError
        Naming the file (and the section and key) at fault, or listing the shipped sheets.
    """
    data, _, path, origin = shipped.read_file(name_or_path, "sheets", "error sheet", FORMAT, "error sheet")
    return dataclasses.replace(parse_sheet(data, str(path)), origin=origin)


