"""The simulator: a problem's experiment as a recording with everything true about it."""

from .simulate import Simulation, simulate, write_simulation

__all__ = ["Simulation", "simulate", "write_simulation"]
