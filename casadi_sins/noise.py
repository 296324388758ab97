"""Sensor noise: the model, its estimate from the raw pulses, and base motion.

The noise of each sensor axis is described by (SI inside, natural units at the edges):

``arw`` / ``vrw``
    white noise of the rate / specific force, as a density: angle random walk (rad/sqrt(s),
    reported in deg/sqrt(h)) and velocity random walk (m/s/sqrt(s), reported in ug/sqrt(Hz));
``quantization``
    white noise of the *accumulated* angle / velocity (rad, m/s): an integer pulse counter
    carries its remainder, so each increment errs by ``e_k - e_{k-1}`` (physics pitfall 8);
``bias_instability``, ``bias_tau``
    a first-order Gauss-Markov bias (steady-state 1 sigma, correlation time).

Raw estimate, independent of any fit (:func:`estimate_sensor_noise`): in every static segment the
increments are summed into blocks of ``m`` samples and third-differenced.  A bias, a slow drift and a
swaying base (periods of seconds) vanish in third differences of short blocks (pitfall 9); what is
left has the variance ``20 m s^2 + 70 s_e^2``: white noise (``s`` per sample) grows with the block,
quantization (``s_e``) does not.  A weighted line over ``m = 1, 2, 4, ...`` separates them.  Blocks
long enough for sway or drift to show are dropped (the line stops fitting).  Bias instability with
correlation times of minutes cannot be seen in segments of a minute or two: it comes from the
datasheet (:class:`SensorNoise` given by the user) or stays zero, which the report says.

Base motion (:func:`base_motion`): in a static segment the gyro-integrated angle, less its straight
line, wanders only by the angle random walk; a sway of the base shows as an excess at periods of
seconds.  Its variance enters the noise of the static gyro means.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .units import ARCSEC, DEG, DEG_PER_H, UG

#: Floors of noise terms the data do not determine (far below any real sensor): ARW (rad/sqrt(s)),
#: VRW (m/s/sqrt(s)).  They keep noise-free data from giving one kind of residual an absurd weight.
GYRO_ARW_FLOOR = 1e-6 * DEG / 60.0
ACCEL_VRW_FLOOR = 0.05 * UG
#: Block sizes (samples) tried by the raw estimate, and the longest block (s).
BLOCK_SIZES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
MAX_BLOCK_S = 3.0
#: A term of the raw estimate is "determined" when its relative standard error is below this.
DETERMINED = 0.25

ARW_UNIT = DEG / 60.0  # 1 deg/sqrt(h) in rad/sqrt(s)
VRW_UNIT = UG  # 1 ug/sqrt(Hz) in m/s/sqrt(s)


@dataclasses.dataclass
class SensorNoise:
    """Noise of the six sensor axes (SI; per axis arrays of 3).

    ``None`` in a field of a user specification means "estimate it".
    """

    gyro_arw: np.ndarray | None = None  # rad/sqrt(s)
    accel_vrw: np.ndarray | None = None  # m/s/sqrt(s)
    gyro_quantization: np.ndarray | None = None  # rad
    accel_quantization: np.ndarray | None = None  # m/s
    gyro_bias_instability: float | None = None  # rad/s
    gyro_bias_tau: float = 600.0  # s
    accel_bias_instability: float | None = None  # m/s^2
    accel_bias_tau: float = 900.0  # s
    # errors outside the sensor model, estimated from the fit when its checks fail (kalman module)
    unmodelled_acceleration: float = 0.0  # m/s^2, constant per static segment
    unmodelled_rate: float = 0.0  # rad/s, on each static gyro mean
    unmodelled_step: float = 0.0  # m/s, on each velocity step across a rotation

    FIELDS = ("gyro_arw", "accel_vrw", "gyro_quantization", "accel_quantization")

    def __post_init__(self):
        for name in self.FIELDS:
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy())

    def merged(self, other: "SensorNoise") -> "SensorNoise":
        """These values where given, ``other``'s elsewhere."""
        out = dataclasses.replace(other)
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if value is not None and not field.name.endswith("_tau"):
                setattr(out, field.name, value)
        if self.gyro_bias_instability is not None:
            out.gyro_bias_tau = self.gyro_bias_tau
        if self.accel_bias_instability is not None:
            out.accel_bias_tau = self.accel_bias_tau
        return out

    def natural(self) -> dict[str, object]:
        """The model in natural units: ARW deg/sqrt(h), VRW ug/sqrt(Hz), quantization arcsec and mm/s,
        bias instability deg/h and ug, correlation times s."""

        def conv(value, unit):
            return None if value is None else np.asarray(value) / unit

        return {"gyro_arw_deg_rth": conv(self.gyro_arw, ARW_UNIT),
                "accel_vrw_ug_rthz": conv(self.accel_vrw, VRW_UNIT),
                "gyro_quantization_arcsec": conv(self.gyro_quantization, ARCSEC),
                "accel_quantization_mm_s": conv(self.accel_quantization, 1e-3),
                "gyro_bias_instability_deg_h": conv(self.gyro_bias_instability, DEG_PER_H),
                "gyro_bias_tau_s": self.gyro_bias_tau,
                "accel_bias_instability_ug": conv(self.accel_bias_instability, UG),
                "accel_bias_tau_s": self.accel_bias_tau}

    @classmethod
    def from_natural(cls, values: dict) -> "SensorNoise":
        """From natural units (the keys of :meth:`natural`; missing keys: estimate)."""

        def get(key, unit):
            return None if values.get(key) is None else np.asarray(values[key], dtype=float) * unit

        gyro_bi, accel_bi = get("gyro_bias_instability_deg_h", DEG_PER_H), get("accel_bias_instability_ug", UG)
        return cls(get("gyro_arw_deg_rth", ARW_UNIT), get("accel_vrw_ug_rthz", VRW_UNIT),
                   get("gyro_quantization_arcsec", ARCSEC), get("accel_quantization_mm_s", 1e-3),
                   None if gyro_bi is None else float(gyro_bi), float(values.get("gyro_bias_tau_s", 600.0)),
                   None if accel_bi is None else float(accel_bi), float(values.get("accel_bias_tau_s", 900.0)))

    @classmethod
    def from_per_sample(cls, accel_noise_ug: float, gyro_noise_deg_h: float, dt: float) -> "SensorNoise":
        """White noise given the paper's way, 1 sigma per sample (ug, deg/h), as densities."""
        return cls(gyro_arw=gyro_noise_deg_h * DEG_PER_H * math.sqrt(dt),
                   accel_vrw=accel_noise_ug * UG * math.sqrt(dt))

    @classmethod
    def from_deviations(cls, dev, dt: float, pulse_gyro=None, pulse_accel=None) -> "SensorNoise":
        """The noise a problem file simulates (:class:`problem.Deviations`); integer pulses of the given
        sizes (rad, m/s) add a uniform remainder (``pulse / sqrt(12)``)."""
        quantized = getattr(dev, "quantize", False) and pulse_gyro is not None
        return cls(gyro_arw=math.hypot(dev.gyro_noise_deg_h * DEG_PER_H * math.sqrt(dt), dev.gyro_arw_deg_rth * ARW_UNIT),
                   accel_vrw=math.hypot(dev.accel_noise_ug * UG * math.sqrt(dt), dev.accel_vrw_ug_rthz * VRW_UNIT),
                   gyro_quantization=np.asarray(pulse_gyro) / math.sqrt(12.0) if quantized else 0.0,
                   accel_quantization=np.asarray(pulse_accel) / math.sqrt(12.0) if quantized else 0.0,
                   gyro_bias_instability=dev.gyro_bias_instability_deg_h * DEG_PER_H, gyro_bias_tau=dev.gyro_bias_tau_s,
                   accel_bias_instability=dev.accel_bias_instability_ug * UG, accel_bias_tau=dev.accel_bias_tau_s)

    def complete(self) -> "SensorNoise":
        """Zeros for the terms still unknown."""
        out = dataclasses.replace(self)
        for name in self.FIELDS:
            if getattr(out, name) is None:
                setattr(out, name, np.zeros(3))
        out.gyro_bias_instability = out.gyro_bias_instability or 0.0
        out.accel_bias_instability = out.accel_bias_instability or 0.0
        return out


NOISE_KEYS = ("gyro_arw_deg_rth", "accel_vrw_ug_rthz", "gyro_quantization_arcsec", "accel_quantization_mm_s",
              "gyro_bias_instability_deg_h", "gyro_bias_tau_s", "accel_bias_instability_ug", "accel_bias_tau_s")


class NoiseSpecError(ValueError):
    """A sensor-noise specification that cannot be used; the message names the file and key."""


def read_noise_spec(path) -> SensorNoise:
    """A sensor datasheet as TOML, natural units (any subset of :data:`NOISE_KEYS`; the rest is estimated)::

        gyro_arw_deg_rth = 0.002
        accel_vrw_ug_rthz = 15
        gyro_bias_instability_deg_h = 0.002
        gyro_bias_tau_s = 600
    """
    import tomllib
    from pathlib import Path

    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise NoiseSpecError(f"{path}: no such noise specification") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise NoiseSpecError(f"{path}: not a readable TOML noise specification ({exc})") from None
    doc = doc.get("noise", doc)
    unknown = sorted(set(doc) - set(NOISE_KEYS))
    if unknown:
        raise NoiseSpecError(f"{path}: unknown key(s) {', '.join(unknown)}; known: {', '.join(NOISE_KEYS)}")
    for key, value in doc.items():
        values = value if isinstance(value, list) else [value]
        if (len(values) not in (1, 3) or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in values)
                or not all(math.isfinite(v) and v >= 0 for v in values)
                or (key.endswith("_tau_s") and min(values) <= 0) or (len(values) == 3 and "bias" in key)):
            raise NoiseSpecError(f"{path}: {key} must be a non-negative number (or 3 for the white and "
                                 f"quantization terms), found {value!r}")
    return SensorNoise.from_natural(doc)


# --------------------------------------------------------------------------- raw estimate
@dataclasses.dataclass
class TermEstimate:
    """One noise term of one sensor axis from the raw data."""

    value: float  # SI
    standard_error: float  # SI (of the value)

    @property
    def determined(self) -> bool:
        return self.standard_error <= DETERMINED * max(self.value, 1e-300)

    @property
    def upper_bound(self) -> float:
        return self.value + 2.0 * self.standard_error


@dataclasses.dataclass
class RawNoise:
    """The raw-data estimate: per sensor (``"gyro"``, ``"accel"``) and axis, white and quantization terms."""

    white: dict[str, list[TermEstimate]]  # density, rad/sqrt(s) or m/s/sqrt(s)
    quantization: dict[str, list[TermEstimate]]  # rad or m/s
    blocks: dict[str, np.ndarray]  # block sizes used per sensor
    samples: int

    def model(self) -> SensorNoise:
        """Determined terms as a :class:`SensorNoise`; undetermined ones left ``None``."""

        def pick(terms):
            return None if not all(t.determined or t.value == 0.0 for t in terms) else np.array([t.value for t in terms])

        return SensorNoise(gyro_arw=pick(self.white["gyro"]), accel_vrw=pick(self.white["accel"]),
                           gyro_quantization=self._quantization("gyro"),
                           accel_quantization=self._quantization("accel"))

    def _quantization(self, sensor: str) -> np.ndarray:
        # the quantization term is bounded well either way: its estimate (or zero) is the model
        return np.array([max(t.value, 0.0) for t in self.quantization[sensor]])

    def upper_bounds(self) -> SensorNoise:
        return SensorNoise(gyro_arw=np.array([t.upper_bound for t in self.white["gyro"]]),
                           accel_vrw=np.array([t.upper_bound for t in self.white["accel"]]),
                           gyro_quantization=self._quantization("gyro"),
                           accel_quantization=self._quantization("accel"))


def third_difference_variances(increments: list[np.ndarray], blocks) -> tuple[np.ndarray, np.ndarray]:
    """Mean square of third differences of block sums, per block size and axis, pooled over segments.

    Returns ``(variance (len(blocks), 3), count (len(blocks),))``.
    """
    variance = np.zeros((len(blocks), 3))
    count = np.zeros(len(blocks))
    for b, m in enumerate(blocks):
        total = np.zeros(3)
        n_total = 0
        for x in increments:
            n = len(x) // m
            if n < 8:
                continue
            sums = x[: n * m].reshape(n, m, 3).sum(axis=1)
            d3 = np.diff(sums, n=3, axis=0)
            total += np.sum(d3**2, axis=0)
            n_total += len(d3)
        if n_total:
            variance[b] = total / n_total
            count[b] = n_total
    return variance, count


def _fit_line(m: np.ndarray, v: np.ndarray, count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least squares ``v = slope m + intercept`` (both >= 0); returns values and standard errors."""
    if not np.any(v > 0):  # noise-free data
        return np.zeros(2), np.zeros(2)
    # third differences of neighbouring blocks are correlated: about a third as many independent values
    weights = (count / 3.0) / (2.0 * np.maximum(v, 1e-12 * v.max()) ** 2)
    design = np.column_stack([m, np.ones_like(m)])
    for free in ([0, 1], [0], [1]):
        a = design[:, free]
        info = a.T @ (a * weights[:, None])
        root = np.sqrt(weights)
        coef = np.linalg.lstsq(a * root[:, None], v * root, rcond=None)[0]
        if np.linalg.cond(info) > 1e12:
            info = info + np.eye(len(free)) * 1e-12 * np.trace(info)
        if np.all(coef >= 0):
            out, err = np.zeros(2), np.zeros(2)
            out[free] = coef
            # a misfit beyond the sampling error (e.g. the sawtooth of coarse pulses, not white) widens the errors
            dof = len(v) - len(free)
            misfit = float(np.sum(weights * (v - a @ coef) ** 2) / dof) if dof > 0 else 1.0
            err[free] = np.sqrt(np.diag(np.linalg.inv(info)) * max(misfit, 1.0))
            unfit = [i for i in (0, 1) if i not in free]
            for i in unfit:  # a term pinned at zero: its bound from the other fit
                err[i] = np.sqrt(1.0 / np.sum(weights * design[:, i] ** 2))
            return out, err
    return np.zeros(2), np.sqrt(1.0 / np.array([np.sum(weights * m**2), np.sum(weights)]))


def estimate_sensor_noise(rec, params) -> RawNoise:
    """Noise of every sensor axis from the static segments' raw pulses (see the module docstring).

    ``params`` only sets the pulse sizes (the scale factors); nothing is fitted.
    """
    from .strapdown import compensated_increments

    segments = [rec.segment_samples(s) for s in rec.static_segments]
    dtheta, dv = zip(*(compensated_increments(rec, params, sl) for sl in segments)) if segments else ((), ())
    white, quant, used = {}, {}, {}
    max_block = max(1, int(MAX_BLOCK_S * rec.rate_hz))
    for sensor, increments in (("gyro", list(dtheta)), ("accel", list(dv))):
        blocks = np.array([m for m in BLOCK_SIZES if m <= max_block], dtype=float)
        var, count = third_difference_variances(increments, blocks.astype(int))
        ok = count > 0
        blocks, var, count = blocks[ok], var[ok], count[ok]
        per_axis_white, per_axis_quant = [], []
        for axis in range(3):
            keep = np.ones(len(blocks), bool)
            # drop the longest blocks while they lie far above the line (sway, drift)
            while keep.sum() > 3:
                coef, err = _fit_line(blocks[keep], var[keep, axis], count[keep])
                last = np.flatnonzero(keep)[-1]
                predicted = coef[0] * blocks[last] + coef[1]
                spread = var[last, axis] * np.sqrt(6.0 / max(count[last], 1.0))
                if var[last, axis] - predicted <= 4.0 * spread:
                    break
                keep[last] = False
            coef, err = _fit_line(blocks[keep], var[keep, axis], count[keep])
            # V = 20 m s^2 + 70 s_e^2 -> density s / sqrt(dt), quantization s_e
            s2, s2_err = coef[0] / 20.0, err[0] / 20.0
            e2, e2_err = coef[1] / 70.0, err[1] / 70.0
            density = math.sqrt(s2 / rec.dt)
            density_err = (s2_err / (2.0 * math.sqrt(s2)) if s2 > 0 else math.sqrt(s2_err)) / math.sqrt(rec.dt)
            per_axis_white.append(TermEstimate(density, density_err))
            per_axis_quant.append(TermEstimate(math.sqrt(e2), e2_err / (2.0 * math.sqrt(e2)) if e2 > 0
                                               else math.sqrt(e2_err)))
        white[sensor], quant[sensor], used[sensor] = per_axis_white, per_axis_quant, blocks
    return RawNoise(white, quant, used, sum(sl.stop - sl.start for sl in segments))


def allan_deviation(rates: list[np.ndarray], dt: float, max_fraction: float = 1.0 / 3.0):
    """Overlapping Allan deviation of rate samples (list of (n, 3) segments), pooled over segments.

    Returns ``(tau (K,), adev (K, 3))`` for octave-spaced cluster times up to ``max_fraction`` of the
    shortest usable segment.
    """
    longest = max((len(r) for r in rates), default=0)
    taus = []
    m = 1
    while m <= longest * max_fraction:
        taus.append(m)
        m *= 2
    out = np.full((len(taus), 3), np.nan)
    for k, m in enumerate(taus):
        total, count = np.zeros(3), 0
        for r in rates:
            if len(r) < 3 * m:
                continue
            theta = np.concatenate([np.zeros((1, 3)), np.cumsum(r, axis=0) * dt])
            d = theta[2 * m:] - 2.0 * theta[m:-m] + theta[: -2 * m]
            total += np.sum(d**2, axis=0)
            count += len(d)
        if count:
            out[k] = np.sqrt(total / count / 2.0) / (m * dt)
    return np.array(taus) * dt, out


# --------------------------------------------------------------------------- base motion
#: Window lengths (s) at which the wander of the gyro angle is compared with its noise.
SWAY_WINDOWS_S = (0.5, 1.0, 2.0, 4.0, 8.0, 16.0)
#: A sway is reported when its variance is this many standard errors above zero and adds at least
#: this fraction to the noise variance of a static gyro mean.
SWAY_SIGNIFICANCE = 6.0
SWAY_RELEVANCE = 0.1


@dataclasses.dataclass
class SegmentMotion:
    segment: int  # segment number
    variance: np.ndarray  # (3,) variance of the base angle about each body axis, rad^2
    amplitude_arcsec: float  # largest axis, sqrt(2 variance): the amplitude of a sinusoid
    period_s: float  # dominant period (from zero crossings of the largest axis), nan when unknown
    significant: bool
    gyro_mean_variance: np.ndarray  # (3,) variance it adds to the segment's mean gyro rate, (rad/s)^2


def base_motion(rec, params, noise: SensorNoise) -> list[SegmentMotion]:
    """Angular motion of the base in every static segment, beyond the gyro noise.

    The gyro angle over windows of ``w`` seconds changes by ``mean rate x w`` plus noise of variance
    ``arw^2 w + 2 q^2``; a sway of variance ``V`` adds up to ``2 V``.  The excess over the noise, at
    the window where it is largest, estimates ``2 V``; ``V`` adds ``2 V / T^2`` to the variance of the
    segment's mean rate (the angle at both ends of a segment of ``T`` seconds).
    """
    from .strapdown import compensated_increments

    model = noise.complete()
    out = []
    for seg in rec.static_segments:
        sl = rec.segment_samples(seg)
        dtheta, _ = compensated_increments(rec, params, sl)
        n = len(dtheta)
        duration = n * rec.dt
        theta = np.concatenate([np.zeros((1, 3)), np.cumsum(dtheta - dtheta.mean(axis=0), axis=0)])
        best = np.zeros(3)
        best_z = np.zeros(3)
        for window in SWAY_WINDOWS_S:
            m = int(round(window * rec.rate_hz))
            if m < 1 or n < 4 * m:
                continue
            d = theta[m:] - theta[:-m]
            observed = np.mean(d**2, axis=0)
            expected = model.gyro_arw**2 * m * rec.dt + 2.0 * model.gyro_quantization**2
            independent = max(n / m, 1.0)
            excess = observed - expected
            z = excess / (np.maximum(expected, 1e-300) * np.sqrt(2.0 / independent))  # under "no sway"
            better = excess > best
            best = np.where(better, excess, best)
            best_z = np.where(better, z, best_z)
        variance = np.maximum(best, 0.0) / 2.0
        gyro_mean_var = 2.0 * variance / duration**2
        noise_var = (model.gyro_arw**2 * duration + 2.0 * model.gyro_quantization**2) / duration**2
        significant = bool(np.any((best_z > SWAY_SIGNIFICANCE) & (gyro_mean_var > SWAY_RELEVANCE * noise_var)))
        axis = int(np.argmax(variance))
        wander = theta[:, axis] - np.linspace(theta[0, axis], theta[-1, axis], n + 1)
        crossings = np.count_nonzero(np.diff(np.signbit(wander - wander.mean())))
        period = 2.0 * duration / crossings if crossings >= 4 else float("nan")
        out.append(SegmentMotion(seg.number, variance, math.sqrt(2.0 * variance[axis]) / ARCSEC, period,
                                 significant, gyro_mean_var))
    return out


def describe_motion(motions: list[SegmentMotion]) -> str | None:
    """One sentence about a swaying base (``None`` when the base was still)."""
    moving = [m for m in motions if m.significant]
    if not moving:
        return None
    amp = max(m.amplitude_arcsec for m in moving)
    periods = [m.period_s for m in moving if np.isfinite(m.period_s)]
    period = f", periods around {np.median(periods):.3g} s" if periods else ""
    return (f"the base moved (sway) in {len(moving)} of {len(motions)} static segments: up to "
            f"{amp:.3g} arcsec{period} (segments {', '.join(str(m.segment) for m in moving[:8])}"
            f"{', ...' if len(moving) > 8 else ''})")


def natural_noise_frame(models: dict[str, SensorNoise]):
    """A table of noise models side by side (rows: term and axis; columns: the models)."""
    import pandas as pd

    rows = []
    for term, key, unit in (("gyro angle random walk", "gyro_arw_deg_rth", "deg/sqrt(h)"),
                            ("accel velocity random walk", "accel_vrw_ug_rthz", "ug/sqrt(Hz)"),
                            ("gyro quantization", "gyro_quantization_arcsec", "arcsec"),
                            ("accel quantization", "accel_quantization_mm_s", "mm/s"),
                            ("gyro bias instability", "gyro_bias_instability_deg_h", "deg/h"),
                            ("accel bias instability", "accel_bias_instability_ug", "ug")):
        axes = ("x", "y", "z") if "bias" not in key else ("",)
        for k, axis in enumerate(axes):
            row = {"term": term, "axis": axis, "unit": unit}
            for label, model in models.items():
                value = model.natural()[key]
                row[label] = np.nan if value is None else float(np.atleast_1d(value)[k if axis else 0])
            rows.append(row)
    return pd.DataFrame(rows)


# --------------------------------------------------------------------------- the model in use
@dataclasses.dataclass
class NoisePlan:
    """The noise model of a calibration and where each term came from."""

    raw: RawNoise
    given: SensorNoise  # datasheet terms (None where not given)
    model: SensorNoise  # in use: given, else raw where determined, else fitted
    source: dict[str, str]  # term -> "datasheet" | "raw data" | "fit" | "not modelled"
    motions: list

    def free_terms(self) -> dict[str, list[str]]:
        """Terms the fit must set, by residual kind they show in most."""
        return {"velocity": [t for t in ("accel_vrw",) if self.source[t] == "fit"],
                "gyro": [t for t in ("gyro_arw",) if self.source[t] == "fit"]}


def plan_noise(rec, reference: np.ndarray, given: SensorNoise | None = None) -> NoisePlan:
    """Raw-data noise estimate, merged with a datasheet; base motion."""
    raw = estimate_sensor_noise(rec, reference)
    given = given or SensorNoise()
    determined = raw.model()
    bounds = raw.upper_bounds()
    model = SensorNoise(
        gyro_arw=_first(given.gyro_arw, determined.gyro_arw, np.maximum(bounds.gyro_arw, GYRO_ARW_FLOOR)),
        accel_vrw=_first(given.accel_vrw, determined.accel_vrw, np.maximum(bounds.accel_vrw, ACCEL_VRW_FLOOR)),
        gyro_quantization=_first(given.gyro_quantization, determined.gyro_quantization),
        accel_quantization=_first(given.accel_quantization, determined.accel_quantization),
        gyro_bias_instability=given.gyro_bias_instability or 0.0, gyro_bias_tau=given.gyro_bias_tau,
        accel_bias_instability=given.accel_bias_instability or 0.0, accel_bias_tau=given.accel_bias_tau)
    model.gyro_arw = np.maximum(model.gyro_arw, GYRO_ARW_FLOOR)
    model.accel_vrw = np.maximum(model.accel_vrw, ACCEL_VRW_FLOOR)

    def source(given_value, determined_value):
        return "datasheet" if given_value is not None else ("raw data" if determined_value is not None else "fit")

    sources = {"gyro_arw": source(given.gyro_arw, determined.gyro_arw),
               "accel_vrw": source(given.accel_vrw, determined.accel_vrw),
               "gyro_quantization": "datasheet" if given.gyro_quantization is not None else "raw data",
               "accel_quantization": "datasheet" if given.accel_quantization is not None else "raw data",
               "gyro_bias_instability": "datasheet" if given.gyro_bias_instability is not None else "not modelled",
               "accel_bias_instability": "datasheet" if given.accel_bias_instability is not None else "not modelled"}
    motions = base_motion(rec, reference, model)
    return NoisePlan(raw, given, model, sources, motions)


def _first(*values):
    for value in values:
        if value is not None:
            return np.asarray(value, dtype=float).copy()
    return None
