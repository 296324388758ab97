"""The noise terms of one sensor axis at rest, in closed form: quantization, white noise, a first-order
Gauss-Markov bias.

A sensor axis at rest outputs increments ``x_k = theta(t_k) - theta(t_{k-1})`` of an angle (or velocity)
``theta`` sampled every ``dt``.  Beyond a constant rate, three terms (IEEE Std 952-1997, annex C):

``white`` ``N``
    white rate noise of density ``N`` (unit/sqrt(s)): angle random walk (gyro), velocity random walk
    (accelerometer);
``quantization`` ``Q``
    white noise of the *accumulated* angle, ``Q`` (unit) per sample boundary: each increment errs by
    ``e_k - e_{k-1}`` (a pulse counter carrying its remainder: ``Q = pulse / sqrt(12)``);
``gm_sigma`` ``sigma``, ``gm_tau`` ``T``
    a first-order Gauss-Markov rate ``b' = -b / T + w``, steady-state standard deviation ``sigma``
    (unit/s): the bias instability of :class:`model.noise.SensorNoise` (its ``bias_instability`` is
    this ``sigma``, not the Allan floor).

Written once here, in the three forms the identification uses:

* the Allan variance at cluster time ``tau`` (:func:`allan_variance`)::

      3 Q^2 / tau^2  +  N^2 / tau  +  (2 sigma^2 T / tau) [1 - (T / 2 tau)(3 - 4 e^(-tau/T) + e^(-2 tau/T))]

  (the Gauss-Markov term: Lawrence C. Ng and D. J. Pines, "Characterization of ring laser gyro
  performance using the Allan variance method", J. Guidance 20 (1997); it rises as ``2 sigma^2 tau / 3 T``
  for ``tau << T``, peaks at ``0.6174 sigma`` in deviation at ``tau = 1.893 T`` and falls as
  ``2 sigma^2 T / tau``, a white noise, for ``tau >> T``);
* the structure function ``D(t) = E[(theta(s + t) - theta(s))^2]`` of the angle (:func:`structure`),
  whose second differences give the covariance of any Allan variance estimate (:mod:`noise.allan`)::

      N^2 |t|  +  2 Q^2 [t != 0]  +  2 sigma^2 T^2 (|t| / T - 1 + e^(-|t|/T))

* the spectrum of the increments summed over intervals of ``g`` seconds, at ``omega`` (rad per interval;
  :func:`spectrum_columns`), exact for the sampled process (no continuous-time approximation), and the
  expectation of a periodogram of a finite number of such sums (the lags weighed by ``1 - h / n``)::

      S(omega) = N^2 g  +  2 Q^2 (1 - cos omega)  +  sigma^2 T^2 [2 (x - 1 + a) + 2 (1 - a)^2 (cos omega - a) / (1 - 2 a cos omega + a^2)]

  with ``x = g / T``, ``a = e^(-x)``: the sums' autocovariance is ``2 sigma^2 T^2 (x - 1 + a)`` at lag 0
  and ``sigma^2 T^2 (1 - a)^2 a^(h - 1)`` at lag ``h >= 1``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

#: The Gauss-Markov term's Allan deviation peaks at this fraction of its sigma ...
GM_PEAK_FRACTION = 0.6174
#: ... at this multiple of its correlation time.
GM_PEAK_TAU = 1.893
#: A flicker floor's Allan deviation is this times the "bias instability" coefficient B of IEEE Std 952.
FLICKER_FLOOR = 0.664


@dataclasses.dataclass(frozen=True)
class AxisTerms:
    """The noise terms of one axis, in the unit of the data (pulses, rad or m/s) per the module docstring.

    Attributes
    ----------
    white : float
        Density ``N`` of the white rate noise, unit/sqrt(s).
    quantization : float
        ``Q`` of the accumulated angle, unit.
    gm_sigma : float
        Steady-state 1 sigma of the Gauss-Markov rate, unit/s (0: none).
    gm_tau : float
        Its correlation time, s.
    """

    white: float
    quantization: float = 0.0
    gm_sigma: float = 0.0
    gm_tau: float = math.inf

    def allan_variance(self, tau) -> np.ndarray:
        """The Allan variance at cluster times ``tau`` (s), (unit/s)^2."""
        return allan_variance(tau, self.white, self.quantization, self.gm_sigma, self.gm_tau)

    def scaled(self, factor: float) -> "AxisTerms":
        """The same terms in another unit: every amplitude times ``factor`` (a scale factor, unit per pulse)."""
        return dataclasses.replace(self, white=self.white * factor, quantization=self.quantization * factor,
                                   gm_sigma=self.gm_sigma * factor)


def allan_variance(tau, white: float, quantization: float = 0.0, gm_sigma: float = 0.0,
                   gm_tau: float = math.inf) -> np.ndarray:
    """The Allan variance of the three terms at cluster times ``tau`` (module docstring)."""
    tau = np.asarray(tau, dtype=float)
    out = 3.0 * quantization**2 / tau**2 + white**2 / tau
    if gm_sigma > 0.0 and math.isfinite(gm_tau):
        out = out + gm_sigma**2 * gauss_markov_allan(tau / gm_tau)
    return out


def gauss_markov_allan(x) -> np.ndarray:
    """The Gauss-Markov term's Allan variance over ``sigma^2`` at ``x = tau / T``:
    ``(2 / x) [1 - (3 - 4 e^-x + e^-2x) / 2x]``, by its series for small ``x`` (no cancellation)."""
    x = np.asarray(x, dtype=float)
    small = x < 1e-2
    xs = np.where(small, 1.0, x)
    inner = 1.0 - (-4.0 * np.expm1(-xs) + np.expm1(-2.0 * xs)) / (2.0 * xs)
    series = x**2 / 3.0 - x**3 / 4.0 + 7.0 * x**4 / 60.0 - x**5 / 24.0
    return 2.0 * np.where(small, series, inner) / np.where(x > 0, x, 1.0)


def _x_minus_one_plus_exp(x) -> np.ndarray:
    """``x - 1 + e^-x`` without cancellation for small ``x``."""
    x = np.asarray(x, dtype=float)
    return np.where(x < 1e-4, x**2 / 2.0 - x**3 / 6.0 + x**4 / 24.0, x + np.expm1(-x))


def structure(t, white: float, quantization: float = 0.0, gm_sigma: float = 0.0,
              gm_tau: float = math.inf) -> np.ndarray:
    """The structure function ``D(t)`` of the angle (module docstring); the quantization's jump at ``t = 0``
    included (``D(0) = 0``)."""
    t = np.abs(np.asarray(t, dtype=float))
    out = white**2 * t + 2.0 * quantization**2 * (t > 0)
    if gm_sigma > 0.0 and math.isfinite(gm_tau):
        out = out + 2.0 * gm_sigma**2 * gm_tau**2 * _x_minus_one_plus_exp(t / gm_tau)
    return out


def gauss_markov_column(omega, spacing: float, tau: float, length: int | None = None) -> np.ndarray:
    """The Gauss-Markov term's spectrum over ``sigma^2`` for sums over ``spacing`` seconds at ``omega`` (rad
    per interval); with ``length`` the expectation of a periodogram of that many sums instead, its lags
    weighed by ``1 - h / length`` (exact at the Fourier frequencies: no leakage left to bias the lowest ones,
    where a correlation time of a tenth of the record lives).  Written with ``1 - a`` and
    ``sin^2(omega / 2)`` so that no digits cancel when the correlation time is many intervals."""
    omega = np.asarray(omega, dtype=float)
    x = spacing / tau
    one_minus_a = -math.expm1(-x)
    a = 1.0 - one_minus_a
    lag0 = 2.0 * float(_x_minus_one_plus_exp(x))
    if length is None:  # lags >= 1: 2 (1 - a)^2 (cos w - a) / (1 - 2 a cos w + a^2), cos w - a = (1 - a) - 2 s2
        s2 = np.sin(0.5 * omega) ** 2
        rest = 2.0 * one_minus_a**2 * (one_minus_a - 2.0 * s2) / (one_minus_a**2 + 4.0 * a * s2)
        return tau**2 * (lag0 + rest)
    n = int(length)
    z = a * np.exp(-1j * omega)
    one_minus_z = one_minus_a + a * (1.0 - np.exp(-1j * omega))
    z_n1 = a ** (n - 1) * np.exp(-1j * np.mod(omega * (n - 1), 2.0 * np.pi))
    first = z * (1.0 - z_n1) / one_minus_z  # sum_{h=1}^{n-1} z^h
    weighted = z * (1.0 - n * z_n1 + (n - 1) * z_n1 * z) / one_minus_z**2  # sum_{h=1}^{n-1} h z^h
    rest = 2.0 * one_minus_a**2 / a * np.real(first - weighted / n)
    return tau**2 * (lag0 + rest)


def spectrum_columns(omega, spacing: float, tau: float | None = None, length: int | None = None) -> np.ndarray:
    """The spectrum's columns for ``(N^2, Q^2[, sigma^2])`` at ``omega`` (rad per interval) for sums over
    ``spacing`` seconds: ``S = columns @ (N^2, Q^2, sigma^2)``.

    With ``length`` the expectation of a periodogram of that many sums instead (the quantization's lag-one
    autocovariance weighed by ``1 - 1 / length``, the Gauss-Markov term's lags by ``1 - h / length``); the
    Gauss-Markov column is left out without ``tau``.
    """
    omega = np.asarray(omega, dtype=float)
    taper = 1.0 if length is None else 1.0 - 1.0 / length
    cols = [np.full_like(omega, spacing), 2.0 * (1.0 - taper * np.cos(omega))]
    if tau is not None:
        cols.append(gauss_markov_column(omega, spacing, tau, length))
    return np.column_stack(cols)
