"""The CasADi/Ipopt estimator: calibration as one nonlinear least-squares problem over all rotations."""
