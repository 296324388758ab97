"""The design as a problem file: the input's unit, noise, site and truth verbatim, the schedule replaced.

The input problem's text is kept table for table (``[site]``, ``[imu]``, ``[errors]``, ``[truth]`` and
any other, comments included) except ``[timing]`` and ``[[groups]]``, which are written anew, and the
top-level ``name`` and ``description``.  The text is read back with the problem reader and its
schedule compared with the design's before anything is written, so the file is what ``simulate``,
``analyze`` and ``montecarlo`` will take.
"""

from __future__ import annotations

import json
import re
import tempfile
from pathlib import Path

from ...data.problem import FORMAT, Problem, load_problem

_HEADER = re.compile(r"^\s*\[\[?\s*([A-Za-z0-9_.-]+)\s*\]\]?")
_REPLACED = {"timing", "groups"}


def kept_tables(text: str) -> str:
    """The tables of a problem file's text other than ``[timing]`` and ``[[groups]]``, verbatim."""
    out, table = [], None
    for line in text.splitlines():
        match = _HEADER.match(line)
        if match:
            table = match.group(1)
        if table is not None and table not in _REPLACED:
            out.append(line)
    return "\n".join(out).strip() + "\n"


def _number(x: float) -> str:
    return f"{round(float(x), 3):g}"


def schedule_toml(problem: Problem) -> str:
    """``[timing]`` and ``[[groups]]`` of a problem in the problem format."""
    t = problem.timing
    lines = ["[timing]", f"static_s = {_number(t.static_s)}", f"rotation_s = {_number(t.rotation_s)}",
             f"gap_s = {_number(t.gap_s)}", f"rate_profile = {json.dumps(t.rate_profile)}",
             f"handling = {json.dumps(t.handling)}", ""]
    for plan in problem.groups:
        lines += ["[[groups]]", f"start = {json.dumps(plan.start)}",
                  "rotations = [" + ", ".join(json.dumps(r) for r in plan.rotations) + "]",
                  "statics_s = [" + ", ".join(_number(s) for s in plan.statics_s) + "]"]
        if plan.rotations_s:
            lines.append("rotations_s = [" + ", ".join(_number(s) for s in plan.rotations_s) + "]")
        lines.append("")
    return "\n".join(lines)


def problem_text(design: Problem, base: Problem, header: str) -> str:
    """The text of the design's problem file (``base`` must have been read from a file)."""
    source = Path(base.source).read_text(encoding="utf-8")
    comment = "".join(f"# {line}\n" for line in header.splitlines())
    top = (f"{comment}format = {json.dumps(FORMAT)}\nname = {json.dumps(design.name)}\n"
           f"description = {json.dumps(design.description)}\n\n")
    return top + kept_tables(source) + "\n" + schedule_toml(design)


def checked_text(design: Problem, base: Problem, header: str) -> str:
    """:func:`problem_text`, read back by the problem reader and compared with the design's schedule.

    Raises
    ------
    RuntimeError
        If the text does not read back as the design (a fault of ours).
    """
    text = problem_text(design, base, header)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "design.toml"
        path.write_text(text, encoding="utf-8")
        back = load_problem(path)
    if back.segments() != design.segments() or back.rate_hz != base.rate_hz or back.deviations != base.deviations:
        raise RuntimeError("the design's problem file does not read back as the design")
    return text
