"""The thermal model's C header: it compiles, and compensates at any temperature as Python does."""

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
        casadi_sins_compensate_t(g, a, dt, t, dtheta, dv);
        printf("%.17g %.17g %.17g %.17g %.17g %.17g\n", dtheta[0], dtheta[1], dtheta[2], dv[0], dv[1], dv[2]);
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
    subprocess.run([COMPILER, "-std=c99", "-Wall", "-Werror", "-pedantic", "-O2", "-o", str(tmp_path / "comp"),
                    str(tmp_path / "main.c")], check=True, cwd=tmp_path)
    temps = np.array([-40.0, -10.0, 25.0, 33.7, 70.0])
    pulses = rng.normal(size=(len(temps), 6)) * 1e4
    dt = 0.01
    text = "\n".join(" ".join(repr(float(x)) for x in [t, dt, *row]) for t, row in zip(temps, pulses)) + "\n"
    out = subprocess.run([str(tmp_path / "comp")], input=text, capture_output=True, text=True, check=True).stdout
    got = np.array([[float(x) for x in line.split()] for line in out.strip().split("\n")])
    for k, t in enumerate(temps):
        dtheta, dv = compensate(pulses[k:k + 1, :3], pulses[k:k + 1, 3:], model.at(t).values, dt)
        np.testing.assert_allclose(got[k, :3], dtheta[0], rtol=1e-13, atol=1e-13 * np.abs(dtheta).max())
        np.testing.assert_allclose(got[k, 3:], dv[0], rtol=1e-13, atol=1e-13 * np.abs(dv).max())
    cold, hot = (compensate(pulses[:1, :3], pulses[:1, 3:], model.at(t).values, dt)[0] for t in (-40.0, 70.0))
    assert not np.allclose(cold, hot, rtol=1e-9, atol=0)  # the temperature matters
