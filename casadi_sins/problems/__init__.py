"""Shipped problem files (``format = "casadi-sins-problem/1"``): the paper's experiment and others, error sheets
of the modulation analysis and the example tolerance sheet, one TOML file each; package data, also reached in a
checkout as ``problems/``."""
