"""Progress on a stream that is no terminal: whole lines, a line per 10 % or 10 s, never a carriage return."""

import io
import sys

from casadi_sins.cli import main
from casadi_sins.core import progress as P


def test_lines_every_ten_percent_and_at_the_end():
    stream = io.StringIO()
    with P.Progress(200, "work", "run", stream=stream) as bar:
        assert bar.mode == "lines"
        for k in range(1, 201):
            bar.update(k)
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue()
    assert len(lines) == 10 and lines[-1].startswith("work: 200/200 runs (100 %)")


def test_a_line_after_ten_seconds_even_without_ten_percent(monkeypatch):
    now = [0.0]
    monkeypatch.setattr(P.time, "monotonic", lambda: now[0])
    stream = io.StringIO()
    bar = P.Progress(1000, "slow", "run", stream=stream)
    bar.update(1)
    assert stream.getvalue() == ""
    now[0] = 10.5
    bar.update(2)
    assert stream.getvalue().count("\n") == 1 and "2/1000 runs" in stream.getvalue()


def test_disabled_by_the_environment(monkeypatch):
    monkeypatch.setenv("TQDM_DISABLE", "1")
    assert P.progress_mode(io.StringIO()) == "off"
    monkeypatch.setenv("TQDM_DISABLE", "0")
    assert P.progress_mode(io.StringIO()) == "lines"


def test_every_long_command_takes_quiet_and_no_progress(capsys):
    from casadi_sins.cli.registry import COMMANDS

    long_commands = [c.name for c in COMMANDS if c.long]
    assert {"calibrate", "batch", "montecarlo"} <= set(long_commands)
    for name in long_commands:
        try:
            main([name, "--help"])
        except SystemExit:
            pass
        text = capsys.readouterr().out
        assert "--quiet" in text and "--no-progress" in text, name


def test_montecarlo_with_stderr_to_a_file_writes_no_carriage_return(tmp_path):
    import os
    import subprocess
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "problems" / "kang2013.toml").read_text()
    problem = tmp_path / "short.toml"
    problem.write_text(text.replace("static_s = 100.0", "static_s = 8.0").replace("rotation_s = 10.0",
                                                                                    "rotation_s = 4.0"))
    with open(tmp_path / "err.txt", "wb") as err, open(tmp_path / "out.txt", "wb") as out:
        done = subprocess.run([sys.executable, "-m", "casadi_sins", "montecarlo", str(problem), "--runs", "2",
                               "--solvers", "ils", "--workers", "1", "--out", str(tmp_path / "mc")],
                              stdout=out, stderr=err, env={**os.environ, "OMP_NUM_THREADS": "1"}, timeout=600)
    assert done.returncode == 0, (tmp_path / "err.txt").read_text()
    logged = (tmp_path / "err.txt").read_bytes()
    assert b"\r" not in logged and b"\r" not in (tmp_path / "out.txt").read_bytes()
    lines = logged.decode().splitlines()
    assert any("2/2 runs (100 %)" in line for line in lines), lines
