"""Compiled CasADi functions: the cache, the fallback without a compiler, and the same numbers either way."""

import json
import os
import subprocess
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from casadi_sins.core import compiled


def _step():
    x, const, data = ca.SX.sym("x", 2), ca.SX.sym("c", 1), ca.SX.sym("d", 2)
    # a zero data row changes nothing
    nxt = ca.vertcat(x[0] * ca.cos(data[0]) - x[1] * ca.sin(data[0]) + const[0] * data[1], x[1] + data[1] * x[0])
    return ca.Function("toy_step", [x, const, data], [nxt, const, nxt])


def test_cache_folder_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.delenv("CASADI_SINS_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert compiled.cache_dir() == tmp_path / "xdg" / "casadi-sins" / f"casadi-{ca.__version__}"
    monkeypatch.setenv("CASADI_SINS_CACHE", str(tmp_path / "own"))
    assert compiled.cache_dir().parent == tmp_path / "own" / "casadi-sins"
    monkeypatch.delenv("CASADI_SINS_CACHE")
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert compiled.cache_dir().parent == Path.home() / ".cache" / "casadi-sins"


@pytest.mark.skipif(compiled.find_compiler() is None, reason="no C compiler on this machine")
def test_a_library_is_compiled_once_and_loaded_after(monkeypatch, tmp_path):
    monkeypatch.setenv("CASADI_SINS_CACHE", str(tmp_path))
    monkeypatch.delenv("CASADI_SINS_NO_COMPILE", raising=False)
    builds = []

    def build():
        builds.append(1)
        return [_step()]

    first = compiled.cached_functions("toy", "key", ["toy_step"], build)[0]
    second = compiled.cached_functions("toy", "key", ["toy_step"], build)[0]
    assert len(builds) == 1 and first.class_name() == second.class_name() == "External"
    libraries = list(compiled.cache_dir().glob("toy-*.so"))
    assert len(libraries) == 1 and not list(compiled.cache_dir().glob("*.c"))  # no temporary left behind
    other = compiled.cached_functions("toy", "another key", ["toy_step"], build)[0]
    assert len(builds) == 2 and other.class_name() == "External"
    args = [np.array([0.3, -1.2]), np.array([0.5]), np.array([0.7, 2.0])]
    for a, b in zip(first(*args), _step()(*args)):
        assert np.array_equal(np.asarray(a), np.asarray(b))


def test_without_a_compiler_the_virtual_machine_computes_with_one_note(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("CASADI_SINS_CACHE", str(tmp_path))
    monkeypatch.delenv("CASADI_SINS_NO_COMPILE", raising=False)
    monkeypatch.setattr(compiled, "find_compiler", lambda: None)
    monkeypatch.setattr(compiled, "_NOTES", set())
    for key in ("a", "b"):
        function = compiled.cached_functions("toy", key, ["toy_step"], lambda: [_step()])[0]
        assert function.class_name() == "SXFunction"
    err = capsys.readouterr().err
    assert err.count("casadi-sins: no C compiler found") == 1 and len(err.strip().splitlines()) == 1
    assert not list(tmp_path.rglob("*.so"))


def test_step_chain_equals_the_step_applied_row_by_row(tmp_path, monkeypatch):
    monkeypatch.setenv("CASADI_SINS_CACHE", str(tmp_path))
    rng = np.random.default_rng(1)
    data = rng.standard_normal((1234, 2)) * 0.1
    chain = compiled.StepChain("toy_chain", "rows", _step, block=50, blocks_per_call=4)
    out, final = chain(np.array([1.0, 0.5]), np.array([0.01]), data, pad=np.zeros(2))
    x, step, expected = np.array([1.0, 0.5]), _step(), []
    for row in data:
        x = np.asarray(step(x, 0.01, row)[0]).ravel()
        expected.append(x)
    assert np.allclose(out, expected, rtol=1e-13, atol=1e-13)
    assert np.allclose(final, expected[-1], rtol=1e-13, atol=1e-13)


CALIBRATE = """
import json, sys
import numpy as np
from casadi_sins.calibrate import calibrate_ils, calibrate_nlp
from casadi_sins.data.description import read_recording
rec = read_recording(sys.argv[1])
nlp, ils = calibrate_nlp(rec), calibrate_ils(rec)
print(json.dumps({k: [r.parameters.values.tolist(), r.parameters.sigma.tolist()] for k, r in (("nlp", nlp), ("ils", ils))}))
"""


def test_both_solvers_give_the_same_results_compiled_and_on_the_virtual_machine(short_problem, tmp_path):
    """The whole calibration in two fresh processes, compiled and with ``CASADI_SINS_NO_COMPILE=1``: values and
    sigmas agree to round-off (far below 1e-6 sigma)."""
    from casadi_sins.data.description import write_recording
    from casadi_sins.sim import simulate

    sim = simulate(short_problem, seed=2)
    path = write_recording(sim.recording, tmp_path / "short.toml")
    runs = {}
    for mode in ("compiled", "virtual"):
        env = dict(os.environ, PYTHONPATH=str(Path(compiled.__file__).resolve().parents[2]))
        if mode == "virtual":
            env["CASADI_SINS_NO_COMPILE"] = "1"
        done = subprocess.run([sys.executable, "-c", CALIBRATE, str(path)], env=env, capture_output=True, text=True,
                              check=True)
        runs[mode] = json.loads(done.stdout.strip().splitlines()[-1])
    for solver in ("nlp", "ils"):
        (values_c, sigma_c), (values_v, sigma_v) = runs["compiled"][solver], runs["virtual"][solver]
        sigma = np.asarray(sigma_c)
        assert np.max(np.abs(np.subtract(values_c, values_v)) / sigma) < 1e-6, solver
        assert np.max(np.abs(np.subtract(sigma_c, sigma_v)) / sigma) < 1e-6, solver


def test_no_compile_says_so_in_one_line(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("CASADI_SINS_CACHE", str(tmp_path))
    monkeypatch.setenv("CASADI_SINS_NO_COMPILE", "1")
    monkeypatch.setattr(compiled, "_NOTES", set())
    for key in ("a", "b"):
        assert compiled.cached_functions("toy", key, ["toy_step"], lambda: [_step()])[0].class_name() == "SXFunction"
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "CASADI_SINS_NO_COMPILE" in err[0]


def test_a_failing_compiler_is_named_with_its_status(monkeypatch, tmp_path, capsys):
    fake = tmp_path / "cc"
    fake.write_text("#!/bin/sh\nexit 4\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CASADI_SINS_CACHE", str(tmp_path / "cache"))
    monkeypatch.delenv("CASADI_SINS_NO_COMPILE", raising=False)
    monkeypatch.setattr(compiled, "find_compiler", lambda: str(fake))
    monkeypatch.setattr(compiled, "_NOTES", set())
    assert compiled.cached_functions("toy", "k", ["toy_step"], lambda: [_step()])[0].class_name() == "SXFunction"
    err = capsys.readouterr().err
    assert "exit status 4, no message" in err and "()" not in err
