"""The C header export: it compiles, and compensates samples exactly as the Python compensation does."""

import json
import shutil
import subprocess

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.data.tables import write_table
from casadi_sins.model import registry as R
from casadi_sins.model.output import compensate_table
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.report.cheader import c_header

COMPILER = shutil.which("gcc") or shutil.which("cc") or shutil.which("clang")

PROGRAM = r"""
#include <stdio.h>
#include "unit.h"
int main(void) {
    double g[3], a[3], dt, dtheta[3], dv[3];
    while (scanf("%lf %lf %lf %lf %lf %lf %lf", &dt, &g[0], &g[1], &g[2], &a[0], &a[1], &a[2]) == 7) {
        casadi_sins_compensate(g, a, dt, dtheta, dv);
        printf("%.17g %.17g %.17g %.17g %.17g %.17g\n", dtheta[0], dtheta[1], dtheta[2], dv[0], dv[1], dv[2]);
    }
    printf("%s\n", casadi_sins_unit_id);
    return 0;
}
"""


def _gyro_extras_table(kang_problem):
    """The paper's unit with gyro g-sensitivity (deg/h/g) and scale asymmetry (ppm)."""
    names = R.model_names(("gyro_gsens", "gyro_asym"))
    gsens = np.arange(1, 10) * 1e-3 * R.GROUPS["gyro_gsens"].natural_scale
    return ParameterSet(np.concatenate([kang_problem.truth.core, gsens, [3e-6, -4e-6, 5e-6]]), names=names)


@pytest.mark.skipif(COMPILER is None, reason="no C compiler on this machine")
@pytest.mark.parametrize("extras", [False, True])
def test_the_header_compiles_and_compensates_like_python(tmp_path, kang_problem, extras):
    """With the gyro's extra groups too (g-sensitivity, scale asymmetry: per-sample terms)."""
    params = _gyro_extras_table(kang_problem) if extras else kang_problem.truth
    assert "EXTRAS_NOT_COMPENSATED" not in c_header(params)
    (tmp_path / "unit.h").write_text(c_header(params, {"unit_id": "SN 7 */ \"x\"", "recording_sha256": "ab" * 32}))
    (tmp_path / "main.c").write_text(PROGRAM)
    subprocess.run([COMPILER, "-std=c99", "-Wall", "-Werror", "-pedantic", "-O2", "-o", str(tmp_path / "comp"),
                    str(tmp_path / "main.c")], check=True, cwd=tmp_path)
    rng = np.random.default_rng(3)
    pulses = rng.normal(size=(50, 6)) * 1e4
    dt = 0.01
    text = "\n".join(" ".join(repr(float(x)) for x in [dt, *row]) for row in pulses) + "\n"
    out = subprocess.run([str(tmp_path / "comp")], input=text, capture_output=True, text=True, check=True).stdout
    lines = out.strip().split("\n")
    assert lines[-1] == 'SN 7 */ "x"'  # the comment is defused, the string kept
    got = np.array([[float(x) for x in line.split()] for line in lines[:-1]])
    dtheta, dv = compensate_table(pulses[:, :3], pulses[:, 3:], params.values, params.names, dt)
    np.testing.assert_allclose(got[:, :3], dtheta, rtol=1e-14, atol=1e-13 * np.abs(dtheta).max())
    np.testing.assert_allclose(got[:, 3:], dv, rtol=1e-14, atol=1e-13 * np.abs(dv).max())


def test_export_reads_the_tables_companion_report_for_its_provenance(tmp_path, kang_problem):
    table = write_table(tmp_path / "t.csv", kang_problem.truth)
    report = {"format": "casadi-sins-report/1", "created": "2024-03-01T10:00:00+00:00", "unit_id": "SN9",
              "software": "casadi-sins 0.2.0", "solver": "nlp", "versions": {"casadi": "3.8.2"},
              "recording": {"name": "r", "sha256": "cd" * 32}}
    (tmp_path / "t.report.json").write_text(json.dumps(report))
    for fmt, name in (("c", "t.h"), ("json", "t.json"), ("yaml", "t.yaml"), ("psins", "t.m")):
        assert main(["export", str(table), "--format", fmt, "--out", str(tmp_path / name)]) == 0
        text = (tmp_path / name).read_text()
        assert "cd" * 32 in text and "SN9" in text and "2024-03-01T10:00:00+00:00" in text, fmt
    assert main(["export", str(table), "--format", "c", "--out", str(tmp_path / "x.h"), "--unit-id", "SN8"]) == 2
