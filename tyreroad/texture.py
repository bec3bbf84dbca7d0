"""Texture statistics of road surfaces (ISO 13473): rms, skewness, MPD, texture level spectrum.

These are the statistics the surface stage stores for the whole field (:mod:`tyreroad.surface`):

* :func:`rms_height` and :func:`skewness` of the heights;
* :func:`mean_profile_depth`, the mean profile depth of ISO 13473-1 on profiles along x;
* :func:`texture_level_spectrum`, the 1/3-octave texture level spectrum of ISO 13473-4 style on
  the same profiles (band centres from :func:`third_octave_wavelengths`);
* :func:`peak_fraction_within`, the fraction of element peaks within a depth of the highest one
  (the statistic the patch selection rule uses).

Profiles are detrended by a least-squares straight line (:func:`detrend_linear`) before MPD and the
spectrum. Conventions: arrays are indexed ``[x, y]``; profiles run along x.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.fft

logger = logging.getLogger(__name__)

__all__ = [
    "TEXTURE_REFERENCE",
    "PEAK_DEPTHS",
    "MPD_BASELINE",
    "rms_height",
    "skewness",
    "detrend_linear",
    "mean_profile_depth",
    "third_octave_wavelengths",
    "texture_level_spectrum",
    "peak_fraction_within",
]

#: Reference amplitude of texture levels, ISO 13473-4 [m].
TEXTURE_REFERENCE = 1.0e-6
#: Depths below the patch's top at which the fraction of element peaks is reported [m].
PEAK_DEPTHS = (0.05e-3, 0.10e-3, 0.15e-3)
#: MPD baseline of ISO 13473-1 [m].
MPD_BASELINE = 0.1


def rms_height(height: np.ndarray) -> float:
    """Rms height about the mean [m]."""
    h = np.asarray(height, dtype=float)
    return float(np.sqrt(np.mean((h - h.mean()) ** 2)))


def skewness(height: np.ndarray) -> float:
    """Sample skewness of the heights, ``mean((h - mean)^3) / rms^3`` [-]."""
    h = np.asarray(height, dtype=float)
    d = h - h.mean()
    d2 = d * d
    m2 = np.mean(d2)
    if m2 == 0:
        raise ValueError("skewness: heights are constant")
    d2 *= d
    return float(np.mean(d2) / m2**1.5)


def detrend_linear(profiles: np.ndarray, axis: int = 0) -> np.ndarray:
    """Remove the least-squares straight line from each profile along ``axis``."""
    p = np.moveaxis(np.asarray(profiles, dtype=float), axis, 0)
    n = p.shape[0]
    t = np.arange(n) - 0.5 * (n - 1)
    mean = p.mean(axis=0)
    slope = np.tensordot(t, p, axes=(0, 0)) / np.dot(t, t) if n > 1 else np.zeros_like(mean)
    out = p - mean - t.reshape((-1,) + (1,) * (p.ndim - 1)) * slope
    return np.moveaxis(out, 0, axis)


def mean_profile_depth(height: np.ndarray, step: float, baseline: float = MPD_BASELINE) -> float:
    """Mean profile depth (MPD) per ISO 13473-1 of the profiles along x.

    Every profile (one per y sample) is cut into consecutive, non-overlapping baselines of
    ``baseline`` length; on each, the least-squares straight line is removed, the peak levels of
    the two half-baselines are found, and the mean segment depth is their mean (relative to the
    detrended mean level, which is zero). MPD is the average over all baselines of all profiles.
    When the field is shorter than ``baseline`` in x, one baseline of the field's length is
    used (not ISO conforming; callers should say so).

    Parameters
    ----------
    height : numpy.ndarray
        Heights [m], ``[x, y]`` (or a single 1-D profile along x).
    step : float
        Sample step along x [m].
    baseline : float
        Baseline length [m] (ISO 13473-1: 100 mm).

    Returns
    -------
    float
        MPD [m].

    References
    ----------
    ISO 13473-1:2019, Characterization of pavement texture by use of surface profiles --
    Part 1: Determination of mean profile depth.
    """
    h = np.asarray(height, dtype=float)
    if h.ndim == 1:
        h = h[:, None]
    nb = min(int(round(baseline / step)), h.shape[0])
    if nb < 4:
        raise ValueError(f"mean_profile_depth: baseline of {nb} samples is too short")
    nseg = h.shape[0] // nb
    seg = h[: nseg * nb].reshape(nseg, nb, -1).swapaxes(0, 1)  # [sample, segment, profile]
    seg = detrend_linear(seg, axis=0)
    half = nb // 2
    msd = 0.5 * (seg[:half].max(axis=0) + seg[half:].max(axis=0))
    return float(msd.mean())


def third_octave_wavelengths(lo: float = 0.5e-3, hi: float = 50e-3) -> np.ndarray:
    """Centre wavelengths of 1/3-octave bands (base-10 series 10^(m/10) mm) from ``lo`` to ``hi`` [m].

    The exact base-10 centres are used (e.g. 0.501 mm, 0.631 mm, ... 50.1 mm, nominally
    0.5, 0.63, ... 50 mm); the band edges are ``centre * 10^(+-1/20)``.
    """
    m = np.arange(int(np.floor(10 * np.log10(lo / 1e-3) + 0.5)), int(np.floor(10 * np.log10(hi / 1e-3) + 0.5)) + 1)
    return 1e-3 * 10.0 ** (m / 10.0)


def texture_level_spectrum(height: np.ndarray, step: float, lo: float = 0.5e-3, hi: float = 50e-3):
    """1/3-octave texture level spectrum L_tx(lambda) of the profiles along x (ISO 13473-4 style).

    Each profile (one per y sample) over the full field length ``L`` is detrended (least-squares
    line), Hann-windowed (power corrected by the window's mean square), and its one-sided
    periodogram is summed over the FFT bins inside each band's spatial-frequency edges
    ``(1/lambda_c) 10^(+-1/20)``; the band mean square, averaged over profiles, gives
    ``L = 20 log10(a_rms / 1 um)``. A band is kept when it contains at least one bin with two or
    more periods in the profile (``lambda <= L/2``) and its short-wavelength edge is at least four
    samples long.

    The Hann window spreads a sinusoid's power over its bin and the two neighbours (1/4 : 1/16 :
    1/16 in amplitude squared); a band holding three or more bins (lambda below about L/13) keeps
    all of it, while in the long-wavelength bands, which hold one or two bins, part of a pure tone's
    power is counted in the neighbouring band (total power is kept). For broadband road texture
    this evens out; the window avoids the leakage of the profile's end mismatch.

    Parameters
    ----------
    height : numpy.ndarray
        Heights [m], ``[x, y]`` (or a 1-D profile along x).
    step : float
        Sample step along x [m].
    lo, hi : float
        Range of centre wavelengths considered [m].

    Returns
    -------
    wavelength : numpy.ndarray
        Band centre wavelengths [m], increasing.
    level : numpy.ndarray
        Texture levels [dB re 1e-6 m].

    References
    ----------
    ISO 13473-4:2008, Characterization of pavement texture by use of surface profiles --
    Part 4: Spectral analysis of surface profiles.
    """
    h = np.asarray(height, dtype=float)
    if h.ndim == 1:
        h = h[:, None]
    n = h.shape[0]
    if n < 8:
        raise ValueError(f"texture_level_spectrum: profile of {n} samples is too short")
    # Periodic Hann: a sinusoid with an integer number of periods then leaks into its two
    # neighbouring bins only, which lie inside its 1/3-octave band for bands above 3 bins.
    w = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n) / n)
    prof = detrend_linear(h, axis=0) * w[:, None]
    ms_w = np.mean(w * w)
    # Profiles in chunks keep the complex spectrum small for large fields.
    power = np.zeros(n // 2 + 1)
    chunk = max(1, 2_000_000 // n)
    for j in range(0, h.shape[1], chunk):
        spec = scipy.fft.rfft(prof[:, j : j + chunk], axis=0)
        power += np.sum(spec.real**2 + spec.imag**2, axis=1)
    power /= h.shape[1] * n * n * ms_w
    power[1 : (n + 1) // 2] *= 2.0  # one-sided: all bins except DC and Nyquist appear twice
    power[0] = 0.0
    freq = scipy.fft.rfftfreq(n, d=step)  # cycles per m
    centres = third_octave_wavelengths(lo, hi)
    keep, levels = [], []
    length = n * step
    for lam in centres:
        f_lo, f_hi = 10 ** (-0.05) / lam, 10 ** 0.05 / lam
        sel = (freq >= f_lo) & (freq < f_hi) & (freq >= 2.0 / length)
        if not sel.any() or lam / 10 ** 0.05 < 4 * step:
            continue
        ms = power[sel].sum()
        keep.append(lam)
        levels.append(10 * np.log10(ms / TEXTURE_REFERENCE**2) if ms > 0 else -np.inf)
    return np.asarray(keep), np.asarray(levels)


def peak_fraction_within(z1: np.ndarray, depth) -> np.ndarray:
    """Fraction of element peaks within ``depth`` below the highest peak, ``z1 >= max z1 - depth``.

    Parameters
    ----------
    z1 : numpy.ndarray
        Element peak heights [m].
    depth : float or array_like
        Depth(s) below the top [m].

    Returns
    -------
    numpy.ndarray
        Fraction(s) [-], same shape as ``depth``.
    """
    z = np.asarray(z1, dtype=float).ravel()
    d = np.asarray(depth, dtype=float)
    return np.mean(z[None, :] >= z.max() - d.reshape(-1, 1), axis=1).reshape(d.shape)
