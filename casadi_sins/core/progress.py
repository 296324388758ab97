"""Progress of a long command on standard error: a bar on a terminal, plain lines in a log.

On a terminal (the stream is a TTY) a ``tqdm`` bar redraws itself in place.  Anywhere else (a CI log,
a file, a pipe) a redrawn bar would leave carriage returns and thousands of partial lines, so the
progress is written as whole lines instead: one each time another 10 % is done or 10 s have passed
since the last line, and one at the end.  ``mode="off"`` (``--no-progress``, ``--quiet``, or the
environment variable ``TQDM_DISABLE`` set to anything but ``0``/``false``) writes nothing.
"""

from __future__ import annotations

import os
import sys
import time

#: A line at least every this many seconds, and at every this fraction of the work.
LINE_SECONDS = 10.0
LINE_FRACTION = 0.1


def progress_mode(stream=None, enabled: bool = True) -> str:
    """``"bar"`` on a terminal, ``"lines"`` elsewhere, ``"off"`` when disabled (argument or ``TQDM_DISABLE``)."""
    stream = stream or sys.stderr
    if not enabled or os.environ.get("TQDM_DISABLE", "").strip().lower() not in ("", "0", "false"):
        return "off"
    try:
        return "bar" if stream.isatty() else "lines"
    except (AttributeError, ValueError):
        return "lines"


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


class Progress:
    """Progress of ``total`` steps: ``update(done)`` with the count done so far (a context manager).

    Parameters
    ----------
    total : float
    desc : str
        What is being done (starts every line).
    unit : str
        The word for one step ("run", "unit", ...).
    mode : str, optional
        ``"bar"``, ``"lines"`` or ``"off"``; default :func:`progress_mode` of ``stream``.
    stream : file, optional
        Default standard error.
    """

    def __init__(self, total: float, desc: str, unit: str = "step", mode: str | None = None, stream=None):
        self.total, self.desc, self.unit = float(total), desc, unit
        self.stream = stream or sys.stderr
        self.mode = mode or progress_mode(self.stream)
        self.done = 0.0
        self._start = self._last_time = time.monotonic()
        self._last_fraction = 0.0
        self._bar = None
        if self.mode == "bar":
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=desc, unit=unit, file=self.stream)

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __call__(self, done: float, total: float | None = None) -> None:
        """``update`` under the signature ``progress(done, total)`` of the library's callbacks."""
        self.update(done, total)

    def update(self, done: float, total: float | None = None) -> None:
        """Set the count done (and, if given, a new total)."""
        if total is not None:
            self.total = float(total)
        self.done = float(done)
        if self._bar is not None:
            self._bar.total = self.total
            self._bar.update(self.done - self._bar.n)
        elif self.mode == "lines":
            fraction = self.done / self.total if self.total > 0 else 1.0
            now = time.monotonic()
            if (fraction >= 1.0 or fraction - self._last_fraction >= LINE_FRACTION - 1e-12
                    or now - self._last_time >= LINE_SECONDS):
                self._line(fraction, now)

    def _line(self, fraction: float, now: float) -> None:
        elapsed = now - self._start
        left = (f", about {_duration(elapsed * (1 - fraction) / fraction)} left"
                if 0 < fraction < 1 else "")
        count = f"{self.done:g}/{self.total:g} {self.unit}s " if self.unit and self.done.is_integer() else ""
        print(f"{self.desc}: {count}({100 * fraction:.0f} %), {_duration(elapsed)} elapsed{left}",
              file=self.stream, flush=True)
        self._last_time, self._last_fraction = now, fraction

    def close(self) -> None:
        """End the bar (or write the last line if the work ended short of a line)."""
        if self._bar is not None:
            self._bar.close()
