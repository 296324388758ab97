"""Mutations of a valid recording, and an independent oracle of what the mutated files mean.

Shared by the property-based tests (tests/fuzz/test_mutations.py) and the mutation benchmark
(benchmarks/bench_mutations.py).  A mutation edits the CSV or the TOML text; the oracle parses the
mutated CSV with Python's own ``csv`` module, strictly (every row as wide as the header, the format's
columns finite floats).  The reader must then either refuse the file with one clear error, or return
exactly the oracle's numbers: anything else is a silently wrong table.
"""

from __future__ import annotations

import csv
import io
import math
import random
import re

import numpy as np

COLUMNS = ("time", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: The format's numbers: plain ASCII decimal (no ``1_000``, no other scripts' digits, no hex, no inf/nan).
PLAIN = re.compile(r"\s*[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?\s*")


def oracle(text: str) -> np.ndarray | None:
    """The (N, 7) numbers a strict reader must find in a CSV text, or ``None`` when the text is no valid
    CSV of samples (missing or repeated column, a row of another width, a value that is not a finite float)."""
    try:
        rows = list(csv.reader(io.StringIO(text, newline=""), skipinitialspace=True))
    except csv.Error:
        return None
    if not rows:
        return None
    header = [c.strip() for c in rows[0]]
    if any(header.count(c) != 1 for c in COLUMNS):
        return None
    take = [header.index(c) for c in COLUMNS]
    out = []
    for row in rows[1:]:
        if not row or row == [""]:
            continue
        if len(row) != len(header):
            return None
        if not all(PLAIN.fullmatch(row[j]) for j in take):
            return None
        values = [float(row[j]) for j in take]
        if not all(math.isfinite(v) for v in values):
            return None
        out.append(values)
    return np.array(out, dtype=float).reshape(-1, 7)


def _data_line(lines, rng):
    return rng.randrange(1, len(lines)) if len(lines) > 1 else 0


def _insert_comma(lines, rng):
    k = _data_line(lines, rng)
    pos = rng.randrange(len(lines[k]) + 1)
    lines[k] = lines[k][:pos] + "," + lines[k][pos:]


def _delete_comma(lines, rng):
    k = _data_line(lines, rng)
    commas = [i for i, c in enumerate(lines[k]) if c == ","]
    if commas:
        i = rng.choice(commas)
        lines[k] = lines[k][:i] + lines[k][i + 1:]


def _append_field(lines, rng):
    lines[_data_line(lines, rng)] += rng.choice([",0", ",", ",1.5"])


def _delete_line(lines, rng):
    del lines[_data_line(lines, rng)]


def _duplicate_line(lines, rng):
    k = _data_line(lines, rng)
    lines.insert(k, lines[k])


def _swap_lines(lines, rng):
    a, b = _data_line(lines, rng), _data_line(lines, rng)
    lines[a], lines[b] = lines[b], lines[a]


def _replace_char(lines, rng):
    k = rng.randrange(len(lines))
    if lines[k]:
        i = rng.randrange(len(lines[k]))
        lines[k] = lines[k][:i] + rng.choice("0123456789.-+eE ,;\"'xX\t") + lines[k][i + 1:]


def _replace_field(lines, rng):
    k = _data_line(lines, rng)
    fields = lines[k].split(",")
    fields[rng.randrange(len(fields))] = rng.choice(["nan", "inf", "-inf", "", "1e309", "abc", "0x10", "1_000",
                                                     "  7", "1e300", "-0", "+3", "\"2.5\"", "١٢٣", "１２３",
                                                     "1e160"])
    lines[k] = ",".join(fields)


def _rename_column(lines, rng):
    fields = lines[0].split(",")
    fields[rng.randrange(len(fields))] = rng.choice(["gyro_q", "", "time", "accel_x", "Time", " gyro_x "])
    lines[0] = ",".join(fields)


def _reorder_columns(lines, rng):
    order = list(range(len(lines[0].split(","))))
    rng.shuffle(order)
    lines[:] = [",".join(line.split(",")[i] for i in order) if line.count(",") + 1 == len(order) else line
                for line in lines]


def _add_column(lines, rng):
    lines[0] += ",temperature"
    for k in range(1, len(lines)):
        lines[k] += f",{rng.uniform(20, 30):.3f}"


def _scale_value(lines, rng):
    k = _data_line(lines, rng)
    fields = lines[k].split(",")
    j = rng.randrange(1, len(fields))
    try:
        fields[j] = repr(float(fields[j]) * rng.choice([10.0, -1.0, 1.0001]))
    except ValueError:
        return
    lines[k] = ",".join(fields)


def _blank_line(lines, rng):
    lines.insert(_data_line(lines, rng), rng.choice(["", " ", ","]))


def _crlf(lines, rng):
    lines[:] = [line + "\r" for line in lines]


CSV_MUTATIONS = {f.__name__.lstrip("_"): f for f in (
    _insert_comma, _delete_comma, _append_field, _delete_line, _duplicate_line, _swap_lines, _replace_char,
    _replace_field, _rename_column, _reorder_columns, _add_column, _scale_value, _blank_line, _crlf)}


def mutate_csv(text: str, kind: str, seed: int) -> str:
    """One mutation of ``kind`` (a key of :data:`CSV_MUTATIONS`) of a CSV text."""
    rng = random.Random(seed)
    lines = text.split("\n")
    trailing = lines[-1] == ""
    if trailing:
        lines = lines[:-1]
    CSV_MUTATIONS[kind](lines, rng)
    return "\n".join(lines) + ("\n" if trailing else "")


TOML_EDITS = [
    ("height_m = ", "# height_m = "), ("latitude_deg = ", "latitude_deg = 1e999 #"), ('axis = "+Z"', 'axis = "z"'),
    ('axis = "+Z"', 'axis = "+Z\\n"'), ('orientation = "NUE"', 'orientation = "nue"'), ("rate_hz = ", "rate_hz = -"),
    ("angle_deg = 90.0", "angle_deg = 0"), ("group = 2", "group = 1"), ('kind = "static"', 'kind = "Static"'),
    ('name = "', 'name = "x\\nsystem(1) %'), ('name = "', 'name = "../../'), ("end_s = ", "end_s = -"),
    ("[[segments]]", "[[segments]]\n[[segments]]"), ("[imu]", "[imu]\n[imu]"), ('format = "', 'format = "x'),
    ("rate_hz = 100.0", "rate_hz = 100.05"), ("[site]", "[site]\nnested = [[[[[[[[[[[1]]]]]]]]]]]"),
    ("start_s = ", "start_s = \"0\" #"), ('data = "', 'data = "/dev/zero" #'),
]


def mutate_toml(text: str, index: int, seed: int) -> str:
    """Edit number ``index`` of :data:`TOML_EDITS`, at a random one of its places."""
    old, new = TOML_EDITS[index % len(TOML_EDITS)]
    places = [i for i in range(len(text)) if text.startswith(old, i)]
    if not places:
        return text
    at = random.Random(seed).choice(places)
    return text[:at] + new + text[at + len(old):]
