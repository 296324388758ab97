"""Foundations used by every other part: units, the Earth, rotations, errors, files."""
