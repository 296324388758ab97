"""Error budget of a calibrated unit: covariance propagation of static free-inertial navigation, by source.

The linear error model of free-inertial navigation on a static base (ENU, vertical channel held;
attitude error ``phi`` with ``C_hat = (I - [phi x]) C``), with the 21 parameter errors as constant
states::

    phi'   = -w_ie x phi + d(w_ie)/dL dL + d(w_en)/dv dv - C (T_g w^b + eps) - C w_g
    dv_h'  = (f^n x phi)_h - (2 w_ie x dv)_h + (C (T_a f^b + Delta))_h + (C w_a)_h
    dL'    = dv_N / R_M,      dlon' = dv_E / (R_N cos L)

(the calibration's error model, :mod:`nav.errormodel`, extended by position and Coriolis).  The state
starts from the alignment (eq. 14): its attitude error is the linearised alignment of the parameter
errors plus the alignment's own noise.  Being linear, the covariance splits exactly into the
contributions of independent sources (Guan et al. 2023): each parameter group's residual
error (from the calibration covariance; correlations between groups are left out of the split but kept
in the total), the alignment noise, and the sensor noise during navigation.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from ..core.earth import earth_rate_enu
from ..core.linalg import expm
from ..core.orientation import orientation_to_dcm
from ..core.units import DEG_PER_H, UG
from ..model.noise import SensorNoise
from ..model.output import rest_sensitivity
from ..model.registry import CORE_SPANS, GROUPS, N_PARAMS, NAMES, groups_in, relative_covariance
from ..nav.alignment import alignment_error
from ..nav.errormodel import alignment_sensitivity, input_sensitivity
from ..nav.errorstate import N_NAV, navigation_block, position_metres, with_sensor_inputs
from ..report.plots import legend_outside, pyplot, save_figure
from ..report.rounding import display, float_columns
from ..core.files import safe_stem
from ..report.tables import write_frame

# error state: phi (3), dv_E, dv_N, dL, dlon (nav.errorstate), then the parameter errors (the 21, then any extra groups)
N_STATE = N_NAV + N_PARAMS
#: Longest navigation time of a budget, h (six weeks: beyond, the linear model and the noise model are stretched,
#: and the propagation's one-minute steps add up to a long wait).
MAX_HOURS = 1000.0


def parameter_inputs(attitude: np.ndarray, w_body: np.ndarray, f_body: np.ndarray, names=NAMES):
    """``(d(C d_omega)/dx, d(C d_f)/dx)`` (3, parameters) at rest: the 21's (:func:`nav.errormodel.input_sensitivity`)
    and each extra group's (:func:`model.output.rest_sensitivity`)."""
    rest_g, rest_a = rest_sensitivity(names, w_body, f_body)
    gyro = np.hstack([input_sensitivity(w_body[None], 1.0, "gyro")[0], rest_g])
    accel = np.hstack([input_sensitivity(f_body[None], 1.0, "accel")[0], rest_a])
    return attitude @ gyro, attitude @ accel


def error_dynamics(attitude: np.ndarray, latitude: float, height: float, gravity: float, names=NAMES) -> np.ndarray:
    """Continuous-time matrix ``F`` of the augmented error state on a static base (parameters ``names``):
    :func:`nav.errorstate.navigation_block` with the parameters' inputs."""
    w_body = attitude.T @ earth_rate_enu(latitude)
    f_body = attitude.T @ np.array([0.0, 0.0, gravity])
    gyro_input, accel_input = parameter_inputs(attitude, w_body, f_body, names)  # d(C d_omega)/dx, (3, parameters)
    nav = navigation_block(latitude, height, gravity, N_NAV + len(names))
    return with_sensor_inputs(nav, gyro_input, accel_input)


def noise_input(attitude: np.ndarray, n_params: int = N_PARAMS) -> np.ndarray:
    """``G`` mapping gyro and accelerometer white noise (body, 6) into the error state."""
    g = np.zeros((N_NAV + n_params, 6))
    g[0:3, 0:3] = -attitude
    g[3:5, 3:6] = attitude[:2]
    return g


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


def error_budget(calibration_covariance: np.ndarray, nominal: np.ndarray, attitude: np.ndarray, latitude: float,
                 height: float, gravity: float, accel_noise_ug: float, gyro_noise_deg_h: float, rate_hz: float,
                 duration_s: float = 86400.0, step_s: float = 60.0, align_s: float = 300.0, names=NAMES) -> Budget:
    """1-sigma north/east position error of static navigation by source, over ``duration_s``; ``names``
    the parameters of the covariance (the 21, then any extra groups: each is a source)."""
    dt = 1.0 / rate_hz
    names = tuple(names)
    n_params = len(names)
    f_matrix = error_dynamics(attitude, latitude, height, gravity, names)
    g_matrix = noise_input(attitude, n_params)
    q_gyro = (gyro_noise_deg_h * DEG_PER_H) ** 2 * dt  # white noise per sample -> PSD
    q_accel = (accel_noise_ug * UG) ** 2 * dt
    q = np.diag([q_gyro] * 3 + [q_accel] * 3)
    # discretisation (Van Loan)
    n = N_NAV + n_params
    van_loan = np.zeros((2 * n, 2 * n))
    van_loan[:n, :n] = -f_matrix
    van_loan[:n, n:] = g_matrix @ q @ g_matrix.T
    van_loan[n:, n:] = f_matrix.T
    ex = expm(van_loan * step_s)
    phi_d = ex[n:, n:].T
    q_d = phi_d @ ex[:n, n:]

    # alignment: attitude error = linearised alignment of the parameter errors + noise of the means
    w_ie = earth_rate_enu(latitude)
    w_b, f_b = attitude.T @ w_ie, attitude.T @ np.array([0.0, 0.0, gravity])
    samples = int(round(align_s * rate_hz))
    align_map = alignment_map(w_b, f_b, dt, names)  # (3, parameters)
    noise_means = np.diag([q_accel / dt / samples] * 3 + [q_gyro / dt / samples] * 3)  # variance of the means
    means_map = alignment_error(f_b, w_b, np.eye(6))  # d(phi_0)/d(mean f, mean w), (3, 6)
    align_noise = means_map @ noise_means @ means_map.T

    def initial(param_cov: np.ndarray, with_align_noise: bool) -> np.ndarray:
        p0 = np.zeros((n, n))
        t0 = np.zeros((n, n_params))
        t0[0:3] = align_map
        t0[N_NAV:] = np.eye(n_params)
        p0 += t0 @ param_cov @ t0.T
        if with_align_noise:
            p0[0:3, 0:3] += align_noise
        return p0

    steps = int(round(duration_s / step_s))
    time = np.arange(steps + 1) * step_s
    to_metres = position_metres(latitude, height)

    def propagate(p0: np.ndarray, noise: bool) -> np.ndarray:
        out = np.zeros((steps + 1, 2))
        p = p0.copy()
        for k in range(steps + 1):
            out[k] = np.sqrt(np.clip(np.diag(p)[5:7], 0, None)) * to_metres
            p = phi_d @ p @ phi_d.T + (q_d if noise else 0.0)
        return out

    covariance = _error_state_covariance(calibration_covariance, nominal, names)
    contributions = {}
    for label, sl in source_spans(names):
        block = np.zeros_like(covariance)
        block[sl, sl] = covariance[sl, sl]
        contributions[f"residual {label}"] = propagate(initial(block, False), False)
    zero = np.zeros((n_params, n_params))
    contributions["alignment noise"] = propagate(initial(zero, True), False)
    contributions["sensor noise in navigation"] = propagate(initial(zero, False), True)
    total = propagate(initial(covariance, True), True)
    return Budget(time, contributions, total)


def source_spans(names) -> list[tuple[str, slice]]:
    """``(label, slice)`` of each parameter group among ``names`` (the 21's six, then the extra groups)."""
    spans = [(label, sl) for label, sl, _ in CORE_SPANS]
    for key in groups_in(names):
        index = [names.index(n) for n in GROUPS[key].names if n in names]
        spans.append((GROUPS[key].label, slice(min(index), max(index) + 1)))
    return spans


def alignment_map(w_b: np.ndarray, f_b: np.ndarray, dt: float, names=NAMES) -> np.ndarray:
    """``d(phi_0)/dx`` (3, parameters) of the coarse alignment at rest: the 21's (eq. 15) and the extras'."""
    core = alignment_sensitivity(np.tile(w_b * dt, (4, 1)), np.tile(f_b * dt, (4, 1)), dt)
    rest_g, rest_a = rest_sensitivity(names, w_b, f_b)
    return np.hstack([core, alignment_error(f_b, w_b, np.vstack([rest_a, rest_g]))])


def _error_state_covariance(calibration_covariance: np.ndarray, nominal: np.ndarray, names=NAMES) -> np.ndarray:
    """Covariance of the paper's error terms (scale factors relative) from that of the values."""
    return relative_covariance(names, nominal, calibration_covariance)


def propagate_mean(errors: np.ndarray, attitude: np.ndarray, latitude: float, height: float, gravity: float,
                   rate_hz: float, duration_s: float, step_s: float = 60.0) -> tuple[np.ndarray, np.ndarray]:
    """North/east position error (m) of given parameter errors (the paper's convention), noise-free."""
    dt = 1.0 / rate_hz
    phi_d = expm(error_dynamics(attitude, latitude, height, gravity) * step_s)
    w_b = attitude.T @ earth_rate_enu(latitude)
    f_b = attitude.T @ np.array([0.0, 0.0, gravity])
    z = np.zeros(N_STATE)
    z[0:3] = alignment_sensitivity(np.tile(w_b * dt, (4, 1)), np.tile(f_b * dt, (4, 1)), dt) @ errors
    z[N_NAV:] = errors
    scale = position_metres(latitude, height)
    steps = int(round(duration_s / step_s))
    out = np.zeros((steps + 1, 2))
    for k in range(steps + 1):
        out[k] = z[5:7] * scale
        z = phi_d @ z
    return np.arange(steps + 1) * step_s, out


def plot_budget(budget: Budget, path: str | Path, title: str) -> Path:
    """Latitude and longitude error by source over time (log scale)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(14, 5), sharey=True)
    hours = budget.time / 3600
    for axis, name in enumerate(("latitude (north)", "longitude (east)")):
        ax = axes[axis]
        for source, sig in budget.contributions.items():
            ax.semilogy(hours, np.maximum(sig[:, axis], 1e-3), lw=1.0, label=source)
        ax.semilogy(hours, np.maximum(budget.total[:, axis], 1e-3), "k", lw=2.0, label="total")
        ax.set_title(f"{name} error, 1 sigma")
        ax.set_xlabel("time (h)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("m")
    legend_outside(axes[1], fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, path)


def write_budget(budget: Budget, out_dir: str | Path, name: str) -> pd.DataFrame:
    """The budget's table at 1 h and 24 h (CSV, Markdown) and its plot; returns the table."""
    table = budget.table([3600.0, 86400.0])
    stem = safe_stem(name)
    write_frame(table, Path(out_dir) / f"{stem}-budget",
                f"{name}: static navigation error by source after calibration (1 sigma, m)",
                display=display(table, sigmas=float_columns(table)))
    plot_budget(budget, Path(out_dir) / f"{stem}-budget.png", f"{name}: error budget of static navigation")
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
