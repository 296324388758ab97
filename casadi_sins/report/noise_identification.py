"""The products of ``casadi-sins noise`` in natural units: the JSON, the Markdown report, the Allan deviation plots.

Natural units (SI inside): gyros in deg/h (Allan deviation, Gauss-Markov sigma), deg/sqrt(h) (angle random
walk), arcsec (quantization); accelerometers in ug, ug/sqrt(Hz), mm/s.  Without scale factors everything is
in pulses, and says so in every label.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np

from ..core.units import ARCSEC, ARW_UNIT, DEG_PER_H, UG, VRW_UNIT
from ..core.version import build_identity
from ..noise.identify import DETECTION, TAU_FRACTION, UPPER_LR, AxisFit, Estimate
from ..noise.allan import BAND
from ..noise.terms import FLICKER_FLOOR, GM_PEAK_FRACTION, GM_PEAK_TAU, allan_variance, gauss_markov_allan
from .plots import figure_bytes, pyplot


@dataclasses.dataclass(frozen=True)
class Units:
    """Sizes (in the data's unit) and names of the quantities of one sensor."""

    rate: tuple[float, str]  # Allan deviation, Gauss-Markov sigma
    white: tuple[float, str]
    quantization: tuple[float, str]
    random_walk: tuple[float, str]  # rate random walk sigma sqrt(2 / T)


NATURAL = {"gyro": Units((DEG_PER_H, "deg/h"), (ARW_UNIT, "deg/sqrt(h)"), (ARCSEC, "arcsec"),
                         (DEG_PER_H / 60.0, "deg/h/sqrt(h)")),
           "accel": Units((UG, "ug"), (VRW_UNIT, "ug/sqrt(Hz)"), (1e-3, "mm/s"), (UG / 60.0, "ug/sqrt(h)"))}
PULSES = Units((1.0, "pulse/s"), (1.0, "pulse/sqrt(s)"), (1.0, "pulse"), (1.0, "pulse/s/sqrt(s)"))
SENSOR_NAMES = {"gyro": "gyros", "accel": "accelerometers"}


def units_of(study, sensor: str) -> Units:
    """The units of a sensor's quantities in a study (natural with a scale, else pulses)."""
    return NATURAL[sensor] if study.scale.si else PULSES


def _natural(estimate: Estimate, size: float) -> dict:
    out = estimate.scaled(1.0 / size).as_dict()
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}


def axis_summary(study, axis: int) -> dict:
    """One axis's terms in natural units (the JSON's ``axes`` entry)."""
    fit: AxisFit = study.identification.fits[axis]
    sensor = "gyro" if axis < 3 else "accel"
    units = units_of(study, sensor)
    adev, tau, floor = study_floor(study, axis)
    return {"white": _natural(fit.white, units.white[0]), "white_unit": units.white[1],
            "quantization": _natural(fit.quantization, units.quantization[0]),
            "quantization_unit": units.quantization[1],
            "gauss_markov_sigma": _natural(fit.gm_sigma, units.rate[0]), "gauss_markov_sigma_unit": units.rate[1],
            "gauss_markov_tau_s": _natural(fit.gm_tau, 1.0), "gauss_markov": fit.status,
            "maximum_likelihood": {"sigma": fit.terms.gm_sigma / units.rate[0] if fit.terms.gm_sigma else 0.0,
                                   "tau_s": fit.terms.gm_tau if math.isfinite(fit.terms.gm_tau) else None},
            "likelihood_ratio": fit.likelihood_ratio,
            "rate_random_walk": fit.rate_random_walk / units.random_walk[0], "rate_random_walk_unit": units.random_walk[1],
            "allan_floor": {"adev": adev / units.rate[0], "tau_s": tau, "over_0.664": floor / units.rate[0]},
            "counter": bool(study.integer[axis]),
            "spectral_check": {"z": fit.check.z, "frequency_hz": fit.check.frequency_hz, "ratio": fit.check.ratio,
                               "passed": fit.check.passed}}


def noise_json(study) -> str:
    """The JSON report (every number; Allan deviation in the sensor's rate unit)."""
    ident = study.identification
    notes, warnings = study.messages()
    allan = {"tau_s": ident.allan.tau.tolist(), "terms": ident.allan.terms.tolist(), "band": BAND}
    for axis, name in enumerate(ident.axes):
        size = units_of(study, "gyro" if axis < 3 else "accel").rate[0]
        allan[name] = {"adev": (ident.allan.adev[:, axis] / size).tolist(),
                       "band_low": (ident.band[0, :, axis] / size).tolist(),
                       "band_high": (ident.band[1, :, axis] / size).tolist(),
                       "dof": [min(float(d), 1e12) for d in ident.dof[:, axis]]}
    sheet = study.datasheet()
    doc = {"command": "noise", "software": build_identity(), "created": study.created, "inputs": study.inputs,
           "recording": study.run.name, "samples_from": study.run.label, "rate_hz": ident.rate_hz,
           "samples": study.samples, "duration_s": ident.duration, "seconds": study.seconds,
           "scale": study.scale.source, "in_pulses": not study.scale.si,
           "units": {s: dataclasses.asdict(units_of(study, s)) for s in ("gyro", "accel")},
           "axes": {name: axis_summary(study, i) for i, name in enumerate(ident.axes)},
           "datasheet": None if sheet is None else {k: (v.tolist() if isinstance(v, np.ndarray) else v)
                                                    for k, v in sheet[0].natural().items() if v is not None},
           "notes": notes, "warnings": warnings, "allan": allan}
    return json.dumps(_plain(doc), indent=1, allow_nan=False) + "\n"


def _plain(value):
    """JSON values: NumPy numbers and arrays as Python's, a number that is not finite as null."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.integer, np.bool_)):
        return value.item()
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


def shown(estimate: Estimate, size: float) -> str:
    """An estimate in a table cell: ``value +- sigma``, ``< bound``, ``>= bound`` or ``-``."""
    if estimate.kind == "none" or not math.isfinite(estimate.value):
        return "-"
    value = estimate.value / size
    if estimate.kind == "upper bound":
        return f"< {value:.3g}"
    if estimate.kind == "lower bound":
        return f">= {value:.3g}"
    sigma = estimate.sigma / size if estimate.sigma is not None and math.isfinite(estimate.sigma) else None
    return f"{value:.4g} ± {sigma:.2g}" if sigma is not None else f"{value:.4g}"


def noise_markdown(study) -> str:
    """The Markdown report: what was read, one table per sensor, the notes, the plots, the datasheet."""
    ident = study.identification
    notes, warnings = study.messages()
    lines = [f"# Noise of {study.run.name}", "",
             f"- samples: {study.run.label}; {study.samples} samples at {ident.rate_hz:g} Hz, "
             f"{ident.duration / 3600:.4g} h at rest",
             f"- scale: {study.scale.source}",
             f"- software: {build_identity()}; {study.created}; {study.seconds:.1f} s",
             *[f"- input `{path}`: sha256 `{digest}`" for path, digest in study.inputs.items()], ""]
    for sensor, rows in (("gyro", range(3)), ("accel", range(3, 6))):
        units = units_of(study, sensor)
        lines += [f"## {SENSOR_NAMES[sensor].capitalize()}", "",
                  f"| axis | white ({units.white[1]}) | quantization ({units.quantization[1]}) | Gauss-Markov sigma "
                  f"({units.rate[1]}) | correlation time (s) | 2 ln LR | Allan floor ({units.rate[1]}) at tau (s) |",
                  "| --- | --- | --- | --- | --- | --- | --- |"]
        for axis in rows:
            fit = ident.fits[axis]
            adev, tau, _ = study_floor(study, axis)
            tau_cell = shown(fit.gm_tau, 1.0)
            if fit.status == "determined" and fit.gm_tau.low is not None:
                tau_cell += f" (95 %: {fit.gm_tau.low:.3g}-{fit.gm_tau.high:.3g})"
            lines.append(f"| {ident.axes[axis]} | {shown(fit.white, units.white[0])} | "
                         f"{shown(fit.quantization, units.quantization[0])} | {shown(fit.gm_sigma, units.rate[0])} | "
                         f"{tau_cell} | {fit.likelihood_ratio:.1f} | {adev / units.rate[0]:.3g} at {tau:.3g} |")
        lines += ["", f"![Allan deviation of the {SENSOR_NAMES[sensor]}](allan-{sensor}.png)", ""]
    lines += ["## What the numbers are", "",
              "Each axis is fitted with white rate noise (angle or velocity random walk), quantization of the "
              "accumulated angle or velocity, and a first-order Gauss-Markov bias, by the likelihood of the "
              "record's periodograms (docs/noise-model.md, *Noise identification from a long rest*). "
              "`± x` is one standard error, intervals are 95 %; `<` is a one-sided 95 % upper bound "
              f"(2 ln LR = {UPPER_LR:g}), `>=` a lower bound.",
              "",
              "**The Gauss-Markov sigma is the bias's steady-state 1 sigma**, the `*_bias_instability_*` of the "
              f"datasheet `calibrate --noise` reads. Its Allan deviation peaks at {GM_PEAK_FRACTION:.3f} sigma at "
              f"{GM_PEAK_TAU:.2f} times its correlation time; the *Allan floor* column is the minimum of the "
              f"measured Allan deviation, and a vendor's \"bias instability\" is usually that floor over "
              f"{FLICKER_FLOOR} (a flicker noise's coefficient), about {GM_PEAK_FRACTION / FLICKER_FLOOR:.2f} sigma "
              "for a Gauss-Markov bias alone.",
              "", f"Band on the plots: {BAND * 100:.0f} % of the overlapping Allan deviation's estimate, from its "
              "equivalent degrees of freedom under the fitted terms. The Gauss-Markov term counts when twice "
              f"its log-likelihood ratio exceeds {DETECTION:g}; an undetected one is bounded for correlation times up to "
              f"{TAU_FRACTION:g} of the record.", ""]
    if warnings:
        lines += ["## Warnings", ""] + [f"- {w}" for w in warnings] + [""]
    if notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    sheet = study.datasheet()
    if sheet is not None:
        from ..data.datasheet import datasheet_toml
        lines += ["## Datasheet for `calibrate --noise`", "", "`datasheet.toml`:", "", "```toml",
                  datasheet_toml(*sheet).rstrip(), "```", ""]
    else:
        lines += ["## Datasheet", "", "Not written: the noise is in pulses. Give the unit's scale factors "
                  "(`--params` a calibration's table, or `--scale` nominal pulse weights) for SI and the datasheet.", ""]
    return "\n".join(lines)


def study_floor(study, axis: int) -> tuple[float, float, float]:
    """``(Allan deviation minimum, its tau, over 0.664)`` of an axis."""
    adev, tau = study.identification.floor(axis)
    return adev, tau, adev / FLICKER_FLOOR


def allan_figure(study, sensor: str) -> bytes:
    """The Allan deviation of a sensor triad: the estimates with their band and the fitted terms (PNG)."""
    plt = pyplot()
    ident = study.identification
    units = units_of(study, sensor)
    size, label = units.rate
    first = 0 if sensor == "gyro" else 3
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.4), sharey=True)
    tau = ident.allan.tau
    fine = np.geomspace(tau[0], tau[-1], 200)
    for k, ax in enumerate(axes):
        axis = first + k
        fit = ident.fits[axis]
        terms = fit.terms
        ax.fill_between(tau, ident.band[0, :, axis] / size, ident.band[1, :, axis] / size, color="C0", alpha=0.25,
                        lw=0, label=f"{BAND * 100:.0f} % band")
        ax.loglog(tau, ident.allan.adev[:, axis] / size, "o", ms=2.5, color="C0", label="overlapping Allan deviation")
        ax.loglog(fine, np.sqrt(terms.allan_variance(fine)) / size, "k-", lw=1.2, label="fitted terms")
        parts = (("white", np.sqrt(allan_variance(fine, terms.white)), "C1"),
                 ("quantization", np.sqrt(allan_variance(fine, 0.0, terms.quantization)), "C2"))
        if terms.gm_sigma > 0:
            parts += (("Gauss-Markov", terms.gm_sigma * np.sqrt(gauss_markov_allan(fine / terms.gm_tau)), "C3"),)
        for name, values, color in parts:
            if np.any(values > 0):
                ax.loglog(fine, values / size, "--", lw=0.9, color=color, label=name)
        ax.set_title(f"{ident.axes[axis]}: {fit.status}", fontsize=10)
        ax.set_xlabel("cluster time tau (s)")
        ax.grid(True, which="both", lw=0.3)
    axes[0].set_ylabel(f"Allan deviation ({label})")
    low = np.nanmin(ident.band[0, :, first:first + 3] / size)
    high = np.nanmax(ident.band[1, :, first:first + 3] / size)
    if math.isfinite(low) and math.isfinite(high) and low > 0:
        axes[0].set_ylim(low / 2.0, high * 2.0)
    seen = {}
    for ax in axes:  # one legend for the three panels, every line once
        for handle, text in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(text, handle)
    axes[-1].legend(list(seen.values()), list(seen), fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0),
                    borderaxespad=0.0)
    fig.suptitle(f"{study.run.name}: Allan deviation of the {SENSOR_NAMES[sensor]}"
                 + ("" if study.scale.si else " (in pulses: no scale factors given)"))
    return figure_bytes(fig)
