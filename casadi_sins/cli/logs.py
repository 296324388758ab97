"""What the commands write while they work: ``--quiet`` and ``--no-progress``, the progress
(:class:`core.progress.Progress`: a bar on a terminal, a line per 10 % or 10 s in a log), and the
diagnostics.

One rule for every command: **results on standard output** (tables, verdicts, the files written),
**diagnostics on standard error** (the solvers' step lines such as ``nlp: ...``, ``note:`` and
``warning:`` lines, progress), so that ``casadi-sins CMD ... > result.txt`` keeps the results alone."""

from __future__ import annotations

import sys

from ..core.progress import Progress, progress_mode

def add_log_options(p) -> None:
    """``--quiet`` and ``--no-progress`` on a long command's parser (:attr:`cli.command.Command.long`)."""
    p.add_argument("--no-progress", action="store_true", help="no progress bar or progress lines (also: the "
                   "environment variable TQDM_DISABLE=1); without it, a bar on a terminal and a line per 10 %% or "
                   "10 s in a log or file")
    p.add_argument("--quiet", action="store_true", help="only the results, warnings and errors: no progress, no "
                   "per-step messages")


def progress_for(args, total: float, desc: str, unit: str = "step") -> Progress:
    """The progress of a command's work (off with ``--quiet`` or ``--no-progress``)."""
    enabled = not (getattr(args, "quiet", False) or getattr(args, "no_progress", False))
    return Progress(total, desc, unit, mode=progress_mode(enabled=enabled))


def steps_printer(args):
    """A printer of the library's step messages (``nlp: ...``) on standard error, or None with ``--quiet`` or
    ``--no-progress``."""
    if getattr(args, "quiet", False) or getattr(args, "no_progress", False):
        return None
    return lambda message: print(message, file=sys.stderr, flush=True)


def note(text: str) -> None:
    """A ``note:`` line on standard error (a diagnostic: not with the results)."""
    print(f"note: {text}", file=sys.stderr)


def warning(text: str) -> None:
    """A ``warning:`` line on standard error."""
    print(f"warning: {text}", file=sys.stderr)


def message_printer(args, command: str):
    """A progress-message callback for the long searches (``design``, ``design-scheme``): a line on standard
    error, or nothing with ``--quiet`` or ``--no-progress``."""
    if getattr(args, "quiet", False) or getattr(args, "no_progress", False):
        return lambda message: None
    return lambda message: print(f"{command}: {message}", file=sys.stderr, flush=True)
