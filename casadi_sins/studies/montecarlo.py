"""Monte Carlo over seeds: simulate, calibrate, collect errors in natural units."""

from __future__ import annotations

import functools
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from ..calibrate import calibrate, prepare_compiled
from ..calibrate.result import CalibrationError
from ..core.errors import InputError
from ..core.units import DEG_PER_H, UG
from ..data.problem import Problem
from ..model.noise import SensorNoise
from ..model.parameters import joint_chi_square, natural_errors
from ..model.registry import CORE_SPANS, NAMES, group_of
from ..report.plots import legend_outside, pyplot, save_figure
from ..sim import simulate
from .consistency import consistency
from .parallel import run_all

#: What the paper's noise allows (1 sigma, an efficient estimator's bound): (low, high) per group.
NOISE_FLOOR = {
    "accel bias": (0.2, 0.2), "accel scale": (0.25, 0.25), "accel misalignment": (0.12, 0.12),
    "gyro bias": (0.0013, 0.0017), "gyro scale": (0.5, 0.65), "gyro misalignment": (0.12, 0.17),
}
#: The paper's reported accuracy after 3 iterations.
PAPER_ACCURACY = {
    "accel bias": 0.5, "accel scale": 0.5, "accel misalignment": 0.2,
    "gyro bias": 0.0003, "gyro scale": 0.5, "gyro misalignment": 0.2,
}


def datasheet(problem: Problem):
    """The sensor datasheet of a problem: its bias instability (what a recording of minutes shows of it only in part)."""
    dev = problem.deviations
    if not (dev.gyro_bias_instability_deg_h or dev.accel_bias_instability_ug):
        return None
    return SensorNoise(gyro_bias_instability=dev.gyro_bias_instability_deg_h * DEG_PER_H,
                       gyro_bias_tau=dev.gyro_bias_tau_s, accel_bias_instability=dev.accel_bias_instability_ug * UG,
                       accel_bias_tau=dev.accel_bias_tau_s)


def run_seed(problem: Problem, seed: int, solvers: Sequence[str] = ("ils",), use_datasheet: bool = True,
             model: str = "21") -> list[dict]:
    """Simulate one seed and calibrate it with each solver; one row per solver and parameter.

    ``use_datasheet`` gives the calibration the problem's bias instability, as an engineer would from
    the unit's datasheet (the white noise is always measured from the recording).  ``model`` is the NLP's
    parameter model (the ILS fits the 21).
    """
    sim = simulate(problem, seed=seed)
    rows = []
    noise = datasheet(problem) if use_datasheet else None
    for solver in solvers:
        try:
            options = {"model": model} if solver == "nlp" else {}
            res = calibrate(sim.recording, solver=solver, noise=noise, **options)
        except CalibrationError as exc:
            rows.append({"seed": seed, "solver": solver, "failed": str(exc)})
            continue
        params = res.parameters
        err = natural_errors(params, sim.truth)
        sigma = params.natural_sigma()
        truth = sim.truth.aligned(params.names)
        chi_square = joint_chi_square(params, sim.truth)
        first = (natural_errors(np.asarray(res.history[1])[: len(params.names)], truth, params.names)
                 if len(res.history) > 1 else err)
        for i, name in enumerate(params.names):
            rows.append({"seed": seed, "solver": solver, "parameter": name, "group": group_of(name).label,
                         "unit": params.natural_units[i], "error": err[i], "sigma": sigma[i],
                         "first_iteration_error": first[i], "iterations": res.nit,
                         "wall_time": res.wall_time, "warnings": len(res.warnings), "chi_square": chi_square,
                         "distrusted": bool(res.distrust), "failed": ""})
    return rows


#: The most runs a Monte Carlo makes (each a simulation and calibrations: more would take weeks).
MAX_RUNS = 100_000


def check_runs(runs: int, option: str = "--runs") -> None:
    """Refuse a number of Monte Carlo runs below 1 or beyond :data:`MAX_RUNS` (naming the option), before any
    list of seeds is made."""
    if not 1 <= runs <= MAX_RUNS:
        raise InputError(None, f"{option} must be between 1 and {MAX_RUNS} runs (each simulates and calibrates a "
                         f"recording), found {runs}")


def run(problem: Problem, seeds: Sequence[int], solvers: Sequence[str] = ("ils",), workers: int | None = None,
        progress: Callable[[int, int], None] | None = None, scheduler: str | None = None,
        use_datasheet: bool = True, model: str = "21") -> pd.DataFrame:
    """Run seeds in parallel (:func:`studies.parallel.run_all`); rows of :func:`run_seed`.

    Parameters
    ----------
    workers : int, optional
        Local processes (default: one per core).
    scheduler : str, optional
        A Dask distributed scheduler address (``tcp://host:8786``), or ``"local"`` for a Dask
        cluster on this machine: the runs are submitted there instead (needs ``dask[distributed]``).
    """
    task = functools.partial(_seed_rows, problem, tuple(solvers), use_datasheet, model)
    # compiled here once, not by every worker at the same time (with an empty cache)
    # without a datasheet a wander the static data show may enter (issue 16): its filter as well
    prepare_compiled(model, not use_datasheet or datasheet(problem) is not None)
    rows: list[dict] = []
    for result in run_all(task, list(seeds), workers, scheduler, progress):
        rows += result
    return pd.DataFrame(rows)


def _seed_rows(problem, solvers, use_datasheet, model, seed):
    return run_seed(problem, seed, solvers, use_datasheet, model)


def with_prediction(summary_frame: pd.DataFrame, predicted_sigma: np.ndarray) -> pd.DataFrame:
    """Add the predicted sigma (natural units) and RMS/predicted to a :func:`summary`."""
    out = summary_frame.copy()
    out["predicted_sigma"] = out["parameter"].map(dict(zip(NAMES, predicted_sigma)))
    out["rms_over_predicted"] = out["rms_error"] / out["predicted_sigma"]
    return out


def plot_summary(summary_frame: pd.DataFrame, path) -> object:
    """Bars of the RMS error per parameter and solver against the predicted sigma."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(14, 7))
    for ax, (label, sl, unit) in zip(axes.ravel(), CORE_SPANS):
        names = list(NAMES[sl])
        x = np.arange(len(names))
        solvers = list(dict.fromkeys(summary_frame["solver"]))
        width = 0.8 / (len(solvers) + 1)
        for k, solver in enumerate(solvers):
            part = summary_frame[summary_frame["solver"] == solver].set_index("parameter").loc[names]
            ax.bar(x + k * width, part["rms_error"], width, label=f"{solver} RMS error")
        if "predicted_sigma" in summary_frame:
            part = summary_frame.drop_duplicates("parameter").set_index("parameter").loc[names]
            ax.bar(x + len(solvers) * width, part["predicted_sigma"], width, color="0.6", label="predicted sigma")
        ax.set_xticks(x + width * len(solvers) / 2, [n.split("_", 2)[-1] for n in names])
        ax.set_title(f"{label} ({unit})", fontsize=10)
        ax.set_ylim(bottom=0)
    legend_outside(axes[0, 0], fontsize=8)
    fig.suptitle("Monte Carlo: RMS error per parameter against the predicted sigma")
    fig.tight_layout()
    return save_figure(fig, path)


def summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per solver and parameter: RMS error, mean sigma, their ratio, and the floor ratio."""
    ok = frame[frame["failed"] == ""]
    out = ok.groupby(["solver", "parameter"], sort=False).agg(
        group=("group", "first"), unit=("unit", "first"),
        rms_error=("error", lambda e: float(np.sqrt(np.mean(np.square(e))))),
        mean_sigma=("sigma", "mean"), max_abs_z=("error", "size"),
        rms_first_iteration=("first_iteration_error", lambda e: float(np.sqrt(np.mean(np.square(e))))),
        runs=("error", "size")).reset_index()
    z = ok.assign(z=np.abs(ok["error"] / ok["sigma"])).groupby(["solver", "parameter"], sort=False)["z"].max()
    out["max_abs_z"] = z.to_numpy()
    beyond = ok.assign(b=np.abs(ok["error"] / ok["sigma"]) > 4.5).groupby(["solver", "parameter"], sort=False)["b"]
    out["beyond_4_5_sigma"] = beyond.sum().to_numpy()
    out["rms_over_sigma"] = out["rms_error"] / out["mean_sigma"]
    out["floor"] = [NOISE_FLOOR[g][0] if g in NOISE_FLOOR else np.nan for g in out["group"]]
    out["rms_over_floor"] = out["rms_error"] / out["floor"]
    out["paper"] = [PAPER_ACCURACY[g] if g in PAPER_ACCURACY else np.nan for g in out["group"]]
    return out


def montecarlo_files(problem: Problem, rows: pd.DataFrame, summary_frame: pd.DataFrame, out_dir, runs: int,
                     elapsed: float) -> dict:
    """The Monte Carlo's files (runs, summary as CSV and Markdown, plot) as ``{path: bytes}``."""
    from pathlib import Path

    from ..report.tables import frame_files

    out = Path(out_dir)
    stem = out / f"{problem.name}-montecarlo"
    files = frame_files(rows, out / f"{problem.name}-montecarlo-runs")
    files.update(frame_files(summary_frame[SUMMARY_COLUMNS], stem, f"{problem.name}: {runs} runs in {elapsed:.0f} s; "
                             "RMS error against the solver's sigma and the predicted sigma (natural units)",
                             display=summary_display(summary_frame)))
    checks = consistency(rows)
    if checks:
        md = stem.with_name(stem.name + ".md")  # not with_suffix: a name may hold a dot
        text = "\n## Is the sigma honest?\n\n" + "".join(f"- {c.line()}\n" for c in checks)
        files[md] = files[md] + text.encode()
    import io

    plot = io.BytesIO()
    plot_summary(summary_frame, plot)
    files[stem.with_name(stem.name + ".png")] = plot.getvalue()
    return files


#: The columns of the Monte Carlo summary shown to the user.
SUMMARY_COLUMNS = ["solver", "parameter", "unit", "rms_error", "mean_sigma", "predicted_sigma", "rms_over_predicted",
                   "rms_over_sigma", "max_abs_z", "runs"]


def summary_display(summary_frame: pd.DataFrame) -> pd.DataFrame:
    """The summary as people read it (Markdown, terminal): RMS and sigmas to two significant digits in
    natural units, the ratios to two decimals."""
    from ..report.rounding import display

    return display(summary_frame[SUMMARY_COLUMNS], sigmas=["rms_error", "mean_sigma", "predicted_sigma"],
                   ratios=["rms_over_predicted", "rms_over_sigma", "max_abs_z"])
