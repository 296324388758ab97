"""Names of the interchange format and of the importers, light enough for ``casadi-sins --help`` (the
readers in :mod:`data.recording` and :mod:`data.importers` take them from here)."""

from __future__ import annotations

#: The pulse columns of a recording's CSV, after ``time`` (the interchange format).
PULSE_COLUMNS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: The foreign formats ``import`` reads (:mod:`data.importers`): name -> what it reads.
IMPORT_FORMATS = {
    "psins": "[wm vm t] array (.mat variable 'imu' or a text file)",
    "mat": "variables by name",
    "hdf5": "datasets by path",
    "parquet": "columns by name",
}
#: The names ``import --map KEY=NAME`` takes: the columns, whole three-axis arrays, and a temperature.
IMPORT_KEYS = ("time",) + PULSE_COLUMNS + ("gyro", "accel", "temperature")
