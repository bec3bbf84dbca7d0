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

#: Relative level below which a margin p counts as zero: of the largest |entry| of G_d on the patch's matrices,
#: of the largest |eigenvalue| of its circulant in :func:`circulant_margin` (which bounds every entry). G_d(1)
#: and G_d(-1) are real, so their symbols' imaginary parts are rounding (~1e-20 m/N), whose sign must not
#: certify p > 0 at phi = +-pi/2 (it did: the fold kernel of tread-rho2 on 20 x 20 was stored stable for every
#: spring, with lambda_min G_d(-1) = -2.96e-5 m/N, a root at z = -1 for uniform springs of 3.38e4 N/m).
MARGIN_TOLERANCE = 1e-9

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
    margin_stiffness : float
        The kernel's stability margin over the whole unit circle [N/m]: the greens file's
        ``critical_stiffness`` (:mod:`tyreroad.margin`), the stiffest spring stable on every contact set
        (inf: every spring; nan: the kernel does not know its margin). Never above ``critical_stiffness``,
        which is only the fs/2 point of the circle.
    """

    def __init__(self, critical_stiffness, nyquist_eigenvalue, max_spring_stiffness, alternation,
                 margin_stiffness=float("nan")):
        self.critical_stiffness = float(critical_stiffness)
        self.nyquist_eigenvalue = float(nyquist_eigenvalue)
        self.max_spring_stiffness = np.asarray(max_spring_stiffness, dtype=float)
        self.alternation = float(alternation)
        self.margin_stiffness = float(margin_stiffness)

    @property
    def limit(self) -> float:
        """The stiffness the run's springs must stay below [N/m]: the whole-circle margin where known, else fs/2's."""
        return self.critical_stiffness if np.isnan(self.margin_stiffness) else self.margin_stiffness

    @property
    def first_step_past_limit(self) -> int | None:
        """The first step whose stiffest spring exceeds :attr:`limit`, or None."""
        past = np.flatnonzero(self.max_spring_stiffness > self.limit)
        return int(past[0]) if past.size else None

    def variables(self) -> dict:
        """The record as dataset variables (docs/data_contracts.md)."""
        return {
            "max_spring_stiffness": ("step", self.max_spring_stiffness, {
                "units": "N/m", "long_name": "stiffest tangent contact spring of the step"}),
            "nyquist_critical_stiffness": ((), self.critical_stiffness, {
                "units": "N/m", "long_name": "spring stiffness at which the time march's kernel admits an fs/2 "
                "alternation, -1/lambda_min(G_d(-1)) over the patch (inf: none)"}),
            "margin_critical_stiffness": ((), self.margin_stiffness, {
                "units": "N/m", "long_name": "the run's kernel's stability margin over the whole unit circle: the "
                "stiffest spring stable on every contact set of its patch (the greens file's critical_stiffness; "
                "inf: every spring, nan: not known)"}),
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
    margin = getattr(kernel, "critical_stiffness", None)
    record = StabilityRecord(k_crit, lam, max_spring_stiffness, fs2_alternation(force, window=window),
                             float("nan") if margin is None else margin)
    what = ("the kernel's margin over the unit circle" if not np.isnan(record.margin_stiffness) else "the kernel's fs/2 limit (its whole-circle margin is not known)")
    step = record.first_step_past_limit
    if step is not None:
        logger.warning(
            "stability: the stiffest spring reaches %.3e N/m at step %d, past %s k_crit = %.3e N/m (fs/2: %.3e "
            "N/m, lambda_min = %.3e m/N); fs/2 alternation over the last fifth of the run %.2e of the mean force",
            float(np.max(record.max_spring_stiffness)), step, what, record.limit, k_crit, lam, record.alternation)
    else:
        logger.info("stability: springs up to %.3e N/m, below %s k_crit = %.3e N/m (fs/2: %.3e N/m); "
                    "alternation %.2e", float(np.max(record.max_spring_stiffness, initial=0.0)), what,
                    record.limit, k_crit, record.alternation)
    return record


# ----------------------------------------------------------------------------------------------
# the margin over the whole unit circle, for every contact set: a bound from the circulant embedding


def mask_bands(theta, mask) -> list[tuple[float, float]]:
    """The contiguous runs of grid points where ``mask`` is true, as (first, last) theta [rad]."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], np.asarray(mask).astype(int), [0]])))
    return [(float(theta[a]), float(theta[b - 1])) for a, b in zip(edges[::2], edges[1::2])]


class CirculantMargin:
    r"""A rigorous lower bound of the march's stability margin over the whole unit circle.

    Every contact set's influence matrix over the patch is a principal submatrix of the patch's
    block-Toeplitz matrix G_d(e^{i theta}) = [g_d(e - m)], and that is the leading principal submatrix of
    the block-circulant matrix of the same offset table wrapped on its own (2 nx - 1) x (2 ny - 1) grid.
    For a real phase phi, Herm(e^{i phi} G_d) is, elementwise, Re(e^{i phi} g_d) (g_d is even in the
    offset), and the circulant's eigenvalues are the 2-D DFT of that table, Re(e^{i phi} G^(theta, k))
    with G^ = DFT(g_d) (Cauchy interlacing: a principal submatrix's lambda_min is not smaller). So

        p(theta) >= p_bound(theta) = max_phi min_k Re(e^{i phi} G^(theta, k)),

    and where p_bound <= 0, the smallest uniform spring that can put a root of the march on |z| = 1 at
    theta is at least k_bound(theta) = max_phi cos phi / (-min_k Re(e^{i phi} G^(theta, k))) (see
    :mod:`tyreroad.cq`). ``k_crit`` = min over theta of k_bound: no spring set with every k_e below it,
    on any contact set of the patch, makes the march unstable. It is conservative (the circulant is
    larger than the patch; the phases are a grid) and cheap (one DFT of the kernel per lag, a matrix
    product per theta chunk), so it is evaluated densely (default 8193 theta in [0, pi]: a failing band
    0.001 pi wide spans 8 points).

    Attributes
    ----------
    theta : numpy.ndarray
        theta in [0, pi] [rad] (theta = 2 pi f / fs).
    p_bound : numpy.ndarray
        The lower bound of p(theta) [m/N].
    k_bound : numpy.ndarray
        The lower bound of the spring at which a root reaches |z| = 1 at theta [N/m] (inf where p_bound is
        above the rounding level, :data:`MARGIN_TOLERANCE` times the largest |G^| at that theta: certified).
    """

    def __init__(self, theta, p_bound, k_bound, name: str = "kernel"):
        self.theta = np.asarray(theta, dtype=float)
        self.p_bound = np.asarray(p_bound, dtype=float)
        self.k_bound = np.asarray(k_bound, dtype=float)
        self.name = name

    @property
    def min_p(self) -> float:
        """min over theta of p_bound [m/N] (> 0: stable for every spring set)."""
        return float(self.p_bound.min())

    @property
    def k_crit(self) -> float:
        """min over theta of k_bound [N/m] (inf: stable for every spring set S >= 0, hard contact included)."""
        return float(self.k_bound.min())

    @property
    def theta_k(self) -> float:
        """Where k_crit is reached [rad] (NaN when k_crit is infinite)."""
        return float(self.theta[int(np.argmin(self.k_bound))]) if math.isfinite(self.k_crit) else math.nan

    def failing_bands(self) -> list[tuple[float, float]]:
        """theta intervals [rad] where p > 0 is not certified (p_bound at or below the rounding level)."""
        return mask_bands(self.theta, np.isfinite(self.k_bound))

    def describe(self) -> str:
        if math.isfinite(self.k_crit):
            bands = ", ".join(f"{a / np.pi:.3f}-{b / np.pi:.3f} pi" for a, b in self.failing_bands()[:4])
            return (f"{self.name}: stable for springs below k_crit >= {self.k_crit:.4g} N/m (bound; reached at "
                    f"theta = {self.theta_k / np.pi:.4f} pi); margin fails on {bands}")
        return f"{self.name}: stable for every spring set (min p_bound = {self.min_p:.3e} m/N over the unit circle)"

    def variables(self) -> dict:
        """The margin as greens-dataset variables (docs/data_contracts.md)."""
        return {
            "margin_p": ("theta", self.p_bound, {
                "units": "m/N", "long_name": "lower bound of the march's stability margin p(theta) = max_phi "
                "lambda_min Herm(exp(i phi) G_d(exp(i theta))), from the circulant embedding (> 0: no spring "
                "set S >= 0 puts a root on |z| = 1 there)"}),
            "margin_spring_bound": ("theta", self.k_bound, {
                "units": "N/m", "long_name": "lower bound of the element spring at which a root of the march "
                "reaches |z| = 1 at theta (inf where margin_p > 0)"}),
            "critical_stiffness": ((), self.k_crit, {
                "units": "N/m", "long_name": "springs below this are stable on every contact set of the patch "
                "(min over theta of margin_spring_bound; inf: every spring, hard contact included)"}),
            "critical_theta": ((), self.theta_k, {
                "units": "rad", "long_name": "theta = 2 pi f / fs where critical_stiffness is reached"}),
            "margin_min": ((), self.min_p, {
                "units": "m/N", "long_name": "min over theta of margin_p"}),
        }

    @classmethod
    def from_dataset(cls, ds) -> "CirculantMargin | None":
        """The margin stored in a greens dataset, or None (a file from before it was stored)."""
        if "margin_p" not in ds:
            return None
        return cls(ds["theta"].values, ds["margin_p"].values, ds["margin_spring_bound"].values,
                   str(ds.attrs.get("material", "kernel")))


def circulant_margin(kernel: LayerKernel, shape, n_theta: int = 8193, n_phi: int = 33,
                     chunk: int = 256) -> CirculantMargin:
    """:class:`CirculantMargin` of a dynamic kernel (kept lags + memory) over an (nx, ny) patch.

    Parameters
    ----------
    kernel : LayerKernel
        A dynamic kernel.
    shape : tuple of int
        Patch (nx, ny): the offsets the bound covers (every contact set inside it).
    n_theta : int
        Points on [0, pi].
    n_phi : int
        Phases on [-pi/2, pi/2] (odd: phi = 0 included, exact at theta = 0 and pi).
    chunk : int
        theta per matrix product (memory: chunk x (2 nx - 1)(2 ny - 1) complex).
    """
    if kernel.static:
        raise ValueError(f"{kernel.name}: a static kernel has no time march")
    if n_theta < 3 or n_phi < 1 or n_phi % 2 == 0:
        raise ValueError(f"n_theta >= 3 and odd n_phi expected, got {n_theta}, {n_phi}")
    nx, ny = shape
    g = kernel.table(shape)
    # circulant eigenvalues per lag: offset 0 moved to index 0; g even in the offset -> real DFT
    spectra = np.fft.fft2(np.fft.ifftshift(g, axes=(0, 1)), axes=(0, 1)).real.reshape(-1, g.shape[2])
    theta = np.linspace(0.0, np.pi, int(n_theta))
    phis = np.linspace(-np.pi / 2, np.pi / 2, int(n_phi)) if n_phi > 1 else np.zeros(1)
    rot = np.exp(1j * phis)
    lags = np.arange(g.shape[2])
    m = np.empty((phis.size, theta.size))
    scale = np.empty(theta.size)  # max |G^| per theta: the rounding level of its DFT values (>= every entry)
    for start in range(0, theta.size, chunk):
        t = theta[start:start + chunk]
        sym = spectra @ np.exp(-1j * np.outer(lags, t))  # (K, n_t)
        if kernel.memory is not None:
            cx, cy = (kernel.lags.shape[0] - 1) // 2, (kernel.lags.shape[1] - 1) // 2
            tail = kernel.memory.frequency_response(t * kernel.sample_rate / (2 * np.pi), kernel.sample_rate)
            tail = tail[:, cx - (nx - 1): cx + nx, cy - (ny - 1): cy + ny]
            sym = sym + np.fft.fft2(np.fft.ifftshift(tail, axes=(1, 2)), axes=(1, 2)).reshape(t.size, -1).T
        scale[start:start + t.size] = np.abs(sym).max(axis=0)
        for j, r in enumerate(rot):
            m[j, start:start + t.size] = (r * sym).real.min(axis=0)
    p_bound = m.max(axis=0)
    with np.errstate(divide="ignore"):
        k_phi = np.where(m < 0, np.cos(phis)[:, None] / np.maximum(-m, 1e-300), 0.0)
    k_bound = np.where(p_bound > MARGIN_TOLERANCE * scale, np.inf, k_phi.max(axis=0))
    return CirculantMargin(theta, p_bound, k_bound, kernel.name)
