"""Optimal design of a calibration schedule: positions, turns and dwell times under a time budget.

The predicted covariance of :mod:`studies.prediction` scores every candidate (:mod:`.criteria`); the
table's axes, rates, rests and handling bound the candidates (:mod:`.space`); simulated annealing over
orientation sequences (:mod:`.moves`, :mod:`.search`) and projected gradient descent over dwell times
(:mod:`.dwell`) find the design; :mod:`.problemfile` and :mod:`.report` write it (:mod:`.run`).
"""
