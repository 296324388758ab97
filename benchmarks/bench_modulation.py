"""Regenerate the rotation-modulation results (issue 19) into ``results/modulation/``.

Run from anywhere: ``python benchmarks/bench_modulation.py [section ...] [--out results/modulation]``.
Sections (all by default): guan, latitude, dwell, yuruan, candidates, fig6, coupling, timing, montecarlo.
Everything but the Monte Carlo takes about a minute of CPU; the Monte Carlo (50 runs per source, 6 h, three
schemes and a plain-draw repeat) under a minute.  One process, one BLAS thread.

* guan: Guan et al. 2023, Table 1 sheet, 24 h at 34.25 deg: six schemes (``guan2023/``);
* latitude: the two longitude maxima of the bar against latitude;
* dwell: the 16-position scheme's gyro-bias contribution against the stop length;
* yuruan: Yu and Ruan 2014, common against improved, 24 h at 45.77 deg, with the sheet's initial errors
  and with a static alignment (``yu-ruan2014/``, ``yu-ruan2014-aligned/``, the summary);
* candidates: the candidate orders 5-16 of the improved scheme (how the lost one was reconstructed);
* fig6: the integrated navigation-frame gyro error of both schemes (their Fig. 6);
* coupling: the residual Earth-rate and table-rate coupling of section 2.3;
* timing: 72 h covariance runs;
* montecarlo: the time-domain check against the covariance.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from casadi_sins.core import units
from casadi_sins.core.earth import Site
from casadi_sins.core.files import write_files
from casadi_sins.core.threads import single_threaded
from casadi_sins.report.plots import figure_bytes, pyplot
from casadi_sins.report.tables import frame_files
from casadi_sins.studies.modulation import model as M
from casadi_sins.studies.modulation import residual as R
from casadi_sins.studies.modulation.analysis import analyse, horizontal, run_scheme
from casadi_sins.studies.modulation.covariance import propagate
from casadi_sins.studies.modulation.montecarlo import monte_carlo, montecarlo_files
from casadi_sins.studies.modulation.outputs import modulation_files
from casadi_sins.studies.modulation.schemes import load_scheme, parse_scheme
from casadi_sins.studies.modulation.sources import load_sheet

ROOT = Path(__file__).resolve().parents[1]
GUAN_LAT, YR_LAT = 34.25, 45.77
NMI = 1852.0


def site(lat: float) -> Site:
    """A static site at ``lat`` deg, height 0."""
    return Site(np.radians(lat))


def scheme(name: str):
    """A shipped scheme, by its path relative to the repository (so the reports name it so)."""
    return load_scheme(f"problems/schemes/{name}.toml")


def table(rows: list[dict], stem: Path, title: str, note: str = "") -> dict:
    """Rows as ``stem.csv`` and ``stem.md`` (title, note, table)."""
    files = frame_files(pd.DataFrame(rows), stem, title, "%.4g")
    md = stem.with_name(stem.name + ".md")
    head, rest = files[md].decode().split("\n\n", 1)
    files[md] = (head + "\n\n" + (note + "\n\n" if note else "") + rest).encode()
    return files


def section_guan(out: Path, sheets: dict) -> dict:
    """Guan et al. 2023: six schemes, 24 h."""
    names = ["strapdown", "single-axis-reciprocating", "single-axis-continuous", "single-axis-4pos",
             "dual-axis-16", "yu-ruan2014-improved"]
    doc, results = analyse([scheme(n) for n in names], sheets["guan"], site(GUAN_LAT), 24.0)
    doc["warnings"] = []
    return modulation_files(doc, results, out / "guan2023")


def section_latitude(out: Path, sheets: dict) -> dict:
    """The bar's two longitude maxima against latitude."""
    rows = []
    for lat in (25.0, 30.0, 34.25, 40.0, 45.77):
        lon = {n: float(np.sqrt(run_scheme(scheme(n), sheets["guan"], site(lat), 24.0).total[:, 3, 3]).max())
               for n in ("strapdown", "single-axis-reciprocating")}
        rows.append({"latitude (deg)": lat, "strapdown max longitude (m)": lon["strapdown"],
                     "single-axis max longitude (m)": lon["single-axis-reciprocating"]})
    return table(rows, out / "guan2023-latitude", "Guan et al. 2023 Table 1, 24 h: the longitude maxima against latitude",
                 "Bar: 23 000 m and 13 000 m +-15 %. The bar's latitude is 34.25 deg (Xi'an).")


def _sequence_scheme(seq: str, dwell: float = 45.0, name: str | None = None):
    """A scheme of 180 deg turns at 20 deg/s from a sequence like ``"z+ x- ..."``."""
    return parse_scheme({"name": name or seq, "step": [
        {"axis": s[0], "angle_deg": 180.0 if s[1] == "+" else -180.0, "rate_deg_s": 20.0, "dwell_s": dwell}
        for s in seq.split()]})


def _flip(seq: str) -> str:
    """Every direction of a sequence reversed."""
    return " ".join(s[0] + ("-" if s[1] == "+" else "+") for s in seq.split())


def section_dwell(out: Path, sheets: dict) -> dict:
    """The 16-position scheme's gyro-bias contribution against the stop length."""
    y8 = "z+ x+ z- x- x+ z+ x- z-"
    rows = []
    for dwell in (10.0, 20.0, 30.0, 45.0, 60.0, 120.0, 300.0):
        res = run_scheme(_sequence_scheme(f"{y8} {_flip(y8)}", dwell, f"dwell{dwell:g}"), sheets["guan"],
                         site(GUAN_LAT), 24.0)
        cov = res.by_source["gyro bias"]
        rows.append({"stop (s)": dwell, "gyro bias: max longitude (m)": float(np.sqrt(cov[:, 3, 3]).max()),
                     "gyro bias: max horizontal (m)": float(horizontal(cov).max()),
                     "total max longitude (m)": float(np.sqrt(res.total[:, 3, 3]).max())})
    return table(rows, out / "guan2023-dwell", "The 16-position dual-axis scheme (20 deg/s): gyro-bias contribution "
                 "against the stop length (Table 1, 24 h, 34.25 deg)",
                 "Bar: the three gyro biases <= 10 m (Guan et al., Fig. 4: 'a few metres').")


def section_yuruan(out: Path, sheets: dict) -> dict:
    """Yu and Ruan 2014: common against improved, with the sheet's initial errors and aligned."""
    names = ["yu-ruan2014-common", "yu-ruan2014-improved", "yu-ruan2014-improved-reconstructed",
             "yu-ruan2014-common-8", "yu-ruan2014-improved-8", "yu-ruan2014-reversal-8"]
    rows, files = [], {}
    for initial in ("sheet", "aligned"):
        doc, results = analyse([scheme(n) for n in names], sheets["yr"], site(YR_LAT), 24.0,
                               aligned=initial == "aligned")
        doc["warnings"] = []
        folder = out / ("yu-ruan2014" if initial == "sheet" else "yu-ruan2014-aligned")
        files.update(modulation_files(doc, results, folder, plots=initial == "sheet"))
        for name, s in doc["schemes"].items():
            d = s["deterministic_plus_one_sigma"]
            rows.append({"initial attitude": initial, "scheme": name,
                         "deterministic max position (nmi)": d["max_horizontal_position_error_m"] / NMI,
                         "deterministic max velocity (m/s)": d["max_velocity_error_mps"],
                         "1-sigma max position (nmi)": s["max_horizontal_position_error_m"] / NMI,
                         "1-sigma max velocity (m/s)": s["max_velocity_error_mps"]})
    files.update(table(
        rows, out / "yu-ruan2014-summary", "Yu and Ruan 2014 simulation sheet, 24 h, 45.77 deg: common against improved",
        "Paper: improved 0.4 nmi / 0.5 m/s, common 0.74 nmi / 1 m/s. 'sheet': no initial attitude error (none "
        "stated); 'aligned': the attitude error of a static alignment at the start attitude (tilt = accel bias/g, "
        "heading from the east gyro), which the paper may have had. Deterministic: every error at +1 value."))
    return files


def _candidate_row(label: str, seq: str, sheet, s: Site) -> dict:
    """One candidate sequence: its residual drift, bias leak, oscillation and navigation error."""
    candidate = _sequence_scheme(seq)
    x = sheet.values()
    drift = R.equivalent_drift(candidate, s, "total") @ x[M.N_NAV:] / units.DEG_PER_H
    bias = R.equivalent_drift(candidate, s, "bias")[:, M.GYRO_BIAS.start - M.N_NAV:M.GYRO_BIAS.stop - M.N_NAV]
    _, theta = R.integrated_error(candidate, s, x[M.N_NAV:], 2 * candidate.period / 3600.0, step_s=3.0)
    pp = (theta.max(0) - theta.min(0)) / units.ARCSEC
    prop = propagate(candidate, s, 24.0, sheet.gyro_arw, sheet.accel_vrw)
    m = prop.mean(x)
    return {"sequence": label, "orders": seq, "drift E (deg/h)": float(drift[0]), "drift N": float(drift[1]),
            "drift U": float(drift[2]), "bias leak (largest share)": float(np.abs(bias).max()),
            "p-p of int. error E,N,U (arcsec)": ", ".join(f"{v:.1f}" for v in pp),
            "deterministic max (nmi)": float(np.hypot(m[:, 2], m[:, 3]).max() / NMI),
            "1-sigma max (nmi)": float(horizontal(prop.covariance(sheet.p0)).max() / NMI)}


def section_candidates(out: Path, sheets: dict) -> dict:
    """The candidate orders 5-8 and 9-16 of the improved scheme."""
    first = "z+ y- z+ y-"
    fifth = {"reversal (retrace) y+ z- y+ z-": "y+ z- y+ z-", "axes swapped y- z+ y- z+": "y- z+ y- z+",
             "rejected: same axes, opposite z- y+ z- y+": "z- y+ z- y+"}
    cands = {"1-4 repeated": first}
    for label, s58 in fifth.items():
        cands[f"8: {label}"] = f"{first} {s58}"
        cands[f"16: {label}; 9-16 = 1-8 reversed in direction"] = f"{first} {s58} {_flip(first + ' ' + s58)}"
    published = "z+ y- z+ y- y- z+ y- z+"
    cands["16: published (PSINS): 9-16 = 1-8 with the two axes swapped"] = (
        f"{published} {published.replace('z', 'Y').replace('y', 'z').replace('Y', 'y')}")
    y8 = "z+ y+ z- y- y+ z+ y- z-"
    cands["common (Yuan) 8"] = y8
    cands["common (Yuan) 16"] = f"{y8} {_flip(y8)}"
    rows = [_candidate_row(label, seq, sheets["yr"], site(YR_LAT)) for label, seq in cands.items()]
    return table(rows, out / "yu-ruan2014-candidates",
                 "Reconstructing the improved scheme: candidate orders 5-8 and 9-16 (Yu-Ruan sheet, 45.77 deg), "
                 "and the published order",
                 "drift: the constant navigation-frame gyro drift one period leaves of the sheet's errors (all +1 "
                 "value); bias leak: the largest share of a gyro bias left as constant drift (turns' sin a terms); "
                 "p-p: peak-to-peak of the integrated navigation-frame gyro error over two periods (the paper's Fig. 6).")


def section_fig6(out: Path, sheets: dict) -> dict:
    """The integrated navigation-frame gyro error of the common and improved schemes (Yu and Ruan, Fig. 6)."""
    s, plt = site(YR_LAT), pyplot()
    x = sheets["yr"].values()[M.N_NAV:]
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for name in ("yu-ruan2014-common", "yu-ruan2014-improved"):
        sch = scheme(name)
        t, theta = R.integrated_error(sch, s, x, 3 * sch.period / 3600.0, step_s=2.0)
        for k, ax in enumerate(axes):
            ax.plot(t / 60, theta[:, k] / units.ARCSEC, label=name)
            ax.set_ylabel(f"{'ENU'[k]} (arcsec)")
            ax.grid(True, alpha=0.3)
    axes[0].legend()
    axes[-1].set_xlabel("time (min)")
    fig.suptitle("Integral of the gyro errors in the geographic frame (Yu and Ruan 2014, Fig. 6), 45.77 deg")
    fig.tight_layout()
    return {out / "yu-ruan2014-fig6.png": figure_bytes(fig)}


def section_coupling(out: Path, sheets: dict) -> dict:
    """The residual Earth-rate and table-rate coupling of scale and misalignment (Yu and Ruan, section 2.3)."""
    s = site(YR_LAT)
    errors = {f"gyro_scale_{a}": 1e-5 for a in "xyz"}
    errors.update({n: 2 * units.ARCSEC for n in M.registry.NAMES if n.startswith("gyro_misalign")})
    x = R.sensor_vector(**errors)
    rows = []
    for name in ("yu-ruan2014-reversal-8", "yu-ruan2014-improved-8", "yu-ruan2014-improved",
                 "yu-ruan2014-common-8", "yu-ruan2014-common"):
        for part in ("earth", "table"):
            d = R.equivalent_drift(scheme(name), s, part) @ x / units.DEG_PER_H
            rows.append({"scheme": name, "coupling with": "Earth rate" if part == "earth" else "table rate",
                         "E (deg/h)": float(d[0]), "N (deg/h)": float(d[1]), "U (deg/h)": float(d[2])})
    w = s.earth_rate / units.DEG_PER_H
    note = (f"Scale 1e-5 on each gyro, 2 arcsec on each of the 6 misalignments (all positive), 20 deg/s, 45 s. "
            f"Paper (section 2.3): about 0.0001 deg/h on each of E, N, U for the reversed 8-order sequence. "
            f"Single terms: 1e-5 w_N = {1e-5 * w[1]:.3g}, 1e-5 w_U = {1e-5 * w[2]:.3g}, "
            f"2\" w_N = {2 * units.ARCSEC * w[1]:.3g}, 2\" w_U = {2 * units.ARCSEC * w[2]:.3g} deg/h.")
    return table(rows, out / "earth-rate-coupling", "Residual constant drift of scale and misalignment (Yu and Ruan "
                 "2014, section 2.3), 45.77 deg", note)


def section_timing(out: Path, sheets: dict) -> dict:
    """Covariance runs of 72 h with every source."""
    lines = ["# Timing of 72 h covariance runs (one core, one BLAS thread; shared 2-core machine)", ""]
    for name in ("strapdown", "single-axis-reciprocating", "dual-axis-16", "yu-ruan2014-improved"):
        start, cpu = time.perf_counter(), time.process_time()
        run_scheme(scheme(name), sheets["guan"], site(GUAN_LAT), 72.0)
        lines.append(f"- {name}, 72 h, every source of Guan et al. Table 1: {time.perf_counter() - start:.2f} s wall, "
                     f"{time.process_time() - cpu:.2f} s CPU")
    return {out / "timing.md": ("\n".join(lines) + "\n").encode()}


def section_montecarlo(out: Path, sheets: dict, runs: int = 50, hours: float = 6.0) -> dict:
    """The time-domain Monte Carlo against the covariance (bar: 0.8-1.25 per source group)."""
    guan = sheets["guan"]
    p0 = guan.p0.copy()
    asym = guan.groups()["gyro scale-factor asymmetry"]
    p0[asym, asym] = (5e-6) ** 2
    sheet = dataclasses.replace(guan, p0=p0, name="guan2023-table1 + 5 ppm gyro asymmetry")
    results = []
    for name, matched in (("strapdown", True), ("single-axis-reciprocating", True), ("dual-axis-16", True),
                          ("dual-axis-16", False)):
        cpu = time.process_time()
        res = monte_carlo(scheme(name), sheet, site(GUAN_LAT), hours, runs=runs, seed=0, matched=matched)
        res["cpu_s"] = round(time.process_time() - cpu, 1)
        results.append(res)
        print(f"  {name} ({'matched' if matched else 'plain'}): {res['cpu_s']} s CPU", flush=True)
    note = ("Table 1 + 5 ppm gyro scale asymmetry, 6 h instead of 24 h for run time, navigation steps 1 deg in "
            "turns and 5 s in stops. CPU: " + ", ".join(
                f"{r['scheme']} {'matched' if r['moment_matched'] else 'plain'} {r['cpu_s']} s" for r in results) + ".")
    return montecarlo_files(results, [], out, note)


SECTIONS = {"guan": section_guan, "latitude": section_latitude, "dwell": section_dwell, "yuruan": section_yuruan,
            "candidates": section_candidates, "fig6": section_fig6, "coupling": section_coupling,
            "timing": section_timing, "montecarlo": section_montecarlo}


def main(argv: list[str] | None = None, sections: dict | None = None, doc: str | None = None) -> int:
    """Run the sections asked for (all by default; of ``sections``, default this script's) and write their
    files."""
    sections = SECTIONS if sections is None else sections
    parser = argparse.ArgumentParser(description=(doc or __doc__).split("\n\n")[0])
    parser.add_argument("sections", nargs="*", choices=[[], *sections], help="sections to run (default all)")
    parser.add_argument("--out", default="results/modulation", help="output folder, relative to the repository "
                        "(default results/modulation)")
    args = parser.parse_args(argv)
    os.chdir(ROOT)  # every file named relative to the repository in the reports
    out = Path(args.out)
    sheets = {"guan": load_sheet("problems/guan2023-table1.toml"), "yr": load_sheet("problems/yu-ruan2014-sim.toml")}
    with single_threaded():
        for name in args.sections or sections:
            start = time.process_time()
            written = write_files(sections[name](out, sheets))
            print(f"{name}: {time.process_time() - start:.1f} s CPU, wrote {', '.join(str(p) for p in written)}",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
