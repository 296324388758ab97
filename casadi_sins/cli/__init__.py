"""The command line ``casadi-sins``: parsing and printing only; the work is done by the library.

Every failure is one line on standard error naming the file (and line) at fault, with exit status
2; Ctrl-C prints ``interrupted`` (130), SIGTERM or SIGHUP ``terminated`` (143); nothing is left
half-written (every command writes its outputs together) and no worker process outlives the command.
Every input is registered as it is found (:mod:`core.guard`) and a command owns its output set
(:mod:`cli.outputs`): the files of an earlier run it does not write again are removed with its writes,
and no input is ever written over or removed.
"""

from __future__ import annotations

import contextlib
import os
import sys
import traceback
import warnings

from ..core import signals
from ..core.errors import Caution, InputError, OutputError
from ..core.files import check_writable, claim_outputs, gathered_writes
from ..core.guard import guarded_inputs, last_input
from ..core.signals import Terminated
from ..core.text import one_line
from ..core.threads import single_threaded
from .command import CliError
from .inputs import command_inputs
from .outputs import command_outputs
from .parser import build_parser
from .registry import command

__all__ = ["main", "build_parser", "CliError", "Terminated"]


@contextlib.contextmanager
def _termination_handled():
    """SIGTERM and SIGHUP raise :class:`Terminated`, SIGINT KeyboardInterrupt, in the main thread while the
    command runs; each is remembered (:func:`..core.signals.received`). A signal the console script's own
    handlers received before (during the start-up) is kept: the command then ends at its first check."""
    if not signals.installed():  # a command run in-process (not from the console script): a fresh start
        signals.reset()
    previous = signals.install()
    try:
        yield
    finally:
        signals.restore(previous)


class _ClosedReaderSafe:
    """Standard output that outlives its reader: once a pipe's reader has gone (``casadi-sins ... | head``),
    the rest of the summary goes to the null device, so the command still finishes and writes its files
    (which a broken pipe would otherwise abandon, every output being written together at the end)."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._to_null()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._to_null()

    def _to_null(self) -> None:
        try:  # the interpreter's last flush at exit then finds a sink, not a closed pipe
            null = os.open(os.devnull, os.O_WRONLY)
            os.dup2(null, self._stream.fileno())
            os.close(null)
        except (OSError, ValueError, AttributeError):  # a stream without a descriptor (a test's capture)
            pass

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def _reader_may_leave():
    """:class:`_ClosedReaderSafe` as ``sys.stdout`` while a command runs."""
    previous = sys.stdout
    sys.stdout = _ClosedReaderSafe(previous)
    try:
        yield
    finally:
        sys.stdout = previous


@contextlib.contextmanager
def _warnings_in_our_words():
    """While a command runs, a warning of ours (:class:`~core.errors.Caution`) is one line ``warning: ...``
    on standard error; the libraries' warnings (NumPy's RuntimeWarning on an overflow, matplotlib's, pandas')
    are silenced: what they would mean reaches the user through our own checks and messages."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"warning: {one_line(message, 2000)}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        warnings.filterwarnings("default", category=Caution)
        warnings.showwarning = show
        yield


def main(argv: list[str] | None = None) -> int:
    """Run ``casadi-sins`` with ``argv``; returns the exit status (0; 2 for a failure told in one line; 130
    interrupted; 143 terminated)."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:  # --help, --version (0) or a bad argument, told in one line (2)
        return exc.code if isinstance(exc.code, int) else 2
    record = command(args.command)
    name = f"casadi-sins {record.name}"
    try:
        with _termination_handled(), _reader_may_leave(), _warnings_in_our_words(), \
                guarded_inputs(command_inputs(args)):
            run = record.function()  # the library loads here, once the arguments are known to be sound
            signals.raise_if_received()  # a signal an import swallowed still ends the command
            if getattr(args, "out", None):
                check_writable(args.out, directory=record.output == "folder")  # before any computation
            with single_threaded(), (contextlib.nullcontext() if record.incremental else gathered_writes()):
                claim_outputs(command_outputs(args))  # what this run owns: never an input, before any computation
                status = run(args)
                signals.raise_if_received()  # asked to stop, even if a library swallowed it: nothing is written
                return status
    except BaseException as exc:  # noqa: BLE001 (every outcome is one line and a status)
        return _outcome(name, exc)


def _outcome(name: str, exc: BaseException) -> int:
    """The exit status of a command that raised ``exc`` (and its one line on standard error)."""
    if signals.received() and not isinstance(exc, (KeyboardInterrupt, SystemExit)):  # a signal turned into another error
        exc = signals.interruption()
    calibration = sys.modules.get("casadi_sins.calibrate.result")  # loaded by the commands that calibrate
    told = (InputError, OutputError, CliError, *((calibration.CalibrationError,) if calibration else ()))
    try:
        raise exc
    except told as exc:
        return _fail(name, one_line(exc, 2000))
    except KeyboardInterrupt as exc:  # Ctrl-C, and SIGTERM or SIGHUP (Terminated)
        return signals.told(signals.TERMINATED if isinstance(exc, Terminated) else signals.INTERRUPTED)
    except MemoryError:
        last = last_input()
        return _fail(name, f"not enough memory{f' (last input read: {one_line(last, 300)})' if last else ''}: free "
                     "memory, use a larger machine, or give this command less to do")
    except ImportError as exc:
        return _fail(name, f"cannot load {exc.name or 'a module'} ({one_line(exc)}): reinstall casadi-sins, or "
                     "free memory")
    except OSError as exc:  # a file system failure: one line naming the file, never a traceback
        where = exc.filename or ""
        return _fail(name, f"{where}{': ' if where else ''}{exc.strerror or one_line(exc)}")
    except Exception as exc:  # a fault of ours: still one line, the traceback on request
        if os.environ.get("CASADI_SINS_DEBUG"):
            traceback.print_exc()
        return _fail(name, f"internal error ({type(exc).__name__}: {one_line(exc)}); set CASADI_SINS_DEBUG=1 "
                     "for the traceback and report it", status=1)


def _fail(name: str, message: str, status: int = 2) -> int:
    print(f"{name}: error: {message}", file=sys.stderr)
    return status
