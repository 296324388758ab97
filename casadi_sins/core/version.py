"""The package version, written into reports and exports."""

__version__ = "0.2.0"
