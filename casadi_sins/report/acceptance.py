"""Acceptance of a calibrated unit against the limits of its tolerance sheet: the verdict.

The sheet's ``[accept.sigma]`` bounds each parameter's 1-sigma in natural units (ppm of the value for
scale factors) and ``[accept.value]`` its value in the report's value units (:mod:`data.tolerance`).
A unit passes when every parameter with a limit is within it; a parameter with a sigma limit but no
sigma fails (its uncertainty is not known).  Parameters without a limit are not judged.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..core.errors import InputError
from ..core.files import file_sha256
from ..data.tolerance import ToleranceSheet, read_tolerance_sheet
from ..model.parameters import ParameterSet
from ..model.registry import natural_unit_of, natural_value_of
from .rounding import format_sigma, format_with_sigma, sigma_in_value_unit


@dataclasses.dataclass
class Verdict:
    """``"pass"`` or ``"fail"``, the reasons of a failure, each judged parameter's outcome and its limits
    (``limits[name]``: ``"sigma"``, the largest 1-sigma in natural units, and/or ``"value"``, ``[low, high]`` in
    the report's value units)."""

    verdict: str
    reasons: list[str]
    outcome: dict[str, str]
    sheet: str | None = None
    sheet_sha256: str | None = None
    limits: dict[str, dict] = dataclasses.field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """Whether the unit is accepted."""
        return self.verdict == "pass"

    def as_dict(self) -> dict:
        """The report JSON's ``"acceptance"`` entry."""
        return {"verdict": self.verdict, "reasons": list(self.reasons), "sheet": self.sheet,
                "sheet_sha256": self.sheet_sha256,
                "judged": len(self.outcome), "failed": sorted(n for n, o in self.outcome.items() if o == "fail"),
                "outcome": dict(self.outcome), "limits": {n: dict(v) for n, v in self.limits.items()}}


def _limit(x: float) -> str:
    """A limit as the sheet gives it, never in exponent form."""
    return np.format_float_positional(x, trim="-")


def _sigma_reason(name: str, sigma: float, limit: float) -> str | None:
    unit = natural_unit_of(name)
    if not math.isfinite(sigma):
        return f"{name}: no sigma (its uncertainty is not known), limit {_limit(limit)} {unit}"
    if sigma > limit:
        return f"{name}: sigma {format_sigma(sigma)} {unit} above the limit {_limit(limit)} {unit}"
    return None


def _value_reason(name: str, value: float, sigma_natural: float, bounds: tuple[float, float]) -> str | None:
    shown, unit = natural_value_of(name, value)
    low, high = bounds
    if low <= shown <= high:
        return None
    text = format_with_sigma(shown, sigma_in_value_unit(name, shown, sigma_natural))
    allowed = f"|value| <= {_limit(high)}" if low == -high else f"within [{_limit(low)}, {_limit(high)}]"
    return f"{name}: value {text} {unit} not {allowed} {unit}"


def judge(params: ParameterSet, sheet: ToleranceSheet) -> Verdict:
    """The verdict of a parameter table against a sheet's acceptance limits."""
    sigma = params.natural_sigma()
    reasons, outcome, limits = [], {}, {}
    for i, name in enumerate(params.names):
        found = []
        if name in sheet.accept_sigma:
            found.append(_sigma_reason(name, float(sigma[i]), sheet.accept_sigma[name]))
            limits.setdefault(name, {})["sigma"] = sheet.accept_sigma[name]
        if name in sheet.accept_value:
            found.append(_value_reason(name, float(params.values[i]), float(sigma[i]), sheet.accept_value[name]))
            limits.setdefault(name, {})["value"] = list(sheet.accept_value[name])
        if found:
            failures = [r for r in found if r]
            outcome[name] = "fail" if failures else "pass"
            reasons += failures
    source = str(sheet.source) if sheet.source else None
    return Verdict("fail" if reasons else "pass", reasons, outcome, source, sheet_sha256(source) if source else None,
                   limits)


def allowances(name: str, value_natural: float, sigma_natural: float, limits: dict) -> list[tuple[str, float]]:
    """A judged parameter's limits as text and the margin left to each: the part of the allowance not used,
    1 at the ideal (no sigma; a value of 0, or the middle of an allowed range), 0 at the limit, negative beyond
    it.  ``limits`` is one entry of :attr:`Verdict.limits`; values in the report's value units, sigma natural."""
    out = []
    if "sigma" in limits:
        limit = float(limits["sigma"])
        margin = (limit - sigma_natural) / limit if math.isfinite(sigma_natural) else -math.inf
        out.append((f"σ ≤ {_limit(limit)} {natural_unit_of(name)}", margin))
    if "value" in limits:
        low, high = (float(x) for x in limits["value"])
        unit = natural_value_of(name, 0.0)[1]
        if low == -high:
            out.append((f"|value| ≤ {_limit(high)} {unit}", (high - abs(value_natural)) / high))
        else:
            half = 0.5 * (high - low)
            out.append((f"value {_limit(low)} … {_limit(high)} {unit}",
                        min(value_natural - low, high - value_natural) / half))
    return out


def sheet_sha256(path) -> str | None:
    """SHA-256 of the sheet a verdict was judged against, None when it cannot be read."""
    try:
        return file_sha256(path)
    except OSError:
        return None


def read_acceptance_sheet(path) -> ToleranceSheet:
    """A tolerance sheet that must have acceptance limits (``calibrate --tolerance``, ``batch --tolerance``).

    Raises
    ------
    InputError
        When the sheet cannot be read, or has neither ``[accept.sigma]`` nor ``[accept.value]``.
    """
    sheet = read_tolerance_sheet(path)
    if not sheet.has_acceptance:
        raise InputError(path, "no acceptance limits: add [accept.sigma] and/or [accept.value] (group label or "
                         "parameter name = limit in natural units)")
    return sheet
