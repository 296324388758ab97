"""The certificate as a browser shows and prints it, and as ``--certificate pdf`` writes it.

Run: ``python benchmarks/bench_certificate.py [--out results]`` (needs ``chromium``: ``apt-get install -y
chromium``; and the extras ``pdf`` and ``test``: WeasyPrint, pypdf).  A short unit recording is simulated,
calibrated with ``calibrate --tolerance --certificate`` against a sheet it fails (the gyro-bias sigma
limit half the unit's sigma), and the HTML certificate is rendered by headless Chromium with networking
disabled: ``certificate.png`` (the first screen) and its print to A4; the same calibration with
``--certificate pdf`` writes ``certificate.pdf`` directly (WeasyPrint).  ``certificate.md`` gives the
times, both page counts and whether every page of the PDF names the unit and "page X of Y".
Target: the certificate renders offline (it references nothing outside itself) and prints on A4.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pypdf

from casadi_sins.cli import main
from casadi_sins.data.problem import load_problem
from casadi_sins.data.tables import read_table
from casadi_sins.sim import simulate, write_simulation

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--no-first-run",
         "--hide-scrollbars", "--disable-extensions", "--disable-sync", "--disable-component-update"]


def chromium() -> str:
    """The Chromium executable."""
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    raise SystemExit("chromium not found: apt-get update && apt-get install -y chromium")


def render(page: Path, out: Path) -> dict:
    """A screenshot (PNG, 1240 px wide: A4 at 150 dpi) of the page and the page count of Chromium's A4 print."""
    exe = chromium()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as profile, tempfile.TemporaryDirectory() as printed:
        flags = [*FLAGS, f"--user-data-dir={profile}"]
        subprocess.run([exe, *flags, f"--screenshot={out / 'certificate.png'}", "--window-size=1240,1754",
                        page.resolve().as_uri()], check=True, capture_output=True, timeout=120)
        subprocess.run([exe, *flags, f"--print-to-pdf={Path(printed) / 'chromium.pdf'}", "--no-pdf-header-footer",
                        page.resolve().as_uri()], check=True, capture_output=True, timeout=120)
        pages = len(pypdf.PdfReader(Path(printed) / "chromium.pdf").pages)
    return {"render_s": time.perf_counter() - t0, "pdf_pages": pages}


def pdf_pages(path: Path, unit: str) -> tuple[int, bool]:
    """The page count of a PDF certificate, and whether every page names the unit and "page X of Y"."""
    texts = [p.extract_text() for p in pypdf.PdfReader(path).pages]
    return len(texts), all(f"unit {unit}" in t and f"page {k + 1} of {len(texts)}" in t for k, t in enumerate(texts))


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
        t0 = time.perf_counter()
        assert main(["calibrate", str(rec), "--out", str(tmp / "Q.csv"), "--unit-id", "SN-0042", "--tolerance",
                     str(sheet), "--certificate", "pdf", "--quiet"]) == status
        pdf_s = time.perf_counter() - t0
        shutil.copy(tmp / "Q.certificate.pdf", out / "certificate.pdf")
        os.chdir(here)
    size_kb = (out / "certificate.html").stat().st_size / 1024
    pages, every = pdf_pages(out / "certificate.pdf", "SN-0042")
    (out / "certificate.md").write_text(
        "# Calibration certificate: as Chromium shows and prints it, and as --certificate pdf writes it\n\n"
        f"- calibrate (twice, with and without the sheet): {calibrate_s:.1f} s; exit status with the failing sheet "
        f"{status}\n- certificate.html: {size_kb:.0f} kB, self-contained (plots inline)\n"
        f"- Chromium (screenshot and A4 print, networking disabled): {found['render_s']:.1f} s; A4 pages: "
        f"{found['pdf_pages']}\n"
        f"- calibrate --certificate pdf (WeasyPrint, calibration included): {pdf_s:.1f} s; certificate.pdf: {pages} "
        f"A4 pages, unit id and page X of Y on {'every page' if every else 'NOT every page'}\n"
        "- files: certificate.png (first screen, 1240 px = A4 at 150 dpi), certificate.pdf (--certificate pdf)\n")
    print((out / "certificate.md").read_text())


if __name__ == "__main__":
    main_bench()
