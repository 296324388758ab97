"""Workers start and stop whole (issue 35, item 9): a Ctrl-C or SIGTERM while a local Dask cluster or a process
pool starts is held until it can be closed, then ends the command (130, 143) in one line, no traceback, no
process left behind."""

import importlib.util
import signal
import subprocess
import sys
import time

import pytest

from casadi_sins.sim import simulate, write_simulation

#: A child that runs the command line and sends itself ``SIG`` from inside the start of the workers.
CHILD = """
import os, signal, sys
from casadi_sins.cli import main
KIND, SIG = sys.argv[1], getattr(signal, sys.argv[2])
if KIND == "dask":
    import distributed.deploy.local as local
    start = local.LocalCluster.__init__
    def interrupted_start(self, *args, **kwargs):
        os.kill(os.getpid(), SIG)  # arrives while the cluster starts
        start(self, *args, **kwargs)
    local.LocalCluster.__init__ = interrupted_start
else:
    import multiprocessing.pool as pool
    start = pool.Pool.__init__
    def interrupted_start(self, *args, **kwargs):
        os.kill(os.getpid(), SIG)
        start(self, *args, **kwargs)
    pool.Pool.__init__ = interrupted_start
sys.exit(main(sys.argv[3:]))
"""


@pytest.fixture(scope="module")
def recordings(short_problem, tmp_path_factory):
    folder = tmp_path_factory.mktemp("units")
    for k in range(2):
        write_simulation(simulate(short_problem, seed=50 + k, name=f"U{k}"), folder)
    return sorted(map(str, folder.glob("U*.toml")))


@pytest.mark.parametrize("kind, sig, status, word", [
    ("dask", "SIGINT", 130, "interrupted"), ("dask", "SIGTERM", 143, "terminated"),
    ("pool", "SIGINT", 130, "interrupted"), ("pool", "SIGTERM", 143, "terminated"),
])
def test_a_signal_while_the_workers_start_ends_the_command_cleanly(recordings, tmp_path, kind, sig, status, word):
    if kind == "dask" and importlib.util.find_spec("distributed") is None:
        pytest.skip("dask.distributed not installed")
    out = tmp_path / "out"
    args = ["batch", *recordings, "--out", str(out), "--workers", "2", "--quiet"]
    args += ["--dask", "local"] if kind == "dask" else []
    started = time.perf_counter()
    child = subprocess.Popen([sys.executable, "-c", CHILD, kind, sig, *args], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True, start_new_session=True)
    _, err = child.communicate(timeout=120)
    assert child.returncode == status, err
    assert err.strip() == word, err  # one line: no Dask traceback, no late atexit message
    assert time.perf_counter() - started < 60  # the units were not calibrated first
    assert running_in_session(child.pid) == [] and not (out / "fleet.csv").exists()


def running_in_session(session: int) -> list[str]:
    """The processes of a session still running after a few seconds (an ended one, a zombie its new parent
    has not reaped yet, does not count)."""
    for _ in range(10):
        listing = subprocess.run(["ps", "-s", str(session), "-o", "pid=,stat="], capture_output=True, text=True).stdout
        left = [line.split()[0] for line in listing.splitlines() if line.split() and not line.split()[1].startswith("Z")]
        if not left:
            return []
        time.sleep(0.5)
    return left


def test_a_held_signal_reaches_the_handler_in_place_afterwards():
    from casadi_sins.core.signals import hold_signals, release_signals

    seen = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: seen.append(signum))
    try:
        held = hold_signals()
        signal.raise_signal(signal.SIGTERM)  # recorded only: the step goes on
        assert seen == []
        release_signals(held)
        assert seen == [signal.SIGTERM]
    finally:
        signal.signal(signal.SIGTERM, previous)
