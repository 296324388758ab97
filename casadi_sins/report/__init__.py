"""What a user reads: tables in natural units, the calibration report, plots, exports."""
