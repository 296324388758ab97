"""casadi-sins: system-level calibration of strapdown inertial navigation systems.

The package recovers the 21 parameters of a SINS sensor output model (Kang et
al. 2013, eq. 1) from the navigation velocity errors of a multi-position,
static-rotate-static experiment.  SI units are used everywhere inside the
package; natural units (ug, ppm, arcsec, deg/h) only at the edges.
"""

__version__ = "0.1.0"
