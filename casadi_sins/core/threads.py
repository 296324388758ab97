"""One BLAS thread: the matrices are small, and threads spinning on them cost 3-5x under load."""

from __future__ import annotations

import contextlib
import os

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def single_threaded():
    """BLAS held to one thread in this process, and in every process started meanwhile.

    Worker processes read the variables when they import NumPy, hence spawned (not forked) workers.
    Measured: two NLP solves at once took 2.5 s each with the default thread pools on 2 cores, 1.7 s
    (as one alone) with one thread each.
    """
    from threadpoolctl import threadpool_limits

    saved = {var: os.environ.get(var) for var in THREAD_VARIABLES}
    os.environ.update({var: "1" for var in THREAD_VARIABLES})
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        for var, value in saved.items():
            if value is None:
                os.environ.pop(var, None)
            else:
                os.environ[var] = value
