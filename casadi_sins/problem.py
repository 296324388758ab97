"""Problem files: an experiment to simulate (schedule, timing, site, truth, deviations).

A problem file is TOML (``format = "casadi-sins-problem/1"``)::

    name = "kang2013"
    [site]      latitude_deg, height_m, optional gravity_mps2
    [imu]       rate_hz
    [timing]    static_s, rotation_s, optional first_static_s, gap_s, rate_profile
    [[groups]]  start = "NUE", rotations = ["+Z", "-Y 180", ...] (axis, optional angle),
                optional angle_deg = 90 (the default angle), statics_s = [...] (each static's duration)
    [errors]    start_attitude_deg, rotation_rate_factor, cross_axis_rate,
                accel_noise_ug, gyro_noise_deg_h, quantize
    [truth]     parameter = value (table unit) or {value = ..., unit = "deg/pulse"}; the 21, and any
                extra group in full (accel_quadratic_*, accel_x/y_lever_*, accel_time_offset)

Recordings made from it follow ``recording-format.md``; everything about the
problem that is not in that format (truth, deviations) stays here.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from importlib import resources
from pathlib import Path


from . import frames
from . import parameters as P
from .recording import Segment, Site
from .units import TO_SI

FORMAT = "casadi-sins-problem/1"
PROFILES = ("half-sine", "versine")


class ProblemError(ValueError):
    """A problem file that cannot be used; the message names the file and key."""


@dataclasses.dataclass(frozen=True)
class GroupPlan:
    """One group: its start orientation, the rotations (an axis, or ``"axis angle"`` such as ``"-Y 180"``),
    the default angle, and optionally each static segment's duration (one more than the rotations)."""

    start: str
    rotations: tuple[str, ...]
    angle_deg: float = 90.0
    statics_s: tuple[float, ...] | None = None

    def turns(self) -> list[tuple[str, float]]:
        """``(axis, angle_deg)`` of each rotation."""
        out = []
        for entry in self.rotations:
            parts = entry.split()
            out.append((parts[0], float(parts[1]) if len(parts) > 1 else self.angle_deg))
        return out


@dataclasses.dataclass(frozen=True)
class Timing:
    static_s: float = 100.0
    rotation_s: float = 10.0
    first_static_s: float | None = None
    gap_s: float = 0.0
    rate_profile: str = "half-sine"


@dataclasses.dataclass(frozen=True)
class Deviations:
    """How the simulated experiment departs from nominal, and the sensor noise.

    White noise may be given per sample (``accel_noise_ug``, ``gyro_noise_deg_h``, the paper's way)
    or as a density (``accel_vrw_ug_rthz``, ``gyro_arw_deg_rth``); both add.  Bias instability is a
    first-order Gauss-Markov process per axis (steady-state 1 sigma, correlation time).  Sway turns
    the whole base about the unit's centre: per ENU axis ``sway_components`` sinusoids with
    amplitudes uniform in ``sway_amplitude_arcsec`` and periods log-uniform in ``sway_period_s``.
    """

    start_attitude_deg: float = 0.4  # each start attitude angle off nominal by +/- this (random sign)
    rotation_rate_factor: float = 0.004  # rotation rate scaled by U(1 - r, 1 + r)
    cross_axis_rate: float = 0.004  # the two other body axes turn at this fraction of the rate
    accel_noise_ug: float = 50.0  # white, per sample, 1 sigma
    gyro_noise_deg_h: float = 0.01  # white, per sample, 1 sigma
    accel_vrw_ug_rthz: float = 0.0  # white, velocity random walk density, ug/sqrt(Hz)
    gyro_arw_deg_rth: float = 0.0  # white, angle random walk density, deg/sqrt(h)
    accel_bias_instability_ug: float = 0.0  # Gauss-Markov, steady-state 1 sigma
    accel_bias_tau_s: float = 900.0
    gyro_bias_instability_deg_h: float = 0.0
    gyro_bias_tau_s: float = 600.0
    sway_amplitude_arcsec: tuple[float, float] = (0.0, 0.0)
    sway_period_s: tuple[float, float] = (2.0, 20.0)
    sway_components: int = 2
    quantize: bool = False  # integer pulses, remainder carried

    @property
    def sways(self) -> bool:
        return max(self.sway_amplitude_arcsec) > 0.0


@dataclasses.dataclass(frozen=True)
class Problem:
    name: str
    site: Site
    rate_hz: float
    groups: tuple[GroupPlan, ...]
    timing: Timing
    deviations: Deviations
    truth: P.ParameterSet
    source: Path | None = None
    description: str = ""

    def with_changes(self, **deviations) -> "Problem":
        """A copy with some deviation settings replaced (e.g. ``start_attitude_deg=5``)."""
        return dataclasses.replace(self, deviations=dataclasses.replace(self.deviations, **deviations))

    def segments(self) -> list[Segment]:
        """The nominal schedule as recording segments."""
        segs: list[Segment] = []
        t = 0.0
        for gi, plan in enumerate(self.groups, start=1):
            if gi > 1:
                t += self.timing.gap_s
            dcm = frames.orientation_to_dcm(plan.start)
            durations = plan.statics_s or ((self.timing.first_static_s or self.timing.static_s),) + \
                (self.timing.static_s,) * len(plan.rotations)
            segs.append(Segment(len(segs) + 1, gi, "static", t, t + durations[0], orientation=plan.start))
            t += durations[0]
            for (axis, angle), duration in zip(plan.turns(), durations[1:]):
                segs.append(Segment(len(segs) + 1, gi, "rotation", t, t + self.timing.rotation_s,
                                    axis=axis, angle_deg=angle))
                t += self.timing.rotation_s
                dcm = frames.rotate_body(dcm, axis, math.radians(angle))
                letters = frames.dcm_to_orientation(dcm, tol_deg=1e-6)
                segs.append(Segment(len(segs) + 1, gi, "static", t, t + duration, orientation=letters))
                t += duration
        return [dataclasses.replace(s, start=round(s.start, 9), end=round(s.end, 9)) for s in segs]

    @property
    def duration(self) -> float:
        return self.segments()[-1].end


def default_problem_path() -> Path:
    """The built-in default problem: the paper's experiment."""
    return Path(str(resources.files("casadi_sins.problems") / "kang2013.toml"))


def load_problem(path: str | Path | None = None) -> Problem:
    """Read a problem file (default: the paper's experiment)."""
    path = Path(path) if path is not None else default_problem_path()
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ProblemError(f"{path}: no such problem file") from None
    except IsADirectoryError:
        raise ProblemError(f"{path}: is a folder, not a problem file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ProblemError(f"{path}: cannot be read as a TOML problem file ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ProblemError(f"{path}: not valid TOML: {exc}") from None
    if doc.get("format") != FORMAT:
        raise ProblemError(f"{path}: format must be {FORMAT!r}, found {doc.get('format')!r}")

    def section(name: str) -> dict:
        value = doc.get(name, {})
        if not isinstance(value, dict):
            raise ProblemError(f"{path}: [{name}] must be a table")
        return value

    def number(table: dict, key: str, where: str, default=None) -> float:
        value = table.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ProblemError(f"{path}: [{where}] {key} must be a finite number, found {value!r}")
        return float(value)

    site_doc = section("site")
    gravity = site_doc.get("gravity_mps2")
    site = Site(math.radians(number(site_doc, "latitude_deg", "site")), number(site_doc, "height_m", "site", 0.0),
                None if gravity is None else number(site_doc, "gravity_mps2", "site"))
    rate_hz = number(section("imu"), "rate_hz", "imu")
    if rate_hz <= 0:
        raise ProblemError(f"{path}: [imu] rate_hz must be positive")

    timing_doc = section("timing")
    timing = Timing(
        static_s=number(timing_doc, "static_s", "timing", 100.0),
        rotation_s=number(timing_doc, "rotation_s", "timing", 10.0),
        first_static_s=(number(timing_doc, "first_static_s", "timing") if "first_static_s" in timing_doc else None),
        gap_s=number(timing_doc, "gap_s", "timing", 0.0),
        rate_profile=str(timing_doc.get("rate_profile", "half-sine")),
    )
    if timing.rate_profile not in PROFILES:
        raise ProblemError(f"{path}: [timing] rate_profile must be one of {', '.join(PROFILES)}")
    if min(timing.static_s, timing.rotation_s) <= 0 or timing.gap_s < 0:
        raise ProblemError(f"{path}: [timing] durations must be positive (gap_s may be 0)")

    groups = []
    for gi, item in enumerate(doc.get("groups", []), start=1):
        try:
            start = str(item["start"]).upper()
            frames.orientation_to_dcm(start)
            rotations = tuple(" ".join(str(a).upper().split()) for a in item.get("rotations", []))
            for entry in rotations:
                parts = entry.split()
                frames.parse_axis(parts[0])
                if len(parts) > 2 or (len(parts) == 2 and not math.isfinite(float(parts[1]))):
                    raise ValueError(entry)
        except (KeyError, TypeError, ValueError) as exc:
            raise ProblemError(f"{path}: [[groups]] {gi}: missing or invalid {exc} (rotations are \"+Z\" or "
                               "\"-Y 180\")") from None
        except frames.OrientationError as exc:
            raise ProblemError(f"{path}: [[groups]] {gi}: {exc}") from None
        statics = item.get("statics_s")
        if statics is not None:
            if not isinstance(statics, list) or len(statics) != len(rotations) + 1:
                raise ProblemError(f"{path}: [[groups]] {gi}: statics_s must list {len(rotations) + 1} durations")
            statics = tuple(number({"v": v}, "v", f"groups {gi} statics_s") for v in statics)
            if min(statics) <= 0:
                raise ProblemError(f"{path}: [[groups]] {gi}: statics_s must be positive")
        groups.append(GroupPlan(start, rotations, number(item, "angle_deg", f"groups {gi}", 90.0), statics))
    if not groups:
        raise ProblemError(f"{path}: no [[groups]]")

    err_doc = section("errors")
    known = {f.name for f in dataclasses.fields(Deviations)}
    unknown = set(err_doc) - known
    if unknown:
        raise ProblemError(f"{path}: [errors] unknown key(s) {', '.join(sorted(unknown))}")
    def deviation(key, value):
        if key == "quantize":
            if not isinstance(value, bool):
                raise ProblemError(f"{path}: [errors] quantize must be true or false")
            return value
        if key == "sway_components":
            count = number(err_doc, key, "errors")
            if count != int(count) or count < 1:
                raise ProblemError(f"{path}: [errors] sway_components must be a positive integer")
            return int(count)
        if key in ("sway_amplitude_arcsec", "sway_period_s"):
            pair = value if isinstance(value, list) else [value, value]
            if len(pair) != 2:
                raise ProblemError(f"{path}: [errors] {key} must be a number or [low, high]")
            low, high = (number({"v": v}, "v", f"errors {key}") for v in pair)
            if not 0.0 <= low <= high or (key == "sway_period_s" and low <= 0.0):
                raise ProblemError(f"{path}: [errors] {key} must be 0 <= low <= high (periods > 0)")
            return (low, high)
        result = number(err_doc, key, "errors")
        if result < 0.0 or (key.endswith("_tau_s") and result == 0.0):
            raise ProblemError(f"{path}: [errors] {key} must be positive")
        return result

    deviations = Deviations(**{k: deviation(k, v) for k, v in err_doc.items()})

    truth_doc = section("truth")
    values = {}
    for name, entry in truth_doc.items():
        if name not in P.ALL_NAMES:
            raise ProblemError(f"{path}: [truth] unknown parameter {name!r}")
        value, unit = (entry.get("value"), entry.get("unit")) if isinstance(entry, dict) else (entry, P.unit_of(name))
        if unit not in TO_SI:
            raise ProblemError(f"{path}: [truth] {name}: unknown unit {unit!r}")
        values[name] = number({"v": value}, "v", f"truth {name}") * TO_SI[unit]
    try:
        truth = P.ParameterSet.from_dict(values)
    except P.ParameterTableError as exc:
        raise ProblemError(f"{path}: [truth] {exc}") from None

    problem = Problem(name=str(doc.get("name", path.stem)), site=site, rate_hz=rate_hz, groups=tuple(groups),
                      timing=timing, deviations=deviations, truth=truth, source=path,
                      description=str(doc.get("description", "")))
    try:
        problem.segments()
    except frames.OrientationError as exc:
        raise ProblemError(f"{path}: a rotation angle leads off the letter orientations ({exc})") from None
    return problem
