"""The thermal model's C header: it compiles (C99, not C89), compensates at any temperature as Python does (held
within the calibrated range, flagged outside), and carries the model's provenance whole."""

import shutil
import subprocess

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.data.thermal import write_thermal
from casadi_sins.model.output import compensate
from casadi_sins.model.registry import NAMES, natural_scale_of, relative_mask
from casadi_sins.model.thermal import ThermalModel

COMPILER = shutil.which("gcc") or shutil.which("cc") or shutil.which("clang")

PROGRAM = r"""
#include <stdio.h>
#include "thermal.h"
int main(void) {
    double g[3], a[3], dt, t, dtheta[3], dv[3];
    while (scanf("%lf %lf %lf %lf %lf %lf %lf %lf", &t, &dt, &g[0], &g[1], &g[2], &a[0], &a[1], &a[2]) == 8) {
        int outside = casadi_sins_compensate_t(g, a, dt, t, dtheta, dv);
        printf("%.17g %.17g %.17g %.17g %.17g %.17g %d\n", dtheta[0], dtheta[1], dtheta[2], dv[0], dv[1], dv[2],
               outside);
    }
    return 0;
}
"""


@pytest.mark.skipif(COMPILER is None, reason="no C compiler on this machine")
def test_thermal_header_compensates_like_python(tmp_path, kang_problem):
    rng = np.random.default_rng(7)
    truth = kang_problem.truth.values
    size = natural_scale_of(NAMES) * np.where(relative_mask(NAMES), np.abs(truth), 1.0)
    coef = np.column_stack([truth, rng.normal(size=21) * size * 0.5, rng.normal(size=21) * size * 0.01])
    coef[3, 2] = 0.0
    model = ThermalModel(NAMES, 25.0, coef, np.where(coef[:, 2] == 0, 1, 2), np.eye(63) * 1e-30, (-30.0, 60.0))
    for path, data in write_thermal(tmp_path / "thermal.csv", model).items():
        path.write_bytes(data)
    assert main(["export", str(tmp_path / "thermal.csv"), "--format", "c", "--out", str(tmp_path / "thermal.h"),
                 "--unit-id", "SN1"]) == 0
    assert main(["export", str(tmp_path / "thermal.csv"), "--format", "json", "--out", str(tmp_path / "x.json")]) == 2
    (tmp_path / "main.c").write_text(PROGRAM)
    temps = np.array([-40.0, -10.0, 25.0, 33.7, 70.0])
    pulses = rng.normal(size=(len(temps), 6)) * 1e4
    dt = 0.01
    text = "\n".join(" ".join(repr(float(x)) for x in [t, dt, *row]) for t, row in zip(temps, pulses)) + "\n"
    got = _run(tmp_path, [], text)
    for k, t in enumerate(temps):  # beyond -30 .. 60 degC the model is held at the nearest end, and flagged
        dtheta, dv = compensate(pulses[k:k + 1, :3], pulses[k:k + 1, 3:], model.at(min(max(t, -30.0), 60.0)).values,
                                dt)
        np.testing.assert_allclose(got[k, :3], dtheta[0], rtol=1e-13, atol=1e-13 * np.abs(dtheta).max())
        np.testing.assert_allclose(got[k, 3:6], dv[0], rtol=1e-13, atol=1e-13 * np.abs(dv).max())
    assert got[:, 6].tolist() == [1, 0, 0, 0, 1]
    cold, hot = (compensate(pulses[:1, :3], pulses[:1, 3:], model.at(t).values, dt)[0] for t in (-30.0, 60.0))
    assert not np.allclose(cold, hot, rtol=1e-9, atol=0)  # the temperature matters
    extrapolated = _run(tmp_path, ["-DCASADI_SINS_THERMAL_EXTRAPOLATE"], text)
    for k in (0, 4):  # with the macro, the temperature itself (still flagged)
        dtheta, _ = compensate(pulses[k:k + 1, :3], pulses[k:k + 1, 3:], model.at(temps[k]).values, dt)
        np.testing.assert_allclose(extrapolated[k, :3], dtheta[0], rtol=1e-13, atol=1e-13 * np.abs(dtheta).max())
    assert extrapolated[:, 6].tolist() == [1, 0, 0, 0, 1]
    old_c = subprocess.run([COMPILER, "-std=c89", "-pedantic", "-fsyntax-only", str(tmp_path / "main.c")],
                           cwd=tmp_path, capture_output=True, text=True)
    assert old_c.returncode != 0 and "needs C99" in old_c.stderr


def _run(tmp_path, flags, text):
    subprocess.run([COMPILER, "-std=c99", "-Wall", "-Werror", "-pedantic", "-O2", *flags, "-o",
                    str(tmp_path / "comp"), str(tmp_path / "main.c")], check=True, cwd=tmp_path)
    out = subprocess.run([str(tmp_path / "comp")], input=text, capture_output=True, text=True, check=True).stdout
    return np.array([[float(x) for x in line.split()] for line in out.strip().split("\n")])


def test_thermal_header_carries_provenance(tmp_path, capsys):
    """The header of a fitted model names what every export names: the unit, the model's and its covariance's
    SHA-256, when and by which build it was fitted, the versions, and each calibration's temperature, table and
    recording hashes and date; the parameter list is whole; the range constants are used."""
    import hashlib
    import json

    from casadi_sins.core.version import build_identity

    from casadi_sins.data.tables import write_table
    from casadi_sins.model.parameters import ParameterSet

    tables = []
    sigma = natural_scale_of(NAMES) * np.where(relative_mask(NAMES), 1e-5, 1.0) * 0.2
    for k, t in enumerate((-20.0, 10.0, 45.0)):  # three calibrations, each with its companion report
        values = np.where(relative_mask(NAMES), 1e-5, 0.0) * (1 + 1e-6 * k) + natural_scale_of(NAMES) * 1e-3 * k
        write_table(tmp_path / f"T{k}.csv", ParameterSet(values, sigma=sigma, names=NAMES))
        (tmp_path / f"T{k}.report.json").write_text(json.dumps({
            "format": "casadi-sins-report/1", "created": f"2026-0{k + 1}-02T10:00:00+00:00", "unit_id": "SN-T7",
            "software": "casadi-sins 9.9", "recording": {"name": f"rec{k}", "sha256": f"{k}" * 64}}))
        tables.append(f"{tmp_path / f'T{k}.csv'}@{t:g}")
    assert main(["thermal", *tables, "--out", str(tmp_path / "th"), "--no-plots"]) == 0
    assert main(["export", str(tmp_path / "th" / "thermal.csv"), "--format", "c", "--out", str(tmp_path / "t.h")]) == 0
    header = (tmp_path / "t.h").read_text()
    comment = " ".join(line.lstrip("/ *").strip() for line in header[:header.index("*/")].splitlines())  # unwrapped
    model_hash = hashlib.sha256((tmp_path / "th" / "thermal.csv").read_bytes()).hexdigest()
    json_hash = hashlib.sha256((tmp_path / "th" / "thermal.json").read_bytes()).hexdigest()
    fitted = json.loads((tmp_path / "th" / "thermal.json").read_text())["created"]
    for needle in ("unit_id: SN-T7", f"thermal_model_sha256: {model_hash}", f"thermal_covariance_sha256: {json_hash}",
                   f"fitted: {fitted}", f"fitted_with: {build_identity()}", "versions: casadi-sins", "numpy",
                   "calibration_1: -20.0 degC", "recording sha256 " + "0" * 64, "calibrated 2026-01-02T10:00:00",
                   "calibration_3: 45.0 degC", "Needs C99"):
        assert needle in comment, needle
    assert f'casadi_sins_thermal_model_sha256[] = "{model_hash}"' in header
    listed = comment[comment.index("Parameters (the index"):].split(".")[0]
    assert all(f"{i} {n}" in listed for i, n in enumerate(NAMES))  # whole, over several lines
    assert max(len(line) for line in header[:header.index("*/")].splitlines()) <= 100  # the comment wrapped
    body = header[header.index("*/"):]
    assert "casadi_sins_t_min_c ?" in body and "casadi_sins_t_max_c)" in body  # the range constants are used
