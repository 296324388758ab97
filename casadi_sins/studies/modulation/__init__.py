"""Rotation modulation of a static-base INS (issue 19): navigation error by source under rotation schemes.

An IMU on a turntable that turns it by a single- or dual-axis scheme averages part of its sensor errors
away.  :func:`analysis.analyse` propagates the covariance of the navigation error of a static base
along one or more schemes and splits it by error source (Guan et al. 2023, eqs. 9-30);
:func:`montecarlo.monte_carlo` checks it against free-inertial navigation of simulated runs.

Modules, in the order they build on each other: :mod:`.shipped` (the schemes and sheets shipped in
``casadi_sins.problems``), :mod:`.schemes` (scheme files, the IMU's motion pieces over time), :mod:`.model`
(the package's error state, :mod:`casadi_sins.nav.errorstate`), :mod:`.covariance` (the propagation of
:mod:`casadi_sins.nav.propagation` along a scheme),
:mod:`.sources` (error sheets), :mod:`.calibrated` (a calibrated parameter table and its covariance),
:mod:`.residual` (what a scheme leaves of the gyro errors), :mod:`.analysis` (by source and by
parameter, ``modulation.json``), :mod:`.outputs` (Markdown and plots), :mod:`.timedomain` and
:mod:`.montecarlo` (the time-domain check).  The commands are ``casadi-sins modulate`` and
``casadi-sins modulate-mc`` (:mod:`casadi_sins.cli.modulation`).
"""
