"""Thermal calibration: one unit's calibrations at several temperatures as a temperature model per parameter.

:mod:`.inputs` reads the tables (full covariance, temperature), :mod:`.fit` fits the model by
generalised least squares, :mod:`.outputs` writes ``thermal.csv``, ``thermal.md``, plots and the
tables at chosen temperatures.
"""
