"""Shared fixtures of the rotation-modulation tests: the two papers' error sheets and sites, and this
checkout's shipped schemes and sheets."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from casadi_sins.core.earth import Site
from casadi_sins.model.registry import NAMES
from casadi_sins.studies.modulation import shipped
from casadi_sins.studies.modulation.sources import load_sheet

#: The repository's ``problems/`` folder (installed as ``casadi_sins.problems``).
PROBLEMS = Path(__file__).resolve().parents[3] / "problems"
#: The bar's latitude for Guan et al. 2023: Xi'an (Northwestern Polytechnical University), 34.25 deg N.
GUAN_LATITUDE_DEG = 34.25
#: Yu and Ruan 2014 state 45.77 deg (Harbin) for their section 2.3.
YU_RUAN_LATITUDE_DEG = 45.77


@pytest.fixture(scope="session", autouse=True)
def this_checkouts_problems():
    """Shipped schemes and sheets are those of this checkout, also when the installed package is another
    checkout's (an editable install made elsewhere): the files under test are these."""
    if shipped.shipped_folder().resolve() == PROBLEMS.resolve():
        yield PROBLEMS
        return
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(shipped, "shipped_folder", lambda: PROBLEMS)
        yield PROBLEMS


@pytest.fixture(scope="session")
def guan_sheet(this_checkouts_problems):
    """Guan et al. 2023, Table 1 (problems/guan2023-table1.toml)."""
    return load_sheet(PROBLEMS / "guan2023-table1.toml")


@pytest.fixture(scope="session")
def yu_ruan_sheet(this_checkouts_problems):
    """Yu and Ruan 2014, the simulation of section 3 (problems/yu-ruan2014-sim.toml)."""
    return load_sheet(PROBLEMS / "yu-ruan2014-sim.toml")


@pytest.fixture(scope="session")
def guan_site():
    """34.25 deg N, height 0."""
    return Site(np.radians(GUAN_LATITUDE_DEG))


@pytest.fixture(scope="session")
def yu_ruan_site():
    """45.77 deg N, height 0."""
    return Site(np.radians(YU_RUAN_LATITUDE_DEG))


def _write_table(folder: Path, with_sigma: bool = True, extra_rows=()) -> Path:
    """``folder/params.csv``: a navigation-grade table of the 21 (sigma column empty without ``with_sigma``)
    and any extra rows ``parameter,unit,value,sigma``."""
    rows = []
    for name in NAMES:
        if "_scale_" in name:
            accel = name.startswith("accel")
            unit, value, sigma = ("m/s/pulse", 3.6e-4, 3.6e-10) if accel else ("rad/pulse", 1e-7, 1e-12)
        elif "_bias_" in name:
            unit, value, sigma = ("ug", 100.0, 5.0) if name.startswith("accel") else ("deg/h", 0.1, 0.005)
        else:
            unit, value, sigma = "arcsec", 10.0, 2.0
        rows.append(f"{name},{unit},{value},{sigma if with_sigma else ''}")
    path = folder / "params.csv"
    path.write_text("parameter,unit,value,sigma\n" + "\n".join(rows + list(extra_rows)) + "\n")
    return path


@pytest.fixture
def table_file():
    """The writer of a calibrated table (:func:`_write_table`)."""
    return _write_table
