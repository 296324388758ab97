"""The navigation check and the error budget on a unit's own recording, with its own table.

The paper's check (section 2.3) is free-inertial navigation on a static base after calibration:
:mod:`studies.navcheck` does it on a simulated recording of a problem, where the truth is known.
A user has a recording of the real unit at rest instead: its longest static segment is taken, the
unit is aligned on its first ``align_s`` (eq. 14) and navigates the rest free-inertially with each
table.  The unit does not move, so the distance from the site is the navigation error itself.

The budget (:mod:`studies.budget`) takes the site and sample rate from the recording, the white
noise measured in its static segments (:mod:`noise.raw`), the parameter uncertainty from the
table's sigma, and the orientation of that static segment unless another is given.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.errors import InputError
from ..core.units import DEG_PER_H, UG
from ..core.orientation import orientation_to_dcm
from ..data.recording import Recording, Segment
from ..model.parameters import ParameterSet
from ..nav.free_inertial import NAUTICAL_MILE, NavigationRun, navigate_free
from ..noise.raw import estimate_sensor_noise
from ..report.rounding import display, float_columns
from .budget import Budget, budget_files, error_budget
from .navcheck import check_durations, navigation_check_files


def longest_static(rec: Recording) -> Segment:
    """The longest static segment of a recording (the one to navigate on).

    Raises
    ------
    InputError
        When the recording has no static segment.
    """
    statics = rec.static_segments
    if not statics:
        raise InputError(rec.label, "no static segment: the navigation check needs the unit at rest")
    return max(statics, key=lambda s: s.end - s.start)


def static_part(rec: Recording, seg: Segment, seconds: float | None = None) -> Recording:
    """The samples of one static segment (the first ``seconds`` of it when given) as a recording."""
    sl = rec.segment_samples(seg)
    if seconds is not None:
        sl = slice(sl.start, min(sl.stop, sl.start + int(round(seconds * rec.rate_hz))))
    first = float(rec.time[sl.start] - rec.dt)
    part = Segment(1, 1, "static", first, float(rec.time[sl.stop - 1]), orientation=seg.orientation)
    return dataclasses.replace(rec, segments=[part], time=rec.time[sl], gyro=rec.gyro[sl], accel=rec.accel[sl],
                               source=None, warnings=[],
                               temperature=None if rec.temperature is None else rec.temperature[sl])


def recording_navigation_check(rec: Recording, tables: dict[str, np.ndarray], align_s: float = 300.0,
                               duration_s: float | None = None) -> tuple[list[NavigationRun], pd.DataFrame, Segment]:
    """Free-inertial navigation on the recording's longest static segment with each table.

    Returns the runs, their table (horizontal error at the end and at most, m and nmi) and the segment.

    Raises
    ------
    InputError
        When that segment is too short for the alignment and at least a minute of navigation.
    """
    check_durations(align_s, duration_s, rec.rate_hz)
    seg = longest_static(rec)
    length = seg.end - seg.start
    if length < align_s + 60.0:
        raise InputError(rec.label, f"{seg.describe()} lasts {length:g} s: too short for {align_s:g} s of "
                         "alignment and a minute of navigation (give --align-s or a longer static recording)")
    part = static_part(rec, seg, None if duration_s is None else align_s + duration_s)
    runs = [navigate_free(part, values, align_s, label) for label, values in tables.items()]
    rows = [{"parameters": run.label, "navigation time (s)": float(run.time[-1]),
             "horizontal error at end (m)": run.horizontal_m[-1],
             "horizontal error at end (nmi)": run.horizontal_m[-1] / NAUTICAL_MILE,
             "max horizontal error (nmi)": run.horizontal_m.max() / NAUTICAL_MILE} for run in runs]
    return runs, pd.DataFrame(rows), seg


def measured_white_noise(rec: Recording, params: ParameterSet) -> tuple[float, float]:
    """White accelerometer (ug) and gyro (deg/h) noise per sample, measured in the static segments (the
    upper bound of a term the data do not determine)."""
    raw = estimate_sensor_noise(rec, params.values)
    model = raw.model().merged(raw.upper_bounds())
    per_sample = 1.0 / np.sqrt(rec.dt)
    return (float(np.mean(model.accel_vrw)) * per_sample / UG, float(np.mean(model.gyro_arw)) * per_sample / DEG_PER_H)


def recording_budget(rec: Recording, params: ParameterSet, orientation: str | None = None,
                     hours: float = 24.0) -> tuple[Budget, str, tuple[float, float]]:
    """The error budget of a unit with its table, at its recording's site and noise.

    Returns the budget, the orientation used, and the measured white noise (ug, deg/h per sample).

    Raises
    ------
    InputError
        When the table has no sigma (the budget needs the uncertainty).
    """
    if params.sigma is None:
        raise InputError(None, "the table has no sigma column; the budget needs the uncertainty")
    orientation = orientation or longest_static(rec).orientation
    noise = measured_white_noise(rec, params)
    covariance = (params.covariance if params.covariance is not None  # the report's correlations, when read
                  else np.diag(np.nan_to_num(params.sigma) ** 2))
    budget = error_budget(covariance, params.values, orientation_to_dcm(orientation), rec.site.latitude,
                          rec.site.height, rec.site.g, noise[0], noise[1], rec.rate_hz, duration_s=hours * 3600.0,
                          names=params.names)
    return budget, orientation, noise


def recording_navigation_files(rec: Recording, tables: dict[str, np.ndarray], out_dir: str | Path,
                               align_s: float = 300.0, duration_s: float | None = None
                               ) -> tuple[dict[Path, bytes], pd.DataFrame]:
    """``navcheck`` on a unit's recording: :func:`recording_navigation_check` as the files
    ``OUT/NAME-navcheck.csv/.md/.png`` (for :func:`core.files.write_files`) and the table as shown (errors
    rounded from their sigma)."""
    runs, table, seg = recording_navigation_check(rec, tables, align_s, duration_s)
    shown = display(table, sigmas=[c for c in float_columns(table) if "error" in c])
    files = navigation_check_files(runs, table, shown, Path(out_dir) / f"{rec.file_stem}-navcheck",
                                   f"{rec.name}: free-inertial navigation on {seg.describe()}, after {align_s:g} s "
                                   "of alignment", f"{rec.name}: horizontal position error at rest, after alignment")
    return files, shown


@dataclasses.dataclass(frozen=True)
class RecordingBudget:
    """``budget`` on a unit's recording with its table: the files and what the command says of them.

    Attributes
    ----------
    files : dict
        ``OUT/NAME-budget.csv/.md/.png`` for :func:`core.files.write_files`.
    shown : DataFrame
        The table at 1 h and at the run's end (1 sigma, m), rounded from its sigma.
    orientation : str
        The orientation navigated at.
    noise : str
        The measured white noise, as densities (``VRW ... ug/sqrt(Hz) and ARW ... deg/sqrt(h)``).
    correlations : str
        Where the parameter correlations come from (the table's companion report, or none).
    """

    files: dict
    shown: pd.DataFrame
    orientation: str
    noise: str
    correlations: str


def recording_budget_files(rec: Recording, params: ParameterSet, table_label: str, out_dir: str | Path,
                           orientation: str | None = None, hours: float = 24.0) -> RecordingBudget:
    """:func:`recording_budget` with the table ``table_label`` as the files of ``budget`` on a recording."""
    budget, orientation, (accel_ug, gyro_deg_h) = recording_budget(rec, params, orientation, hours)
    # the noise in the units of a datasheet (densities, as calibrate --noise and analyze take it)
    noise = (f"VRW {accel_ug * math.sqrt(rec.dt):.3g} ug/sqrt(Hz) and ARW {gyro_deg_h * math.sqrt(rec.dt) / 60:.3g} "
             "deg/sqrt(h)")
    correlations = ("with the correlations of its report" if params.covariance is not None
                    else "sigma only: no companion report, correlations between parameters not known")
    table = budget.table([3600.0, hours * 3600.0] if hours != 1.0 else [3600.0])
    files = budget_files(budget, table, Path(out_dir) / f"{rec.file_stem}-budget",
                         f"{rec.name} with {table_label}: static navigation error by source at {orientation} (1 sigma, "
                         f"m); measured white noise {noise}; parameter uncertainty {correlations}",
                         f"{rec.name}: error budget of static navigation at {orientation}")
    return RecordingBudget(files, display(table, sigmas=float_columns(table)), orientation, noise, correlations)
