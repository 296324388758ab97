"""``casadi-sins modulate`` and ``modulate-mc``: normal runs, and every bad input as one line and exit 2."""

import json
from pathlib import Path

import numpy as np
import pytest

from casadi_sins.cli import main
from casadi_sins.core.units import TO_SI
from casadi_sins.model.registry import NAMES

SHEET = str(Path(__file__).resolve().parents[3] / "problems" / "guan2023-table1.toml")
SHEET_FORMAT = 'format = "casadi-sins-errors/1"\n'


def run(capsys, *args, command="modulate"):
    code = main([command, *map(str, args)])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def base(tmp_path, scheme="dual-axis-16", errors=SHEET, hours=2, latitude=34.25):
    return ["--scheme", scheme, "--errors", errors, "--hours", hours, "--latitude", latitude, "--out",
            tmp_path / "out", "--no-plots"]


def scheme_file(tmp_path, body: str, name="mine") -> Path:
    path = tmp_path / f"{name}.toml"
    path.write_text(f'format = "casadi-sins-scheme/1"\nname = "{name}"\n' + body)
    return path


def one_line_error(code, err, *words, command="modulate"):
    assert code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"casadi-sins {command}: error:"), err
    for word in words:
        assert word in lines[0], lines[0]


def test_a_run_writes_json_markdown_and_plots(tmp_path, capsys):
    args = base(tmp_path, hours=1)
    args.remove("--no-plots")
    args[1] = "single-axis-reciprocating"
    args.insert(2, "dual-axis-16")
    code, out, err = run(capsys, *args)
    assert code == 0, err
    doc = json.loads((tmp_path / "out" / "modulation.json").read_text())
    assert set(doc["schemes"]) == {"single-axis-reciprocating", "dual-axis-16"}
    s = doc["schemes"]["dual-axis-16"]
    for key in ("max_horizontal_position_error_m", "max_velocity_error_mps", "by_source", "curves"):
        assert key in s
    assert s["source"] == "dual-axis-16 (shipped)"
    assert {"longitude_error_m", "latitude_error_m", "time_h"} <= set(s["curves"])
    assert set(s["by_source"]["gyro bias"]) == {"max_position_error_m", "ratio_to_strapdown",
                                                "max_longitude_error_m", "max_latitude_error_m"}
    assert (tmp_path / "out" / "modulation.md").read_text().startswith("# Rotation modulation")
    assert (tmp_path / "out" / "dual-axis-16.png").stat().st_size > 10000
    assert (tmp_path / "out" / "comparison.png").stat().st_size > 10000
    assert not list((tmp_path / "out").glob(".*"))  # no temporary left


def test_a_shipped_sheet_by_name(tmp_path, capsys):
    code, out, err = run(capsys, *base(tmp_path, scheme="strapdown", errors="guan2023-table1", hours=0.5))
    assert code == 0, err
    doc = json.loads((tmp_path / "out" / "modulation.json").read_text())
    assert doc["errors"]["origin"] == "guan2023-table1 (shipped)"
    assert doc["schemes"]["strapdown"]["source"] == "strapdown (shipped)"  # the reference's numbers, its own name


def test_a_scheme_that_does_not_return_warns_and_strict_refuses(tmp_path, capsys):
    path = scheme_file(tmp_path, '[[step]]\naxis = "z"\nangle_deg = 90.0\nrate_deg_s = 10.0\ndwell_s = 60.0\n')
    code, out, err = run(capsys, *base(tmp_path, scheme=path, hours=0.5))
    assert code == 0
    assert len(err.strip().splitlines()) == 1 and err.startswith("warning:") and "start attitude" in err
    assert json.loads((tmp_path / "out" / "modulation.json").read_text())["warnings"]
    assert "## Warnings" in (tmp_path / "out" / "modulation.md").read_text()
    code, out, err = run(capsys, *base(tmp_path, scheme=path, hours=0.5), "--strict")
    one_line_error(code, err, "does not return to its start attitude")


@pytest.mark.parametrize("step,words", [
    ('axis = "q"\nangle_deg = 180.0\nrate_deg_s = 10.0\ndwell_s = 5.0', ["unknown axis", "step 1", "line 3"]),
    ('axis = "z"\nangle_deg = 180.0\nrate_deg_s = 0.0\ndwell_s = 5.0', ["rate_deg_s must be > 0"]),
    ('axis = "z"\nangle_deg = 180.0\nrate_deg_s = -10.0\ndwell_s = 5.0', ["rate_deg_s must be > 0"]),
    ('axis = "z"\nangle_deg = 180.0\nrate_deg_s = 10.0\ndwell_s = 0.0', ["dwell_s must be > 0"]),
    ('axis = "z"\nangle_deg = 180.0\nrate_deg_s = 10.0\ndwell_s = -5.0', ["dwell_s must be > 0"]),
    ('axis = "z"\nangle_deg = nan\nrate_deg_s = 10.0\ndwell_s = 5.0', ["angle_deg is not finite"]),
])
def test_bad_scheme_steps(tmp_path, capsys, step, words):
    path = scheme_file(tmp_path, f"[[step]]\n{step}\n")
    code, out, err = run(capsys, *base(tmp_path, scheme=path))
    one_line_error(code, err, str(path), *words)
    assert not (tmp_path / "out").exists()  # nothing written


def test_two_schemes_of_one_name(tmp_path, capsys):
    path = scheme_file(tmp_path, "", name="strapdown")
    args = base(tmp_path, scheme="strapdown")
    args.insert(2, path)
    code, out, err = run(capsys, *args)
    one_line_error(code, err, "share a name")


def test_too_few_integration_steps_per_turn(tmp_path, capsys):
    code, out, err = run(capsys, *base(tmp_path), "--turn-step-deg", 45)
    one_line_error(code, err, "too few steps per turn")


def test_a_sheet_without_sigma(tmp_path, capsys):
    sheet = tmp_path / "sheet.toml"
    sheet.write_text(SHEET_FORMAT + "[gyro]\nbias_deg_h = 0.01\n")
    code, out, err = run(capsys, *base(tmp_path, errors=sheet))
    one_line_error(code, err, "sigma_level")


def test_a_sheet_with_nan(tmp_path, capsys):
    sheet = tmp_path / "sheet.toml"
    sheet.write_text(SHEET_FORMAT + "sigma_level = 1\n[gyro]\nbias_deg_h = nan\n")
    code, out, err = run(capsys, *base(tmp_path, errors=sheet))
    one_line_error(code, err, "bias_deg_h", "not finite")


def test_a_problem_file_is_not_a_sheet(tmp_path, capsys):
    problem = Path(SHEET).parent / "kang2013.toml"
    code, out, err = run(capsys, *base(tmp_path, errors=problem))
    one_line_error(code, err, "format must be 'casadi-sins-errors/1'")


def test_a_table_without_sigma(tmp_path, capsys, table_file):
    args = base(tmp_path)
    args[2:4] = ["--params", table_file(tmp_path, with_sigma=False)]
    code, out, err = run(capsys, *args)
    one_line_error(code, err, "no sigma")


def test_a_table_whose_covariance_is_not_positive_semidefinite(tmp_path, capsys, table_file):
    import pandas as pd

    table = table_file(tmp_path)
    frame = pd.read_csv(table)
    sigma = np.array([s * TO_SI[u] for s, u in zip(frame["sigma"], frame["unit"])])
    cov = np.diag(sigma**2)
    i, j = NAMES.index("gyro_bias_x"), NAMES.index("gyro_bias_y")
    cov[i, j] = cov[j, i] = 1.5 * sigma[i] * sigma[j]  # correlation 1.5: impossible
    path = tmp_path / "cov.csv"
    pd.DataFrame(cov, index=list(NAMES), columns=list(NAMES)).to_csv(path, index_label="parameter")
    args = base(tmp_path)
    args[2:4] = ["--params", table, "--covariance", path]
    code, out, err = run(capsys, *args)
    one_line_error(code, err, "not positive semi-definite")
    # the same with a valid correlation runs, and keeps the correlation in the total
    cov[i, j] = cov[j, i] = 0.5 * sigma[i] * sigma[j]
    pd.DataFrame(cov, index=list(NAMES), columns=list(NAMES)).to_csv(path, index_label="parameter")
    code, out, err = run(capsys, *args)
    assert code == 0, err
    assert "note: no --errors sheet" in err
    assert json.loads((tmp_path / "out" / "modulation.json").read_text())["errors"]["correlated"]


def test_the_covariance_of_a_companion_report(tmp_path, capsys, table_file):
    import pandas as pd

    table = table_file(tmp_path)
    frame = pd.read_csv(table)
    sigma = np.array([s * TO_SI[u] for s, u in zip(frame["sigma"], frame["unit"])])
    (tmp_path / "params.report.json").write_text(json.dumps({"covariance": np.diag(sigma**2).tolist()}))
    args = base(tmp_path, hours=0.5)
    args[2:4] = ["--params", table, "--errors", SHEET]
    code, out, err = run(capsys, *args)
    assert code == 0, err
    errors = json.loads((tmp_path / "out" / "modulation.json").read_text())["errors"]
    assert errors["correlated"] and "params.report.json" in errors["origin"]


def test_covariance_without_params(tmp_path, capsys):
    code, out, err = run(capsys, *base(tmp_path), "--covariance", tmp_path / "c.csv")
    one_line_error(code, err, "--covariance goes with --params")


@pytest.mark.parametrize("latitude", [89.0, -89.5, 95.0])
def test_latitude_too_close_to_the_pole(tmp_path, capsys, latitude):
    code, out, err = run(capsys, *base(tmp_path, latitude=latitude))
    one_line_error(code, err, ">= 89 deg")


@pytest.mark.parametrize("option,value", [("--latitude", "nan"), ("--hours", "nan"), ("--hours", "inf"),
                                          ("--height", "nan"), ("--turn-step-deg", "nan")])
def test_nan_on_the_command_line(tmp_path, capsys, option, value):
    args = base(tmp_path)
    if option in args:
        args[args.index(option) + 1] = value
    else:
        args += [option, value]
    code, out, err = run(capsys, *args)
    one_line_error(code, err, "finite")


def test_unknown_shipped_scheme(tmp_path, capsys):
    code, out, err = run(capsys, *base(tmp_path, scheme="no-such-scheme"))
    one_line_error(code, err, "no such scheme", "dual-axis-16")


def test_zero_hours(tmp_path, capsys):
    code, out, err = run(capsys, *base(tmp_path, hours=0))
    one_line_error(code, err, "hours")


def test_an_output_that_is_a_file(tmp_path, capsys):
    (tmp_path / "out").write_text("")
    code, out, err = run(capsys, *base(tmp_path))
    one_line_error(code, err, "is not a folder")


def test_monte_carlo_command(tmp_path, capsys):
    args = [a for a in base(tmp_path, scheme="strapdown", hours=0.2) if a != "--no-plots"]
    code, out, err = run(capsys, *args, "--runs", 3, command="modulate-mc")
    assert code == 0, err
    doc = json.loads((tmp_path / "out" / "montecarlo.json").read_text())
    assert doc["results"][0]["scheme"] == "strapdown" and doc["results"][0]["runs"] == 3
    assert "gyro bias" in doc["results"][0]["groups"]
    assert (tmp_path / "out" / "montecarlo.md").read_text().startswith("# Time-domain Monte Carlo")
    code, out, err = run(capsys, *args, "--runs", 1, command="modulate-mc")
    one_line_error(code, err, "--runs must be at least 2", command="modulate-mc")


def test_every_option_has_help():
    from casadi_sins.cli.parser import build_parser

    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for command in ("modulate", "modulate-mc"):
        for action in sub.choices[command]._actions:
            assert action.help, (command, action.dest)
