"""The arguments of every command, one function per command adding them to its parser.

Light on purpose: ``casadi-sins --help`` and ``casadi-sins CMD --help`` build the parser from these alone, so
they import argparse and constants from modules that import nothing heavy (:mod:`model.catalog`,
:mod:`report.export_formats`, :mod:`data.formats`, :mod:`studies.choices`, the shipped files' names), never
the library that does the work.  The records of :mod:`cli.registry` name them.
"""
