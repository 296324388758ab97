"""The main job on the built-in problem: simulate the paper's experiment, both solvers side by side, the
navigation check (section 2.3) and the error budget of the calibrated unit."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pandas as pd

from ..core.files import write_files
from ..data.problem import Problem
from ..sim import simulate, write_simulation
from .budget import problem_budget, write_budget
from .compare import Comparison, compare, comparison_files
from .navcheck import navigation_check, write_navigation_check


@dataclasses.dataclass
class Demo:
    """What the demo made: the recording, the comparison, the navigation check and the budget table."""

    recording_path: Path
    comparison: Comparison
    navigation: pd.DataFrame
    budget: pd.DataFrame


def run_demo(problem: Problem, seed: int, out_dir: str | Path, progress=None) -> Demo:
    """Simulate ``problem`` with ``seed`` into ``out_dir/recordings``, calibrate with both solvers, check the
    navigation and the budget; every table and plot into ``out_dir``."""
    out = Path(out_dir)
    sim = simulate(problem, seed=seed)
    rec_path = write_simulation(sim, out / "recordings")
    if progress:
        progress(f"simulated {problem.name} (seed {seed}): {rec_path}")
    comparison = compare(sim.recording, sim.truth, progress=progress)
    write_files(comparison_files(sim.recording, comparison, out, sim.truth))
    runs, nav_table = navigation_check(problem, {name: res.parameters.values
                                                 for name, res in comparison.results.items()}, seed=seed)
    write_navigation_check(runs, nav_table, out, sim.recording.name)
    nlp = comparison.results["nlp"].parameters
    budget = write_budget(problem_budget(problem, nlp.values, nlp.covariance), out, sim.recording.name)
    return Demo(rec_path, comparison, nav_table, budget)
