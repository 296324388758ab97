"""Results on standard output, diagnostics on standard error, the same in every command: the solvers' step lines
(``nlp: ...``), ``note:`` and ``warning:`` lines and progress never reach standard output, so that
``casadi-sins CMD ... > result.txt`` keeps the results alone."""

from __future__ import annotations

import ast
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import casadi_sins.cli as cli_package
from casadi_sins.cli import main
from casadi_sins.cli.parser import build_parser
from casadi_sins.data.description import write_recording
from casadi_sins.data.tables import write_table
from casadi_sins.model.parameters import ParameterSet
from casadi_sins.sim import simulate

#: What a diagnostic line starts with.
DIAGNOSTIC = ("note:", "warning:", "WARNING:", "nlp:", "ils:", "design:", "design-scheme:")


def _printed_text(call: ast.Call) -> str | None:
    """The literal start of a print call's first argument (a string or an f-string), or None."""
    if not call.args:
        return None
    first = call.args[0]
    if isinstance(first, ast.Constant) and isinstance(first.value, str):
        return first.value
    if isinstance(first, ast.JoinedStr) and first.values and isinstance(first.values[0], ast.Constant):
        return str(first.values[0].value)
    return None


def test_every_diagnostic_print_of_the_command_line_goes_to_standard_error():
    """Walk the source of every command module: a print whose text starts as a diagnostic names standard
    error, and no command hands the library plain ``print`` (standard output) for its step messages."""
    folder = Path(cli_package.__file__).parent
    found = 0
    for path in sorted(folder.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not isinstance(node, ast.Call):
                continue
            if isinstance(node.func, ast.Name) and node.func.id == "print":
                text = _printed_text(node)
                if text is not None and text.lstrip().startswith(DIAGNOSTIC):
                    found += 1
                    to_stderr = any(k.arg == "file" and ast.unparse(k.value) == "sys.stderr" for k in node.keywords)
                    assert to_stderr, f"{path.name}:{node.lineno} prints a diagnostic on standard output"
            for k in node.keywords:
                if k.arg == "progress" and isinstance(k.value, ast.Name) and k.value.id == "print":
                    raise AssertionError(f"{path.name}:{node.lineno} passes print (standard output) as progress")
    assert found >= 3  # the helpers note() and warning() among them


@pytest.fixture(scope="module")
def bench(tmp_path_factory, short_problem):
    """A short unit recording and two tables of one unit at two temperatures (for thermal)."""
    tmp = tmp_path_factory.mktemp("streams")
    rec = write_recording(simulate(short_problem, seed=31).recording, tmp / "unit.toml")
    nominal = simulate(short_problem, seed=31, noise=False).truth
    for k, t in enumerate((-10.0, 40.0)):
        params = ParameterSet(nominal.values * (1 + 1e-6 * k), sigma=np.abs(nominal.values) * 1e-6 + 1e-7,
                              names=nominal.names)
        write_table(tmp / f"T{k}.csv", params)
        (tmp / f"T{k}.report.json").write_text(json.dumps({
            "format": "casadi-sins-report/1", "created": "2026-01-01T00:00:00+00:00", "conditions":
            {"temperature_c": t}, "recording": {"name": f"r{k}", "sha256": str(k) * 64}}))
    return tmp, rec


def _commands(tmp: Path, rec: Path) -> list[list[str]]:
    out = str(tmp / "out")
    return [["validate", str(rec)],
            ["rough", str(rec), "--out", f"{out}/rough.csv"],
            ["calibrate", str(rec), "--out", f"{out}/P.csv"],
            ["calibrate", str(rec), "--solver", "ils", "--out", f"{out}/I.csv"],
            ["export", f"{out}/P.csv", "--format", "json", "--out", f"{out}/P.json"],
            ["export", f"{out}/bare.csv", "--format", "yaml", "--out", f"{out}/bare.yaml"],
            ["apply", f"{out}/P.csv", str(rec), "--out", f"{out}/applied"],
            ["navigate", str(rec), "--params", f"{out}/P.csv", "--out", f"{out}/nav"],
            ["segment", str(rec.with_suffix(".csv")), "--rate", "100", "--latitude", "37.5", "--out",
             f"{out}/found.toml"],
            ["budget", str(rec), "--params", f"{out}/P.csv", "--out", f"{out}/budget"],
            ["thermal", str(tmp / "T0.csv"), str(tmp / "T1.csv"), "--out", f"{out}/thermal", "--no-plots"],
            ["compare", str(rec), "--out", f"{out}/compare"]]


def test_the_commands_keep_diagnostics_off_standard_output(bench, capsys):
    """Run the commands one after another (each line of standard output a result); the diagnostics they print
    (the solvers' steps, notes, warnings) are on standard error."""
    tmp, rec = bench
    seen_err = []
    for argv in _commands(tmp, rec):
        if argv[0] == "export" and "bare.csv" in argv[1]:
            shutil.copy(tmp / "out" / "P.csv", tmp / "out" / "bare.csv")  # a table without its report: a note
        assert main(argv) == 0, argv
        printed = capsys.readouterr()
        for line in printed.out.splitlines():
            assert not line.lstrip().startswith(DIAGNOSTIC), f"{argv[0]}: {line!r} on standard output"
            assert "elapsed" not in line, f"{argv[0]}: progress {line!r} on standard output"
        seen_err.append((" ".join(argv), printed.err))
    err = dict(seen_err)
    nlp = next(v for k, v in err.items() if k.startswith("calibrate") and "ils" not in k)
    assert "nlp: " in nlp and "note: bias instability" in nlp
    assert "ils: " in next(v for k, v in err.items() if k.startswith("calibrate") and "--solver ils" in k)
    assert "note: no companion report" in next(v for k, v in err.items() if "bare.csv" in k)
    assert "warning: 2 temperatures" in next(v for k, v in err.items() if k.startswith("thermal"))


def test_every_command_is_either_walked_or_only_writes_results():
    """The commands not run above are long searches or simulations whose only diagnostics are progress (on
    standard error by :mod:`cli.logs`) and the printers checked in the source walk."""
    names = set(build_parser()._subparsers._group_actions[0].choices)  # noqa: SLF001 (argparse keeps them there)
    walked = {argv[0] for argv in _commands(Path("t"), Path("r.toml"))}
    assert walked <= names and len(walked) >= 10
