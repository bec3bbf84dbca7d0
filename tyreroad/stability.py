r"""The stability record of a time march: the kernel's fs/2 limit, the springs reached, the fs/2 alternation.

The march solves, at every step, the springs against the layer's instantaneous compliance G_0 with
the history of the kept lags (and the memory) on the right-hand side. Linearised about a state with
tangent spring stiffnesses S = diag(k_e), its characteristic equation has a root at z = -1 (a
period-2 alternation of the forces, "chatter" at fs/2) once

    I + S^(1/2) G_d(-1) S^(1/2)

loses positive definiteness, with G_d(-1) = sum_l (-1)^l g[dx, dy, l] (plus the memory's part at
fs/2) the kernel's transfer function at the Nyquist frequency: a real, symmetric matrix over the
patch. With lambda_min its smallest eigenvalue, no spring set with every k_e below

    k_crit = -1 / lambda_min          (infinite when lambda_min >= 0)

can put that root on the unit circle at z = -1; by Cauchy interlacing a contact set smaller than
the patch only raises its own limit, so k_crit over the whole patch is a safe bound. It is one
point of the unit circle; :func:`tyreroad.cq.kernel_margin` measures the margin over the whole circle
(dense, seconds to minutes per kernel: a study tool, not part of every run). :func:`nyquist_critical_stiffness` computes it (a dense eigen-solve up to
:data:`tyreroad.solver.FFT_THRESHOLD` elements, Lanczos over the FFT product above).

Every dynamic run records it with the stiffest tangent spring it reached and the fs/2 alternation
of its total force (:func:`fs2_alternation`): the rms of the fourth difference over 16, a
period-2 alternation's amplitude, over the last fifth of the run, relative to the mean force
there. A run whose springs pass k_crit is logged as a warning with the step where they did.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import scipy.sparse.linalg

from .influence import OffsetInfluence
from .kernel import LayerKernel
from .solver import FFT_THRESHOLD

logger = logging.getLogger(__name__)

__all__ = ["nyquist_table", "nyquist_critical_stiffness", "fs2_alternation", "StabilityRecord", "stability_record"]


def nyquist_table(kernel: LayerKernel, shape) -> np.ndarray:
    """G_d(-1)[dx, dy] = sum_l (-1)^l g[dx, dy, l] plus the memory's part at fs/2 [m/N] (cropped to the patch)."""
    if kernel.static:
        raise ValueError(f"{kernel.name}: a static kernel has no time march to be unstable")
    return kernel.own_frequency_response(np.array([0.5 * kernel.sample_rate]), shape)[0].real


def nyquist_critical_stiffness(kernel: LayerKernel, shape, workers: int = 1) -> tuple[float, float]:
    """(k_crit [N/m], lambda_min [m/N]) of the march's kernel at fs/2 over the whole patch.

    Parameters
    ----------
    kernel : LayerKernel
        A dynamic kernel (kept lags and memory).
    shape : tuple of int
        Patch (nx, ny).
    workers : int
        FFT threads (patches above the FFT threshold).

    Returns
    -------
    k_crit : float
        -1 / lambda_min, or ``inf`` for lambda_min >= 0.
    lambda_min : float
        The smallest eigenvalue of G_d(-1) [m/N].
    """
    own = getattr(kernel, "nyquist_critical_stiffness", None)
    if own is not None:  # a kernel whose march is not single-stage says its own limit (tyreroad.stage)
        return own(shape, workers)
    influence = OffsetInfluence(nyquist_table(kernel, shape), shape, workers)
    m = shape[0] * shape[1]
    if m <= FFT_THRESHOLD:
        lam = float(np.linalg.eigvalsh(influence.matrix())[0])
    else:
        op = scipy.sparse.linalg.LinearOperator((m, m), matvec=lambda v: influence.apply(np.ravel(v)), dtype=float)
        lam = float(scipy.sparse.linalg.eigsh(op, k=1, which="SA", tol=1e-8, return_eigenvectors=False)[0])
    return (-1.0 / lam if lam < 0.0 else math.inf), lam


def fs2_alternation(force, fraction: float = 0.2, window=None) -> float:
    """rms of the period-2 alternation of a force series over its last ``fraction``, over its mean there [1].

    The alternation amplitude of step n is the fourth difference over 16,
    |F[n+2] - 4 F[n+1] + 6 F[n] - 4 F[n-1] + F[n-2]| / 16: a pure fs/2 alternation A (-1)^n gives A,
    while a smooth force (a ramp, a loading curve: cubic within five steps) gives nearly nothing (the
    second difference would report the curvature of a short loading run, F'' dt^2 / 4, as alternation).
    ``window``: a boolean mask of contiguous steps to use instead (a rolling pass's steady part).
    NaN when the window carries no force or has fewer than five steps.
    """
    f = np.asarray(force, dtype=float)
    if window is not None:
        window = f[np.asarray(window, dtype=bool)]
    else:
        window = f[int(math.floor((1.0 - fraction) * f.size)):]
    mean = float(np.mean(np.abs(window))) if window.size else 0.0
    if window.size < 5 or not mean > 0:
        return float("nan")
    return float(np.sqrt(np.mean((np.diff(window, 4) / 16.0) ** 2))) / mean


class StabilityRecord:
    """What a dynamic run's file records of its stability (see the module docstring).

    Attributes
    ----------
    critical_stiffness : float
        k_crit of the kernel at fs/2 [N/m] (inf: no limit there).
    nyquist_eigenvalue : float
        lambda_min of G_d(-1) [m/N].
    max_spring_stiffness : numpy.ndarray
        The stiffest tangent spring of each step [N/m].
    alternation : float
        :func:`fs2_alternation` of the total force [1].
    """

    def __init__(self, critical_stiffness, nyquist_eigenvalue, max_spring_stiffness, alternation):
        self.critical_stiffness = float(critical_stiffness)
        self.nyquist_eigenvalue = float(nyquist_eigenvalue)
        self.max_spring_stiffness = np.asarray(max_spring_stiffness, dtype=float)
        self.alternation = float(alternation)

    @property
    def first_step_past_limit(self) -> int | None:
        """The first step whose stiffest spring exceeds k_crit, or None."""
        past = np.flatnonzero(self.max_spring_stiffness > self.critical_stiffness)
        return int(past[0]) if past.size else None

    def variables(self) -> dict:
        """The record as dataset variables (docs/data_contracts.md)."""
        return {
            "max_spring_stiffness": ("step", self.max_spring_stiffness, {
                "units": "N/m", "long_name": "stiffest tangent contact spring of the step"}),
            "nyquist_critical_stiffness": ((), self.critical_stiffness, {
                "units": "N/m", "long_name": "spring stiffness at which the time march's kernel admits an fs/2 "
                "alternation, -1/lambda_min(G_d(-1)) over the patch (inf: none)"}),
            "nyquist_eigenvalue": ((), self.nyquist_eigenvalue, {
                "units": "m/N", "long_name": "smallest eigenvalue of the kernel's transfer matrix at fs/2"}),
            "fs2_alternation": ((), self.alternation, {
                "units": "1", "long_name": "rms fs/2 alternation of the total force over the last fifth of the "
                "run (a rolling pass: its steady part), over the mean force there"}),
        }


def stability_record(kernel: LayerKernel, shape, max_spring_stiffness, force, workers: int = 1,
                     window=None) -> StabilityRecord:
    """The :class:`StabilityRecord` of a dynamic run; logs a warning where its springs pass k_crit.

    ``window``: the steps the alternation is measured over (default the last fifth of the run).
    """
    k_crit, lam = nyquist_critical_stiffness(kernel, shape, workers)
    record = StabilityRecord(k_crit, lam, max_spring_stiffness, fs2_alternation(force, window=window))
    step = record.first_step_past_limit
    if step is not None:
        logger.warning(
            "fs/2 stability: the stiffest spring reaches %.3e N/m at step %d, past the kernel's fs/2 limit "
            "k_crit = %.3e N/m (lambda_min = %.3e m/N); fs/2 alternation over the last fifth of the run %.2e of "
            "the mean force", float(np.max(record.max_spring_stiffness)), step, k_crit, lam, record.alternation)
    else:
        logger.info("fs/2 stability: springs up to %.3e N/m, below k_crit = %.3e N/m; alternation %.2e",
                    float(np.max(record.max_spring_stiffness, initial=0.0)), k_crit, record.alternation)
    return record
