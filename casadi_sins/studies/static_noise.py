"""``casadi-sins noise``: the noise of a unit from hours at rest, and the datasheet a calibration takes.

The recording (:mod:`noise.static_run`) is read once in bounded memory, every axis identified
(:mod:`noise.identify`) in pulses, and the result put in SI by the scale factors:

* ``params``: a parameter table (a calibration of the unit): its scale factors, ``|S_i|`` per axis (the
  misalignments, a few 1e-3, change a noise variance by their square: nothing);
* ``scale``: one pulse weight per sensor (rad/pulse, m/s/pulse), e.g. the nominal one of the unit's
  datasheet, for a unit not yet calibrated;
* neither: the noise stays in pulses, labelled so, and no datasheet is written (a datasheet is physics).

The products (:func:`noise_files`): ``noise.json`` and ``noise.md`` (:mod:`report.noise_identification`),
one Allan deviation plot per sensor triad, and with a scale ``datasheet.toml`` for ``calibrate --noise``.
"""

from __future__ import annotations

import dataclasses
import datetime
import math
import threading
import time
from pathlib import Path

import numpy as np

from ..core.errors import InputError
from ..core.files import file_sha256
from ..data.recording import PULSE_COLUMNS
from ..data.tables import SCALE_RANGE, read_table
from ..model.noise import SensorNoise
from ..model.registry import ACCEL_SCALE, GYRO_SCALE
from ..noise.identify import Identification, identify
from ..noise.static_run import StaticRun, read_rest, static_run
from ..noise.identify import CHECK_LIMIT, TAU_FRACTION

SENSORS = ("gyro", "accel")


@dataclasses.dataclass(frozen=True)
class Scale:
    """Pulse weights per axis (SI per pulse), and where they come from; ``factors`` None: pulses."""

    factors: np.ndarray | None
    source: str

    @property
    def si(self) -> bool:
        """Whether the noise is in SI."""
        return self.factors is not None


def scale_from(params: str | None = None, scale: tuple[float, float] | None = None) -> Scale:
    """The scale of the module docstring from ``--params`` or ``--scale`` (neither: pulses).

    Raises
    ------
    InputError
        Both given, or a pulse weight outside any sensor's.
    """
    if params is not None and scale is not None:
        raise InputError(None, "give the scale factors once: --params (a calibration's table) or --scale")
    if params is not None:
        table = read_table(params)
        values = np.abs(np.concatenate([table.values[GYRO_SCALE], table.values[ACCEL_SCALE]]))
        return Scale(values, f"scale factors of {params}")
    if scale is not None:
        low, high = SCALE_RANGE
        for value, what in zip(scale, ("gyro (rad/pulse)", "accelerometer (m/s/pulse)")):
            if not (math.isfinite(value) and low <= abs(value) <= high):
                raise InputError(None, f"--scale: the {what} pulse weight {value!r} is no sensor's "
                                 f"({low:g}..{high:g} SI per pulse)")
        return Scale(np.repeat(np.abs(np.asarray(scale, dtype=float)), 3), "--scale (nominal pulse weights)")
    return Scale(None, "none: the noise in pulses (give --params or --scale for SI and a datasheet)")


@dataclasses.dataclass
class NoiseStudy:
    """The noise identification of one recording at rest.

    Attributes
    ----------
    run : StaticRun
        The samples used.
    identification : Identification
        Every axis (``gyro_x`` .. ``accel_z``), in SI with a scale, else in pulses.
    scale : Scale
    samples : int
    integer : ndarray (6,) of bool
        Axes whose pulses were all whole numbers (counters: quantization one pulse / sqrt(12)).
    inputs : dict
        Input file -> SHA-256.
    created : str
        ISO date and time.
    seconds : float
        The computation's time.
    """

    run: StaticRun
    identification: Identification
    scale: Scale
    samples: int
    integer: np.ndarray
    inputs: dict
    created: str
    seconds: float

    def sensor(self, name: str) -> slice:
        """The axes of ``"gyro"`` or ``"accel"``."""
        return slice(0, 3) if name == "gyro" else slice(3, 6)

    def datasheet(self) -> tuple[SensorNoise, list[str]] | None:
        """The terms ``calibrate --noise`` takes (SI), with one comment per decision; None in pulses.

        Per axis: the white noise, and the quantization when every axis of the sensor has one fitted.  The
        datasheet has one bias instability per sensor: the root mean square of ``sigma`` over the axes where
        a Gauss-Markov term was detected, with the geometric mean of their correlation times (their
        maximum-likelihood values also where the record does not bound the time from above); none detected:
        left out (the calibration measures the wander itself), the bound stated.
        """
        if not self.scale.si:
            return None
        fits = self.identification.fits
        noise = SensorNoise(gyro_arw=np.array([f.white.value for f in fits[:3]]),
                            accel_vrw=np.array([f.white.value for f in fits[3:]]))
        notes = []
        for sensor in SENSORS:
            first = self.sensor(sensor).start
            axes = fits[self.sensor(sensor)]
            if all(f.quantization.kind == "fitted" for f in axes):
                setattr(noise, f"{sensor}_quantization", np.array([f.quantization.value for f in axes]))
            else:
                notes.append(f"{sensor} quantization left out: not seen on every axis (the calibration estimates "
                             "it, or knows a counter's)")
            detected = [first + i for i, f in enumerate(axes) if f.status != "not detected"]
            if detected:
                sigma = math.sqrt(np.mean([fits[i].terms.gm_sigma**2 for i in detected]))
                tau = math.exp(np.mean([math.log(fits[i].terms.gm_tau) for i in detected]))
                setattr(noise, f"{sensor}_bias_instability", sigma)
                setattr(noise, f"{sensor}_bias_tau", tau)
                weak = [PULSE_COLUMNS[i] for i in detected if fits[i].status != "determined"]
                notes.append(f"{sensor} bias instability: the Gauss-Markov sigma (RMS over "
                             f"{', '.join(PULSE_COLUMNS[i] for i in detected)}) and correlation time (geometric mean)"
                             + (f"; {', '.join(weak)}: the record does not bound the correlation time from above "
                                "(its maximum likelihood taken)" if weak else ""))
            else:
                notes.append(f"{sensor} bias instability left out: no Gauss-Markov term detected (the calibration "
                             "measures the wander itself)")
        return noise, notes


    def messages(self) -> tuple[list[str], list[str]]:
        """``(notes, warnings)``: what the record could not show, what the model misses."""
        from ..report.noise_identification import units_of
        notes, warnings = list(self.run.notes), []
        ident = self.identification
        reach = TAU_FRACTION * ident.duration
        if not self.scale.si:
            notes.append("no scale factors: the noise is in pulses and no datasheet is written; give --params (a "
                         "calibration's table) or --scale (nominal pulse weights) for SI")
        for axis, (name, fit) in enumerate(zip(ident.axes, ident.fits)):
            units = units_of(self, "gyro" if axis < 3 else "accel")
            size, unit = units.rate
            if fit.status == "tau beyond reach":
                notes.append(f"{name}: a Gauss-Markov bias is seen (2 ln LR {fit.likelihood_ratio:.1f}) but the "
                             f"{ident.duration:.0f} s record does not bound its correlation time from above: tau >= "
                             f"{fit.gm_tau.value:.3g} s, sigma >= {fit.gm_sigma.value / size:.3g} {unit} (it shows as a "
                             f"rate random walk of {fit.rate_random_walk / units.random_walk[0]:.3g} "
                             f"{units.random_walk[1]}); a record of five times the correlation time determines it")
            elif fit.status == "determined" and fit.gm_tau.value > reach:
                low = "below the range tried" if fit.gm_tau.low is None else f"{fit.gm_tau.low:.3g}"
                notes.append(f"{name}: the correlation time {fit.gm_tau.value:.3g} s is longer than a fifth of the "
                             f"record ({reach:.0f} s): weakly determined (95 % {low}-{fit.gm_tau.high:.3g} s)")
            elif fit.status == "not detected":
                notes.append(f"{name}: no Gauss-Markov bias seen; sigma < {fit.gm_sigma.value / size:.3g} {unit} (95 %) "
                             f"for any correlation time up to {reach:.0f} s (a fifth of the record)")
            if self.integer[axis]:
                pulse = (self.scale.factors[axis] if self.scale.si else 1.0) / math.sqrt(12.0)
                notes.append(f"{name}: integer pulses (a counter): its quantization is one pulse / sqrt(12) = "
                             f"{pulse / units.quantization[0]:.3g} {units.quantization[1]}")
            if not fit.check.passed:
                warnings.append(f"{name}: the periodogram departs from the fitted terms near "
                                f"{fit.check.frequency_hz:.3g} Hz ({fit.check.ratio:.3g} times the expected power, "
                                f"z = {fit.check.z:.1f}, limit {CHECK_LIMIT:g}): a term the model lacks (a flicker "
                                "floor, a vibration line, a drift); the fitted terms describe the rest")
        return notes, warnings


def run_noise(path: str | Path, rate_hz: float | None = None, segment: int | None = None,
              scale: Scale | None = None, progress=None, axis_progress=None) -> NoiseStudy:
    """Identify the noise of a recording at rest (module docstring).

    Parameters
    ----------
    path : str or Path
        A recording description (``.toml``) or a bare CSV (then ``rate_hz``).
    segment : int, optional
        The static segment of a description with several.
    scale : Scale, optional
        Default: pulses.
    progress, axis_progress : callable, optional
        ``(done, total)`` of the reading (bytes) and of the fits (axes).
    """
    started = time.perf_counter()
    scale = scale or scale_from()
    run = static_run(path, rate_hz, segment)
    hashes, stop = {}, threading.Event()

    def hash_inputs():  # beside the parsing, on the other core (hashlib lets go of the interpreter)
        for p in (run.description, run.data):
            if p is not None:
                hashes[str(p)] = file_sha256(p, stop.is_set)

    hashing = threading.Thread(target=hash_inputs, daemon=True)
    hashing.start()
    try:
        record = read_rest(run, progress)
        result = identify(record, PULSE_COLUMNS, axis_progress)
        hashing.join()
    finally:
        stop.set()
    if scale.si:
        result = result.scaled(scale.factors)
    inputs = {str(p): hashes.get(str(p)) or file_sha256(p) for p in (run.description, run.data) if p is not None}
    created = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
    return NoiseStudy(run, result, scale, record.samples, record.integer, inputs, created,
                      time.perf_counter() - started)


def noise_files(study: NoiseStudy, out: str | Path, plots: bool = True) -> dict:
    """``{path: bytes}`` of every product (module docstring), for :func:`core.files.write_files`."""
    from ..data.datasheet import datasheet_toml
    from ..report.noise_identification import allan_figure, noise_json, noise_markdown
    out = Path(out)
    files = {out / "noise.json": noise_json(study).encode("utf-8"), out / "noise.md": noise_markdown(study).encode("utf-8")}
    if plots:
        for sensor in SENSORS:
            files[out / f"allan-{sensor}.png"] = allan_figure(study, sensor)
    sheet = study.datasheet()
    if sheet is not None:
        noise, notes = sheet
        files[out / "datasheet.toml"] = datasheet_toml(noise, _datasheet_header(study) + notes).encode("utf-8")
    return files


def _datasheet_header(study: NoiseStudy) -> list[str]:
    return [f"noise of {study.run.label}: {study.identification.duration / 3600:.3g} h at rest, "
            f"{study.identification.rate_hz:g} Hz; scale: {study.scale.source}",
            f"written by casadi-sins noise on {study.created}"]
