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

    # spawned workers that ignore Ctrl-C and SIGTERM from the terminal: the parent handles them, terminates
    # the workers (the pool's exit) and reports
    with _children_ignore_ctrl_c():  # a Ctrl-C while a worker is still starting is ignored there too
        pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_worker_setup, initargs=(os.getpid(),))
    with pool:
        yield from pool.imap_unordered(task, items)


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
    with _children_ignore_ctrl_c():
        cluster = (LocalCluster(n_workers=workers or os.cpu_count() or 1, threads_per_worker=1, processes=True,
                                dashboard_address=None, silence_logs=logging.CRITICAL)
                   if scheduler == "local" else None)
    try:
        try:
            client = Client(cluster if cluster is not None else scheduler, timeout="20s")
        except (OSError, ValueError, TypeError) as exc:
            raise InputError(None, f"--dask {one_line(scheduler, 80)}: cannot reach the scheduler "
                             f"({one_line(exc, 200)})") from None
        with client:
            futures = [client.submit(task, item, pure=False) for item in items]
            try:
                for future in dask_completed(futures):
                    yield future.result()
            finally:
                client.cancel(futures)
    finally:
        if cluster is not None:
            cluster.close()


@contextlib.contextmanager
def _children_ignore_ctrl_c():
    """Processes started in the block inherit an ignored SIGINT (kept across ``exec``): a Ctrl-C on the
    terminal reaches the whole process group, and only the parent reports it."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _worker_setup(parent: int) -> None:
    """In a worker: ignore the terminal's signals (the parent stops the pool) and exit when the parent dies."""
    import signal
    import threading
    import time

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


