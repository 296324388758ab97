"""Tapered means on a swaying base: a static segment's gyro mean that the sway does not reach.

A static segment's plain mean rate is its gyro angle from end to end over its length: a swaying
base adds the sway's angle change over the segment divided by its length.  A bounded sway has no
power at zero frequency, so a smooth window kills it: the *tapered mean* of the segment's rate
weighs the rate of each navigation step by a window that rises from zero and falls back to it,

    m = sum_k u_k (psi_k - psi_{k-1}),   u_k = w(t_k) / sum_j w(t_j) h_j,   sum_k u_k h_k = 1,

with ``psi_k`` the gyro-integrated attitude after step ``k`` (its log map, not the raw rate: sway
rotations do not commute, and the raw rate carries a slow beat of them).  The window is the first
discrete prolate spheroidal (Slepian) sequence of time-half-bandwidth ``NW``: of all windows of a
segment's length it keeps the most of its weight at frequencies below ``NW / T``; a sway faster
than that leaks about ``1e-6`` of its rate (``NW`` 4.5-6).  The window's first step is left out
(``u_0 = 0``), so the mean reads the attitude after the segment's first step on.

The price is noise: white gyro noise reaches the tapered mean with ``sum_k u_k^2 h_k`` times its
density (about twice a plain mean's).  :func:`choose_taper` picks ``NW`` per segment, the one of
least noise plus leakage, the leakage bounded from the segment's own attitude rate
(:func:`leakage_variance`).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

#: Navigation step in the static segments of a moving base (s): a sway's period is many of them.
STEP_S = 0.1
#: Time-half-bandwidth products tried: the window keeps sway of periods above ``T / NW`` (20 s at
#: ``NW`` 5 on 100 s), and leaks little beyond.
BANDWIDTHS = (2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5, 6.0, 7.0)
#: Motion of fewer cycles per segment is not told from a drift of the bias (nor from the spread of the mean).
SLOWEST_CYCLES = 2
#: The attitude rate's lines are sought in its means over this long (s): a sway's periods are many of them.
ANALYSIS_STEP_S = 0.4
#: Zero padding of the spectra (fine frequency grid).
PADDING = 4
#: A spectral bin counts as motion only above this many times the white noise's expected power (a
#: noise bin exceeds it with probability ``exp(-6)``).
MOTION_OVER_NOISE = 6.0


@functools.lru_cache(maxsize=64)
def window(n: int, nw: float) -> np.ndarray:
    """The first Slepian sequence of ``n`` points and time-half-bandwidth ``nw``, positive, peak 1 (read-only):
    the eigenvector of the largest eigenvalue of its tridiagonal form (Percival and Walden, section 8.3)."""
    from scipy.linalg import eigh_tridiagonal  # imported here: only a moving base needs it

    if n <= 2:
        return np.ones(n)
    k = np.arange(n)
    diagonal = ((n - 1 - 2.0 * k) / 2.0) ** 2 * np.cos(2.0 * np.pi * nw / n)
    off = k[1:] * (n - k[1:]) / 2.0
    w = np.abs(eigh_tridiagonal(diagonal, off, select="i", select_range=(n - 1, n - 1))[1][:, 0])
    w = w / w.max()
    w.flags.writeable = False
    return w


def rate_weights(step_dt: np.ndarray, nw: float) -> np.ndarray:
    """``u`` (K,) of a segment of ``K`` steps: the weights of the steps' rates, ``u_0 = 0``, ``sum u h = 1``."""
    step_dt = np.asarray(step_dt, dtype=float)
    w = np.concatenate([[0.0], window(len(step_dt) - 1, nw)])
    return w / np.sum(w * step_dt)


def point_coefficients(u: np.ndarray) -> np.ndarray:
    """``c`` (K,): the tapered mean as ``sum_k c_k psi_k`` over the attitudes after each step,
    ``c_k = u_k - u_{k+1}`` (``u_K = 0``); ``sum c = 0``, so a constant attitude offset does not count."""
    return u - np.concatenate([u[1:], [0.0]])


@dataclasses.dataclass(frozen=True)
class TaperChoice:
    """The window of one segment's tapered mean.

    Attributes
    ----------
    nw : float
        Time-half-bandwidth product of the window.
    noise_factor : float
        White gyro noise reaches the tapered mean with this many times its variance in a plain mean.
    leakage : ndarray
        (3,) bound of the variance the base motion leaves in it, per body axis, (rad/s)^2.
    """

    nw: float
    noise_factor: float
    leakage: np.ndarray


def _spectrum(rates: np.ndarray) -> tuple[np.ndarray, float]:
    """Power of ``rates`` (N, 3) per fine frequency bin (Hann taper, :data:`PADDING`), scaled so that a
    sinusoid's bins add up to its mean square; and the expected power of one bin of unit white noise."""
    n = len(rates)
    hann = np.hanning(n + 2)[1:-1]
    hann = hann / hann.sum()
    enbw = n * np.sum(hann**2)
    spectrum = np.abs(np.fft.rfft(hann[:, None] * (rates - hann @ rates), n=PADDING * n, axis=0)) ** 2
    scale = 2.0 / (enbw * PADDING)
    return spectrum * scale, float(np.sum(hann**2) * scale)


def _response(weights: np.ndarray, cycles: np.ndarray) -> np.ndarray:
    """``|W(f)|^2`` of rate windows (``sum W = 1``; (N,) or (N, J)) at ``cycles`` per segment (any reals)."""
    n = len(weights)
    phase = np.exp(-2j * np.pi * np.outer(np.asarray(cycles, dtype=float), (np.arange(n) + 0.5) / n))
    return np.abs(phase @ weights) ** 2


def _response_envelope(weights: np.ndarray, n: int) -> np.ndarray:
    """``max |W(f')|^2`` over ``f'`` within one coarse bin of each fine bin, ``W`` the window's transfer function
    of a rate (``sum W = 1``): the leakage of motion anywhere near the bin."""
    response = np.abs(np.fft.rfft(weights, n=PADDING * n)) ** 2
    padded = np.concatenate([np.full(PADDING, response[0]), response, np.full(PADDING, response[-1])])
    return np.max(np.lib.stride_tricks.sliding_window_view(padded, 2 * PADDING + 1), axis=1)[:len(response)]


@dataclasses.dataclass(frozen=True)
class RateLines:
    """The sinusoids of an attitude rate, and what is left of it."""

    cycles: np.ndarray  # (L,) frequency of each line, cycles per segment
    power: np.ndarray  # (L, 3) mean square of each line on each axis, (rad/s)^2
    remainder: np.ndarray  # (N, 3) the rate less its mean and the lines
    cosine: np.ndarray | None = None  # (L, 3) each line's amplitude of cos(2 pi f t) on the three axes
    sine: np.ndarray | None = None  # (L, 3) and of sin(2 pi f t)


#: Lines sought, and the frequency uncertainty of a line (cycles per segment) over which its leakage is bounded.
MAX_LINES = 16
LINE_SPREAD = 0.25
#: Lines closer than this (cycles per segment) blur in the spectrum: found together, refined together at once.
CLOSE_LINES = 3.0


def rate_lines(rates: np.ndarray, floor: np.ndarray) -> RateLines:
    """The strong sinusoids of a rate (N, 3), one at a time: the highest peak of the axes' Blackman spectra
    over ``floor`` (3,) (power per fine bin), its frequency refined on a parabola, then every line's frequency
    and amplitudes on every axis fitted again with a straight line (:func:`_refine_lines`); until no peak
    stands above the floor, or :data:`MAX_LINES`.

    A sway is many orders of magnitude above the gyro noise: a spectral window's own leakage would hide the
    tapered mean's response to it.  Fitted as lines (the axes share them: one motion seen along three axes,
    and its products), it leaks through the tapered mean's response at its own frequency.
    """
    n = len(rates)
    grid = (np.arange(n) + 0.5) / n
    taper = np.blackman(n)
    taper = taper / taper.sum()
    scale = 2.0 / (n * np.sum(taper**2) * PADDING)
    cycles: list[float] = []
    coef, remainder = _line_fit(rates, grid, np.zeros(0))[1:]
    for _ in range(MAX_LINES):
        spectrum = np.abs(np.fft.rfft(taper[:, None] * remainder, n=PADDING * n, axis=0)) ** 2 * scale
        above = np.sum(spectrum / floor[None, :], axis=1)
        above[:PADDING] = 0.0
        peak = int(np.argmax(above))
        if above[peak] <= 3.0 or peak >= len(above) - 1:
            break
        left, middle, right = np.log(above[peak - 1:peak + 2] + 1e-300)
        curvature = left - 2.0 * middle + right
        shift = 0.5 * (left - right) / curvature if curvature < 0 else 0.0
        cycles.append((peak + float(np.clip(shift, -0.5, 0.5))) / PADDING)
        close = np.abs(np.array(cycles[:-1]) - cycles[-1]) < CLOSE_LINES
        if np.any(close):  # lines closer than the spectrum resolves: their frequencies refined together
            cycles, coef, remainder = _refine_lines(rates, grid, np.array(cycles))
            cycles = list(cycles)
        else:
            coef, remainder = _line_fit(rates, grid, np.array(cycles))[1:]
    if cycles:
        cycles, coef, remainder = _refine_lines(rates, grid, np.array(cycles))
    count = len(cycles)
    power = (coef[2:2 + count] ** 2 + coef[2 + count:] ** 2) / 2.0 if count else np.zeros((0, 3))
    return RateLines(np.array(cycles), power, remainder, coef[2:2 + count], coef[2 + count:])


def motion_floor(n: int, step_s: float, noise_density: np.ndarray) -> np.ndarray:
    """(3,) the power per fine bin above which a rate's spectrum counts as motion: :data:`MOTION_OVER_NOISE`
    times white noise of ``noise_density`` (rad/s/sqrt(Hz)) over ``n`` steps of ``step_s``."""
    unit = _spectrum(np.zeros((n, 1)))[1]
    return MOTION_OVER_NOISE * unit * np.asarray(noise_density, dtype=float) ** 2 / step_s


def _line_fit(rates: np.ndarray, grid: np.ndarray, cycles: np.ndarray):
    """A straight line and lines at ``cycles`` fitted to ``rates``: ``(design, coefficients, remainder)``; the
    coefficients: mean, slope, the lines' cosines, their sines."""
    arg = 2.0 * np.pi * np.outer(grid, cycles)
    design = np.column_stack([np.ones(len(grid)), grid - 0.5, np.cos(arg), np.sin(arg)])
    coef = np.linalg.lstsq(design, rates, rcond=None)[0]
    return design, coef, rates - design @ coef


#: Gauss-Newton steps on the lines' frequencies after each new line.
REFINE_STEPS = 4


def _refine_lines(rates: np.ndarray, grid: np.ndarray, cycles: np.ndarray):
    """The lines' frequencies refined together (Gauss-Newton with the amplitudes projected out, steps of at most
    a quarter cycle, kept only when the remainder shrinks): ``(cycles, coefficients, remainder)``."""
    count = len(cycles)
    design, coef, remainder = _line_fit(rates, grid, cycles)
    cost = float(np.sum(remainder**2))
    for _ in range(REFINE_STEPS):
        arg = 2.0 * np.pi * np.outer(grid, cycles)
        # d(fit)/d(cycles_j), per axis: 2 pi t (-a sin + b cos), (sample, axis, line)
        jac = 2.0 * np.pi * grid[:, None, None] * (-np.sin(arg)[:, None, :] * coef[2:2 + count].T[None]
                                                   + np.cos(arg)[:, None, :] * coef[2 + count:].T[None])
        basis = np.linalg.qr(design)[0]  # the amplitudes' directions, projected out (variable projection)
        projected = jac - np.einsum("ij,jak->iak", basis, np.einsum("ij,iak->jak", basis, jac))
        projected = projected.reshape(-1, count)
        step = np.linalg.lstsq(projected, remainder.reshape(-1), rcond=None)[0]
        step = np.clip(step, -LINE_SPREAD, LINE_SPREAD)
        trial = np.clip(cycles + step, 1.0, len(grid) / 2.0 - 1.0)  # a line of less than a cycle is a trend
        trial_design, trial_coef, trial_remainder = _line_fit(rates, grid, trial)
        trial_cost = float(np.sum(trial_remainder**2))
        if trial_cost >= cost:
            break
        cycles, design, coef, remainder, cost = trial, trial_design, trial_coef, trial_remainder, trial_cost
    return cycles, coef, remainder


def mean_response(frequency_hz: np.ndarray, q: int, step_s: float) -> np.ndarray:
    """``|H(f)|^2`` of the mean of ``q`` consecutive steps of ``step_s`` (1 at zero frequency)."""
    x = np.pi * np.asarray(frequency_hz, dtype=float) * step_s
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(np.abs(np.sin(x)) > 1e-12, np.sin(q * x) / (q * np.sin(x)), 1.0)
    return ratio**2


def leakage_variance(lines: RateLines, floor: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """A bound of the variance the base motion leaves in tapered means, per axis: (3,) for one window's weights
    (N,), (3, J) for J windows' (N, J).

    ``lines``: the lines of the rate of the gyro-integrated attitude (:func:`rate_lines`, above ``floor``,
    :func:`motion_floor`); ``weights``: the tapered mean's weights of the rates (``sum = 1``).  The lines
    leak through the window's largest response within :data:`LINE_SPREAD` of their frequency (a line's
    mean square times the response: the variance over its unknown phase); of what is left, each
    frequency bin above :data:`MOTION_OVER_NOISE` times the noise counts as motion, and leaks through
    the window's largest response within a bin of it.  Motion slower than :data:`SLOWEST_CYCLES` over the
    segment is not told from a drift of the bias and does not count.
    """
    weights = np.asarray(weights, dtype=float)
    columns = weights[:, None] if weights.ndim == 1 else weights
    out = np.zeros((3, columns.shape[1]))
    strong = lines.cycles >= SLOWEST_CYCLES
    if np.any(strong):
        near = (lines.cycles[strong, None] + np.linspace(-LINE_SPREAD, LINE_SPREAD, 11)[None, :]).ravel()
        response = _response(columns, near).reshape(-1, 11, columns.shape[1]).max(axis=1)  # (lines, J)
        out += lines.power[strong].T @ response
    excess = np.maximum(_spectrum(lines.remainder)[0] - floor[None, :], 0.0)
    excess[:SLOWEST_CYCLES * PADDING] = 0.0
    envelope = np.column_stack([_response_envelope(w, len(w)) for w in columns.T])  # fine bins of the same width
    out += excess.T @ envelope[:len(excess)]
    return out[:, 0] if weights.ndim == 1 else out


def choose_taper(rates: np.ndarray, step_s: float, noise_density: np.ndarray) -> TaperChoice:
    """The window of least noise plus leakage (summed over the axes) for a segment whose attitude rate over
    steps of ``step_s`` is ``rates`` (N, 3); ``noise_density`` (3,) the white gyro noise (rad/s/sqrt(Hz))."""
    n = len(rates)
    candidates = [nw for nw in BANDWIDTHS if 2.0 * nw < n / 4]
    if not candidates:
        raise ValueError(f"a segment of {n} steps is too short for a tapered mean")
    weights = np.column_stack([window(n, nw) / np.sum(window(n, nw)) for nw in candidates])
    noise_factor = n * np.sum(weights**2, axis=0)
    # the lines are sought in the rate's means over ANALYSIS_STEP_S (a sway's periods are many of them); their
    # power is restored for what the means took
    q = max(1, min(int(round(ANALYSIS_STEP_S / step_s)), n // 64))
    coarse = rates[:n // q * q].reshape(n // q, q, 3).mean(axis=1)
    floor = motion_floor(len(coarse), q * step_s, noise_density)
    lines = rate_lines(coarse, floor)
    kept = mean_response(lines.cycles / (n * step_s), q, step_s)
    lines = dataclasses.replace(lines, power=lines.power / kept[:, None])
    leakage = leakage_variance(lines, floor, weights)
    density = np.asarray(noise_density, dtype=float) ** 2
    total = np.sum(density[:, None] * noise_factor[None, :] / (n * step_s) + leakage, axis=0)
    best = int(np.argmin(total))
    return TaperChoice(candidates[best], float(noise_factor[best]), leakage[:, best])
