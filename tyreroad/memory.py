r"""Long memory of the tread: the creep beyond the kept lags of the Green's function (SPEC 9).

The kept kernel holds L lags (256 at 51.2 kHz = 5 ms); a fractional tread creeps for seconds. Once
t >> h / c_s the layer responds quasi-statically with the visco-elastic modulus and, because nu does
not depend on frequency, the response separates in space and time. The tail beyond the kept lags is

    g[dx, dy, l] = R(dx, dy) c[l],   l >= L,        R = g(omega = 0) - sum_{l < L} g[dx, dy, l],

with c[l] the material's creep-rate sequence beyond L, normalised to sum_{l >= L} c[l] = 1. Every
offset keeps the sum rule sum_l g = g(omega = 0) by construction.

Creep from a retardation spectrum
---------------------------------
The creep-rate sequence comes from the material's creep compliance J(t), obtained by fitting its
complex compliance 1 / E(omega) with a retardation (Kelvin-Voigt chain) spectrum

    1 / E(omega) ~ J_g + sum_k J_k / (1 + i omega tau_k),      J(t) = J_g + sum_k J_k (1 - exp(-t / tau_k)),

with log-spaced retardation times tau_k (8 per decade, from 0.1 / (2 pi f_max) to 10 / (2 pi f_min),
f_min = 1e-7 Hz, fitted on f_min ... f_max) and J_g, J_k >= 0 (non-negative least squares on Re and Im, each frequency
weighted by |E|, i.e. relative error; J_g + sum J_k = 1 / E(0) is imposed with a large weight). A
causal, passive material with a positive retardation spectrum (fractional Kelvin-Voigt,
generalised Maxwell) is fitted to ~1e-4 relative (the default tread: 4e-5, and J(t) within 1e-8 of
the Mittag-Leffler form). The paper's loss-scaled variants are not causal (scaling eta at constant
|E| breaks the Kramers-Kronig relations): no causal creep holds them exactly, and the joint fit of
Re and Im is their nearest causal creep (relative error ~5 % at 1 Hz, 13 % at fs/2). The tail's
amplitude R is exact either way (sum rule); only its time shape carries that error. The largest
relative error over the fit band is recorded in the greens file and logged. The sequence is the increment of J over
one sample, c[l] proportional to J(t_{l + 1/2}) - J(t_{l - 1/2}): a sum of decaying exponentials, so
the tail history runs as a recursive filter whose cost per step does not grow with the run length
(:class:`tyreroad.history.TailHistory`).

Wrap-around and the non-causal precursor
----------------------------------------
The kept lags come from an inverse FFT over n_fft samples, which folds every lag l >= n_fft back onto
l mod n_fft. For the slow creep that is not negligible (the default tread still creeps after 80 ms).
Beyond n_fft / 2 samples the kernel is quasi-static, g[l] = g(0) E(0) (J(t_{l+1/2}) - J(t_{l-1/2})), so
the folded part is a geometric series per retardation term and is subtracted exactly from the kept
lags (:func:`wrapped_creep`). The same creep identifies the band-limited kernel's non-causal
precursor: the second half of the transform (n >= n_fft / 2) holds the causal creep from n_fft / 2
to n_fft samples plus the ringing just before t = 0 (an alternating Nyquist ringing, because the
fractional tread's compliance has not decayed at fs / 2). Discarding that precursor drops its sum
(-1.85 % of g(0) at the excitation element of the default tread) from the step response; for a
causal material (creep fit error <= 1e-2) the greens stage therefore puts the precursor back at
t >= 0: a correction of the first lags with the precursor's sum (the DC gain) and its spectrum up to
0.15 fs (:func:`tyreroad.greens.precursor_correction`), so that the kept lags hold the causal creep
at t_L (to 1e-4 of g(0)) and every later time of the step response is right, not only its limit. A
material that is not causal itself (the seed's loss-scaled variants) has a long negative-time
response of its own (+8 % of g(0) for eta x 0.5, -11 % for eta x 1.5, growing with the window
rather than converging like ringing); folding that onto lag 0 would change those variants' kernels
far beyond a discretisation fix (and makes the eta x 1.5 unloading ring), so it stays discarded,
as the seed discarded it.

References
----------
Schapery, R. A., & Park, S. W. (1999). Methods of interconversion between linear viscoelastic material
functions. Part II. Int. J. Solids Struct. 36(11), 1677-1699. doi:10.1016/S0020-7683(98)00060-2
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from . import checks
from .history import TailHistory

logger = logging.getLogger(__name__)

__all__ = ["RetardationSpectrum", "fit_retardation_spectrum", "wrapped_creep", "TailModel"]

#: Retardation times per decade of the creep fit.
TERMS_PER_DECADE = 8
#: Lowest frequency of the creep fit [Hz]: retardation times up to 1 / (2 pi 1e-7 Hz) = 18 days.
LOWEST_FIT_FREQUENCY = 1e-7
#: Fit error above which the creep fit is refused: the material is not a creeping solid the
#: retardation series can hold (e.g. an active table). The paper's loss-scaled variants (eta x s at
#: constant |E|) are not causal -- scaling eta alone breaks the Kramers-Kronig relations -- and are
#: held to about 13 % at fs/2 and 5 % at 1 Hz: their tail is the nearest causal creep.
MAX_FIT_ERROR = 0.25


@dataclass(frozen=True)
class RetardationSpectrum:
    """Creep compliance J(t) = J_g + sum_k J_k (1 - exp(-t / tau_k)).

    Attributes
    ----------
    glassy_compliance : float
        J_g [1/Pa], the instantaneous part.
    compliances : numpy.ndarray
        J_k [1/Pa], >= 0.
    times : numpy.ndarray
        tau_k [s].
    fit_error : float
        Largest |J_fit* - 1/E| / |1/E| over the fit band [1].
    """

    glassy_compliance: float
    compliances: np.ndarray
    times: np.ndarray
    fit_error: float

    @property
    def relaxed_compliance(self) -> float:
        """J(t -> inf) [1/Pa]."""
        return float(self.glassy_compliance + self.compliances.sum())

    def creep(self, t) -> np.ndarray:
        """J(t) [1/Pa] at times t [s] (>= 0)."""
        t = np.asarray(t, dtype=float)
        return self.glassy_compliance + np.sum(
            self.compliances * -np.expm1(-t[..., None] / self.times), axis=-1
        )

    def complex_compliance(self, omega) -> np.ndarray:
        """J*(omega) = J_g + sum_k J_k / (1 + i omega tau_k) [1/Pa]."""
        w = np.asarray(omega, dtype=float)
        return self.glassy_compliance + np.sum(self.compliances / (1.0 + 1j * w[..., None] * self.times), axis=-1)

    def term_increments(self, lags, dt: float) -> np.ndarray:
        """J_k [exp(-t_{l-1/2} / tau_k) - exp(-t_{l+1/2} / tau_k)] per lag l and term k [1/Pa].

        The creep of retardation term k over sample l >= 1, shape (n_lags, n_terms): the one
        formula behind :meth:`creep_increments`, :func:`wrapped_creep` and
        :meth:`TailModel.from_spectrum`. At l <= 0 it is the formal continuation (the folding of
        :func:`wrapped_creep` evaluates it at l + p n_fft); :meth:`creep_increments` gives lag 0
        its half sample.
        """
        lag = np.asarray(lags, dtype=float)
        return self.compliances * np.exp(-(lag[:, None] - 0.5) * dt / self.times) * -np.expm1(-dt / self.times)

    def creep_increments(self, start: int, stop: int, sample_rate: float) -> np.ndarray:
        """J(t_{l+1/2}) - J(t_{l-1/2}) for l = start ... stop - 1, t_l = l / fs [1/Pa] (J(t < 0) = 0)."""
        dt = 1.0 / sample_rate
        first = max(start, 1)
        out = np.zeros(stop - start)
        out[first - start:] = self.term_increments(np.arange(first, stop), dt).sum(axis=1)
        if start == 0:
            out[0] = self.glassy_compliance + float(np.sum(self.compliances * -np.expm1(-0.5 * dt / self.times)))
        return out


def fit_retardation_spectrum(material, max_frequency: float) -> RetardationSpectrum:
    """Fit 1 / E(omega) of a material with a non-negative retardation spectrum (see the module docstring).

    Parameters
    ----------
    material : Material
        Provides ``modulus(omega)`` [Pa] and ``name``.
    max_frequency : float
        Upper end of the fit band [Hz] (the kernel's fs / 2).

    Returns
    -------
    RetardationSpectrum

    Raises
    ------
    ValueError
        If the largest relative fit error exceeds :data:`MAX_FIT_ERROR` (naming the material).
    """
    f_max = checks.real("max_frequency", max_frequency, positive=True)
    decades = np.log10(f_max / LOWEST_FIT_FREQUENCY)
    n_terms = int(np.ceil(decades * TERMS_PER_DECADE)) + 1
    # one decade beyond each end of the band, so that no end of the band is held by the last term alone
    n_terms += 2 * TERMS_PER_DECADE
    times = np.logspace(np.log10(10 / (2 * np.pi * LOWEST_FIT_FREQUENCY)), np.log10(0.1 / (2 * np.pi * f_max)), n_terms)
    freq = np.logspace(np.log10(LOWEST_FIT_FREQUENCY), np.log10(f_max), 4 * n_terms)
    omega = 2 * np.pi * freq
    target = 1.0 / np.asarray(material.modulus(omega), dtype=complex)
    e0 = float(np.real(material.modulus(np.array([0.0]))[0]))
    basis = np.concatenate([np.ones((omega.size, 1)), 1.0 / (1.0 + 1j * omega[:, None] * times)], axis=1)
    weight = 1.0 / np.abs(target)
    rows = np.concatenate([(basis.real * weight[:, None]), (basis.imag * weight[:, None])])
    rhs = np.concatenate([target.real * weight, target.imag * weight])
    # J(inf) = 1 / E(0): the relaxed compliance is the long-time limit the tail must reach
    rows = np.vstack([rows, 1e3 * e0 * np.ones(basis.shape[1])])
    rhs = np.append(rhs, 1e3)
    # columns scaled to unit norm: NNLS converges on the compliance scale 1e-8 1/Pa
    scale = np.linalg.norm(rows, axis=0)
    coef, _ = nnls(rows / scale, rhs, maxiter=50 * rows.shape[1])
    coef = coef / scale
    spectrum = RetardationSpectrum(float(coef[0]), coef[1:].copy(), times, 0.0)
    error = float(np.max(np.abs(spectrum.complex_compliance(omega) - target) * weight))
    spectrum = RetardationSpectrum(spectrum.glassy_compliance, spectrum.compliances, times, error)
    name = getattr(material, "name", "material")
    logger.info(
        "creep fit %s: %d retardation times %.1e ... %.1e s, max relative error %.1e, J(inf) E(0) = %.6f",
        name, n_terms, times[-1], times[0], error, spectrum.relaxed_compliance * e0,
    )
    if error > 0.02:
        logger.warning(
            "creep fit %s: max relative compliance error %.1e: the material is not causal (e.g. a loss-scaled "
            "variant); the tail beyond the kept lags is its nearest causal creep", name, error,
        )
    if error > MAX_FIT_ERROR:
        raise ValueError(
            f"materials.{name}: the compliance 1/E(omega) cannot be held by a non-negative retardation "
            f"spectrum (max relative error {error:.2e} > {MAX_FIT_ERROR}); the long memory needs a passive, "
            "creeping material"
        )
    return spectrum


def wrapped_creep(spectrum: RetardationSpectrum, n_fft: int, n_lags: int, sample_rate: float, first: int = 0) -> np.ndarray:
    """The creep folded onto lags ``first`` ... ``first + n_lags - 1`` by an n_fft-point inverse FFT,
    per unit relaxed compliance.

    sum_{p >= 1} [J(t_{l + p N + 1/2}) - J(t_{l + p N - 1/2})] / J(inf), N = n_fft: a geometric series
    per retardation term, summed in closed form. Times g(0) this is what the inverse FFT added to
    those lags from beyond its period.

    Returns
    -------
    numpy.ndarray
        Shape (n_lags,) [1].
    """
    dt = 1.0 / sample_rate
    # lag l + p N for p >= 1: the increment at l times ratio^p, a geometric series
    ratio = np.exp(-n_fft * dt / spectrum.times)
    per_term = spectrum.term_increments(np.arange(first, first + n_lags), dt) * ratio / -np.expm1(-n_fft * dt / spectrum.times)
    return per_term.sum(axis=1) / spectrum.relaxed_compliance


@dataclass(frozen=True)
class TailModel:
    """The kernel beyond the kept lags as a spatial factor times a recursive time filter.

    g[dx, dy, l] = R[dx, dy] c[l] for l >= L, c[l] = sum_k weight_k decay_k^(l - L), sum_{l >= L} c = 1.

    Attributes
    ----------
    residual_compliance : numpy.ndarray
        R[dx, dy] [m/N], the static compliance the kept lags miss.
    weights : numpy.ndarray
        weight_k [1].
    decays : numpy.ndarray
        decay_k = exp(-dt / tau_k) [1].
    delay : int
        L, the first lag of the tail.
    """

    residual_compliance: np.ndarray
    weights: np.ndarray
    decays: np.ndarray
    delay: int

    @classmethod
    def from_spectrum(cls, residual_compliance, spectrum: RetardationSpectrum, sample_rate: float, n_lags: int,
                      cutoff: float = 1e-17) -> "TailModel":
        """Tail of a kernel with ``n_lags`` kept lags; terms whose weight is below ``cutoff`` of the
        total (retardation far faster than the kept lags) are dropped."""
        dt = 1.0 / sample_rate
        times = spectrum.times
        # the creep still to come at t_{L - 1/2} per term (the sum of term_increments over l >= L)
        start = np.exp(-(n_lags - 0.5) * dt / times) * spectrum.compliances
        total = start.sum()
        if not total > 0:
            raise ValueError("TailModel: the material does not creep beyond the kept lags (no tail to model)")
        weights = start * -np.expm1(-dt / times) / total
        keep = weights > cutoff * weights.sum()
        return cls(np.asarray(residual_compliance, dtype=float), weights[keep], np.exp(-dt / times[keep]), int(n_lags))

    def sequence(self, stop: int) -> np.ndarray:
        """c[l] for l = L ... stop - 1 [1] (for tests and plots)."""
        steps = np.arange(self.delay, stop) - self.delay
        return (self.decays[None, :] ** steps[:, None]) @ self.weights

    # the memory-model protocol of tyreroad.kernel
    def history(self, shape, method: str, workers: int = 1):
        """The recursive tail filter as a history term (:class:`tyreroad.history.TailHistory`)."""
        return TailHistory(self, shape, method, workers)

    def frequency_response(self, frequencies, sample_rate: float) -> np.ndarray:
        """The tail's part of the kernel's transfer function, sum_{l >= L} g[dx, dy, l] exp(-i omega l / fs) [m/N].

        Per term a geometric series: R weight_k exp(-i omega L dt) / (1 - decay_k exp(-i omega dt)).

        Returns
        -------
        numpy.ndarray
            Complex offset tables, shape (n_f,) + R.shape.
        """
        z = np.exp(-2j * np.pi * np.asarray(frequencies, dtype=float) / float(sample_rate))
        c = (z**self.delay) * np.sum(self.weights / (1.0 - self.decays * z[:, None]), axis=1)
        return c[:, None, None] * self.residual_compliance[None, :, :]

    def describe(self) -> str:
        """What the log says of this memory."""
        return f"creep tail from lag {self.delay}, {self.weights.size} retardation terms"
