"""The sensor noise model: white noise, quantization, bias instability, errors outside the model.

The noise of each sensor axis is described by (SI inside, natural units at the edges):

``arw`` / ``vrw``
    white noise of the rate / specific force, as a density: angle random walk (rad/sqrt(s),
    reported in deg/sqrt(h)) and velocity random walk (m/s/sqrt(s), reported in ug/sqrt(Hz));
``quantization``
    white noise of the *accumulated* angle / velocity (rad, m/s): an integer pulse counter
    carries its remainder, so each increment errs by ``e_k - e_{k-1}`` (physics pitfall 8);
``bias_instability``, ``bias_tau``
    a first-order Gauss-Markov bias (steady-state 1 sigma, correlation time);
``unmodelled_*``
    errors outside the sensor model, given a place in it when a fit's checks fail.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.units import ARCSEC, ARW_UNIT, DEG_PER_H, UG, VRW_UNIT

#: Floors of noise terms the data do not determine (far below any real sensor): ARW (rad/sqrt(s)),
#: VRW (m/s/sqrt(s)).  They keep noise-free data from giving one kind of residual an absurd weight.
GYRO_ARW_FLOOR = 1e-6 * ARW_UNIT
ACCEL_VRW_FLOOR = 0.05 * UG


@dataclasses.dataclass
class SensorNoise:
    """Noise of the six sensor axes (SI; per axis arrays of 3).

    ``None`` in a field of a user specification means "estimate it".
    """

    gyro_arw: np.ndarray | None = None  # rad/sqrt(s)
    accel_vrw: np.ndarray | None = None  # m/s/sqrt(s)
    gyro_quantization: np.ndarray | None = None  # rad
    accel_quantization: np.ndarray | None = None  # m/s
    gyro_bias_instability: float | None = None  # rad/s
    gyro_bias_tau: float = 600.0  # s
    accel_bias_instability: float | None = None  # m/s^2
    accel_bias_tau: float = 900.0  # s
    # errors outside the sensor model, estimated from the fit when its checks fail (kalman module)
    unmodelled_acceleration: float = 0.0  # m/s^2, constant per static segment
    unmodelled_rate: float = 0.0  # rad/s, on each static gyro mean
    unmodelled_step: float = 0.0  # m/s, on each velocity step across a rotation

    FIELDS = ("gyro_arw", "accel_vrw", "gyro_quantization", "accel_quantization")

    def __post_init__(self):
        for name in self.FIELDS:
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy())

    def merged(self, other: "SensorNoise") -> "SensorNoise":
        """These values where given, ``other``'s elsewhere."""
        out = dataclasses.replace(other)
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if value is not None and not field.name.endswith("_tau"):
                setattr(out, field.name, value)
        if self.gyro_bias_instability is not None:
            out.gyro_bias_tau = self.gyro_bias_tau
        if self.accel_bias_instability is not None:
            out.accel_bias_tau = self.accel_bias_tau
        return out

    def natural(self) -> dict[str, object]:
        """The model in natural units: ARW deg/sqrt(h), VRW ug/sqrt(Hz), quantization arcsec and mm/s,
        bias instability deg/h and ug, correlation times s."""

        def conv(value, unit):
            return None if value is None else np.asarray(value) / unit

        return {"gyro_arw_deg_rth": conv(self.gyro_arw, ARW_UNIT),
                "accel_vrw_ug_rthz": conv(self.accel_vrw, VRW_UNIT),
                "gyro_quantization_arcsec": conv(self.gyro_quantization, ARCSEC),
                "accel_quantization_mm_s": conv(self.accel_quantization, 1e-3),
                "gyro_bias_instability_deg_h": conv(self.gyro_bias_instability, DEG_PER_H),
                "gyro_bias_tau_s": self.gyro_bias_tau,
                "accel_bias_instability_ug": conv(self.accel_bias_instability, UG),
                "accel_bias_tau_s": self.accel_bias_tau}

    @classmethod
    def from_natural(cls, values: dict) -> "SensorNoise":
        """From natural units (the keys of :meth:`natural`; missing keys: estimate)."""

        def get(key, unit):
            return None if values.get(key) is None else np.asarray(values[key], dtype=float) * unit

        gyro_bi, accel_bi = get("gyro_bias_instability_deg_h", DEG_PER_H), get("accel_bias_instability_ug", UG)
        return cls(get("gyro_arw_deg_rth", ARW_UNIT), get("accel_vrw_ug_rthz", VRW_UNIT),
                   get("gyro_quantization_arcsec", ARCSEC), get("accel_quantization_mm_s", 1e-3),
                   None if gyro_bi is None else float(gyro_bi), float(values.get("gyro_bias_tau_s", 600.0)),
                   None if accel_bi is None else float(accel_bi), float(values.get("accel_bias_tau_s", 900.0)))

    @classmethod
    def from_deviations(cls, dev, dt: float, pulse_gyro=None, pulse_accel=None) -> "SensorNoise":
        """The noise a problem file simulates (:class:`data.problem.Deviations`); integer pulses of the given
        sizes (rad, m/s) add a uniform remainder (``pulse / sqrt(12)``)."""
        quantized = getattr(dev, "quantize", False) and pulse_gyro is not None
        return cls(gyro_arw=math.hypot(dev.gyro_noise_deg_h * DEG_PER_H * math.sqrt(dt), dev.gyro_arw_deg_rth * ARW_UNIT),
                   accel_vrw=math.hypot(dev.accel_noise_ug * UG * math.sqrt(dt), dev.accel_vrw_ug_rthz * VRW_UNIT),
                   gyro_quantization=np.asarray(pulse_gyro) / math.sqrt(12.0) if quantized else 0.0,
                   accel_quantization=np.asarray(pulse_accel) / math.sqrt(12.0) if quantized else 0.0,
                   gyro_bias_instability=dev.gyro_bias_instability_deg_h * DEG_PER_H, gyro_bias_tau=dev.gyro_bias_tau_s,
                   accel_bias_instability=dev.accel_bias_instability_ug * UG, accel_bias_tau=dev.accel_bias_tau_s)

    def complete(self) -> "SensorNoise":
        """Zeros for the terms still unknown."""
        out = dataclasses.replace(self)
        for name in self.FIELDS:
            if getattr(out, name) is None:
                setattr(out, name, np.zeros(3))
        out.gyro_bias_instability = out.gyro_bias_instability or 0.0
        out.accel_bias_instability = out.accel_bias_instability or 0.0
        return out


NOISE_KEYS = ("gyro_arw_deg_rth", "accel_vrw_ug_rthz", "gyro_quantization_arcsec", "accel_quantization_mm_s",
              "gyro_bias_instability_deg_h", "gyro_bias_tau_s", "accel_bias_instability_ug", "accel_bias_tau_s")
#: The largest value of each noise term (natural units; the per-sample white noise of problem files too) that
#: an inertial sensor could have: far beyond the worst consumer MEMS part, so a larger one is a typing error
#: (and would overflow the noise model's arithmetic).
NOISE_CEILINGS = {"gyro_arw_deg_rth": 1e3, "accel_vrw_ug_rthz": 1e5, "gyro_quantization_arcsec": 1e6,
                  "accel_quantization_mm_s": 1e4, "gyro_bias_instability_deg_h": 1e5, "gyro_bias_tau_s": 1e9,
                  "accel_bias_instability_ug": 1e6, "accel_bias_tau_s": 1e9, "accel_noise_ug": 1e6,
                  "gyro_noise_deg_h": 1e6}
