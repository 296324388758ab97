"""The ``casadi-sins`` console script (and ``python -m casadi_sins``).

Its first act is to handle the signals (:mod:`.core.signals`), before the command line's heavy
imports: Ctrl-C at any instant prints ``interrupted`` and exits with 130, SIGTERM or SIGHUP
``terminated`` and 143, never a traceback. ``--version`` is answered without loading CasADi, pandas
or matplotlib.
"""

from __future__ import annotations

import sys

from .core import signals

signals.install()


def run(argv: list[str] | None = None) -> int:
    """The command line with ``argv`` (default ``sys.argv[1:]``): its exit status."""
    argv = sys.argv[1:] if argv is None else argv
    try:
        if argv == ["--version"]:
            from .core.version import build_identity
            print(build_identity())
            return 0
        from .cli import main
    except BaseException as exc:  # noqa: BLE001 (a signal during the start-up: one line, its status)
        status = signals.exit_status(exc)
        if status is None:
            raise
        return signals.told(status)
    return main(argv)


def console() -> None:
    """Entry point of the console script: :func:`run`, then an exit that no late signal can turn into a
    traceback (the interpreter's shutdown ignores Ctrl-C and SIGTERM)."""
    try:
        status = run()
    except BaseException as exc:  # noqa: BLE001 (a signal between the start-up and the command's own handling)
        status = signals.exit_status(exc)
        if status is None:
            raise
        signals.told(status)
    signals.ignore_all()
    _forget_handled_interrupt()
    sys.exit(status)


def _forget_handled_interrupt() -> None:
    """Clear CPython's record of a KeyboardInterrupt that escaped code it ran for a C extension (``PyRun_*``
    during an import) and that we then handled: CPython 3.11 keeps it and ends the process by SIGINT at exit
    (status -2 instead of ours; seen in about 1 of 15 Ctrl-Cs during the imports on a loaded machine). Where the
    record cannot be reached (a CPython that keeps it elsewhere, 3.12 and later), nothing is done."""
    import ctypes  # noqa: PLC0415 (only at the exit)

    try:
        flag = ctypes.c_int.in_dll(ctypes.pythonapi, "_Py_UnhandledKeyboardInterrupt")
    except (ValueError, AttributeError, OSError):
        return
    flag.value = 0
