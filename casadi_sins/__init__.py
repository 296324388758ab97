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

import importlib
import sys
import types

from .core.version import __version__

#: The public names and the module each comes from; each is imported on first use, so that importing
#: the package (and ``casadi-sins --help`` or ``--version``) loads neither CasADi nor pandas.
_PUBLIC = {
    "CalibrationError": ".calibrate", "CalibrationResult": ".calibrate", "calibrate": ".calibrate",
    "InputError": ".core.errors", "read_recording": ".data.description", "write_recording": ".data.description",
    "load_problem": ".data.problem", "Table": ".data.tables", "read_table": ".data.tables",
    "write_table": ".data.tables", "ParameterSet": ".model.parameters", "simulate": ".sim",
}

__all__ = ["__version__", *sorted(_PUBLIC)]


def __getattr__(name: str):
    if name in _PUBLIC:
        return getattr(importlib.import_module(_PUBLIC[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_PUBLIC))


class _Package(types.ModuleType):
    """The package's module type: ``casadi_sins.calibrate`` is the function :func:`calibrate` (as it was when
    the package imported it eagerly), although the subpackage of the same name binds itself here when it is
    imported."""

    @property
    def calibrate(self):
        return getattr(importlib.import_module(".calibrate", __name__), "calibrate")

    @calibrate.setter
    def calibrate(self, value) -> None:  # the import system binding the subpackage: the name stays the function
        pass


sys.modules[__name__].__class__ = _Package
