"""Display rounding from the uncertainty: a number is shown to the decimal of its sigma's second
significant digit, and the sigma with two significant digits.

Only what people read is rounded (terminal and Markdown tables); every CSV and JSON keeps the full
float64.  A gyro bias of 4.8535e-7 rad/s with sigma 1.02e-4 deg/h reads ``0.10011 +/- 0.00010``
deg/h, not ``+0.0000``; a scale factor with sigma 0.24 ppm keeps the 8 significant digits that
resolve it, not 6.
"""

from __future__ import annotations

import math

import pandas as pd

from ..model.registry import group_of


def decimals(sigma: float, digits: int = 2) -> int | None:
    """Decimals that show ``digits`` significant digits of ``sigma`` (None when sigma is not positive)."""
    if sigma is None or not math.isfinite(sigma) or sigma <= 0:
        return None
    return digits - 1 - math.floor(math.log10(abs(sigma)))


def format_with_sigma(value: float, sigma: float, signed: bool = False, digits: int = 2) -> str:
    """``value`` rounded to the decimal of the ``digits``-th significant digit of ``sigma``.

    Without a usable sigma the value is shown with 6 significant digits.
    """
    if value is None or not math.isfinite(value):
        return ""
    sign = "+" if signed else ""
    places = decimals(sigma, digits)
    if places is None:
        return f"{value:{sign}.6g}"
    if places >= 0:
        return f"{value:{sign}.{places}f}"
    return f"{round(value, places):{sign}.0f}"


def format_sigma(sigma: float, digits: int = 2) -> str:
    """A sigma with ``digits`` significant digits (never in exponent form for ordinary sizes)."""
    places = decimals(sigma, digits)
    if places is None:
        return "" if sigma is None or not math.isfinite(sigma) else f"{sigma:.2g}"
    return f"{sigma:.{max(places, 0)}f}"


def sigma_in_value_unit(name: str, value: float, sigma_natural: float) -> float:
    """A parameter's sigma in the unit its value is shown in: scale factors' ppm times the value."""
    return sigma_natural * 1e-6 * abs(value) if group_of(name).relative else sigma_natural


def rounded(frame: pd.DataFrame, pairs: dict[str, str], signed: bool = False) -> pd.DataFrame:
    """A copy of ``frame`` with each column of ``pairs`` (value column -> sigma column) as text rounded
    from the sigma, and the sigma columns with two significant digits."""
    out = frame.copy()
    for col, sig in pairs.items():
        if col in out and sig in frame:
            out[col] = [format_with_sigma(v, s, signed) for v, s in zip(frame[col], frame[sig])]
    for sig in set(pairs.values()):
        if sig in out:
            out[sig] = [format_sigma(s) for s in frame[sig]]
    return out


def parameter_display(data: dict) -> pd.DataFrame:
    """The report's parameters as people read them: natural units, each value (and error) rounded to the
    second significant digit of its sigma, the sigma to two digits (text columns)."""
    frame = pd.DataFrame(data["parameters"])
    cols = ["parameter", "value_natural", "value_unit", "sigma_natural", "sigma_unit"]
    cols += [c for c in ("error_natural", "error_over_sigma") if c in frame]
    frame["_sigma"] = [sigma_in_value_unit(n, v, s) for n, v, s in
                       zip(frame["parameter"], frame["value_natural"], frame["sigma_natural"])]
    shown = rounded(frame, {"value_natural": "_sigma", "error_natural": "sigma_natural"})  # from the sigma
    if "error_over_sigma" in shown:
        shown["error_over_sigma"] = [f"{x:+.2f}" if isinstance(x, (int, float)) and math.isfinite(x) else ""
                                     for x in frame["error_over_sigma"]]
    return shown[cols]


def significant(x, digits: int = 2) -> str:
    """A number without a sigma of its own (an uncertainty, an RMS, an error realisation) to ``digits``
    significant digits, in the form :func:`format_sigma` gives (signed when negative)."""
    if x is None or isinstance(x, str):
        return "" if x is None else x
    x = float(x)
    if not math.isfinite(x):
        return ""
    text = format_sigma(abs(x), digits) if x != 0 else "0"
    return f"-{text}" if x < 0 else text


def display(frame: pd.DataFrame, pairs: dict[str, str] | None = None, sigmas=(), ratios=(),
            signed: bool = False) -> pd.DataFrame:
    """The one display rule of every table people read (Markdown, terminal); the numbers as text.

    Each value column of ``pairs`` is rounded to the second significant digit of its sigma column
    (:func:`rounded`); the columns of ``sigmas`` (sigmas, RMS, errors without a sigma of their own) get
    two significant digits, those of ``ratios`` (error/sigma, z, RMS/sigma) two decimals.  Columns not
    named are left as they are.
    """
    out = rounded(frame, pairs or {}, signed)
    for col in sigmas:
        if col in frame:
            out[col] = [significant(x) for x in frame[col]]
    for col in ratios:
        if col in frame:
            out[col] = [f"{x:.2f}" if isinstance(x, (int, float)) and math.isfinite(x) else "" for x in frame[col]]
    return out


def float_columns(frame: pd.DataFrame) -> list[str]:
    """The columns of floating-point numbers of a frame."""
    return [c for c in frame.columns if pd.api.types.is_float_dtype(frame[c])]
