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
from ..model.output import compensate_table
from ..model.parameters import ParameterSet
from ..report.rounding import display
from ..report.tables import frame_files

#: The columns of the check, natural units.
CHECK_COLUMNS = ("gravity_error_ug", "gravity_noise_ug", "earth_rate_error_deg_h", "earth_rate_noise_deg_h",
                 "earth_rate_up_error_deg_h", "earth_rate_horizontal_error_deg_h")


@dataclasses.dataclass
class Applied:
    """A compensated recording, its check per static segment, and notes for the user."""

    recording: Recording
    check: pd.DataFrame
    notes: list[str]

    def worst(self) -> dict[str, float]:
        """The largest absolute error of each kind over the static segments (natural units)."""
        return {c: float(self.check[c].abs().max()) for c in CHECK_COLUMNS if "error" in c}


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


def apply_table(rec: Recording, params: ParameterSet) -> Applied:
    """Compensate a recording with a table and check it at rest."""
    compensated = compensated_recording(rec, params)
    notes = []
    if not rec.static_segments:
        notes.append("the recording has no static segment: nothing to check against gravity and the Earth rate")
    return Applied(compensated, static_check(compensated), notes)


def check_display(check: pd.DataFrame) -> pd.DataFrame:
    """The check as people read it: each error rounded to the noise of its mean, the noise to two digits."""
    pairs = {c: c.replace("_error", "_noise") for c in CHECK_COLUMNS if "error" in c and c.replace("_error", "_noise")
             in check}
    pairs.update({c: "earth_rate_noise_deg_h" for c in CHECK_COLUMNS if c.startswith("earth_rate_") and "error" in c
                  and c not in pairs})
    return display(check, pairs, signed=True)


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
