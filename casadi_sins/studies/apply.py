"""Apply a parameter table to a recording: the compensated recording and its check at rest.

The raw pulses of every sample are compensated with the table (eq. 1 inverted and every extra group's
correction, :func:`model.output.compensate_table`) and written as a recording of the same format whose "pulses" are
the compensated increments themselves: ``gyro_*`` in rad, ``accel_*`` in m/s per sample, the pulse
size 1 rad and 1 m/s implied.  Such a recording calibrates to the identity table (scale factors 1,
misalignments and biases 0) within its sigma, when the table was right.

The check, per static segment (the unit at rest): the mean compensated specific force must have the
magnitude of the site's gravity and the mean rate that of the Earth, with the component along the
vertical ``Omega sin L`` and the horizontal one ``Omega cos L``; the noise columns are the 1-sigma of
each mean from the scatter of its samples.  A table that is off shows here as errors far beyond
the noise.  The extra groups are applied sample by sample
(the lever arms and the time offset act not at rest; the gyro g-sensitivity does).

**The verdict.**  Each error is judged against what a right table would still leave: the noise of its
mean and the table's own uncertainty at that orientation (the gravity and Earth-rate magnitudes
differentiated with respect to the 21 parameters at the segment's mean pulses, one sigma each,
combined with the table's covariance when its report gives it, else its sigma), ``z = error /
sqrt(noise^2 + table^2)``.  The table fails the check when some static segment's ``|z|`` exceeds
:data:`Z_LIMIT` (5: with white noise and the right table, 40 segments' two magnitudes pass at the
level of 1e-5).  The Earth rate is judged only where that combined sigma is below a quarter of the
Earth rate (a gyro that does not resolve it cannot be checked by it: said in a note).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.earth import EARTH_RATE
from ..core.files import safe_stem
from ..core.text import code_comment
from ..core.units import DEG_PER_H, UG
from ..data.description import description_toml
from ..data.recording import Recording
from ..data.samples import samples_csv
from ..data.record import read_record
from ..model.output import compensate, compensate_table
from ..model.registry import N_PARAMS
from ..model.parameters import ParameterSet
from ..report.rounding import display
from ..report.tables import frame_files

#: The columns of the check, natural units.
CHECK_COLUMNS = ("gravity_error_ug", "gravity_noise_ug", "earth_rate_error_deg_h", "earth_rate_noise_deg_h",
                 "earth_rate_up_error_deg_h", "earth_rate_horizontal_error_deg_h")
#: A static segment whose gravity or Earth-rate error exceeds this many combined sigma fails the check.
Z_LIMIT = 5.0
#: The Earth rate is judged only where the combined sigma of its magnitude is below this part of it.
EARTH_RATE_RESOLVED = 0.25
#: The least sigma an error is judged against (ug, deg/h): below them the compensation of a noise-free recording
#: with its true table is at float64 rounding (1e-6 ug, 1e-9 deg/h), not at fault.
FLOOR_UG, FLOOR_DEG_H = 1e-3, 1e-6


@dataclasses.dataclass
class Applied:
    """A compensated recording, its check per static segment, and notes for the user."""

    recording: Recording
    check: pd.DataFrame
    notes: list[str]

    def worst(self) -> dict[str, float]:
        """The largest absolute error of each kind over the static segments (natural units)."""
        return {c: float(self.check[c].abs().max()) for c in CHECK_COLUMNS if "error" in c}

    def verdict(self) -> tuple[str | None, list[str]]:
        """``("pass" | "fail", reasons)`` of the check (see the module docstring); ``(None, [])`` without a static
        segment to judge.  A reason names the segment, the error, its sigma parts and ``z``."""
        check = self.check
        if check.empty or "gravity_z" not in check:
            return None, []
        reasons = []
        for row in check.itertuples(index=False):
            where = f"segment {row.segment} ({row.orientation})"
            if abs(row.gravity_z) > Z_LIMIT:
                reasons.append(f"{where}: gravity error {row.gravity_error_ug:+.3g} ug is {row.gravity_z:+.1f} sigma "
                               f"(noise of the mean {row.gravity_noise_ug:.2g} ug, table {row.gravity_table_ug:.2g} "
                               f"ug), beyond {Z_LIMIT:g}")
            if np.isfinite(row.earth_rate_z) and abs(row.earth_rate_z) > Z_LIMIT:
                reasons.append(f"{where}: Earth-rate error {row.earth_rate_error_deg_h:+.3g} deg/h is "
                               f"{row.earth_rate_z:+.1f} sigma (noise of the mean {row.earth_rate_noise_deg_h:.2g} "
                               f"deg/h, table {row.earth_rate_table_deg_h:.2g} deg/h), beyond {Z_LIMIT:g}")
        return ("fail" if reasons else "pass"), reasons


def compensated_recording(rec: Recording, params: ParameterSet) -> Recording:
    """The recording with its pulses replaced by compensated increments (rad, m/s; pulse size 1)."""
    dtheta, dv = compensate_table(rec.gyro, rec.accel, params.values, params.names, rec.dt)
    return dataclasses.replace(rec, name=f"{rec.name}-compensated", gyro=dtheta, accel=dv, source=None,
                               warnings=list(rec.warnings))


def static_check(compensated: Recording) -> pd.DataFrame:
    """Per static segment: gravity and Earth-rate errors of the mean compensated increments (natural units)."""
    site = compensated.site
    rows = []
    for seg in compensated.static_segments:
        sl = compensated.segment_samples(seg)
        f = compensated.accel[sl] / compensated.dt
        w = compensated.gyro[sl] / compensated.dt
        n = len(f)
        f_mean, w_mean = f.mean(axis=0), w.mean(axis=0)
        up = f_mean / np.linalg.norm(f_mean)
        w_up = float(w_mean @ up)
        w_horizontal = float(np.linalg.norm(w_mean - w_up * up))
        along_w = w_mean / np.linalg.norm(w_mean)
        rows.append({"segment": seg.number, "group": seg.group, "orientation": seg.what, "samples": n,
                     "gravity_error_ug": (np.linalg.norm(f_mean) - site.g) / UG,
                     "gravity_noise_ug": float(np.std(f @ up, ddof=1) / math.sqrt(n)) / UG if n > 1 else np.nan,
                     "earth_rate_error_deg_h": (np.linalg.norm(w_mean) - EARTH_RATE) / DEG_PER_H,
                     "earth_rate_noise_deg_h": (float(np.std(w @ along_w, ddof=1) / math.sqrt(n)) / DEG_PER_H
                                                if n > 1 else np.nan),
                     "earth_rate_up_error_deg_h": (w_up - EARTH_RATE * math.sin(site.latitude)) / DEG_PER_H,
                     "earth_rate_horizontal_error_deg_h":
                         (w_horizontal - EARTH_RATE * math.cos(site.latitude)) / DEG_PER_H})
    return pd.DataFrame(rows)


def table_sigma(rec: Recording, params: ParameterSet) -> pd.DataFrame:
    """Per static segment of the raw recording: the 1-sigma of the compensated gravity magnitude (ug) and
    Earth-rate magnitude (deg/h) that the table's own uncertainty leaves (its 21 parameters, one sigma each
    way at the segment's mean pulses, combined with the covariance's correlations; 0 without sigma)."""
    n = N_PARAMS
    sigma = params.sigma[:n] if params.sigma is not None else np.zeros(n)
    if params.covariance is not None:
        cov = params.covariance[:n, :n]
        corr = cov / np.outer(np.sqrt(np.diag(cov)), np.sqrt(np.diag(cov)))
    else:
        corr = np.eye(n)
    corr = np.nan_to_num(corr)
    values = params.values[:n]
    rows = []
    for seg in rec.static_segments:
        sl = rec.segment_samples(seg)
        g_bar, a_bar = rec.gyro[sl].mean(axis=0)[None], rec.accel[sl].mean(axis=0)[None]
        slopes = np.zeros((2, n))
        for i in np.flatnonzero(sigma > 0):
            step = np.zeros(n)
            step[i] = sigma[i]
            up, down = (compensate(g_bar, a_bar, values + s, rec.dt) for s in (step, -step))
            slopes[0, i] = (np.linalg.norm(up[1]) - np.linalg.norm(down[1])) / (2 * rec.dt) / UG
            slopes[1, i] = (np.linalg.norm(up[0]) - np.linalg.norm(down[0])) / (2 * rec.dt) / DEG_PER_H
        var = np.einsum("ki,ij,kj->k", slopes, corr, slopes)
        rows.append({"gravity_table_ug": float(np.sqrt(max(var[0], 0.0))),
                     "earth_rate_table_deg_h": float(np.sqrt(max(var[1], 0.0)))})
    return pd.DataFrame(rows, columns=["gravity_table_ug", "earth_rate_table_deg_h"])


def table_with_covariance(path) -> ParameterSet:
    """A parameter table with the covariance of its companion report when there is one (its sigma alone else):
    :attr:`data.record.CalibrationRecord.parameters`."""
    return read_record(path).parameters


def judged_check(check: pd.DataFrame, table: pd.DataFrame) -> pd.DataFrame:
    """The check with the table's sigma and ``z`` per segment (gravity always; the Earth rate where resolved)."""
    out = pd.concat([check.reset_index(drop=True), table.reset_index(drop=True)], axis=1)
    if out.empty:
        return out
    g_sigma = np.maximum(np.hypot(out["gravity_noise_ug"].fillna(0.0), out["gravity_table_ug"]), FLOOR_UG)
    w_sigma = np.maximum(np.hypot(out["earth_rate_noise_deg_h"].fillna(0.0), out["earth_rate_table_deg_h"]),
                         FLOOR_DEG_H)
    out["gravity_z"] = out["gravity_error_ug"] / g_sigma
    resolved = w_sigma < EARTH_RATE_RESOLVED * EARTH_RATE / DEG_PER_H
    out["earth_rate_z"] = np.where(resolved, out["earth_rate_error_deg_h"] / w_sigma, np.nan)
    return out


def apply_table(rec: Recording, params: ParameterSet) -> Applied:
    """Compensate a recording with a table, check it at rest and judge the check (:meth:`Applied.verdict`)."""
    compensated = compensated_recording(rec, params)
    notes = []
    if not rec.static_segments:
        notes.append("the recording has no static segment: nothing to check against gravity and the Earth rate")
    check = judged_check(static_check(compensated), table_sigma(rec, params))
    if "earth_rate_z" in check and check["earth_rate_z"].isna().any():
        notes.append("the gyros do not resolve the Earth rate in some static segments (noise of the mean and table "
                     f"sigma above {EARTH_RATE_RESOLVED:g} of it): their Earth-rate error is not judged")
    return Applied(compensated, check, notes)


def check_display(check: pd.DataFrame) -> pd.DataFrame:
    """The check as people read it: each error rounded to the noise of its mean, the noise and the table's sigma to
    two digits, ``z`` to two decimals."""
    pairs = {c: c.replace("_error", "_noise") for c in CHECK_COLUMNS if "error" in c and c.replace("_error", "_noise")
             in check}
    pairs.update({c: "earth_rate_noise_deg_h" for c in CHECK_COLUMNS if c.startswith("earth_rate_") and "error" in c
                  and c not in pairs})
    return display(check, pairs, sigmas=["gravity_table_ug", "earth_rate_table_deg_h"],
                   ratios=["gravity_z", "earth_rate_z"], signed=True)


def apply_files(applied: Applied, out_dir: str | Path, table_label: str, table_sha256: str | None = None
                ) -> dict[Path, bytes]:
    """The compensated recording (``NAME-compensated.toml`` and ``.csv``) and its check (``-check.csv/.md``)
    as ``{path: bytes}``, to be written together."""
    out = Path(out_dir)
    rec = applied.recording
    stem = safe_stem(rec.name)
    csv_path = out / f"{stem}.csv"
    header = (f"# compensated with {code_comment(table_label)}" + (f" (sha256 {table_sha256})" if table_sha256 else "") + "\n"
              "# gyro_* are increments in rad and accel_* in m/s per sample (pulse size 1): this recording\n"
              "# calibrates to the identity table when the table was right\n")
    files = {out / f"{stem}.toml": (header + description_toml(rec, csv_path.name)).encode(),
             csv_path: samples_csv(rec.time, rec.gyro, rec.accel).encode()}
    worst = applied.worst()
    title = (f"{rec.name}: static segments after compensation with {table_label}; worst |gravity error| "
             f"{worst.get('gravity_error_ug', math.nan):.3g} ug, |Earth-rate error| "
             f"{worst.get('earth_rate_error_deg_h', math.nan):.3g} deg/h")
    files.update(frame_files(applied.check, out / f"{stem}-check", title, display=check_display(applied.check)))
    return files
