"""The recording's optional attitude reference columns (ref_roll_deg, ref_pitch_deg, ref_heading_deg)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from casadi_sins.core.errors import InputError
from casadi_sins.data.description import read_recording, write_recording


def test_a_reference_round_trips_and_a_partial_or_impossible_one_is_refused(tmp_path, short_problem):
    from casadi_sins.sim import simulate

    rec = simulate(short_problem, seed=1).recording
    angles = np.radians(np.column_stack([np.full(len(rec.time), 1.5), np.linspace(-2, 2, len(rec.time)),
                                         np.full(len(rec.time), 359.0)]))
    path = write_recording(dataclasses.replace(rec, reference=angles), tmp_path / "ref.toml")
    back = read_recording(path)
    assert np.allclose(back.reference, angles, atol=1e-12) and np.array_equal(back.gyro, rec.gyro)
    assert read_recording(write_recording(rec, tmp_path / "none.toml")).reference is None
    csv = path.with_suffix(".csv")
    lines = csv.read_text().splitlines()
    csv.write_text("\n".join(line.rsplit(",", 1)[0] for line in lines) + "\n")  # the heading left out
    with pytest.raises(InputError, match="needs all of ref_roll_deg, ref_pitch_deg, ref_heading_deg"):
        read_recording(path)
    lines[5] = ",".join(lines[5].split(",")[:-2] + ["95", "0"])
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"line 6: ref_pitch_deg 95 is beyond \+/-90 deg"):
        read_recording(path)
