"""Predicted accuracy of a schedule, before any data: the covariance of the NLP's linearisation.

For a problem file the experiment is simulated without noise at its truth; for a recording its own
schedule and data are used around the rough initial values.  The NLP's residual Jacobian there,
weighted with the stated noise (accelerometer and gyro white noise per sample, and the white velocity
noise of integer pulses), gives the covariance ``(J^T W J)^-1`` that an efficient estimate reaches:
the Cramer-Rao bound of this noise model.  No Monte Carlo is needed (Guan et al. 2023).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd

from ..calibrate.initial import rough_parameters
from ..calibrate.nlp.graph import build_graph, variable_scale
from ..calibrate.nlp.selection import model_groups
from ..calibrate.steps import default_observation_spacing
from ..core.toml import read_toml
from ..core.units import ARW_UNIT, VRW_UNIT
from ..data.description import read_recording
from ..data.problem import Problem, load_problem
from ..data.recording import Recording
from ..core.files import safe_stem
from ..data.tables import write_table
from ..model.noise import SensorNoise
from ..model.parameters import ParameterSet
from ..model.registry import ACCEL_SCALE, CORE_SPANS, GYRO_SCALE, GROUPS, N_PARAMS, NAMES, SCALE_MASK, group_of, groups_in, model_names, natural_unit_of
from ..noise.kalman import NoiseSystem
from ..noise.plan import plan_noise
from ..report.plots import legend_outside, pyplot, save_figure
from ..report.rounding import display
from ..report.tables import write_frame
from ..sim import simulate

#: A parameter is reported weakly observable when its predicted sigma exceeds this many times the
#: best one of its group (natural units), or its group's ``weak_level`` (:mod:`model.registry`).
WEAK_RATIO = 3.0


@dataclasses.dataclass
class Prediction:
    """Predicted 1-sigma of a schedule's parameters at a noise model, and the weakly observable ones."""

    name: str
    nominal: ParameterSet  # nominal values with the predicted covariance
    sigma_natural: np.ndarray
    weak: list[str]
    noise: SensorNoise

    def frame(self) -> pd.DataFrame:
        """Parameter-table layout (``parameter,unit,value,sigma``) plus natural units."""
        frame = self.nominal.to_frame()[["parameter", "unit", "value", "sigma"]]
        frame["natural unit"] = self.nominal.natural_units
        frame["sigma (natural)"] = self.sigma_natural
        frame["weakly observable"] = [n in self.weak for n in self.nominal.names]
        return frame




def predict(rec: Recording, nominal, noise: SensorNoise, name: str | None = None, model="21") -> Prediction:
    """Predicted covariance of the parameters for a recording's schedule and a sensor noise model.

    The NLP's residual Jacobian at ``nominal``, whitened by the Kalman filter of the noise model
    (:mod:`noise.kalman`), gives ``(J_w^T J_w)^-1``: the Cramer-Rao bound of that model.  ``model`` adds
    the extra groups (:func:`calibrate.nlp.selection.model_groups`): their sigma shows what a schedule can see of lever arms,
    a time offset and quadratic scale.
    """
    names = model_names(model_groups(model))
    nominal = nominal.aligned(names) if isinstance(nominal, ParameterSet) else np.asarray(nominal, float)
    if len(nominal) < len(names):
        nominal = np.concatenate([nominal, [group_of(n).prior for n in names[len(nominal):]]])
    built = build_graph(rec, nominal, default_observation_spacing(rec), names=names)
    z = np.zeros(built.n_variables)
    _, jac = built.jacobian(z)
    system = NoiseSystem(built.tracks(np.asarray(built.trajectory(z)), True), rec.site.g, rec.site.earth_rate)
    jw = system.whiten(np.asarray(jac), noise).columns
    u, s, vt = np.linalg.svd(jw, full_matrices=False)
    cov_z = (vt.T / s**2) @ vt
    n = len(names)
    scale = variable_scale(nominal, names)
    covariance = cov_z[:n, :n] * np.outer(scale, scale)
    sigma_nat = np.sqrt(np.diag(cov_z)[:n])
    weak = []
    spans = [sl for _, sl, _ in CORE_SPANS]
    offset = N_PARAMS
    for key in groups_in(names):
        spans.append(slice(offset, offset + len(GROUPS[key].names)))
        offset += len(GROUPS[key].names)
    for sl in spans:
        best = sigma_nat[sl].min()
        for i in range(sl.start, sl.stop):
            if sigma_nat[i] > WEAK_RATIO * best or sigma_nat[i] > group_of(names[i]).weak_level:
                weak.append(names[i])
    return Prediction(name or rec.name, ParameterSet(nominal, covariance=covariance, names=names), sigma_nat,
                      weak, noise)


def predict_problem(problem: Problem, model="21") -> Prediction:
    """Predicted accuracy of a problem's schedule at its stated noise (noise-free simulation at truth)."""
    sim = simulate(problem, seed=0, noise=False)
    dt = 1.0 / problem.rate_hz
    truth = problem.truth.values
    noise = SensorNoise.from_deviations(problem.deviations, dt, truth[GYRO_SCALE], truth[ACCEL_SCALE])
    return predict(sim.recording, problem.truth, noise, name=problem.name, model=model)


def predict_problem_ils(problem: Problem) -> np.ndarray:
    """Predicted 1-sigma (natural units) of the paper's ILS on a problem's schedule at its stated noise: its
    equations' covariance on a noise-free simulation at the truth
    (:func:`calibrate.ils.predicted.predicted_covariance`).  The ILS aligns each group on its first position, so on schedules of few
    groups it can be far from the NLP's (:func:`predict_problem`)."""
    from ..calibrate.ils.predicted import predicted_covariance

    sim = simulate(problem, seed=0, noise=False)
    truth = problem.truth.values[:N_PARAMS]
    noise = SensorNoise.from_deviations(problem.deviations, 1.0 / problem.rate_hz, truth[GYRO_SCALE],
                                        truth[ACCEL_SCALE])
    cov = predicted_covariance(sim.recording, truth, noise)
    relative = np.sqrt(np.diag(cov))
    return ParameterSet(truth, sigma=relative * np.where(SCALE_MASK, np.abs(truth), 1.0)).natural_sigma()


def predict_file(path: str | Path, accel_vrw_ug_rthz: float | None = None, gyro_arw_deg_rth: float | None = None,
                 noise: SensorNoise | None = None, model="21") -> Prediction:
    """Predicted accuracy for a problem file or a recording (TOML), told apart by their ``format``.

    A problem states its noise; for a recording the noise is measured in its raw data (``noise``, a
    datasheet, overrides); ``accel_vrw_ug_rthz`` (ug/sqrt(Hz)) / ``gyro_arw_deg_rth`` (deg/sqrt(h)), the
    white noise densities of a datasheet, override both.
    """
    path = Path(path)
    fmt = str(read_toml(path, "problem file or recording description").get("format", ""))
    if fmt.startswith("casadi-sins-problem"):
        problem = load_problem(path)
        changes = {}
        if accel_vrw_ug_rthz is not None:  # the stated density replaces the problem's white noise
            changes.update(accel_vrw_ug_rthz=accel_vrw_ug_rthz, accel_noise_ug=0.0)
        if gyro_arw_deg_rth is not None:
            changes.update(gyro_arw_deg_rth=gyro_arw_deg_rth, gyro_noise_deg_h=0.0)
        return predict_problem(problem.with_changes(**changes) if changes else problem, model)
    rec = read_recording(path)
    nominal = rough_parameters(rec).values
    model_noise = plan_noise(rec, nominal, noise).model
    if accel_vrw_ug_rthz is not None:
        model_noise.accel_vrw = np.full(3, accel_vrw_ug_rthz * VRW_UNIT)
    if gyro_arw_deg_rth is not None:
        model_noise.gyro_arw = np.full(3, gyro_arw_deg_rth * ARW_UNIT)
    return predict(rec, nominal, model_noise, model=model)


def describe_noise(noise: SensorNoise) -> str:
    """The noise model in one line of natural units."""
    nat = noise.complete().natural()
    text = (f"ARW {np.mean(nat['gyro_arw_deg_rth']):.3g} deg/sqrt(h), VRW {np.mean(nat['accel_vrw_ug_rthz']):.3g} "
            "ug/sqrt(Hz)")
    if np.any(nat["accel_quantization_mm_s"] > 0):
        text += f", quantization {np.mean(nat['accel_quantization_mm_s']):.3g} mm/s"
    if nat["gyro_bias_instability_deg_h"] or nat["accel_bias_instability_ug"]:
        text += (f", bias instability {nat['gyro_bias_instability_deg_h']:.3g} deg/h "
                 f"({nat['gyro_bias_tau_s']:g} s), {nat['accel_bias_instability_ug']:.3g} ug "
                 f"({nat['accel_bias_tau_s']:g} s)")
    return text


def comparison_frame(predictions: list[Prediction]) -> pd.DataFrame:
    """Predicted sigma of several schedules side by side."""
    names = list(dict.fromkeys(n for pred in predictions for n in pred.nominal.names))
    frame = pd.DataFrame({"parameter": names, "natural unit": [natural_unit_of(n) for n in names]})
    for pred in predictions:
        lookup = dict(zip(pred.nominal.names, pred.sigma_natural))
        frame[f"{pred.name} sigma"] = [lookup.get(n, np.nan) for n in names]
        frame[f"{pred.name} weak"] = [n in pred.weak for n in names]
    return frame


def plot_predictions(predictions: list[Prediction], path: str | Path) -> Path:
    """Bars of the predicted sigma per parameter group and schedule."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 3, figsize=(14, 7))
    width = 0.8 / len(predictions)
    for ax, (label, sl, unit) in zip(axes.ravel(), CORE_SPANS):
        names = [n.split("_", 2)[-1] for n in NAMES[sl]]
        x = np.arange(len(names))
        for k, pred in enumerate(predictions):
            ax.bar(x + k * width, pred.sigma_natural[sl], width, label=pred.name)
        ax.set_xticks(x + width * (len(predictions) - 1) / 2, names)
        ax.set_title(f"{label} ({unit}, 1 sigma)", fontsize=10)
        ax.set_ylim(bottom=0)
    legend_outside(axes[0, 0], fontsize=8)
    fig.suptitle("Predicted accuracy of each schedule (covariance of the NLP's linearisation)")
    fig.tight_layout()
    return save_figure(fig, path)


def analysis_display(table: pd.DataFrame) -> pd.DataFrame:
    """The schedules' predicted sigmas as people read them: two significant digits, natural units."""
    return display(table, sigmas=[c for c in table.columns if c.endswith(" sigma")])


def write_analysis(predictions: list[Prediction], out_dir: str | Path) -> pd.DataFrame:
    """Write each prediction's table and the comparison (CSV, Markdown, PNG); returns the comparison."""
    out_dir = Path(out_dir)
    for pred in predictions:
        stem = safe_stem(pred.name)  # a recording's name may be "../../x" or absolute: never a path
        write_table(out_dir / f"{stem}-predicted.csv", pred.nominal)
        frame = pred.frame()
        write_frame(frame, out_dir / f"{stem}-predicted-natural",
                    f"{pred.name}: predicted 1-sigma at {describe_noise(pred.noise)}",
                    display=display(frame, {"value": "sigma"}, sigmas=["sigma (natural)"]))
    table = comparison_frame(predictions)
    if len(predictions) > 1:
        write_frame(table, out_dir / "schedules-predicted", "Predicted 1-sigma per schedule (natural units)",
                    display=analysis_display(table))
    plot_predictions(predictions, out_dir / ("schedules-predicted.png" if len(predictions) > 1
                                             else f"{safe_stem(predictions[0].name)}-predicted.png"))
    return table
