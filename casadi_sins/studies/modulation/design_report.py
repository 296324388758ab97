"""The files of ``casadi-sins design-scheme``: ``scheme.toml`` (a scheme file ``modulate --scheme`` takes),
``design.json`` and ``design.md`` (the design beside every shipped scheme of the same size)."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

from ...core import units
from ...core.earth import Site
from ...core.text import markdown_text
from .covariance import propagate
from .designer import Design, criterion_value
from .schemes import FORMAT, Scheme, load_scheme, parse_scheme
from .shipped import shipped_names
from .sources import Sources
from .tilt import mean_tilt_table

UNITS = {"position": "m", "velocity": "m/s", "final": "m"}


def _toml_string(text: str) -> str:
    """A TOML basic string."""
    return json.dumps(text, ensure_ascii=False)


def scheme_toml(scheme: Scheme) -> str:
    """The scheme file of a scheme that starts ENU (:mod:`.schemes` format); checked by reading it back."""
    lines = [f"format = {_toml_string(FORMAT)}", f"name = {_toml_string(scheme.name)}",
             f"description = {_toml_string(scheme.description)}", 'start = "ENU"']
    if scheme.initial_dwell > 0:
        lines.append(f"initial_dwell_s = {scheme.initial_dwell!r}")
    for step in scheme.steps:
        lines += ["", "[[step]]", f"axis = {_toml_string(step.axis)}",
                  f"angle_deg = {round(math.degrees(step.angle), 9)!r}",
                  f"rate_deg_s = {round(step.rate / units.DEG, 9)!r}", f"dwell_s = {step.dwell!r}"]
    text = "\n".join(lines) + "\n"
    back = parse_scheme(tomllib.loads(text), "scheme.toml")
    same = len(back.steps) == len(scheme.steps) and all(
        a.axis == b.axis and math.isclose(a.angle, b.angle) and math.isclose(a.dwell, b.dwell)
        for a, b in zip(back.steps, scheme.steps)) and math.isclose(back.initial_dwell, scheme.initial_dwell)
    if not same:
        raise RuntimeError("scheme.toml does not read back as the design")
    return text


def same_size_schemes(positions: int) -> list[Scheme]:
    """The shipped schemes of ``positions`` steps."""
    schemes = [load_scheme(name) for name in shipped_names("schemes")]
    return [s for s in schemes if len(s.steps) == positions]


def comparison(result: Design, sources: Sources, site: Site) -> dict:
    """The design and every shipped scheme of its size, each propagated in full over the run
    (:func:`covariance.propagate`, the discretisation shared): its criterion, largest horizontal position and
    velocity errors, and the period-mean tilt's prediction."""
    req, cache, rows = result.request, {}, {}
    for scheme in [result.scheme] + same_size_schemes(req.positions):
        prop = propagate(scheme, site, req.hours, sources.gyro_arw, sources.accel_vrw, cache=cache,
                         names=sources.names)
        tilt = mean_tilt_table(scheme, sources, site)
        rows[scheme.name] = {
            "criterion": round(criterion_value(prop, sources, req.criterion), 6),
            "max_horizontal_position_error_m": round(criterion_value(prop, sources, "position"), 3),
            "max_velocity_error_mps": round(criterion_value(prop, sources, "velocity"), 5),
            "two_r_mean_tilt_m": tilt["two_r_horizontal_total_m"] if tilt else None,
            "source": scheme.source}
    shipped = [v["criterion"] for n, v in rows.items() if n != result.scheme.name]
    best = min(shipped) if shipped else None
    for v in rows.values():
        v["ratio_to_best_shipped"] = None if not best else round(v["criterion"] / best, 4)
    return rows


def design_doc(result: Design, sources: Sources, site: Site) -> dict:
    """``design.json``: the request, the search, the design and the comparison."""
    req, best = result.request, result.best
    return {
        "request": {"positions": req.positions, "axes": req.axes, "rate_deg_s": round(req.rate / units.DEG, 9),
                    "stop_s": req.stop, "hours": req.hours, "latitude_deg": round(site.latitude / units.DEG, 9),
                    "height_m": site.height, "criterion": req.criterion, "criterion_unit": UNITS[req.criterion],
                    "errors": sources.name, "origin": sources.origin, "correlated": sources.correlated},
        "design": {"sequence": best.notation(), "first_turn_after_s": best.dwell0,
                   "criterion": round(best.value, 6), "proxy": round(best.proxy, 6)},
        "search": {"candidates_scored_by_proxy": result.scored, "confirmed_by_propagation": len(result.confirmed),
                   "seconds": round(result.seconds, 3),
                   "best_confirmed": [{"sequence": c.notation(), "first_turn_after_s": c.dwell0,
                                       "proxy": round(c.proxy, 6), "criterion": round(c.value, 6)}
                                      for c in result.confirmed[:10]]},
        "comparison": comparison(result, sources, site),
    }


def design_markdown(doc: dict) -> str:
    """``design.md`` of :func:`design_doc`."""
    req, des, unit = doc["request"], doc["design"], doc["request"]["criterion_unit"]
    what = {"position": "largest horizontal position error of the run", "velocity": "largest horizontal "
            "velocity error of the run", "final": "horizontal position error at the end of the run"}[req["criterion"]]
    lines = [f"# Designed rotation scheme: {req['positions']} positions, {req['axes']} axis(es)", "",
             f"Errors: {markdown_text(req['errors'])} ({markdown_text(req['origin'])}"
             + (", full covariance" if req["correlated"] else "") + f"); {req['hours']:g} h at latitude "
             f"{req['latitude_deg']:g} deg; {req['rate_deg_s']:g} deg/s, {req['stop_s']:g} s per stop; "
             f"criterion: the {what} (1 sigma of the covariance propagation).", "",
             f"**Design:** `{des['sequence']}` (180 deg turns about IMU axes from x east, y north, z up; "
             f"first turn after {des['first_turn_after_s']:g} s): {des['criterion']:.4g} {unit}.", "",
             "| scheme | criterion | ratio to the best shipped | max horizontal position (m) | max velocity (m/s) "
             "| 2 R x period-mean tilt (m) |", "| --- | ---: | ---: | ---: | ---: | ---: |"]
    for name, v in doc["comparison"].items():
        ratio = "-" if v["ratio_to_best_shipped"] is None else f"{v['ratio_to_best_shipped']:.3f}"
        tilt = "-" if v["two_r_mean_tilt_m"] is None else f"{v['two_r_mean_tilt_m']:.4g}"
        lines.append(f"| {markdown_text(name)} | {v['criterion']:.4g} | {ratio} | "
                     f"{v['max_horizontal_position_error_m']:.4g} | {v['max_velocity_error_mps']:.4g} | {tilt} |")
    s = doc["search"]
    lines += ["", f"Search: {s['candidates_scored_by_proxy']} sequences scored by the proxy (the error the "
              f"period-mean tilt and the residual drift cause through the static error dynamics), "
              f"{s['confirmed_by_propagation']} confirmed by the full covariance propagation, "
              f"{s['seconds']:.1f} s.  No seed sequence: random start sequences (or all of them, when few).", "",
              "| best confirmed | first turn after (s) | proxy | criterion |", "| --- | ---: | ---: | ---: |"]
    lines += [f"| `{c['sequence']}` | {c['first_turn_after_s']:g} | {c['proxy']:.4g} | {c['criterion']:.4g} |"
              for c in s["best_confirmed"]]
    return "\n".join(lines) + "\n"


def design_files(result: Design, sources: Sources, site: Site, out) -> dict[Path, bytes]:
    """``scheme.toml``, ``design.json`` and ``design.md`` as ``{path: bytes}`` for the project's writer."""
    out = Path(out)
    doc = design_doc(result, sources, site)
    return {out / "scheme.toml": scheme_toml(result.scheme).encode(),
            out / "design.json": (json.dumps(doc, indent=1, allow_nan=False) + "\n").encode(),
            out / "design.md": design_markdown(doc).encode()}
