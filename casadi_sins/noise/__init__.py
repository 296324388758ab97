"""The noise of a calibration: the raw-data estimate, base motion, the plan, the Kalman whitener."""
