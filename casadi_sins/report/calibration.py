"""The report of a calibration: what an engineer needs to trust (or refuse) a parameter table.

Written beside the parameter table (its companion, ``NAME.report.json`` and ``NAME.report.md``) and,
with ``--report DIR``, with plots and the per-iteration table.  It carries: provenance (software
version, date, recording hash), the table in natural units with sigma, the noise model (measured in
the raw data, given, fitted) in ARW/VRW units, every warning, every consistency check, the solver's
status (Ipopt status and iterations, the post-solve steps), the most correlated parameter pairs and
the base motion found.
"""

from __future__ import annotations

import functools
import hashlib
import math
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd

from ..calibrate.result import CalibrationResult
from ..calibrate.wander import INCLUDE_LR, SENSOR_WORDS, TAU_WORDS, p_value
from ..core.units import DEG_PER_H, UG
from ..data.conditions import conditions_dict
from ..data.record import CalibrationRecord, companion_paths, parameter_rows  # noqa: F401 (also read from here)
from ..data.recording import Recording
from ..model.noise import SensorNoise
from ..model.parameters import ParameterSet
from ..core.text import markdown_text, plural
from .acceptance import Verdict
from .certificate import certificate_html, certificate_number, certificate_pdf
from .exports import EXPORTS, export_path
from .grade import grade_data, grade_markdown
from .plots import noise_plot, residual_plot
from .rounding import parameter_display
from .tables import calibration_tables, checks_frame, markdown_table, natural_noise_frame


def recording_hash(rec) -> str | None:
    """SHA-256 over the recording's TOML and data files (None for a recording made in memory)."""
    if rec.source is None:
        return None
    paths = [Path(rec.source)]
    try:
        data = tomllib.loads(paths[0].read_text(encoding="utf-8")).get("data")
        if data:
            paths.append(paths[0].parent / data)
        # the table's metadata and the report both ask: the files are read once while they are unchanged
        return _files_hash(tuple((str(path), path.stat().st_size, path.stat().st_mtime_ns) for path in paths))
    except (OSError, ValueError):
        return None


@functools.lru_cache(maxsize=8)
def _files_hash(files: tuple) -> str:
    digest = hashlib.sha256()
    for path, _, _ in files:
        with open(path, "rb") as handle:
            for block in iter(lambda: handle.read(1 << 20), b""):
                digest.update(block)
    return digest.hexdigest()


def strongest_correlations(params: ParameterSet, count: int = 6) -> list[dict]:
    """The most correlated parameter pairs (the weakly separated directions of the schedule)."""
    if params.covariance is None:
        return []
    sd = np.sqrt(np.diag(params.covariance))
    corr = params.covariance / np.outer(sd, sd)
    n = len(params.names)
    pairs = sorted(((abs(corr[i, j]), i, j) for i in range(n) for j in range(i + 1, n)), reverse=True)
    return [{"a": params.names[i], "b": params.names[j], "correlation": float(corr[i, j])}
            for _, i, j in pairs[:count]]


def _noise_dict(noise: SensorNoise | None) -> dict | None:
    if noise is None:
        return None
    out = {}
    for key, value in noise.complete().natural().items():
        out[key] = value.tolist() if isinstance(value, np.ndarray) else float(value)
    out["unmodelled_acceleration_ug"] = noise.unmodelled_acceleration / UG
    out["unmodelled_rate_deg_h"] = noise.unmodelled_rate / DEG_PER_H
    out["unmodelled_step_mm_s"] = noise.unmodelled_step * 1e3
    return out


def _wander_dict(wander: dict) -> dict | None:
    """The bias instability the static data show (:mod:`calibrate.wander`), per sensor in natural units (ug,
    deg/h); ``upper`` ``None`` when the data do not bound it."""
    if not wander:
        return None
    unit = {s: scale for s, (_, _, scale) in SENSOR_WORDS.items()}
    return {s: {"sigma": w.sigma / unit[s], "upper": w.upper / unit[s] if math.isfinite(w.upper) else None,
                "lr": w.lr, "lr_threshold": INCLUDE_LR[s], "p_value": p_value(w.lr), "tau_s": w.tau,
                "included": bool(w.included), "mismatch": bool(w.mismatch), "bias_sigma_factor": w.cost}
            for s, w in wander.items()}


def report_data(result: CalibrationResult, rec: Recording, truth: ParameterSet | None = None, command: str | None = None,
                unit_id: str | None = None, verdict: Verdict | None = None) -> dict:
    """Everything of the report as plain data (the JSON file, :func:`calibration_record`)."""
    return calibration_record(result, rec, truth, command, unit_id, verdict).report


def calibration_record(result: CalibrationResult, rec: Recording, truth: ParameterSet | None = None,
                       command: str | None = None, unit_id: str | None = None,
                       verdict: Verdict | None = None) -> CalibrationRecord:
    """The record of a calibration (:class:`data.record.CalibrationRecord`): its table, provenance, conditions and
    warnings, and as details the solver's status, the checks, the noise, the grade and the base motion; with a
    ``verdict`` (:func:`report.acceptance.judge`) also ``"verdict"`` (``"pass"`` or ``"fail"``) and
    ``"acceptance"`` (its reasons and sheet)."""
    raw = result.noise.raw
    checks = [c.as_dict() for c in result.checks]
    motion = result.base_motion
    details = {
        "converged": bool(result.success),
        "iterations": int(result.nit),
        "wall_time_s": float(result.wall_time),
        "sigma_meaning": result.sigma_meaning,
        "status": int(result.status),
        "message": result.message,
        "notes": list(result.notes),
        "distrusted": list(result.distrust),
        "checks": checks,
        "variance_factor": float(result.variance_factor),
        "grade": grade_data(result.parameters, rec),
        "strongest_correlations": strongest_correlations(result.parameters),
        "noise": {"model": _noise_dict(result.noise.model), "fitted": _noise_dict(result.noise.fitted),
                  "raw": _noise_dict(raw.model().merged(raw.upper_bounds()) if raw is not None else None),
                  "raw_determined": ({s: [t.determined for t in raw.white[s]] for s in raw.white}
                                     if raw is not None else None),
                  "sources": dict(result.noise.sources), "bias_wander": _wander_dict(result.noise.bias_wander)},
        "base_motion": [{"segment": m.segment, "amplitude_arcsec": m.amplitude_arcsec,
                         "period_s": None if not np.isfinite(m.period_s) else m.period_s,
                         "significant": m.significant,
                         **({"tapered_mean": _taper_dict(m.taper)} if m.taper is not None else {})}
                        for m in motion],
        "linear_base_motion": _linear_motion_dict(result.linear_motion),
    }
    if result.nlp is not None:
        nlp = result.nlp
        details["ipopt"] = {"status": nlp.ipopt_status, "iterations": nlp.ipopt_iterations}
        details["post_solve_steps_sigma"] = [float(s) for s in nlp.gls_steps]
        details["rotation_steps_used"] = bool(nlp.rotation_steps_used)
        details["start_offsets_arcsec"] = {str(g): [float(x) for x in v] for g, v in nlp.start_offsets_arcsec.items()}
        details["model"] = {"extra_groups": list(nlp.model), "selection": nlp.model_selection,
                         "left_out": nlp.left_out}
    if result.ils is not None:
        details["equations"] = result.ils.equations
    recording = {"name": rec.name, "source": str(rec.source) if rec.source else None, "sha256": recording_hash(rec),
                 "samples": int(len(rec.time)), "rate_hz": rec.rate_hz, "groups": len(rec.group_ids),
                 "segments": len(rec.segments), "latitude_deg": math.degrees(rec.site.latitude),
                 "gravity_mps2": rec.site.g}
    return CalibrationRecord.of_calibration(
        result.parameters, solver=result.solver, command=command,
        unit_id=unit_id or rec.conditions.unit_id,  # --unit-id, else the recording's
        recording=recording, conditions=conditions_dict(rec), warnings=result.warnings, details=details,
        verdict=verdict and verdict.verdict, acceptance=verdict and verdict.as_dict(), truth=truth)


def report_markdown(data: dict) -> str:
    """The report as Markdown."""
    rec = data["recording"]
    lines = [f"# Calibration report: {markdown_text(rec['name'])} ({data['solver']})", "",
             f"- unit: {markdown_text(data.get('unit_id') or '(no --unit-id given)')}",
             f"- software: {data['software']}, created {data['created']}",
             "- versions: " + ", ".join(f"{k} {v}" for k, v in data.get("versions", {}).items()),
             f"- recording: {markdown_text(rec['source'] or '(in memory)')}, sha256 `{rec['sha256']}`",
             f"- {rec['samples']} samples at {rec['rate_hz']:g} Hz, {plural(rec['groups'], 'group')}, "
             f"{plural(rec['segments'], 'segment')}; latitude {rec['latitude_deg']:.6g} deg, gravity {rec['gravity_mps2']:.9g} m/s^2"]
    if data.get("table_sha256"):
        lines.append(f"- table: {markdown_text(data.get('table') or '')}, sha256 `{data['table_sha256']}`")
    if data.get("certificate"):
        lines.append(f"- certificate: {data['certificate']['number']} "
                     f"({markdown_text(data['certificate']['file'])})")
    if data.get("command"):
        lines.append(f"- command: {markdown_text(data['command'])}")
    lines += _verdict_lines(data)
    status = "converged" if data["converged"] else "NOT converged"
    if "ipopt" in data:
        ip = data["ipopt"]
        lines.append(f"- solver: NLP, Ipopt {ip['status']} after {ip['iterations']} iterations; generalised least "
                     "squares steps " + ", ".join(f"{s:.3g}" for s in data["post_solve_steps_sigma"]) + " sigma; "
                     f"velocity steps across rotations {'used' if data['rotation_steps_used'] else 'NOT used'}")
    else:
        lines.append(f"- solver: ILS (the paper's), {data['iterations']} iterations, {data['equations']} equations, "
                     f"{status}")
    lines.append(f"- wall time {data['wall_time_s']:.2f} s; sigma: {data['sigma_meaning']}")
    lines += _conditions_lines(data.get("conditions"))[:-1]
    lines += grade_markdown(data.get("grade"))
    if data.get("distrusted"):
        lines += ["", "## NOT TO BE TRUSTED", "", "The calibration's own checks do not trust this table; it was "
                  "written only because --accept-distrusted asked for it (exit status 4):", ""]
        lines += [f"- **{markdown_text(w)}**" for w in data["distrusted"]]
    lines += ["", "## Warnings", ""]
    lines += [f"- **{markdown_text(w)}**" for w in data["warnings"]] or ["- none"]
    if data.get("notes"):
        lines += ["", "## Notes", ""] + [f"- {markdown_text(n)}" for n in data["notes"]]
    lines += ["", "## Parameters", ""]
    lines.append(markdown_table(parameter_display(data), "%.3g"))
    lines += ["", "Values rounded to the second significant digit of their sigma; the full SI values (the table "
              "to load) are in the CSV; scale-factor sigma in ppm of the value.", "",
              "## Noise", ""]
    noise = data["noise"]
    models = {k: SensorNoise.from_natural(v) for k, v in (("raw data", noise["raw"]), ("in the model", noise["model"]),
                                                          ("implied by the fit", noise["fitted"])) if v}
    if models:
        lines.append(markdown_table(natural_noise_frame(models), "%.4g"))
        if noise.get("sources"):
            lines += ["", "Where each term of the model comes from: "
                      + ", ".join(f"{k} {v}" for k, v in noise["sources"].items()) + "."]
        for sensor, wander in (noise.get("bias_wander") or {}).items():
            lines += ["", _wander_sentence(sensor, wander)]
        model = noise["model"]
        if model and (model["unmodelled_acceleration_ug"] or model["unmodelled_rate_deg_h"]):
            lines += ["", f"Errors outside the model, added to it: {model['unmodelled_acceleration_ug']:.3g} ug "
                      f"per static segment, {model['unmodelled_rate_deg_h']:.3g} deg/h per static gyro mean."]
    lines += _model_lines(data.get("model"))
    lines += ["", "## Checks", ""]
    if data["checks"]:
        lines.append(markdown_table(checks_frame(data["checks"])))
    lines.append(f"\nVariance factor applied to the covariance: {data['variance_factor']:.4g}")
    if data["strongest_correlations"]:
        lines += ["", "## Most correlated parameters", "",
                  markdown_table(pd.DataFrame(data["strongest_correlations"]), "%+.3f")]
    moving = [{k: v for k, v in m.items() if k != "tapered_mean"} | _taper_columns(m.get("tapered_mean"))
              for m in data["base_motion"] if m["significant"]]
    linear = data.get("linear_base_motion") or {}
    if moving or linear.get("moving"):
        lines += ["", "## Base motion", ""]
    if linear.get("moving"):
        lines += [f"- {linear['description']}", "", markdown_table(pd.DataFrame(linear["lines"]), "%.3g"), ""]
    if moving:
        lines += ["Sway per static segment (angle amplitude and period; a swaying segment's gyro mean is tapered: "
                  "its window's time-half-bandwidth, its noise over a plain mean's, the sway's leakage bound):", "",
                  markdown_table(pd.DataFrame(moving), "%.3g")]
    return "\n".join(lines) + "\n"


def _taper_dict(taper) -> dict:
    """A tapered gyro mean (:class:`noise.taper.TaperChoice`) as plain data."""
    return {"nw": taper.nw, "noise_factor": taper.noise_factor,
            "leakage_deg_h": [float(x) for x in np.sqrt(taper.leakage) / DEG_PER_H]}


def _taper_columns(taper: dict | None) -> dict:
    """A tapered mean's columns of the sway table."""
    if not taper:
        return {}
    return {"taper_nw": taper["nw"], "noise_factor": taper["noise_factor"],
            "leakage_deg_h": max(taper["leakage_deg_h"])}


def _linear_motion_dict(linear) -> dict | None:
    """The base's linear motion (a deck's heave and surge) as plain data, ``None`` when it was not looked for."""
    if linear is None:
        return None
    return {"moving": bool(linear.moving), "significance": float(linear.significance), "excess": float(linear.excess),
            "description": linear.describe(),
            "lines": [{"segment": line.segment, "period_s": line.period_s,
                       "acceleration_mg": line.amplitude / 9.80665 * 1e3, "displacement_cm": line.displacement * 100,
                       "velocity_mm_s": line.velocity * 1e3} for line in linear.lines] if linear.moving else []}


def _conditions_lines(conditions: dict | None) -> list[str]:
    """The recording conditions (Markdown lines, before the solver's)."""
    lines = ["", "## Conditions", ""]
    if not conditions:
        return lines + ["- none given (add a [conditions] table to the description: temperature_c, date, operator, "
                        "bench, unit_id)", ""]
    words = {"temperature_c": "temperature", "date": "recorded", "operator": "operator", "bench": "bench",
             "unit_id": "unit id (description)"}
    for key, word in words.items():
        if key in conditions:
            value = conditions[key]
            text = f"{value:.3g} degC" if key == "temperature_c" else markdown_text(str(value))
            if key == "temperature_c" and conditions.get("temperature_source"):
                text += f" ({conditions['temperature_source']})"
            lines.append(f"- {word}: {text}")
    return lines + [""]
def _verdict_lines(data: dict) -> list[str]:
    """The verdict against the tolerance sheet and its reasons (Markdown list lines; none without a sheet)."""
    if "verdict" not in data:
        return []
    acc = data.get("acceptance") or {}
    lines = [f"- **verdict: {data['verdict'].upper()}** against {markdown_text(acc.get('sheet') or 'the tolerance sheet')}"
             f" ({acc.get('judged', 0)} parameters with a limit)"]
    return lines + [f"  - {markdown_text(r)}" for r in acc.get("reasons", [])]


def _wander_sentence(sensor: str, v: dict) -> str:
    """One sentence on a sensor's bias instability without a datasheet: modelled from the static data, or not
    and how large it could be."""
    name, unit, _ = SENSOR_WORDS[sensor]
    if v["included"]:
        return (f"Bias instability of the {name} from the static data (no datasheet): {v['sigma']:.3g} {unit}, "
                f"Gauss-Markov with an assumed correlation time of {v['tau_s']:.0f} s ({TAU_WORDS}), likelihood "
                f"ratio {v['lr']:.3g} against none (p = {_p(v)}, threshold {v['lr_threshold']:.3g}); it widened "
                f"the bias sigmas up to {v.get('bias_sigma_factor', 1.0):.3g} times.")
    bound = (f"95 % upper bound {v['upper']:.3g} {unit}" if v["upper"] is not None else "not bounded by the data")
    seen = (f"what the static data show of a wander (likelihood ratio {v['lr']:.3g}) is explained better by an "
            "acceleration in each static segment: a model mismatch, left to the checks" if v["mismatch"] else
            f"the static data show no wander beyond the white noise (likelihood ratio {v['lr']:.3g} against none, "
            f"p = {_p(v)}, threshold {v['lr_threshold']:.3g})")
    return (f"Bias instability is not modelled for the {name}: no datasheet value was given and {seen}; {bound} at "
            f"a correlation time of {v['tau_s']:.0f} s. The sigma of the biases excludes an instability below that "
            "bound, and any part of it constant over the recording: give the datasheet (`--noise`).")


def _p(v: dict) -> str:
    """A wander's p-value in words (reports written before it was stored give it from the ratio)."""
    return f"{v.get('p_value', p_value(v['lr'])):.2g}"


def _model_lines(model: dict | None) -> list[str]:
    """The parameter model and, with ``--model auto``, the selection of each extra group (Markdown lines)."""
    if not model:
        return []
    extras = model.get("extra_groups") or []
    lines = ["", "## Parameter model", "",
             f"- estimated: the 21 of eq. 1{' + ' + ', '.join(extras) if extras else ''}; terms not estimated are at "
             "their prior (0)"]
    for key, choice in (model.get("selection") or {}).items():
        lines.append(f"- {key}: Wald statistic {choice['statistic']:.3g} against {choice['threshold']:.3g} "
                     f"(k ln n): {'kept' if choice['selected'] else 'left at 0'}")
    lines += [f"- {left['note']}" for left in (model.get("left_out") or {}).values()]
    return lines


def certificate_path(table_path: str | Path, kind: str = "html") -> Path:
    """``NAME.certificate.html`` (or ``.pdf``) beside a parameter table ``NAME.csv``."""
    stem = Path(table_path).with_suffix("")
    return stem.with_name(f"{stem.name}.certificate.{kind}")


def certificate_files(data: dict, table_path: str | Path, kind: str, plots: dict[str, bytes]) -> dict[Path, bytes]:
    """The certificate of a report (``kind`` ``"html"`` or ``"pdf"``) as ``{path: bytes}``; its number goes into
    ``data["certificate"]`` (the report JSON written after it names it)."""
    number = certificate_number(data.get("unit_id"), str(data.get("created")), data.get("table_sha256"))
    path = certificate_path(table_path, kind)
    data["certificate"] = {"number": number, "file": path.name}
    page = certificate_html(data, plots)
    return {path: certificate_pdf(page) if kind == "pdf" else page.encode()}


def calibration_outputs(table_path: str | Path) -> list[Path]:
    """The output set of a calibration written as ``NAME.csv``: the table and every file of its stem that
    ``calibrate`` may write (report JSON and Markdown, certificate, each export).  A run owns them all
    (:func:`core.files.claim_outputs`): those it does not write again are removed with its writes, so that no
    certificate or export of an earlier run contradicts the table beside it."""
    table_path = Path(table_path)
    certificate = certificate_path(table_path)
    return [table_path, *companion_paths(table_path), certificate, certificate.with_suffix(".pdf"),
            *(export_path(table_path, fmt) for fmt in EXPORTS)]


def report_files(result: CalibrationResult, rec: Recording, table_path: str | Path, report_dir: str | Path | None = None,
                 truth: ParameterSet | None = None, command: str | None = None,
                 unit_id: str | None = None, verdict: Verdict | None = None,
                 certificate: str | bool | None = None, table_sha256: str | None = None) -> dict[Path, bytes]:
    """Every file of a calibration's report, as ``{path: content}`` (written together by the caller); with
    ``certificate`` (``"html"``, ``"pdf"``; True: html) also the certificate ``NAME.certificate.html`` or ``.pdf``
    (:mod:`report.certificate`).  ``table_sha256``: the SHA-256 of the table as written (in the report, on the
    certificate and in its number)."""
    record = calibration_record(result, rec, truth, command, unit_id, verdict).with_table(table_path, table_sha256)
    data = record.report
    json_path, md_path = companion_paths(table_path)
    plots = ({"velocity in the static intervals after calibration": residual_plot(result, rec),
              "Allan deviation of the static data against the noise model": noise_plot(result, rec)}
             if report_dir is not None or certificate else {})
    files = {}
    if certificate:
        files.update(certificate_files(data, table_path, "html" if certificate is True else certificate, plots))
    text = report_markdown(data)
    files.update({json_path: record.report_json(), md_path: text.encode()})
    if report_dir is not None:
        out = Path(report_dir)
        stem = f"{rec.file_stem}-{result.solver}"
        files[out / f"{stem}-report.md"] = text.encode()
        files[out / f"{stem}-report.json"] = files[json_path]
        files.update(calibration_tables(result, out / stem, rec.name, truth))
        residuals, allan = plots.values()
        files[out / f"{stem}-residuals.png"] = residuals
        files[out / f"{stem}-allan.png"] = allan
    return files

