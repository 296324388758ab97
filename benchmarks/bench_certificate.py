"""The certificate as a browser shows and prints it: a screenshot and an A4 PDF from headless Chromium.

Run: ``python benchmarks/bench_certificate.py [--out results]`` (needs ``chromium``: ``apt-get install -y
chromium``).  A short unit recording is simulated, calibrated with ``calibrate --tolerance --certificate``
against a sheet it fails (the gyro-bias sigma limit half the unit's sigma), and the certificate is
rendered with networking disabled: ``certificate.png`` (the first screen) and ``certificate.pdf`` (A4)
are written, with the time to calibrate and to render and the page count in ``certificate.md``.
Target: the certificate renders offline (it references nothing outside itself) and prints on A4.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from casadi_sins.cli import main
from casadi_sins.data.problem import load_problem
from casadi_sins.data.tables import read_table
from casadi_sins.sim import simulate, write_simulation

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--no-first-run",
         "--hide-scrollbars", "--disable-extensions", "--disable-sync"]


def chromium() -> str:
    """The Chromium executable."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    raise SystemExit("chromium not found: apt-get update && apt-get install -y chromium")


def render(page: Path, out: Path) -> dict:
    """A screenshot (PNG, 1240 px wide: A4 at 150 dpi) and an A4 PDF of the page."""
    exe = chromium()
    t0 = time.perf_counter()
    subprocess.run([exe, *FLAGS, f"--screenshot={out / 'certificate.png'}", "--window-size=1240,1754",
                    page.resolve().as_uri()], check=True, capture_output=True, timeout=120)
    subprocess.run([exe, *FLAGS, f"--print-to-pdf={out / 'certificate.pdf'}", "--no-pdf-header-footer",
                    page.resolve().as_uri()], check=True, capture_output=True, timeout=120)
    pdf = (out / "certificate.pdf").read_bytes()
    pages = len(re.findall(rb"/Type\s*/Page[^s]", pdf))
    return {"render_s": time.perf_counter() - t0, "pdf_pages": pages}


def main_bench() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="results", help="output folder (default results)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    problem = load_problem()
    problem = dataclasses.replace(problem, timing=dataclasses.replace(problem.timing, static_s=30.0, rotation_s=6.0))
    out = out.resolve()
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)  # the certificate names the recording and the sheet as the line would: relative paths
        tmp = Path(".")
        rec = write_simulation(simulate(problem, seed=7, name="SN-0042"), tmp)
        t0 = time.perf_counter()
        assert main(["calibrate", str(rec), "--out", str(tmp / "P.csv"), "--quiet"]) == 0
        sigma = read_table(tmp / "P.csv").natural_sigma()[9:12].max()
        sheet = tmp / "sheet.toml"
        sheet.write_text(f'format = "casadi-sins-tolerance/1"\n[accept.sigma]\n"gyro bias" = {0.5 * sigma:.3g}\n'
                         '"accel scale" = 100.0\n')
        status = main(["calibrate", str(rec), "--out", str(tmp / "P.csv"), "--unit-id", "SN-0042", "--tolerance",
                       str(sheet), "--certificate", "--quiet"])
        calibrate_s = time.perf_counter() - t0
        page = tmp / "P.certificate.html"
        shutil.copy(page, out / "certificate.html")
        found = render(page, out)
        os.chdir(here)
    size_kb = (out / "certificate.html").stat().st_size / 1024
    (out / "certificate.md").write_text(
        "# Calibration certificate rendered by headless Chromium\n\n"
        f"- calibrate (twice, with and without the sheet): {calibrate_s:.1f} s; exit status with the failing sheet "
        f"{status}\n- certificate.html: {size_kb:.0f} kB, self-contained (plots inline)\n"
        f"- render (screenshot and PDF, networking disabled): {found['render_s']:.1f} s; A4 PDF pages: "
        f"{found['pdf_pages']}\n- files: certificate.png (first screen, 1240 px = A4 at 150 dpi), certificate.pdf\n")
    print((out / "certificate.md").read_text())


if __name__ == "__main__":
    main_bench()
