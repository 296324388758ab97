"""What a calibration is worth: predicted accuracy, error budget, navigation check, Monte Carlo, comparison."""
