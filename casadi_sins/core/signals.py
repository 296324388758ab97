"""Steps no signal may cut in two: Ctrl-C, SIGTERM and SIGHUP held while they run, then delivered.

Renaming a command's outputs into place (:func:`core.files.write_files`) and starting or stopping a pool
of workers (:mod:`studies.parallel`) are done whole: a signal received meanwhile is only recorded, and
delivered again (to the handler that was in place) once the step is over, so the command still ends as
interrupted or terminated, after it.  The signals are also blocked in the calling thread: processes and
threads started meanwhile inherit that mask, so worker processes never see the terminal's Ctrl-C (only
the parent reports it).  Blocking alone would not do: the signal may be delivered to another thread (a
BLAS thread), and Python then runs the handler in the main thread all the same.
"""

from __future__ import annotations

import contextlib
import signal
import threading

#: The signals a command ends on (:mod:`cli`).
HELD = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


def hold_signals():
    """Start holding :data:`HELD` (the main thread only; elsewhere nothing); returns what
    :func:`release_signals` needs."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        return None
    received: list[int] = []

    def record(signum, frame):
        received.append(signum)

    handlers = {sig: signal.signal(sig, record) for sig in HELD}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, HELD)
    return mask, handlers, received


def release_signals(state) -> None:
    """Stop holding: the handlers and the mask as they were, then the first signal received meanwhile
    delivered again (it raises here what its handler raises: KeyboardInterrupt for Ctrl-C)."""
    if state is None:
        return
    mask, handlers, received = state
    for sig, handler in handlers.items():
        signal.signal(sig, signal.SIG_DFL if handler is None else handler)
    signal.pthread_sigmask(signal.SIG_SETMASK, mask)  # a signal still pending arrives at its own handler now
    if received:
        signal.raise_signal(received[0])


@contextlib.contextmanager
def signals_held():
    """The block runs whole; a signal received meanwhile is delivered when it ends."""
    state = hold_signals()
    try:
        yield
    finally:
        release_signals(state)
