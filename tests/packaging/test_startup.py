"""Start-up: the package imports lightly, and a signal at any instant of a command is one line and a status."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

HEAVY = ("casadi", "pandas", "matplotlib", "scipy")


def loaded_after(code: str) -> set[str]:
    """The heavy libraries in ``sys.modules`` after a fresh interpreter runs ``code``."""
    probe = f"{code}\nimport sys\nprint(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return set(done.stdout.split())


def test_importing_the_package_loads_no_heavy_library():
    assert loaded_after("import casadi_sins; casadi_sins.__version__") == set()


def test_version_needs_no_heavy_library():
    code = ("import sys, io, contextlib\nfrom casadi_sins.console import run\nout = io.StringIO()\n"
            "with contextlib.redirect_stdout(out):\n    assert run(['--version']) == 0\n"
            "assert out.getvalue().startswith('casadi-sins ')")
    assert loaded_after(code) == set()


def test_help_of_every_command_needs_no_heavy_library():
    """``casadi-sins --help`` and ``casadi-sins CMD --help`` for every command load neither CasADi, pandas,
    matplotlib, SciPy nor NumPy (one interpreter for all: a command's help must not load what the next one's
    would then find loaded, so each is checked right after it)."""
    code = ("import sys, io, contextlib\nfrom casadi_sins.console import run\n"
            "from casadi_sins.cli.registry import COMMANDS\nheavy = " + repr(HEAVY + ("numpy",)) + "\n"
            "for argv in [['--help']] + [[c.name, '--help'] for c in COMMANDS]:\n"
            "    out = io.StringIO()\n"
            "    with contextlib.redirect_stdout(out):\n"
            "        assert run(argv) == 0, argv\n"
            "    assert out.getvalue().startswith('usage: casadi-sins'), argv\n"
            "    loaded = [m for m in heavy if m in sys.modules]\n"
            "    assert not loaded, (argv, loaded)\n"
            "print(len(COMMANDS))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) >= 20


def test_public_names_are_still_reached_from_the_package():
    import casadi_sins
    from casadi_sins import calibrate, read_recording

    import casadi_sins.calibrate.nlp  # noqa: F401 (the subpackage binding itself must not replace the function)

    assert callable(calibrate) and casadi_sins.calibrate is calibrate and callable(read_recording)
    assert set(casadi_sins.__all__) <= set(dir(casadi_sins))
    with pytest.raises(AttributeError):
        casadi_sins.no_such_name  # noqa: B018


def wait_for_our_handlers(pid: int, timeout_s: float = 30.0) -> None:
    """Wait until process ``pid`` catches SIGTERM (the first thing the console module does; the interpreter
    itself leaves SIGTERM alone), read from the kernel's signal mask of the process."""
    status = Path(f"/proc/{pid}/status")
    if not status.exists():
        return
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        caught = next((int(line.split()[1], 16) for line in status.read_text().splitlines()
                       if line.startswith("SigCgt:")), 0)
        if caught & (1 << (signal.SIGTERM - 1)):
            return
        time.sleep(0.002)


@pytest.fixture(scope="module")
def paper_recording(kang_problem, tmp_path_factory):
    """The paper's experiment, written: its calibration lasts long beyond the latest signal."""
    from casadi_sins import simulate, write_recording

    return write_recording(simulate(kang_problem, seed=3).recording, tmp_path_factory.mktemp("rec") / "r.toml")


@pytest.mark.parametrize("delay_s", [0.05, 0.2, 0.5])
@pytest.mark.parametrize("signum, status, word", [(signal.SIGINT, 130, "interrupted"),
                                                   (signal.SIGTERM, 143, "terminated")])
def test_a_signal_at_any_instant_of_a_command_is_one_line_and_its_status(delay_s, signum, status, word,
                                                                          paper_recording, tmp_path):
    """A signal while the command is still importing CasADi and pandas, reading the recording or solving: one
    line, 130 or 143, no traceback, nothing written."""
    recording = paper_recording
    out = tmp_path / "t.csv"
    proc = subprocess.Popen([sys.executable, "-m", "casadi_sins", "calibrate", str(recording), "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    started = time.monotonic()
    wait_for_our_handlers(proc.pid)  # the interpreter's own start-up is not ours to handle; the rest is
    time.sleep(max(0.0, delay_s - (time.monotonic() - started)))
    if proc.poll() is not None:
        pytest.skip(f"the command ended before {delay_s} s")
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == status, err
    assert err.strip() == word
    assert not out.exists()


def test_a_ctrl_c_a_library_swallowed_still_ends_the_command_with_nothing_written(paper_recording, tmp_path,
                                                                                     monkeypatch, capsys):
    """A Ctrl-C whose KeyboardInterrupt a library catches on the way (an ``except:`` around an import, C code
    that clears the error) is still remembered: the command ends interrupted and writes nothing."""
    import os

    from casadi_sins.cli import commands, main

    real = commands.cmd_rough

    def swallowing(args):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(1.0)  # the handler runs here and raises
        except KeyboardInterrupt:
            pass  # what a careless library does
        return real(args)

    monkeypatch.setattr(commands, "cmd_rough", swallowing)
    out = tmp_path / "rough.csv"
    assert main(["rough", str(paper_recording), "--out", str(out)]) == 130
    assert capsys.readouterr().err.strip() == "interrupted"
    assert not out.exists()


def test_an_interrupt_cpython_remembers_after_we_handled_it_does_not_end_the_process_by_sigint(tmp_path):
    """CPython 3.11 keeps a flag for a KeyboardInterrupt that escaped code it ran for an extension, even once
    handled, and ends ``python -m casadi_sins`` by SIGINT (status -2) at exit; the console clears it."""
    import os

    (tmp_path / "flagged.py").write_text(
        "import ctypes, sys\n"
        "try:\n    flag = ctypes.c_int.in_dll(ctypes.pythonapi, '_Py_UnhandledKeyboardInterrupt')\n"
        "except ValueError:\n    sys.exit(99)\n"
        "from casadi_sins.console import console\nflag.value = 1\nsys.argv = ['casadi-sins', '--version']\n"
        "console()\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path))
    done = subprocess.run([sys.executable, "-m", "flagged"], capture_output=True, text=True, timeout=60, env=env)
    if done.returncode == 99:
        pytest.skip("this CPython keeps the flag elsewhere")
    assert done.returncode == 0, done.stderr
