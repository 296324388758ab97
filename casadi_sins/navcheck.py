"""Navigation check after calibration (the paper's section 2.3): free-inertial navigation on a static base.

A fresh static recording is simulated (the problem's sensors, truth and noise, one level position),
each parameter table is applied, the unit is aligned on the first minutes (eq. 14) and then navigates
free-inertially: position, transport rate, Coriolis and normal gravity at the computed position, the
vertical channel held at the known height (as navigation systems do without an altimeter).  The
horizontal position error after 1 h is what the paper reports (< 1 nmile for its real product).

The step reuses the calibration's building blocks (:func:`strapdown.corrected_increments`,
:func:`strapdown.attitude_update`, :func:`strapdown.specific_force_increment`) and the Earth model of
:mod:`frames`; only the position, transport-rate and Coriolis terms are added here.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import casadi as ca
import numpy as np
import pandas as pd

from . import frames
from .problem import GroupPlan, Problem, Timing
from .recording import Recording
from .report import save_figure, write_frame
from .simulate import simulate
from .strapdown import (align, attitude_update, compensated_increments, corrected_increments, dcm_to_quat,
                        specific_force_increment)

NAUTICAL_MILE = 1852.0
# state: q (4), v ENU (3), latitude, longitude, height (3), previous dtheta (3), previous dv (3)
FREE_STATE = 16


def free_inertial_step_expr(state, dtheta, dv, dt):
    q, v = state[0:4], state[4:7]
    lat, lon, h = state[7], state[8], state[9]
    r_m, r_n = frames.earth_radii(lat)
    w_ie = frames.EARTH_RATE * ca.vertcat(0, ca.cos(lat), ca.sin(lat))
    w_en = ca.vertcat(-v[1] / (r_m + h), v[0] / (r_n + h), v[0] * ca.tan(lat) / (r_n + h))
    w_in_dt = (w_ie + w_en) * dt
    phi, dv_body = corrected_increments(dtheta, dv, state[10:13], state[13:16])
    gravity = ca.vertcat(0, 0, -frames.normal_gravity(lat, h))
    v_next = v + specific_force_increment(q, dv_body, w_in_dt) + (gravity - ca.cross(2 * w_ie + w_en, v)) * dt
    v_next = ca.vertcat(v_next[0], v_next[1], 0)  # vertical channel held at the known height
    v_mid = (v + v_next) / 2
    lat_next = lat + v_mid[1] / (r_m + h) * dt
    lon_next = lon + v_mid[0] / ((r_n + h) * ca.cos(lat)) * dt
    return ca.vertcat(attitude_update(q, phi, w_in_dt), v_next, lat_next, lon_next, h, dtheta, dv)


@functools.lru_cache(maxsize=None)
def free_inertial_step() -> ca.Function:
    x, dth, dv, dt = ca.SX.sym("x", FREE_STATE), ca.SX.sym("dtheta", 3), ca.SX.sym("dv", 3), ca.SX.sym("dt")
    return ca.Function("free_inertial_step", [x, dth, dv, dt], [free_inertial_step_expr(x, dth, dv, dt)])


def navigation_problem(problem: Problem, duration_s: float = 3600.0, align_s: float = 300.0,
                       orientation: str = "ENU") -> Problem:
    """One static position: ``align_s`` of alignment, then ``duration_s`` of navigation."""
    timing = Timing(static_s=align_s + duration_s, rotation_s=1.0, rate_profile=problem.timing.rate_profile)
    return dataclasses.replace(problem, name=f"{problem.name}-navcheck", groups=(GroupPlan(orientation, ()),),
                               timing=timing)


@dataclasses.dataclass
class NavigationRun:
    label: str
    time: np.ndarray  # s since the start of navigation
    north_m: np.ndarray
    east_m: np.ndarray

    @property
    def horizontal_m(self) -> np.ndarray:
        return np.hypot(self.north_m, self.east_m)


def navigate_free(rec: Recording, params: np.ndarray, align_s: float, label: str, step_s: float = 0.1,
                  output_s: float = 1.0) -> NavigationRun:
    """Align on the first ``align_s`` and navigate the rest free-inertially; position error from the site.

    The base is static, so the increments are summed into ``step_s`` steps (exact for a body at rest:
    a noise-free recording with the true parameters stays within 1e-6 m over an hour).
    """
    dtheta, dv = compensated_increments(rec, params)
    n_align = int(round(align_s * rec.rate_hz))
    attitude = align(dtheta[:n_align], dv[:n_align], rec.dt)
    block = max(1, int(round(step_s * rec.rate_hz)))
    steps = (len(dtheta) - n_align) // block
    used = slice(n_align, n_align + steps * block)
    dtheta = dtheta[used].reshape(steps, block, 3).sum(axis=1)
    dv = dv[used].reshape(steps, block, 3).sum(axis=1)
    lat0, h0 = rec.site.latitude, rec.site.height
    x0 = np.concatenate([dcm_to_quat(attitude), np.zeros(3), [lat0, 0.0, h0], dtheta[0], dv[0]])
    chain = free_inertial_step().mapaccum("free_inertial", steps)
    every = max(1, int(round(output_s / (block * rec.dt))))
    states = np.asarray(chain(x0, dtheta.T, dv.T, block * rec.dt)).T[every - 1::every]
    decimate = every * block
    r_m, r_n = frames.earth_radii(lat0)
    north = (states[:, 7] - lat0) * (r_m + h0)
    east = states[:, 8] * (r_n + h0) * np.cos(lat0)
    t = (np.arange(len(states)) + 1) * decimate * rec.dt
    return NavigationRun(label, t, north, east)


def navigation_check(problem: Problem, tables: dict[str, np.ndarray], seed: int = 0, duration_s: float = 3600.0,
                     align_s: float = 300.0) -> tuple[list[NavigationRun], pd.DataFrame]:
    """Navigate a fresh static recording with each parameter table (plus the rough values and the truth)."""
    sim = simulate(navigation_problem(problem, duration_s, align_s), seed=seed)
    rec = sim.recording
    sets = {"rough initial values": _rough_for(problem, seed), **tables, "truth": sim.truth.values}
    runs = [navigate_free(rec, values, align_s, label) for label, values in sets.items()]
    rows = [{"parameters": run.label, "horizontal error at end (m)": run.horizontal_m[-1],
             "horizontal error at end (nmi)": run.horizontal_m[-1] / NAUTICAL_MILE,
             "max horizontal error (nmi)": run.horizontal_m.max() / NAUTICAL_MILE} for run in runs]
    return runs, pd.DataFrame(rows)


def _rough_for(problem: Problem, seed: int) -> np.ndarray:
    """The rough initial values the paper would start from: those of a calibration recording."""
    from .initial import rough_parameters

    return rough_parameters(simulate(problem, seed=seed).recording).values


def plot_navigation_check(runs: list[NavigationRun], path: str | Path, title: str) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 5))
    for run in runs:
        ax.semilogy(run.time / 60, np.maximum(run.horizontal_m, 1e-3) / NAUTICAL_MILE, label=run.label)
    ax.axhline(1.0, color="k", ls=":", lw=0.8, label="1 nmile")
    ax.set_xlabel("time of free-inertial navigation (min)")
    ax.set_ylabel("horizontal position error (nmile)")
    ax.legend(fontsize=8)
    ax.set_title(title)
    return save_figure(fig, path)


def write_navigation_check(runs, table: pd.DataFrame, out_dir: str | Path, name: str) -> None:
    out_dir = Path(out_dir)
    write_frame(table, out_dir / f"{name}-navcheck", f"{name}: 1 h static free-inertial navigation after calibration")
    plot_navigation_check(runs, out_dir / f"{name}-navcheck.png",
                          f"{name}: horizontal position error, static base, after alignment")
