"""Signals as exceptions, from the first instant of a command to its last.

Ctrl-C (SIGINT) raises :class:`KeyboardInterrupt`, SIGTERM and SIGHUP raise :class:`Terminated` (a
subclass, so that every ``except KeyboardInterrupt`` cleanup runs for both), in the main thread. The
signal received is remembered (:func:`received`): a library may turn the exception into an error of
its own (CasADi reports an interrupted Ipopt as a ``RuntimeError``), and the command still ends as
interrupted (exit status 130) or terminated (143).

This module imports nothing but the standard library: the console script installs its handlers
before the package's heavy imports (CasADi, pandas), so that a signal during the start-up is told in
one line like any other.

Some steps no signal may cut in two: renaming a command's outputs into place
(:func:`core.files.write_files`) and starting or stopping a pool of workers (:mod:`studies.parallel`).
During them (:func:`signals_held`) Ctrl-C, SIGTERM and SIGHUP are only recorded, and delivered again
(to the handler that was in place) once the step is over, so the command still ends as interrupted or
terminated, after it. The signals are also blocked in the calling thread: processes and threads
started meanwhile inherit that mask, so worker processes never see the terminal's Ctrl-C (only the
parent reports it). Blocking alone would not do: the signal may be delivered to another thread (a BLAS
thread), and Python then runs the handler in the main thread all the same.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading

#: Exit status of a command ended by Ctrl-C, and by SIGTERM or SIGHUP (128 + SIGINT, 128 + SIGTERM).
INTERRUPTED, TERMINATED = 130, 143

HANDLED = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

_received = 0


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP: handled as Ctrl-C is (everything stops, nothing half-written), told apart."""


def received() -> int:
    """The signal received since :func:`reset` (0: none)."""
    return _received


def reset() -> None:
    """Forget the signal received (a new command starts)."""
    global _received
    _received = 0


def _handler(signum, frame):  # noqa: ARG001 (the signal module's signature)
    global _received
    _received = _received or signum
    if signum == signal.SIGINT:
        raise KeyboardInterrupt
    raise Terminated(signal.Signals(signum).name)


def install() -> dict:
    """Handle SIGINT, SIGTERM and SIGHUP as exceptions in the main thread; returns the handlers replaced
    (for :func:`restore`). Elsewhere than in the main thread nothing is changed (``{}``). A SIGINT
    handler of the caller's own (not Python's default) is left in place."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    previous = {}
    for sig in HANDLED:
        current = signal.getsignal(sig)
        if sig == signal.SIGINT and current not in (signal.default_int_handler, _handler):
            continue
        previous[sig] = signal.signal(sig, _handler)
    return previous


def installed() -> bool:
    """Whether our handlers are in place already (the console script installs them before any import)."""
    return (threading.current_thread() is threading.main_thread()
            and signal.getsignal(signal.SIGTERM) is _handler)


def interruption() -> KeyboardInterrupt | None:
    """The exception the signal received so far raises (:class:`Terminated` or KeyboardInterrupt; None: none)."""
    if not _received:
        return None
    return KeyboardInterrupt() if _received == signal.SIGINT else Terminated(signal.Signals(_received).name)


def raise_if_received() -> None:
    """Raise :func:`interruption`, even when the exception the signal raised was swallowed on the way (a
    library's ``except:`` around an import, C code that clears the error): a command that was asked to stop
    never writes its outputs."""
    exc = interruption()
    if exc is not None:
        raise exc


def restore(previous: dict) -> None:
    """Put back the handlers :func:`install` replaced."""
    for sig, old in previous.items():
        signal.signal(sig, old)


def ignore_all() -> None:
    """Ignore every handled signal: for the interpreter's shutdown, which no late signal may turn into a
    traceback once a command has decided its exit status."""
    for sig in HANDLED:
        signal.signal(sig, signal.SIG_IGN)


def told(status: int) -> int:
    """Print the one line of a command ended by a signal (``interrupted`` or ``terminated``); returns ``status``."""
    print("terminated" if status == TERMINATED else "interrupted", file=sys.stderr)
    return status


def exit_status(exc: BaseException) -> int | None:
    """130 or 143 when ``exc`` (or a signal received meanwhile) ends the command, else ``None``."""
    if isinstance(exc, Terminated) or _received in (signal.SIGTERM, signal.SIGHUP):
        return TERMINATED
    if isinstance(exc, KeyboardInterrupt) or _received == signal.SIGINT:
        return INTERRUPTED
    return None



def hold_signals():
    """Start holding :data:`HANDLED` (the main thread only; elsewhere nothing); returns what
    :func:`release_signals` needs."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        return None
    received: list[int] = []

    def record(signum, frame):
        received.append(signum)

    handlers = {sig: signal.signal(sig, record) for sig in HANDLED}
    mask = signal.pthread_sigmask(signal.SIG_BLOCK, HANDLED)
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
