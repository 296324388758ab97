"""casadi-sins: system-level calibration of strapdown inertial navigation systems.

The package recovers the 21 parameters of a SINS sensor output model (Kang et al. 2013, eq. 1) from
the navigation velocity errors of a multi-position, static-rotate-static experiment.  SI units are
used everywhere inside the package; natural units (ug, ppm, arcsec, deg/h) only at the edges.

The data path, one subpackage each: :mod:`core` (units, Earth, rotations, files) ->
:mod:`model` (the parameter registry, eq. 1, the noise model) -> :mod:`data` (recordings, tables,
problem files, segmentation) -> :mod:`nav` (strapdown step, alignment, error model) -> :mod:`noise`
(raw-data estimate, Kalman whitener) -> :mod:`calibrate` (NLP, ILS) -> :mod:`report` ->
:mod:`studies` -> :mod:`cli`; :mod:`sim` simulates recordings.

Typical use::

    from casadi_sins import read_recording, calibrate, write_table
    result = calibrate(read_recording("unit42.toml"))
    write_table("unit42.csv", result.parameters)

and on the line, a table applied to raw pulses in a DataFrame (as ``casadi-sins apply`` does)::

    from casadi_sins import read_table
    increments = read_table("unit42.csv").compensate(raw)   # columns time, gyro_x.., accel_x..
"""

from .calibrate import CalibrationError, CalibrationResult, calibrate
from .core.errors import InputError
from .core.version import __version__
from .data.description import read_recording, write_recording
from .data.problem import load_problem
from .data.tables import Table, read_table, write_table
from .model.parameters import ParameterSet
from .sim import simulate

__all__ = ["__version__", "CalibrationError", "CalibrationResult", "InputError", "ParameterSet", "Table", "calibrate",
           "load_problem", "read_recording", "read_table", "simulate", "write_recording", "write_table"]
