"""What a rolling pass measures: belt power and work, the steady part, 1/3-octave spectra.

References
----------
ANSI S1.11 / IEC 61260: base-10 one-third-octave band centres f_c = 1000 * 10^(k/10) Hz.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from .recorder import RollingResult

__all__ = ["belt_power", "pass_work", "steady_mask", "third_octave_centres", "band_levels"]


def belt_power(result: RollingResult, speed: float, radius: float) -> np.ndarray:
    """P = sum_e F_e (-dz2_e/dt) = (v / R) sum_e F_e (x_e - x_c) [W]."""
    return speed / radius * result.moment


def pass_work(result: RollingResult, speed: float, radius: float) -> tuple[float, float]:
    """(W, W_in) [J]: the belt's work over the pass and its positive part (trapezoid rule in time).

    In terms of x_c, W = int sum_e F_e (x_e - x_c) / R dx_c does not depend on v for a
    quasi-static pass; W_in (the work while the power is positive, i.e. mainly while the
    contact grows) scales the round-off and discretisation of W.
    """
    m = result.moment / radius
    dx = np.diff(result.x_c)
    w = float(np.sum(0.5 * (m[1:] + m[:-1]) * dx))
    mp = np.maximum(m, 0.0)
    w_in = float(np.sum(0.5 * (mp[1:] + mp[:-1]) * dx))
    return w, w_in


def steady_mask(x_c: np.ndarray, info: Mapping[str, float], margin: int, entry: float = 0.0) -> np.ndarray:
    """Steps of the steady part: the contact (half-length a plus ``margin`` elements) lies on the
    strip, and its rear has travelled ``entry`` [m] onto it (:class:`RollingSettings`)."""
    c = info["element_size"]
    reach = info["half_length"] + margin * c
    lo = info.get("strip_start", 0.0) + max(reach, info["half_length"] + entry)
    hi = info.get("strip_start", 0.0) + info["strip_length"] - reach
    return (x_c >= lo) & (x_c <= hi)


def third_octave_centres(lo: float, hi: float) -> np.ndarray:
    """Base-10 1/3-octave band centres 1000 * 10^(k/10) Hz from lo to hi (inclusive, to 1 %)."""
    k = np.arange(math.floor(10 * math.log10(lo / 1000.0) - 0.05), math.ceil(10 * math.log10(hi / 1000.0) + 0.05) + 1)
    f = 1000.0 * 10.0 ** (k / 10.0)
    return f[(f >= lo * 0.99) & (f <= hi * 1.01)]


def band_levels(signal: np.ndarray, dt: float, centres: np.ndarray, reference: float = 1.0) -> np.ndarray:
    """1/3-octave band levels of a signal's fluctuation, 10 log10(P_band / ref^2) [dB re ``reference``].

    The mean is removed, a Hann window applied (its power restored by the factor 8/3), and the
    one-sided periodogram summed over the bins inside each band [f_c 10^-0.05, f_c 10^0.05), so
    that the band powers add up to the mean square of the fluctuation. Bands whose centre lies
    below 2 / T (fewer than two periods in the record) are NaN: the record does not resolve them.
    """
    x = np.asarray(signal, dtype=float)
    n = x.size
    out = np.full(len(centres), np.nan)
    if n < 8:
        return out
    x = (x - x.mean()) * np.hanning(n)
    spec = np.fft.rfft(x)
    power = np.abs(spec) ** 2 / n**2 * (8.0 / 3.0)
    power[1:] *= 2.0
    if n % 2 == 0:
        power[-1] /= 2.0
    freq = np.fft.rfftfreq(n, dt)
    duration = n * dt
    for i, fc in enumerate(centres):
        if fc < 2.0 / duration or fc * 10**0.05 > 0.5 / dt:
            continue
        band = (freq >= fc * 10**-0.05) & (freq < fc * 10**0.05)
        if not band.any():
            continue  # no frequency bin inside the band: not resolved
        p = power[band].sum()
        out[i] = 10.0 * math.log10(p / reference**2) if p > 0 else -np.inf
    return out
