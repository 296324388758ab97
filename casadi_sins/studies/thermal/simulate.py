"""A thermal problem simulated: one recording per setpoint, the unit's true parameters at that temperature.

Each recording is the problem's experiment (:func:`sim.simulate`, seed ``seed + k`` for the k-th
setpoint) with the truth of the thermal model at its setpoint, and its ``[conditions] temperature_c``
(and ``unit_id``) set, so that ``calibrate``/``batch`` carry the temperature into each report and
``thermal`` finds it there.  The true model is written as ``thermal-truth.csv`` (same format as a
fitted ``thermal.csv``, no sigma).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ...data.conditions import Conditions
from ...data.thermal import thermal_csv_text
from ...data.thermal_problem import ThermalProblem
from ...model.parameters import ParameterSet
from ...sim.simulate import Simulation, simulate, simulation_files


def setpoint_name(problem_name: str, temperature_c: float) -> str:
    """``NAME-m10C``, ``NAME-25C``: a file stem per setpoint (no leading minus sign)."""
    text = f"{temperature_c:g}".replace("-", "m").replace(".", "p")
    return f"{problem_name}-{text}C"


def simulate_thermal(tp: ThermalProblem, seed: int = 0, noise: bool = True) -> list[Simulation]:
    """One simulation per setpoint, in the order of the setpoints."""
    out = []
    for k, temperature in enumerate(tp.setpoints_c):
        truth = ParameterSet(tp.model.values_at(temperature), names=tp.model.names)
        problem = dataclasses.replace(tp.problem, truth=truth)
        sim = simulate(problem, seed=seed + k, noise=noise, name=setpoint_name(tp.problem.name, temperature))
        rec = dataclasses.replace(sim.recording, conditions=Conditions(temperature_c=temperature, unit_id=tp.unit_id))
        out.append(dataclasses.replace(sim, recording=rec))
    return out


def thermal_simulation_files(tp: ThermalProblem, sims: list[Simulation], out_dir: str | Path) -> dict:
    """``{path: content}`` of every recording, its truth, and ``thermal-truth.csv``."""
    files = {}
    for sim in sims:
        files.update(simulation_files(sim, out_dir))
    files[Path(out_dir) / "thermal-truth.csv"] = thermal_csv_text(tp.model).encode()
    return files
