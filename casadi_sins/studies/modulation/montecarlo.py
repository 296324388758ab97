"""Monte Carlo of the time-domain navigation against the covariance, per source group.

Each source is drawn alone (``runs`` draws from its own covariance, or ``runs`` noise realisations), the
batch navigates free-inertially (:mod:`timedomain`) and the RMS over the runs of the horizontal position
error is set against the covariance's 1 sigma ``sqrt(P_NN + P_EE)`` at the same times:

* ``ratio_of_max``: max over time of the RMS / max over time of the sigma (the reported quantity);
* ``ratio_pooled``: ``sqrt(sum_t RMS^2 / sum_t sigma^2)`` over the run (all times at once);
* ``ratio_velocity_of_max``: the same as the first for the horizontal velocity error;
* ``ratio_given_draws``: the RMS against the covariance of the very constants drawn (what remains is
  the model's error, not the sampling's).

By default the constants are drawn moment-matched (:func:`timedomain.draw_errors`): with plain draws a
source of one or three numbers (the heading, the three scale factors) gives a ratio whose sampling
spread alone is about 10 % at 50 runs; ``matched=False`` gives the plain MC.

:func:`run_schemes` runs several schemes in parallel (:func:`casadi_sins.studies.parallel.run_all`);
:func:`montecarlo_files` gives ``montecarlo.json`` and ``montecarlo.md``.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pandas as pd

from ...core.earth import Site
from ...report.tables import markdown_table
from ..parallel import run_all
from .covariance import propagate
from .schemes import Scheme
from .sources import NOISES, Sources
from .timedomain import draw_errors, navigate


def monte_carlo(scheme: Scheme, sources: Sources, site: Site, hours: float, runs: int = 50, seed: int = 0,
                turn_step_deg: float = 1.0, dwell_step_s: float = 5.0, max_step_s: float = 60.0,
                matched: bool = True, progress=None) -> dict:
    """Per source group: the MC's RMS against the covariance (see the module docstring).

    Parameters
    ----------
    scheme : Scheme
    sources : Sources
    site : Site
    hours : float
    runs : int
        Draws per source group (and noise realisations per noise).
    seed : int
    turn_step_deg, dwell_step_s : float
        Largest navigation step in a turn (deg) and in a dwell (s).
    max_step_s : float
        Largest output interval in a dwell, s.
    matched : bool
        Moment-matched draws of the constants (default) or plain ones.
    progress : callable, optional
        ``progress(fraction)`` as the navigation advances.

    Returns
    -------
    dict
        The run's settings and, per group, ``sigma_max_m``, ``mc_rms_max_m`` and the ratios.
    """
    rng = np.random.default_rng(seed)
    prop = propagate(scheme, site, hours, sources.gyro_arw, sources.accel_vrw, max_step_s=max_step_s,
                     names=sources.names)
    errors, labels = draw_errors(sources, runs, rng, matched)
    start = time.perf_counter()
    t, err, ref = navigate(scheme, site, hours, errors, rng, turn_step_deg, dwell_step_s, max_step_s, progress)
    nav_s = time.perf_counter() - start
    if not np.allclose(prop.time, t):
        raise RuntimeError("the navigation and the covariance disagree on the output times")
    labels = np.array(labels)
    out = {"scheme": scheme.name, "hours": hours, "runs": runs, "seed": seed, "moment_matched": matched,
           "latitude_deg": round(float(np.degrees(site.latitude)), 9), "sources": sources.name,
           "turn_step_deg": turn_step_deg, "dwell_step_s": dwell_step_s, "navigation_s": round(nav_s, 2),
           "reference_run_max_error_m": float(np.hypot(ref[:, 2], ref[:, 3]).max()), "groups": {}}
    groups = sources.groups()
    for group in list(groups) + list(NOISES):
        idx = np.where(labels == group)[0]
        if len(idx) == 0:
            continue
        cov = (prop.covariance(sources.group_covariance(group), noises=()) if group in groups
               else prop.noise[group])
        sig_p = np.sqrt(cov[:, 2, 2] + cov[:, 3, 3])
        sig_v = np.sqrt(cov[:, 0, 0] + cov[:, 1, 1])
        if sig_p.max() < 1e-9:  # the source does not reach the horizontal position here (e.g. vertical only)
            out["groups"][group] = {"sigma_max_m": float(sig_p.max()), "note": "no horizontal effect"}
            continue
        rms_p = np.sqrt(np.mean(err[:, idx, 2] ** 2 + err[:, idx, 3] ** 2, axis=1))
        rms_v = np.sqrt(np.mean(err[:, idx, 0] ** 2 + err[:, idx, 1] ** 2, axis=1))
        out["groups"][group] = {
            "sigma_max_m": float(sig_p.max()), "mc_rms_max_m": float(rms_p.max()),
            "ratio_of_max": float(rms_p.max() / sig_p.max()),
            "ratio_pooled": float(np.sqrt(np.sum(rms_p**2) / np.sum(sig_p**2))),
            "ratio_velocity_of_max": float(rms_v.max() / sig_v.max()),
        }
        if group in groups:  # the covariance of the very errors drawn: what is left is the model's
            drawn = errors.x0[idx]
            c_d = prop.covariance(drawn.T @ drawn / len(idx), noises=())
            out["groups"][group]["ratio_given_draws"] = float(rms_p.max() / np.sqrt(c_d[:, 2, 2] + c_d[:, 3, 3]).max())
    return out


def _task(item: tuple) -> dict:
    """One scheme's :func:`monte_carlo` (a picklable task of :func:`run_all`)."""
    scheme, sources, site, hours, options = item
    cpu = time.process_time()
    out = monte_carlo(scheme, sources, site, hours, **options)
    out["cpu_s"] = round(time.process_time() - cpu, 2)
    return out


def run_schemes(schemes: list[Scheme], sources: Sources, site: Site, hours: float, aligned: bool = False,
                workers: int | None = 1, progress=None, **options) -> list[dict]:
    """:func:`monte_carlo` of every scheme, in parallel (one scheme per worker), in the schemes' order.

    ``aligned``: each scheme's initial attitude error is that of a static alignment at its start attitude
    (:meth:`Sources.aligned`) plus the sheet's; ``options`` go to :func:`monte_carlo`.
    """
    items = [(s, sources.aligned(site, s.start) if aligned else sources, site, hours, options) for s in schemes]
    if workers == 1 and progress:  # in this process: progress within each scheme's navigation
        results = []
        for k, item in enumerate(items):
            *head, opts = item
            results.append(_task((*head, {**opts, "progress": lambda f, k=k: progress(k + f, len(items))})))
    else:
        results = list(run_all(_task, items, workers=workers, progress=progress))
    order = {s.name: k for k, s in enumerate(schemes)}
    return sorted(results, key=lambda r: order[r["scheme"]])


def montecarlo_frame(results: list[dict]) -> pd.DataFrame:
    """One row per scheme and source group: sigma, MC RMS and the ratios."""
    rows = []
    for res in results:
        for group, v in res["groups"].items():
            if "note" in v:
                continue
            rows.append({"scheme": res["scheme"], "draws": "moment-matched" if res["moment_matched"] else "plain",
                         "source": group, "1-sigma max (m)": v["sigma_max_m"], "MC RMS max (m)": v["mc_rms_max_m"],
                         "ratio of max": v["ratio_of_max"], "ratio pooled": v["ratio_pooled"],
                         "velocity ratio": v["ratio_velocity_of_max"],
                         "ratio given draws": v.get("ratio_given_draws", float("nan"))})
    return pd.DataFrame(rows)


def montecarlo_files(results: list[dict], warnings: list[str], out, note: str = "") -> dict[Path, bytes]:
    """``montecarlo.json`` (every number) and ``montecarlo.md`` (the table) as ``{path: content}``."""
    out = Path(out)
    first = results[0] if results else {}
    head = (f"{first.get('runs')} runs per source, each source alone, {first.get('hours'):g} h, latitude "
            f"{first.get('latitude_deg'):g} deg, seed {first.get('seed')}. Bar: MC RMS / covariance sigma "
            "within 0.8-1.25 per source group." if first else "no schemes")
    text = "\n".join(["# Time-domain Monte Carlo against the covariance", "", head + (f" {note}" if note else ""), "",
                      markdown_table(montecarlo_frame(results), "%.4g") if results else ""]) + "\n"
    doc = {"warnings": warnings, "results": results}
    return {out / "montecarlo.json": (json.dumps(doc, indent=1) + "\n").encode(), out / "montecarlo.md": text.encode()}
