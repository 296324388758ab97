"""Error budget of a calibrated unit: covariance propagation of static free-inertial navigation, by source.

The linear error model of free-inertial navigation on a static base (:class:`nav.errorstate.ErrorModel`: ENU,
vertical channel held; attitude error ``phi`` with ``C_hat = (I - [phi x]) C``), with the parameter errors
(the 21, then any extra groups) as constant states::

    phi'   = -w_ie x phi + d(w_ie)/dL dL + d(w_en)/dv dv - C (G_w x) - C w_g
    dv_h'  = (f^n x phi)_h - (2 w_ie x dv)_h + (C (G_f x))_h + (C w_a)_h
    dL'    = dv_N / R_M,      dlon' = dv_E / (R_N cos L)

with the sensor-error columns ``G_w``, ``G_f`` of :mod:`nav.errorinputs` (the 21's ``T_g w + eps``,
``T_a f + Delta`` of Kang et al. 2013, eqs. 5-12, and each extra group's own term), propagated by the one
propagator of :mod:`nav.propagation` (the rotation-modulation study's, with the unit still).  The state
starts from the alignment (eq. 14): its attitude error is the linearised alignment of the parameter errors
(eq. 15) plus the alignment's own noise.  Being linear, the covariance splits exactly into the contributions
of independent sources (Guan et al. 2023): each parameter group's residual error (from the calibration
covariance; correlations between groups are left out of the split but kept in the total), the alignment
noise, and the sensor noise during navigation.
"""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.earth import Site
from ..core.orientation import orientation_to_dcm
from ..core.units import DEG_PER_H, UG
from ..model.noise import SensorNoise
from ..model.registry import CORE_SPANS, GROUPS, NAMES, groups_in, relative_covariance
from ..nav.errorstate import N_NAV, PHI, ErrorModel
from ..nav.propagation import Propagation, output_pieces, propagate
from ..report.plots import legend_outside, pyplot, save_figure
from ..report.rounding import display, float_columns
from ..core.files import safe_stem, write_files
from ..report.tables import frame_files
from ..sim.motion import MotionPiece

#: Longest navigation time of a budget, h (six weeks: beyond, the linear model and the noise model are stretched,
#: and the propagation's one-minute steps add up to a long wait).
MAX_HOURS = 1000.0


@dataclasses.dataclass
class Budget:
    """1-sigma north and east position error over time, per source and in total."""

    time: np.ndarray  # s
    contributions: dict[str, np.ndarray]  # source -> (T, 2) 1-sigma north and east position error, m
    total: np.ndarray  # (T, 2) with the full parameter covariance, m

    def table(self, at_s: list[float]) -> pd.DataFrame:
        """The contributions at the given times, one row per source."""
        rows = []
        for source, sig in {**self.contributions, "total": self.total}.items():
            row = {"source": source}
            for t in at_s:
                k = int(np.argmin(np.abs(self.time - t)))
                row[f"north {t / 3600:g} h (m)"] = sig[k, 0]
                row[f"east {t / 3600:g} h (m)"] = sig[k, 1]
            rows.append(row)
        return pd.DataFrame(rows)


def static_propagation(model: ErrorModel, attitude: np.ndarray, gyro_arw: float, accel_vrw: float,
                       duration_s: float, step_s: float = 60.0) -> Propagation:
    """The propagation (:func:`nav.propagation.propagate`) of a unit still at ``C_b^n`` for ``duration_s``,
    outputs every ``step_s`` at most, white noise of densities ``gyro_arw`` (rad/sqrt(s)) and ``accel_vrw``
    (m/s/sqrt(s)) on every axis."""
    pieces = output_pieces([MotionPiece(0.0, duration_s, np.asarray(attitude, dtype=float))], step_s)
    return propagate(model, pieces, np.full(3, gyro_arw), np.full(3, accel_vrw), np.inf)


def error_budget(calibration_covariance: np.ndarray, nominal: np.ndarray, attitude: np.ndarray, latitude: float,
                 height: float, gravity: float, accel_noise_ug: float, gyro_noise_deg_h: float, rate_hz: float,
                 duration_s: float = 86400.0, step_s: float = 60.0, align_s: float = 300.0, names=NAMES) -> Budget:
    """1-sigma north/east position error of static navigation by source, over ``duration_s``; ``names``
    the parameters of the covariance (the 21, then any extra groups: each is a source)."""
    dt = 1.0 / rate_hz
    names = tuple(names)
    n_params = len(names)
    model = ErrorModel(Site(latitude, height, gravity), names)
    per_sample = np.array([accel_noise_ug * UG] * 3 + [gyro_noise_deg_h * DEG_PER_H] * 3)  # white noise per sample
    prop = static_propagation(model, attitude, per_sample[3] * np.sqrt(dt), per_sample[0] * np.sqrt(dt),
                              duration_s, step_s)
    # alignment: attitude error = linearised alignment of the parameter errors + noise of the means
    to_initial = np.zeros((model.n_state, n_params))
    to_initial[PHI] = model.alignment_map(attitude)
    to_initial[N_NAV:] = np.eye(n_params)
    means_map = model.alignment_noise_map(attitude)  # d(phi_0)/d(mean f, mean w), (3, 6)
    align_noise = np.zeros((model.n_state, model.n_state))
    align_noise[PHI, PHI] = means_map @ np.diag(per_sample**2 / (align_s * rate_hz)) @ means_map.T

    def position(p0: np.ndarray, noises=()) -> np.ndarray:
        """1-sigma north and east position error (T, 2) of an initial covariance and noises."""
        cov = prop.covariance(p0, noises)
        return np.sqrt(np.clip(np.stack([cov[:, 2, 2], cov[:, 3, 3]], axis=1), 0, None))

    covariance = relative_covariance(names, nominal, calibration_covariance)
    contributions = {}
    for label, sl in source_spans(names):
        block = np.zeros_like(covariance)
        block[sl, sl] = covariance[sl, sl]
        contributions[f"residual {label}"] = position(to_initial @ block @ to_initial.T)
    contributions["alignment noise"] = position(align_noise)
    contributions["sensor noise in navigation"] = position(np.zeros_like(align_noise), ("gyro noise", "accel noise"))
    total = position(to_initial @ covariance @ to_initial.T + align_noise, ("gyro noise", "accel noise"))
    return Budget(prop.time, contributions, total)


def source_spans(names) -> list[tuple[str, slice]]:
    """``(label, slice)`` of each parameter group among ``names`` (the 21's six, then the extra groups)."""
    spans = [(label, sl) for label, sl, _ in CORE_SPANS]
    for key in groups_in(names):
        index = [names.index(n) for n in GROUPS[key].names if n in names]
        spans.append((GROUPS[key].label, slice(min(index), max(index) + 1)))
    return spans


def propagate_mean(errors: np.ndarray, attitude: np.ndarray, latitude: float, height: float, gravity: float,
                   rate_hz: float, duration_s: float, step_s: float = 60.0) -> tuple[np.ndarray, np.ndarray]:
    """North/east position error (m) of given parameter errors (the 21, the paper's convention), noise-free,
    aligned at the start."""
    model = ErrorModel(Site(latitude, height, gravity), NAMES)
    prop = static_propagation(model, attitude, 0.0, 0.0, duration_s, step_s)
    x0 = np.zeros(model.n_state)
    x0[PHI] = model.alignment_map(attitude) @ errors
    x0[N_NAV:] = errors
    return prop.time, prop.mean(x0)[:, 2:4]


def plot_budget(budget: Budget, path: str | Path, title: str) -> Path:
    """Latitude and longitude error by source over time (log scale)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(14, 5), sharey=True)
    hours = budget.time / 3600
    for axis, name in enumerate(("latitude (north)", "longitude (east)")):
        ax = axes[axis]
        curves, zero = drawn_curves(budget, axis)
        for source, sig in curves.items():
            ax.semilogy(hours, sig, lw=2.0 if source == "total" else 1.0, label=source,
                        **({"color": "k"} if source == "total" else {}))
        ax.set_title(f"{name} error, 1 sigma" + (f"\n(zero, not drawn: {', '.join(zero)})" if zero else ""),
                     fontsize=10)
        ax.set_xlabel("time (h)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("m")
    legend_outside(axes[1], fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def drawn_curves(budget: Budget, axis: int) -> tuple[dict[str, np.ndarray], list[str]]:
    """The curves of one axis of the budget plot: each source's and the total's sigma with zeros masked (a log
    axis has no place for 0: it is left out, never drawn at a floor), and the sources that are zero throughout."""
    curves, zero = {}, []
    for source, sig in [*budget.contributions.items(), ("total", budget.total)]:
        values = np.asarray(sig[:, axis], dtype=float)
        if not np.any(values > 0):
            zero.append(source)
            continue
        curves[source] = np.where(values > 0, values, np.nan)
    return curves, zero


def budget_files(budget: Budget, table: pd.DataFrame, stem: Path, title: str, plot_title: str) -> dict[Path, bytes]:
    """The files of a budget: its table as ``STEM.csv`` (full precision) and ``STEM.md`` (rounded from sigma,
    under ``title``), and its plot ``STEM.png`` (under ``plot_title``), for :func:`core.files.write_files`."""
    files = frame_files(table, stem, title, display=display(table, sigmas=float_columns(table)))
    buffer = io.BytesIO()
    plot_budget(budget, buffer, plot_title)
    files[stem.with_name(f"{stem.name}.png")] = buffer.getvalue()
    return files


def write_budget(budget: Budget, out_dir: str | Path, name: str) -> pd.DataFrame:
    """The budget's table at 1 h and 24 h (CSV, Markdown) and its plot; returns the table."""
    table = budget.table([3600.0, 86400.0])
    write_files(budget_files(budget, table, Path(out_dir) / f"{safe_stem(name)}-budget",
                             f"{name}: static navigation error by source after calibration (1 sigma, m)",
                             f"{name}: error budget of static navigation"))
    return table


def white_noise_densities(problem) -> tuple[np.ndarray, np.ndarray]:
    """A problem's white-noise densities per axis: gyro ARW (rad/sqrt(s)) and accelerometer VRW (m/s/sqrt(s))."""
    noise = SensorNoise.from_deviations(problem.deviations, 1.0 / problem.rate_hz)
    return np.asarray(noise.gyro_arw, float), np.asarray(noise.accel_vrw, float)


def white_noise_per_sample(problem) -> tuple[float, float]:
    """A problem's white accelerometer (ug) and gyro (deg/h) noise per sample, densities included."""
    dt = 1.0 / problem.rate_hz
    gyro_arw, accel_vrw = white_noise_densities(problem)
    return float(accel_vrw[0]) / dt**0.5 / UG, float(gyro_arw[0]) / dt**0.5 / DEG_PER_H


def problem_budget(problem, nominal: np.ndarray, covariance: np.ndarray, orientation: str = "ENU",
                   hours: float = 24.0, names=NAMES) -> Budget:
    """The error budget of a unit with the calibration covariance ``covariance`` (SI, about ``nominal``, the
    parameters ``names``) navigating at ``orientation`` on a problem's site, with its sensors' white noise."""
    return error_budget(covariance, nominal, orientation_to_dcm(orientation), problem.site.latitude,
                        problem.site.height, problem.site.g, *white_noise_per_sample(problem), problem.rate_hz,
                        duration_s=hours * 3600.0, names=names)
