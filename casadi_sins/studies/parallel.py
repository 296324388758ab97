"""Many independent runs at once: local spawned processes, or a Dask cluster; one progress callback.

Used by every study that repeats a calibration (Monte Carlo, sweeps, batches).  Workers get one BLAS
thread each (the runs are the parallelism), leave Ctrl-C and SIGTERM to the parent, which terminates
them, and exit by themselves if the parent dies.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
from typing import Callable, Iterable, Sequence

from ..core.errors import InputError
from ..core.extras import missing_extra
from ..core.signals import hold_signals, release_signals, signals_held
from ..core.text import one_line
from ..core.threads import single_threaded


def run_all(task: Callable, items: Sequence, workers: int | None = None, scheduler: str | None = None,
            progress: Callable[[int, int], None] | None = None) -> Iterable:
    """Yield ``task(item)`` for every item, in the order they finish.

    Parameters
    ----------
    task : callable
        A picklable function of one item.
    items : sequence
    workers : int, optional
        Local processes (default: one per core); 1 runs in this process.
    scheduler : str, optional
        A Dask distributed scheduler address (``tcp://host:8786``), or ``"local"`` for a Dask cluster on
        this machine (needs ``dask[distributed]``).
    progress : callable, optional
        ``progress(done, total)`` after each finished item.
    """
    items = list(items)
    with single_threaded():
        if scheduler:
            results = _on_dask(task, items, workers, scheduler)
        elif (workers or os.cpu_count() or 1) == 1:
            results = (task(item) for item in items)
        else:
            results = _on_processes(task, items, workers or os.cpu_count() or 1)
        for done, result in enumerate(results, 1):
            if progress:
                progress(done, len(items))
            yield result


def _on_processes(task: Callable, items: list, workers: int):
    import multiprocessing

    # spawned workers that ignore Ctrl-C from the terminal: the parent handles it, terminates the workers (the
    # pool's exit) and reports; a Ctrl-C or SIGTERM while they start waits until the pool can be closed
    held = hold_signals()
    try:
        pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_worker_setup, initargs=(os.getpid(),))
    except BaseException:
        release_signals(held)
        raise
    try:
        release_signals(held)  # a signal received while the workers started is raised here: the pool is ended below
        yield from pool.imap_unordered(task, items)
    finally:
        with signals_held():  # the workers and whatever they started (a C compiler) end before the command does
            tree = _descendants(child.pid for child in multiprocessing.active_children())
            pool.terminate()
            pool.join()
            _kill(tree)


def check_scheduler(scheduler: str | None) -> None:
    """Refuse a ``--dask`` value that is neither ``"local"`` nor a scheduler address (before any work).

    Raises
    ------
    InputError
        One line naming the value.
    """
    if scheduler and scheduler != "local" and not re.fullmatch(
            r"(tcp|tls|inproc|ucx|ws|wss)://[^\s/]+(:\d+)?/?|[\w.-]+:\d+", scheduler):
        raise InputError(None, f"--dask {one_line(repr(scheduler), 80)}: not a scheduler address "
                         "(tcp://host:8786) nor 'local'")


def _on_dask(task: Callable, items: list, workers: int | None, scheduler: str):
    try:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed
    except ImportError:
        raise InputError(None, missing_extra(f"--dask {one_line(scheduler, 80)}", "cluster",
                                             "dask.distributed")) from None
    check_scheduler(scheduler)
    cluster = client = None
    futures: list = []
    held = hold_signals()  # the cluster starts whole (its workers ignore the terminal's Ctrl-C); a signal waits
    try:
        try:
            if scheduler == "local":
                cluster = LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                                       dashboard_address=None, silence_logs=logging.CRITICAL)
            client = Client(cluster if cluster is not None else scheduler, timeout="20s")
        except (OSError, ValueError, TypeError) as exc:
            raise InputError(None, f"--dask {one_line(scheduler, 80)}: cannot reach the scheduler "
                             f"({one_line(exc, 200)})") from None
        finally:
            release_signals(held)  # a Ctrl-C or SIGTERM received while it started is raised here
        futures = [client.submit(task, item, pure=False) for item in items]
        for future in dask_completed(futures):
            yield future.result()
    finally:
        held = hold_signals()  # the cluster stops whole: its workers are gone before the command ends
        try:
            _close_dask(client, cluster, futures)
        finally:
            release_signals(held)


def _close_dask(client, cluster, futures) -> None:
    """Cancel the futures, close the client and the local cluster (its workers), quietly."""
    with contextlib.suppress(Exception):
        if client is not None and futures:
            client.cancel(futures)
    with contextlib.suppress(Exception):
        if client is not None:
            client.close()
    if cluster is None:
        return
    import multiprocessing

    tree = _descendants(child.pid for child in multiprocessing.active_children())
    with contextlib.suppress(Exception):
        cluster.close(timeout=CLOSE_TIMEOUT_S)
    for child in multiprocessing.active_children():  # a worker busy in a calibration: killed
        with contextlib.suppress(Exception):
            child.kill()
            child.join(2.0)
    _kill(tree)


#: Seconds a local cluster is given to stop its workers (a busy one is then killed).
CLOSE_TIMEOUT_S = 5.0


def _descendants(pids) -> list[int]:
    """Every process started by ``pids`` or by their children (from ``/proc``; none known elsewhere)."""
    pids = list(pids)
    children: dict[int, list[int]] = {}
    try:
        entries = [e for e in os.listdir("/proc") if e.isdigit()]
    except OSError:
        return []
    for entry in entries:
        try:
            with open(f"/proc/{entry}/stat", encoding="ascii", errors="replace") as handle:
                ppid = int(handle.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        children.setdefault(ppid, []).append(int(entry))
    out, todo = [], list(pids)
    while todo:
        kids = children.get(todo.pop(), [])
        out += kids
        todo += kids
    return out


def _kill(pids) -> None:
    """SIGKILL to each of ``pids`` still running (a worker's C compiler left behind by the worker's end)."""
    import signal

    for pid in pids:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _worker_setup(parent: int) -> None:
    """In a worker: ignore the terminal's signals (the parent stops the pool) and exit when the parent dies."""
    import signal
    import threading
    import time

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGTERM])  # held while the pool started: the pool ends us so

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


