"""Rotation schemes: steps of (axis, signed angle, rate, dwell), repeated; the IMU attitude over time.

A scheme file (TOML, ``format = "casadi-sins-scheme/1"``) is one period of steps.  Each step turns the
IMU at a constant rate about one axis and then holds it still (the dwell)::

    format = "casadi-sins-scheme/1"
    name = "mine"
    start = "ENU"         # IMU x, y, z at time zero: three letters of N S E W U D
    initial_dwell_s = 0.0 # optional still time before the first period

    [[step]]
    axis = "z"          # x | y | z: an axis of the IMU itself (it moves with the IMU)
                        # E | N | U: an axis fixed to the (static) base, i.e. to the ENU frame
    angle_deg = 180.0   # signed, right-hand rule about the axis
    rate_deg_s = 20.0   # > 0, constant during the turn
    dwell_s = 45.0      # > 0, still after the turn; omit it to go straight into the next turn

The period repeats until the end of the run.  A scheme without steps is a strapdown (never-rotating)
IMU.

A turn about a body-fixed axis ``u`` from attitude ``C0`` is exact: ``C(t) = C0 R(u, w t)`` and the
IMU's rate relative to the base is ``w u`` in the body.  A turn about a base axis ``n`` is the same
turn with ``u = C0^T n`` (``R(n, a) C0 = C0 R(C0^T n, a)``).  The pieces of a run are the package's one
description of motion, :class:`sim.motion.MotionPiece` (constant-rate turns and still pieces).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from ...core import units
from ...core.errors import InputError, shown
from ...core.files import safe_stem
from ...core.orientation import OrientationError, orientation_to_dcm
from ...core.toml import array_table_lines
from ...sim.motion import MotionPiece
from . import shipped

#: The ``format`` key of a scheme file.
FORMAT = "casadi-sins-scheme/1"
BODY_AXES = {"x": 0, "y": 1, "z": 2}
BASE_AXES = {"E": 0, "N": 1, "U": 2}
STEP_KEYS = {"axis", "angle_deg", "rate_deg_s", "dwell_s"}
SCHEME_KEYS = {"format", "name", "description", "reference", "start", "initial_dwell_s", "step", "note"}
#: A scheme "returns to its start" when its period's attitude change is below this angle (rad).
CLOSURE_TOL = 1e-9
#: Largest turn of one step, deg (ten revolutions): a larger one is a typing error, and costly.
MAX_TURN_DEG = 3600.0
#: Most pieces (turns and dwells) a run may be cut into: memory and time stay bounded.
MAX_PIECES = 500_000


@dataclasses.dataclass(frozen=True)
class Step:
    """One step of a scheme (SI).

    Attributes
    ----------
    axis : str
        ``"x"``, ``"y"``, ``"z"`` (IMU axes) or ``"E"``, ``"N"``, ``"U"`` (base axes).
    angle : float
        Signed turn, rad.
    rate : float
        Turn rate, rad/s, > 0.
    dwell : float
        Still time after the turn, s (0 only when omitted: a turn straight into the next).
    """

    axis: str
    angle: float
    rate: float
    dwell: float

    @property
    def turn_s(self) -> float:
        """Length of the turn, s."""
        return abs(self.angle) / self.rate


@dataclasses.dataclass(frozen=True)
class Scheme:
    """A rotation scheme: one period of steps from a start attitude.

    Attributes
    ----------
    name : str
        A safe file stem (names the plots).
    steps : tuple of Step
    start : ndarray (3, 3)
        ``C_b^n`` at time zero.
    initial_dwell : float
        Still time before the first period, s.
    description, source : str
        The file's description, and where the scheme came from (a path, or ``NAME (shipped)``).
    """

    name: str
    steps: tuple[Step, ...]
    start: np.ndarray
    initial_dwell: float = 0.0
    description: str = ""
    source: str = ""

    @property
    def period(self) -> float:
        """Length of one period of the steps, s (inf for a strapdown scheme)."""
        return sum(s.turn_s + s.dwell for s in self.steps) if self.steps else math.inf


def still(t0: float, duration: float, attitude: np.ndarray) -> MotionPiece:
    """A still piece of ``duration`` s at ``C_b^n`` from ``t0``."""
    return MotionPiece(t0, t0 + duration, attitude)


def turn(t0: float, duration: float, attitude: np.ndarray, axis: np.ndarray, rate: float) -> MotionPiece:
    """A turn from ``C_b^n`` about the body axis ``axis`` at the constant signed ``rate`` (rad/s) for ``duration``."""
    return MotionPiece(t0, t0 + duration, attitude, axis, rate * duration, "constant")


def _number(value, what: str, where: tuple, positive: bool) -> float:
    """A finite number of a scheme file (``where`` = (path, prefix, line))."""
    path, prefix, line = where
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(path, f"{prefix}{what} must be a number, not {shown(value)}", line=line)
    value = float(value)
    if not math.isfinite(value):
        raise InputError(path, f"{prefix}{what} is not finite ({value})", line=line)
    if positive and value <= 0.0:
        raise InputError(path, f"{prefix}{what} must be > 0 (got {value:g})", line=line)
    return value


def parse_step(raw, where: tuple) -> Step:
    """One ``[[step]]`` table -> :class:`Step` (SI); ``where`` is ``(path, "step K: ", line)``."""
    path, prefix, line = where
    if not isinstance(raw, dict):
        raise InputError(path, f"{prefix}a step must be a table with axis, angle_deg, rate_deg_s[, dwell_s]",
                         line=line)
    unknown = set(raw) - STEP_KEYS
    if unknown:
        raise InputError(path, f"{prefix}unknown key(s) {shown(', '.join(sorted(unknown)))}; a step has "
                         f"{', '.join(sorted(STEP_KEYS))}", line=line)
    for key in ("axis", "angle_deg", "rate_deg_s"):
        if key not in raw:
            raise InputError(path, f"{prefix}missing {key}", line=line)
    axis = raw["axis"]
    if not isinstance(axis, str) or (axis.lower() not in BODY_AXES and axis.upper() not in BASE_AXES):
        raise InputError(path, f"{prefix}unknown axis {shown(axis)}; use x, y, z (IMU axes) or E, N, U (base axes)",
                         line=line)
    axis = axis.lower() if axis.lower() in BODY_AXES else axis.upper()
    angle_deg = _number(raw["angle_deg"], "angle_deg", where, positive=False)
    if abs(angle_deg) > MAX_TURN_DEG:
        raise InputError(path, f"{prefix}angle_deg {angle_deg:g} is more than {MAX_TURN_DEG:g} deg "
                         "(ten revolutions) in one turn", line=line)
    rate = _number(raw["rate_deg_s"], "rate_deg_s", where, positive=True) * units.DEG
    dwell = _number(raw["dwell_s"], "dwell_s", where, positive=True) if "dwell_s" in raw else 0.0
    if angle_deg == 0.0 and dwell == 0.0:
        raise InputError(path, f"{prefix}a step that neither turns nor dwells", line=line)
    return Step(axis, angle_deg * units.DEG, rate, dwell)


def parse_scheme(data: dict, source: str = "<scheme>", step_lines: list[int] | None = None) -> Scheme:
    """A scheme from its TOML table (see the module docstring); ``format`` is not required here.

    Parameters
    ----------
    data : dict
    source : str
        The file (or a label) named by the messages and kept as :attr:`Scheme.source`.
    step_lines : list of int, optional
        1-based line of each ``[[step]]`` header, for the messages.

    Raises
    ------
    InputError
        Naming ``source``, the step and its line.
    """
    unknown = set(data) - SCHEME_KEYS
    if unknown:
        raise InputError(source, f"unknown key(s) {shown(', '.join(sorted(unknown)))}")
    raw_steps = data.get("step", [])
    if not isinstance(raw_steps, list):
        raise InputError(source, "'step' must be an array of tables ([[step]])")
    lines = step_lines or []
    steps = tuple(parse_step(raw, (source, f"step {k + 1}: ", lines[k] if k < len(lines) else None))
                  for k, raw in enumerate(raw_steps))
    initial = data.get("initial_dwell_s", 0.0)
    initial = 0.0 if initial == 0 else _number(initial, "initial_dwell_s", (source, "", None), positive=True)
    try:
        start = orientation_to_dcm(data.get("start", "ENU"))
    except OrientationError as exc:
        raise InputError(source, f"start: {exc}") from None
    name = data.get("name", Path(source).stem)
    description = data.get("description", "")
    if not isinstance(name, str) or not isinstance(description, str):
        raise InputError(source, "name and description must be strings")
    return Scheme(safe_stem(name), steps, start, initial, description, source)


def load_scheme(name_or_path) -> Scheme:
    """A scheme file, or the name of a shipped one (``casadi_sins/problems/schemes/NAME.toml``).

    Raises
    ------
    InputError
        Naming the file (and the step and line) at fault, or listing the shipped schemes.
    """
    data, text, path, origin = shipped.read_file(name_or_path, "schemes", "scheme", FORMAT, "scheme file")
    return dataclasses.replace(parse_scheme(data, str(path), array_table_lines(text, "step")), source=origin)


def body_axis(step: Step, attitude: np.ndarray) -> np.ndarray:
    """The step's rotation axis in the body at the start of its turn (unit vector)."""
    if step.axis in BODY_AXES:
        return np.eye(3)[BODY_AXES[step.axis]]
    return attitude.T @ np.eye(3)[BASE_AXES[step.axis]]


def period_pieces(scheme: Scheme, start: np.ndarray, t0: float = 0.0) -> list[MotionPiece]:
    """The pieces of one period from attitude ``start`` (turn, then dwell, per step)."""
    pieces, attitude, t = [], start, t0
    for step in scheme.steps:
        if step.angle != 0.0:
            piece = turn(t, step.turn_s, attitude, body_axis(step, attitude), math.copysign(step.rate, step.angle))
            pieces.append(piece)
            attitude, t = piece.end_attitude, piece.t1
        if step.dwell > 0.0:
            pieces.append(still(t, step.dwell, attitude))
            t += step.dwell
    return pieces


def closure_error(scheme: Scheme) -> float:
    """Angle (rad) between the attitude after one period and the start attitude (0: the scheme closes)."""
    if not scheme.steps:
        return 0.0
    end = period_pieces(scheme, scheme.start)[-1].end_attitude
    cos = np.clip((np.trace(scheme.start.T @ end) - 1.0) / 2.0, -1.0, 1.0)
    return float(np.arccos(cos)) if cos < 1.0 - 1e-12 else float(np.linalg.norm(end - scheme.start))


def piece_count(scheme: Scheme, duration: float, max_step_s: float = math.inf) -> float:
    """About how many pieces ``duration`` s of the scheme make, dwells cut every ``max_step_s`` s."""
    def cut(length: float) -> float:
        """Output pieces of one dwell."""
        return max(1.0, math.ceil(length / max_step_s)) if math.isfinite(max_step_s) else 1.0

    if not scheme.steps:
        return cut(duration)
    per_period = sum((s.angle != 0.0) + (cut(s.dwell) if s.dwell > 0 else 0) for s in scheme.steps)
    periods = max(duration - scheme.initial_dwell, 0.0) / scheme.period + 1.0
    return periods * per_period + cut(min(scheme.initial_dwell, duration))


def check_size(scheme: Scheme, duration: float, max_step_s: float = math.inf) -> None:
    """Refuse a run that would be cut into more than :data:`MAX_PIECES` pieces.

    Raises
    ------
    InputError
        Naming the scheme's file.
    """
    count = piece_count(scheme, duration, max_step_s)
    if not count <= MAX_PIECES:
        raise InputError(scheme.source or scheme.name, f"{duration / 3600:g} h of this scheme is about {count:.3g} "
                         f"pieces (turns, dwells and output steps), more than {MAX_PIECES}: its steps are too "
                         "short for so long a run (or the output step too small)")


def scheme_pieces(scheme: Scheme, duration: float) -> list[MotionPiece]:
    """All pieces over ``[0, duration]``: the initial dwell, then the period repeated, the last piece cut.

    A scheme that closes repeats the same attitudes exactly (no round-off creeps in over days); one that
    does not continues from where the last period ended.
    """
    check_size(scheme, duration)
    pieces: list[MotionPiece] = []
    t = 0.0
    if not scheme.steps:
        return [still(0.0, duration, scheme.start)]
    if scheme.initial_dwell > 0.0:
        pieces.append(still(0.0, min(scheme.initial_dwell, duration), scheme.start))
        t = pieces[-1].t1
    closes = closure_error(scheme) < CLOSURE_TOL
    template = period_pieces(scheme, scheme.start)
    attitude = scheme.start
    while t < duration - 1e-9:
        period = template if closes else period_pieces(scheme, attitude)
        offset = t - period[0].t0
        for piece in period:
            start = piece.t0 + offset
            if start >= duration - 1e-9:
                break
            moved = piece.shifted(offset)
            pieces.append(moved if moved.t1 <= duration else moved.part(moved.t0, duration))
        t = pieces[-1].t1
        attitude = period[-1].end_attitude
    return pieces
