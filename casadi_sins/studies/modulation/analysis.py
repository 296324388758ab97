"""The modulation analysis of one or more schemes: covariance by source, ratios to strapdown, residuals.

Definitions (every number is 1 sigma):

* latitude error: north position error ``dL (R_M + h)``; longitude error: east position error
  ``dlon (R_N + h) cos L``; both in m.
* horizontal position error: ``sqrt(P_NN + P_EE)`` (the DRMS); velocity error likewise of ``dv_E, dv_N``.
* a source's maximum position error: the largest horizontal position error of that source alone over the
  run; its ratio to strapdown divides by the same source's under the strapdown scheme (none where that
  rounds to zero in the outputs, below :data:`ZERO_M`: an aligned strapdown IMU cancels some terms).
* residual drift: the equivalent constant navigation-frame gyro drift a period leaves of 1 sigma of each
  gyro term (:func:`residual.equivalent_drift`), deg/h.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ...core import units
from ...core.earth import Site
from . import model as M
from .covariance import Propagation, propagate
from .residual import equivalent_drift
from .schemes import CLOSURE_TOL, Scheme, closure_error, load_scheme
from .sources import NOISES, Sources
from .tilt import mean_tilt_table

#: A strapdown contribution below this (m) rounds to zero in the outputs: no ratio is formed with it (the
#: alignment cancels some terms to rounding, e.g. an east accelerometer bias on a level IMU).
ZERO_M = 5e-4
#: The reference of every ratio: an IMU that never turns.
STRAPDOWN = Scheme("strapdown", (), np.eye(3), description="reference: the IMU never turns (x E, y N, z U)",
                   source="built in")


@dataclasses.dataclass
class SchemeResult:
    """One scheme's propagation, split by source and by parameter.

    Attributes
    ----------
    scheme : Scheme
    propagation : Propagation
    total : ndarray (T, 4, 4)
        Covariance of (v_E, v_N, north, east) with every source (correlations kept).
    by_source : dict of str -> ndarray (T, 4, 4)
        Each source alone (:meth:`sources.Sources.groups` and the two noises).
    by_parameter : dict of str -> ndarray (T, 2)
        Each state's 1-sigma north and east position error, m.
    seconds : float
        Compute time.
    """

    scheme: Scheme
    propagation: Propagation
    total: np.ndarray
    by_source: dict[str, np.ndarray]
    by_parameter: dict[str, np.ndarray]
    seconds: float

    @property
    def time_h(self) -> np.ndarray:
        """Output times, h."""
        return self.propagation.time / 3600.0


def horizontal(cov: np.ndarray) -> np.ndarray:
    """Horizontal position error ``sqrt(P_NN + P_EE)`` (m) of covariances (T, 4, 4)."""
    return np.sqrt(np.clip(cov[:, 2, 2] + cov[:, 3, 3], 0.0, None))


def velocity(cov: np.ndarray) -> np.ndarray:
    """Horizontal velocity error (m/s) of covariances (T, 4, 4)."""
    return np.sqrt(np.clip(cov[:, 0, 0] + cov[:, 1, 1], 0.0, None))


def run_scheme(scheme: Scheme, sources: Sources, site: Site, hours: float, step_deg: float = 5.0,
               max_step_s: float = 60.0) -> SchemeResult:
    """Propagate one scheme and split the covariance by source and by parameter.

    Parameters
    ----------
    scheme : Scheme
    sources : Sources
    site : Site
    hours : float
    step_deg, max_step_s : float
        Largest turn sub-step (deg) and output interval in a dwell (s), :func:`covariance.propagate`.
    """
    start = time.perf_counter()
    prop = propagate(scheme, site, hours, sources.gyro_arw, sources.accel_vrw, step_deg, max_step_s,
                     names=sources.names)
    by_source = {g: prop.covariance(sources.group_covariance(g), noises=()) for g in sources.groups()}
    by_source.update({name: prop.noise[name] for name in NOISES})
    sigma = np.sqrt(np.clip(np.diag(sources.p0), 0.0, None))
    columns = sources.initial_map() * sigma  # each independent state's 1-sigma initial error (through any alignment)
    pos = prop.sensitivity[:, 2:4, :] @ columns  # (T, 2, states)
    by_parameter = {name: np.abs(pos[:, :, i]) for i, name in enumerate(sources.state_names) if sigma[i] > 0}
    total = prop.covariance(sources.initial_covariance)
    return SchemeResult(scheme, prop, total, by_source, by_parameter, time.perf_counter() - start)


def _max(a: np.ndarray) -> float:
    return float(np.max(a)) if len(a) else 0.0


def _ratio(value: float, reference: float) -> float | None:
    return None if reference < ZERO_M else value / reference


def envelope(time_h: np.ndarray, curves: dict[str, np.ndarray], points: int = 600) -> dict:
    """Curves cut to about ``points`` samples, each the largest value of its block (an envelope: a
    modulated curve's oscillation is not aliased away); ``time_h`` is each block's last time."""
    n = len(time_h)
    block = max(1, math.ceil(n / points))
    idx = np.arange(0, n, block)
    out = {"time_h": time_h[np.minimum(idx + block - 1, n - 1)].round(5).tolist()}
    for name, curve in curves.items():
        out[name] = [round(float(curve[i:i + block].max()), 4) for i in idx]
    return out


def residual_drift(scheme: Scheme, sources: Sources, site: Site) -> dict[str, list[float]]:
    """Equivalent constant drift (E, N, U, deg/h) each gyro term's 1 sigma leaves per period."""
    drift = equivalent_drift(scheme, site, "total", sources.names)
    sigma = np.sqrt(np.clip(np.diag(sources.p0), 0.0, None))[M.N_NAV:]
    out = {}
    for j, name in enumerate(sources.names):
        if name.startswith("gyro") and sigma[j] > 0:
            out[name] = (drift[:, j] * sigma[j] / units.DEG_PER_H).round(9).tolist()
    return out


def summarise(result: SchemeResult, reference: SchemeResult, sources: Sources, site: Site) -> dict:
    """One scheme's entry of ``modulation.json``."""
    scheme, tot = result.scheme, result.total
    hor = horizontal(tot)
    k = int(np.argmax(hor))
    by_source = {}
    for name, cov in result.by_source.items():
        value = _max(horizontal(cov))
        by_source[name] = {
            "max_position_error_m": round(value, 3),
            "ratio_to_strapdown": _round(_ratio(value, _max(horizontal(reference.by_source[name])))),
            "max_longitude_error_m": round(_max(np.sqrt(cov[:, 3, 3])), 3),
            "max_latitude_error_m": round(_max(np.sqrt(cov[:, 2, 2])), 3),
        }
    by_parameter = {}
    for name, curve in result.by_parameter.items():
        value = _max(np.hypot(curve[:, 0], curve[:, 1]))
        ref = reference.by_parameter[name]
        by_parameter[name] = {"max_position_error_m": round(value, 3),
                              "ratio_to_strapdown": _round(_ratio(value, _max(np.hypot(ref[:, 0], ref[:, 1]))))}
    total_max = float(hor[k])
    not_averaged = [{"name": n, "max_position_error_m": v["max_position_error_m"],
                     "ratio_to_strapdown": v["ratio_to_strapdown"],
                     "share_of_total": round(v["max_position_error_m"] / total_max, 4)}
                    for n, v in sorted(by_parameter.items(), key=lambda item: -item[1]["max_position_error_m"])
                    if n not in M.NAV_NAMES and (v["ratio_to_strapdown"] is None or v["ratio_to_strapdown"] >= 0.5)
                    and v["max_position_error_m"] >= 0.01 * total_max]
    mean = result.propagation.mean(sources.values())  # every source at +1 sigma, noise-free
    curves = {"longitude_error_m": np.sqrt(tot[:, 3, 3]), "latitude_error_m": np.sqrt(tot[:, 2, 2])}
    for name, cov in result.by_source.items():
        curves[f"{name}: longitude_error_m"] = np.sqrt(cov[:, 3, 3])
        curves[f"{name}: latitude_error_m"] = np.sqrt(cov[:, 2, 2])
    return {
        "description": scheme.description.strip(),
        "source": scheme.source,
        "period_s": None if math.isinf(scheme.period) else round(scheme.period, 6),
        "returns_to_start": closure_error(scheme) < CLOSURE_TOL,
        "max_horizontal_position_error_m": round(float(hor[k]), 3),
        "time_of_max_h": round(float(result.time_h[k]), 4),
        "max_velocity_error_mps": round(_max(velocity(tot)), 5),
        "max_longitude_error_m": round(_max(curves["longitude_error_m"]), 3),
        "max_latitude_error_m": round(_max(curves["latitude_error_m"]), 3),
        "by_source": by_source,
        "by_parameter": by_parameter,
        "not_averaged_away": not_averaged,
        "residual_drift_deg_h_per_sigma": residual_drift(scheme, sources, site),
        "period_mean_tilt": mean_tilt_table(scheme, sources, site),
        "deterministic_plus_one_sigma": {
            "max_horizontal_position_error_m": round(_max(np.hypot(mean[:, 2], mean[:, 3])), 3),
            "max_velocity_error_mps": round(_max(np.hypot(mean[:, 0], mean[:, 1])), 5)},
        "compute_s": round(result.seconds, 3),
        "curves": envelope(result.time_h, curves),
    }


def _round(x: float | None, digits: int = 6) -> float | None:
    return None if x is None else round(x, digits)


def analyse(schemes: list[Scheme], sources: Sources, site: Site, hours: float, step_deg: float = 5.0,
            max_step_s: float = 60.0, aligned: bool = False) -> tuple[dict, dict[str, SchemeResult]]:
    """Every scheme and the strapdown reference: the ``modulation.json`` document and the raw results.

    Returns
    -------
    (dict, dict of str -> SchemeResult)

    ``aligned``: the initial attitude error of each scheme is that of a static alignment at its start
    attitude (:meth:`Sources.aligned`) plus the sheet's initial errors; otherwise the sheet's alone.
    """
    def with_start(scheme):
        """The sources of one scheme: aligned at its start attitude, or as given."""
        return sources.aligned(site, scheme.start) if aligned else sources

    reference = run_scheme(STRAPDOWN, with_start(STRAPDOWN), site, hours, step_deg, max_step_s)
    results = {}
    for scheme in schemes:
        same = not scheme.steps and not scheme.initial_dwell and np.allclose(scheme.start, np.eye(3))
        results[scheme.name] = (dataclasses.replace(reference, scheme=scheme) if same  # the reference's numbers
                                else run_scheme(scheme, with_start(scheme), site, hours, step_deg, max_step_s))
    doc = {
        "latitude_deg": round(site.latitude / units.DEG, 9),
        "height_m": site.height,
        "hours": hours,
        "errors": {"name": sources.name, "origin": sources.origin,
                   "correlated": sources.correlated, "initial_attitude": "static alignment at the start "
                   "attitude plus the sheet's initial errors" if aligned else "the sheet's initial errors"},
        "turn_step_deg": step_deg,
        "output_step_s": max_step_s,
        "definitions": {
            "sigma": "every number is 1 sigma of the covariance propagation",
            "longitude_error_m": "east position error dlon (R_N + h) cos L",
            "latitude_error_m": "north position error dL (R_M + h)",
            "max_horizontal_position_error_m": "max over time of sqrt(P_NN + P_EE)",
            "ratio_to_strapdown": "the source's max position error under the scheme / under strapdown (null where "
                                  "the strapdown one rounds to zero, below 0.5 mm: an aligned strapdown IMU cancels "
                                  "some terms)",
            "not_averaged_away": "sensor error terms whose contribution is at least half their strapdown one (or "
                                 "that strapdown cancels) "
                                 "and at least 1 % of the scheme's total: the ones to calibrate best",
            "residual_drift_deg_h_per_sigma": "constant E, N, U gyro drift one period leaves of 1 sigma",
            "period_mean_tilt": "mean attitude error (E, N, U, arcsec) over the first period of 1 sigma of each "
                                "term (accelerometers as the equivalent tilt df/g), and 2 R x its horizontal part "
                                "(m): the Schuler swing it drives; the total 2 R sqrt(M_h P M_h^T) predicts the "
                                "covariance maximum until a residual drift ramps past it (None: strapdown)",
            "curves": "block maxima (envelope) of the 1-sigma curves, at most 600 points",
            "deterministic_plus_one_sigma": "noise-free error with every constant source at +1 sigma "
                                            "(the papers' fixed-value simulations; correlations ignored)",
            "vertical_channel": "held at the known height (no vertical velocity/height error states)",
        },
        "schemes": {name: summarise(res, reference, with_start(res.scheme), site) for name, res in results.items()},
    }
    return doc, results


def load_schemes(names: list[str]) -> list[Scheme]:
    """Schemes by file or shipped name (:func:`schemes.load_scheme`)."""
    return [load_scheme(n) for n in names]
