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

Every value is the sigma of a zero-mean error, independent of every other one.  The sources of the
split are the groups below (:data:`GROUPS`); a calibrated table (:mod:`.calibrated`) replaces the six
sensor groups by its sigma and, when known, its full covariance (then correlated across groups: kept
in the total, Guan et al. 2023, eqs. 20-30).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ...core import units
from ...core.earth import Site
from ...core.errors import InputError, shown
from ...core.toml import read_toml
from ...model import registry
from . import model as M
from . import shipped

#: The ``format`` key of an error sheet.
FORMAT = "casadi-sins-errors/1"

def _registry_groups(sensor: str) -> dict[str, list[int]]:
    """The paper's groups of one sensor with their labels and states, from the registry
    (:data:`casadi_sins.model.registry.GROUPS`), in its order."""
    out = {}
    for key in registry.CORE_GROUPS:
        group = registry.GROUPS[key]
        if group.sensor == sensor:
            first = M.N_NAV + registry.NAMES.index(group.names[0])
            out[group.label] = list(range(first, first + len(group.names)))
    return out


#: The independent sources and their states: the initial attitude, the gyro's groups, its scale asymmetry
#: (the registry's ``gyro_asym``, a state of its own here), the accelerometer's groups.
GROUPS = {
    "initial level": [0, 1],
    "initial heading": [2],
    **_registry_groups("gyro"),
    "gyro scale asymmetry": list(range(M.GYRO_ASYM.start, M.GYRO_ASYM.stop)),
    **_registry_groups("accel"),
}
NOISES = ("gyro noise", "accel noise")
SOURCES = tuple(GROUPS) + NOISES
#: (section, key, states or count, SI per natural unit)
SHEET_KEYS = {
    ("initial", "level_arcsec"): ([0, 1], units.ARCSEC),
    ("initial", "heading_arcmin"): ([2], 60 * units.ARCSEC),
    ("gyro", "bias_deg_h"): (GROUPS["gyro bias"], units.DEG_PER_H),
    ("gyro", "scale_ppm"): (GROUPS["gyro scale"], units.PPM),
    ("gyro", "misalignment_arcsec"): (GROUPS["gyro misalignment"], units.ARCSEC),
    ("gyro", "asymmetry_ppm"): (GROUPS["gyro scale asymmetry"], units.PPM),
    ("accel", "bias_ug"): (GROUPS["accel bias"], units.UG),
    ("accel", "scale_ppm"): (GROUPS["accel scale"], units.PPM),
    ("accel", "misalignment_arcsec"): (GROUPS["accel misalignment"], units.ARCSEC),
    ("gyro", "noise_deg_sqrt_h"): (3, units.ARW_UNIT),
    ("accel", "noise_ug_sqrt_hz"): (3, units.VRW_UNIT),
}


@dataclasses.dataclass
class Sources:
    """Covariance of the independent initial errors (31 states, SI), the white-noise densities, and
    optionally the map of an alignment: the initial state is ``transform @ x`` (``x ~ p0``).

    Attributes
    ----------
    name : str
    p0 : ndarray (31, 31)
        Covariance of the independent initial errors, SI (scale factors relative).
    gyro_arw, accel_vrw : ndarray (3,)
        White-noise densities, rad/sqrt(s) and m/s/sqrt(s).
    correlated : bool
        ``p0`` has terms between groups (a calibrated table's full covariance).
    origin : str
        Where the errors came from (files), for the report.
    transform : ndarray (31, 31) or None
        None: the initial errors as given; else the map of an alignment (:meth:`Sources.aligned`).
    """

    name: str
    p0: np.ndarray
    gyro_arw: np.ndarray
    accel_vrw: np.ndarray
    correlated: bool = False
    origin: str = ""
    transform: np.ndarray | None = None

    def initial_map(self) -> np.ndarray:
        """The map from the independent errors to the initial error state (identity unless aligned)."""
        return np.eye(M.N_STATE) if self.transform is None else self.transform

    @property
    def initial_covariance(self) -> np.ndarray:
        """Covariance of the initial error state (with the alignment's correlations, when aligned)."""
        t = self.initial_map()
        return t @ self.p0 @ t.T

    def group_covariance(self, group: str) -> np.ndarray:
        """The initial covariance of one source alone (its block, through the alignment if aligned)."""
        idx = GROUPS[group]
        p = np.zeros_like(self.p0)
        p[np.ix_(idx, idx)] = self.p0[np.ix_(idx, idx)]
        t = self.initial_map()
        return t @ p @ t.T

    def values(self) -> np.ndarray:
        """Every sigma as an error value (+1 sigma on every state): the papers' deterministic runs."""
        return self.initial_map() @ np.sqrt(np.clip(np.diag(self.p0), 0.0, None))

    def aligned(self, site: Site, attitude: np.ndarray) -> "Sources":
        """The same errors with the initial attitude error of a static alignment at ``attitude`` added:
        ``phi_0 = A x_sensor`` (:func:`model.alignment_map`) plus the sheet's own initial errors."""
        t = np.eye(M.N_STATE)
        t[M.PHI, M.SENSOR] = M.alignment_map(site, attitude)
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
    p0 = np.zeros((M.N_STATE, M.N_STATE))
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
            states, size = SHEET_KEYS[(section, key)]
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
    path, is_shipped = shipped.find_file(name_or_path, "sheets", "error sheet")
    data = read_toml(path, "error sheet")
    if data.get("format") != FORMAT:
        raise InputError(path, f"format must be {FORMAT!r}, found {shown(data.get('format'))}")
    sheet = parse_sheet(data, str(path))
    return dataclasses.replace(sheet, origin=f"{path.stem} (shipped)" if is_shipped else str(path))


