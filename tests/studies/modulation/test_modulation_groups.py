"""Every group of a calibrated table reaches ``modulate`` (issue 39): the g-sensitivity and the scale
asymmetry are sources of their own, with the physics of the package's one error model."""

import json

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.core.units import DEG_PER_H
from casadi_sins.model import registry as R
from casadi_sins.studies.modulation.analysis import run_scheme
from casadi_sins.studies.modulation.calibrated import parameter_sources
from casadi_sins.studies.modulation.schemes import load_scheme

ROWS = [f"gyro_scale_asym_{a},ppm,3,0.05" for a in "xyz"] + [
    f"gyro_gsens_{i}{j},deg/h/g,0.001,0.0002" for i in "xyz" for j in "xyz"]


def test_a_modulated_table_shows_its_g_sensitivity_and_asymmetry(tmp_path, capsys, table_file):
    table = table_file(tmp_path, extra_rows=ROWS)
    out = tmp_path / "out"
    code = main(["modulate", "--scheme", "strapdown", "dual-axis-16", "--params", str(table), "--hours", "2",
                 "--latitude", "34.25", "--out", str(out), "--no-plots"])
    assert code == 0, capsys.readouterr().err
    doc = json.loads((out / "modulation.json").read_text())
    for scheme in ("strapdown", "dual-axis-16"):
        sources = doc["schemes"][scheme]["by_source"]
        assert sources["gyro g-sensitivity"]["max_position_error_m"] > 1.0
        assert sources["gyro scale-factor asymmetry"]["max_position_error_m"] > 0.0
        assert {"gyro_gsens_xz", "gyro_scale_asym_z"} <= set(doc["schemes"][scheme]["by_parameter"])
    assert "gyro g-sensitivity" in (out / "modulation.md").read_text()


@pytest.mark.parametrize("axis", "xyz")
def test_on_a_still_imu_g_sensitivity_is_the_bias_its_force_gives(guan_site, axis):
    """Strapdown, body z up: a g-sensitivity error ``G_iz`` of sigma s is a gyro bias error of sigma ``g s``
    (the error model's own columns of the group, against the 21's bias)."""
    names = R.model_names(("gyro_gsens",))
    values = np.where(R.relative_mask(names), 1e-6, 0.0)  # pulse weights (scale errors are relative)
    sigma = 0.01 * DEG_PER_H / guan_site.g
    runs = {}
    for name, size in ((f"gyro_gsens_{axis}z", sigma), (f"gyro_bias_{axis}", sigma * guan_site.g)):
        cov = np.zeros((len(names), len(names)))
        cov[names.index(name), names.index(name)] = size**2
        sources = parameter_sources(names, values, cov, np.zeros(3), np.zeros(3))
        runs[name] = run_scheme(load_scheme("strapdown"), sources, guan_site, 6.0).by_parameter[name]
    gsens, bias = runs.values()
    np.testing.assert_allclose(gsens, bias, rtol=1e-9, atol=1e-9 * np.abs(bias).max())
    assert np.abs(bias).max() > 10.0
