"""Road surface stage (SPEC section 3): surfaces, contact patch and element peaks.

Three sources of road heights are supported, selected by ``surfaces.<name>.generator``:

``iso10844``
    A synthetic, aggregate-based surface resembling a dense ISO 10844 test track (0/8 mm aggregate,
    MPD 0.5 +- 0.2 mm): elliptical stones with paraboloid caps rolled to a near-common top level,
    embedded in a self-affine mortar base, plus a self-affine micro-texture. This is the default
    (the seed paper's measured scan is not public).
``spectral``
    A Gaussian self-affine surface (Hurst exponent, roll-off wavelength, rms height) with an
    optional monotone transform to a target skewness, for sensitivity studies.
``file``
    A measured scan, read by :mod:`tyreroad.scans`.
``flat``
    A perfectly flat road (all heights 0): the oracle road of the rolling checks (SPEC 12). Its only
    generator key is ``field_size`` (default: the patch itself); its patch is taken at the field
    centre unless ``patch_selection`` says otherwise (every element peak is at the top, so the
    contact-fraction rule has nothing to select). Its skewness is undefined (NaN) and its texture
    levels are -inf. A flat *scan file* stays an error: it is almost always a unit or export mistake.

Whatever the source, the heights are put on a grid of ``element_size / samples_per_element``
(26 samples per 1 mm element), the texture statistics of the whole field are computed by
:mod:`tyreroad.texture` (MPD per ISO 13473-1, rms, skewness, 1/3-octave texture levels per
ISO 13473-4), and a contact patch of
``patch_elements`` elements is cut out. Each element's matching point is its highest sample
(SPEC section 1).

Conventions: arrays are indexed ``[x, y]``; height ``z`` points from the road towards the tread.
Fine samples are cell-centred: sample ``i`` of the patch sits at ``x = (i + 1/2) dx`` from the
patch origin, so element ``(i, j)`` covers ``[i c, (i+1) c] x [j c, (j+1) c]`` and has its centre
at ``((i + 1/2) c, (j + 1/2) c)``.

Patch selection rule (``patch_selection: contact_fraction``, the default): the element peak
heights of the whole field are computed on the element grid that starts at the field's first
sample; every element-aligned origin whose patch fits in the field is a candidate. For each
candidate, the fraction of its element peaks lying within ``fraction_depth`` (0.15 mm) of the
candidate's highest peak is computed. The candidate whose fraction is closest to
``target_fraction`` (0.51) is taken; ties go to the candidate whose centre is closest to the
field centre, then to the smallest (x, y) index. If the chosen fraction lies outside
``fraction_range`` (0.40-0.65) no candidate qualifies and an error is raised. The rule follows the
seed paper's statement that about half of the elements are in contact at d = 0.15 mm.
``patch_selection: centre`` takes the element-aligned patch nearest the field centre, and an
explicit ``origin`` [m, m] (snapped to the nearest sample) overrides both.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import scipy.fft
import xarray as xr
from scipy.optimize import brentq

from . import io, scans
from .texture import (
    MPD_BASELINE,
    PEAK_DEPTHS,
    mean_profile_depth,
    peak_fraction_within,
    rms_height,
    skewness,
    texture_level_spectrum,
)

logger = logging.getLogger(__name__)

__all__ = [
    "Iso10844Parameters",
    "SpectralParameters",
    "PatchSelection",
    "self_affine_field",
    "skew_transform",
    "generate_iso10844",
    "generate_spectral",
    "FlatParameters",
    "element_samples",
    "element_peaks",
    "select_patch",
    "prepare_surface",
    "levelled_scan_hint",
    "surface_dataset",
    "COMMON_KEYS",
]


# Keys every surface preset may carry, with their defaults (None: required or optional without default).
COMMON_KEYS: dict[str, Any] = {
    "generator": None,
    "seed": 0,
    "element_size": 1.0e-3,
    "samples_per_element": 26,
    "patch_elements": [20, 20],
    "patch_selection": "contact_fraction",
    "target_fraction": 0.51,
    "fraction_range": [0.40, 0.65],
    "fraction_depth": 0.15e-3,
    "origin": None,
}


# ---------------------------------------------------------------------------------------------
# Parameters
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Iso10844Parameters:
    """Parameters of the aggregate-based ISO 10844-like generator (all lengths in m).

    Attributes
    ----------
    field_size : tuple of float
        Size of the generated field in x and y [m]. ISO 13473-1 MPD needs >= 0.1 m in x.
    stone_diameter : tuple of float
        Smallest and largest stone diameter (major axis) [m]; diameters are log-uniform.
    stone_coverage : float
        Total plan area of all stone ellipses divided by the field area [-] (stones may overlap,
        so the covered fraction is about ``1 - exp(-stone_coverage)``).
    stone_ellipticity : tuple of float
        Range of the minor/major axis ratio [-], uniform.
    cap_height_ratio : float
        Drop of the paraboloid cap from the stone's top to its rim, divided by the stone's
        major diameter [-]. Small values give flat, well-rolled stone tops.
    top_scatter : float
        Standard deviation of the stone top heights about the common level z = 0 [m].
    roller_level : float or None
        Level of the finishing roller relative to the common level [m]: stones whose top would
        stand above it are pressed down to it (the hot mix yields), so the tops are
        min(N(0, top_scatter), roller_level) and a share of the stones ends exactly at the
        roller plane. None: no rolling (Gaussian tops).
    mortar_depth : float
        Mean level of the mortar below the common stone top level [m].
    mortar_rms : float
        Rms height of the mortar's self-affine texture [m].
    mortar_hurst : float
        Hurst exponent of the mortar texture [-].
    mortar_rolloff : float
        Roll-off wavelength of the mortar texture [m].
    mortar_cutoff : float
        Short cut-off wavelength of the mortar texture [m] (finer scales are micro-texture).
    microtexture_rms : float
        Rms height of the micro-texture added to the whole surface [m].
    microtexture_hurst : float
        Hurst exponent of the micro-texture [-].
    microtexture_rolloff : float
        Roll-off wavelength of the micro-texture [m] (PIARC: micro-texture is below 0.5 mm).
    """

    field_size: tuple[float, float] = (0.1, 0.1)
    stone_diameter: tuple[float, float] = (2.0e-3, 8.0e-3)
    stone_coverage: float = 1.2
    stone_ellipticity: tuple[float, float] = (0.7, 1.0)
    cap_height_ratio: float = 0.06
    top_scatter: float = 0.04e-3
    roller_level: float | None = None
    mortar_depth: float = 1.0e-3
    mortar_rms: float = 0.15e-3
    mortar_hurst: float = 0.8
    mortar_rolloff: float = 5.0e-3
    mortar_cutoff: float = 0.5e-3
    microtexture_rms: float = 10.0e-6
    microtexture_hurst: float = 0.8
    microtexture_rolloff: float = 0.5e-3

    def __post_init__(self) -> None:
        _check_pair("field_size", self.field_size, positive=True)
        _check_pair("stone_diameter", self.stone_diameter, positive=True, ordered=True)
        _check_pair("stone_ellipticity", self.stone_ellipticity, positive=True, ordered=True)
        if self.stone_ellipticity[1] > 1.0:
            raise ValueError(f"stone_ellipticity must lie in (0, 1], got {list(self.stone_ellipticity)}")
        for name in ("stone_coverage", "cap_height_ratio", "mortar_rolloff", "mortar_cutoff", "microtexture_rolloff"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)!r}")
        for name in ("top_scatter", "mortar_depth", "mortar_rms", "microtexture_rms"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.roller_level is not None and not math.isfinite(self.roller_level):
            raise ValueError(f"roller_level must be a finite number [m] or null, got {self.roller_level!r}")
        for name in ("mortar_hurst", "microtexture_hurst"):
            if not 0.0 < getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must lie in (0, 1], got {getattr(self, name)!r}")


@dataclass(frozen=True)
class SpectralParameters:
    """Parameters of the Gaussian self-affine generator (lengths in m).

    Attributes
    ----------
    field_size : tuple of float
        Size of the generated field in x and y [m].
    rms_height : float
        Rms height of the surface [m].
    hurst : float
        Hurst exponent H [-]; the isotropic PSD falls as q^-2(1+H) above the roll-off.
    rolloff_wavelength : float
        Roll-off wavelength [m]; the PSD is flat at longer wavelengths.
    short_cutoff : float or None
        Shortest wavelength with power [m]; None: down to the grid's Nyquist wavelength.
    skewness : float or None
        Target skewness after a monotone transform of the heights; None keeps the Gaussian.
    """

    field_size: tuple[float, float] = (0.1, 0.1)
    rms_height: float = 0.3e-3
    hurst: float = 0.8
    rolloff_wavelength: float = 10.0e-3
    short_cutoff: float | None = None
    skewness: float | None = None

    def __post_init__(self) -> None:
        _check_pair("field_size", self.field_size, positive=True)
        if not self.rms_height > 0:
            raise ValueError(f"rms_height must be > 0, got {self.rms_height!r}")
        if not 0.0 < self.hurst <= 1.0:
            raise ValueError(f"hurst must lie in (0, 1], got {self.hurst!r}")
        if not self.rolloff_wavelength > 0:
            raise ValueError(f"rolloff_wavelength must be > 0, got {self.rolloff_wavelength!r}")
        if self.short_cutoff is not None and not self.short_cutoff > 0:
            raise ValueError(f"short_cutoff must be > 0 or null, got {self.short_cutoff!r}")
        if self.skewness is not None and not abs(self.skewness) <= 3.0:
            raise ValueError(f"skewness must lie in [-3, 3] or be null, got {self.skewness!r}")


@dataclass(frozen=True)
class FlatParameters:
    """Parameters of the flat road (generator ``flat``).

    Attributes
    ----------
    field_size : tuple of float or None
        Size of the field in x and y [m]; None: exactly the patch.
    """

    field_size: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.field_size is not None:
            _check_pair("field_size", self.field_size, positive=True)


@dataclass(frozen=True)
class PatchSelection:
    """How the contact patch is cut out of the field (see the module docstring).

    Attributes
    ----------
    patch_elements : tuple of int
        Number of elements of the patch in x and y.
    rule : str
        ``"contact_fraction"`` or ``"centre"``.
    target_fraction : float
        Wanted fraction of element peaks within ``fraction_depth`` of the patch's top [-].
    fraction_range : tuple of float
        Acceptable range of that fraction [-].
    fraction_depth : float
        Depth below the patch's highest element peak [m].
    origin : tuple of float or None
        Explicit patch origin in field coordinates [m] (overrides ``rule``).
    """

    patch_elements: tuple[int, int] = (20, 20)
    rule: str = "contact_fraction"
    target_fraction: float = 0.51
    fraction_range: tuple[float, float] = (0.40, 0.65)
    fraction_depth: float = 0.15e-3
    origin: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.rule not in ("contact_fraction", "centre"):
            raise ValueError(f"patch_selection must be 'contact_fraction' or 'centre', got {self.rule!r}")
        pe = self.patch_elements
        if len(pe) != 2 or any(int(v) != v or v < 1 for v in pe):
            raise ValueError(f"patch_elements must be two positive integers, got {list(pe)!r}")
        lo, hi = self.fraction_range
        if not 0.0 <= lo <= self.target_fraction <= hi <= 1.0:
            raise ValueError(
                f"need 0 <= fraction_range[0] <= target_fraction <= fraction_range[1] <= 1, got "
                f"target_fraction={self.target_fraction}, fraction_range={list(self.fraction_range)}"
            )
        if not self.fraction_depth > 0:
            raise ValueError(f"fraction_depth must be > 0, got {self.fraction_depth!r}")
        if self.origin is not None and (len(self.origin) != 2 or min(self.origin) < 0):
            raise ValueError(f"origin must be two non-negative lengths [m, m], got {self.origin!r}")


def _check_pair(name: str, value, positive: bool = False, ordered: bool = False) -> None:
    if len(value) != 2 or not all(np.isfinite(v) for v in value):
        raise ValueError(f"{name} must be a pair of finite numbers, got {list(value)!r}")
    if positive and min(value) <= 0:
        raise ValueError(f"{name} must be positive, got {list(value)!r}")
    if ordered and value[0] > value[1]:
        raise ValueError(f"{name} must be [min, max], got {list(value)!r}")


# ---------------------------------------------------------------------------------------------
# Generators
# ---------------------------------------------------------------------------------------------
def _grid_shape(field_size, step) -> tuple[int, int]:
    return tuple(int(math.floor(s / step + 1e-9)) for s in field_size)  # type: ignore[return-value]


def self_affine_field(
    shape: tuple[int, int],
    step: float,
    rms: float,
    hurst: float,
    rolloff_wavelength: float,
    rng: np.random.Generator,
    short_cutoff: float | None = None,
) -> np.ndarray:
    """Gaussian random field with an isotropic self-affine power spectrum.

    The isotropic PSD is ``C(q) = C0`` for ``q < q_r``, ``C0 (q/q_r)^(-2(1+H))`` for
    ``q_r <= q <= q_s`` and zero above ``q_s`` (``q_r = 2 pi / rolloff_wavelength``,
    ``q_s = 2 pi / short_cutoff``), with ``C(0) = 0``. White Gaussian noise drawn from ``rng`` is
    filtered with ``sqrt(C)`` by FFT, and the result is scaled to zero mean and exactly ``rms``.
    The field is periodic over the grid.

    Parameters
    ----------
    shape : tuple of int
        Grid shape ``(nx, ny)``.
    step : float
        Grid step [m].
    rms : float
        Rms height of the result [m].
    hurst : float
        Hurst exponent H [-], 0 < H <= 1.
    rolloff_wavelength : float
        Roll-off wavelength [m].
    rng : numpy.random.Generator
        Source of randomness (consumes ``nx * ny`` standard normals).
    short_cutoff : float, optional
        Short cut-off wavelength [m]; default: no cut-off below the Nyquist wavelength.

    Returns
    -------
    numpy.ndarray
        Heights [m], shape ``shape``.

    References
    ----------
    Persson, Albohr, Tartaglino, Volokitin & Tosatti (2005), On the nature of surface roughness
    with application to contact mechanics, sealing, rubber friction and adhesion,
    J. Phys.: Condens. Matter 17, R1. doi:10.1088/0953-8984/17/1/R01
    """
    nx, ny = shape
    if rms == 0:
        return np.zeros(shape)
    noise = rng.standard_normal((nx, ny))
    spec = scipy.fft.rfft2(noise)
    del noise
    qx = 2 * np.pi * scipy.fft.fftfreq(nx, d=step)
    qy = 2 * np.pi * scipy.fft.rfftfreq(ny, d=step)
    q_r = 2 * np.pi / rolloff_wavelength
    q_s = np.inf if short_cutoff is None else 2 * np.pi / short_cutoff
    # Filter in blocks of rows: a full 2-D q array would add to the peak memory of large fields.
    block = max(1, 4_000_000 // qy.size)
    for i in range(0, nx, block):
        q = np.hypot(qx[i : i + block, None], qy[None, :])
        amp = (np.maximum(q, q_r) / q_r) ** (-(1.0 + hurst))
        amp[q > q_s] = 0.0
        spec[i : i + block] *= amp
    spec[0, 0] = 0.0
    h = scipy.fft.irfft2(spec, s=(nx, ny))
    del spec
    h -= h.mean()
    std = h.std()
    if std == 0:
        raise ValueError("self_affine_field: the filter removed all power (short_cutoff below the grid step?)")
    h *= rms / std
    return h


def skew_transform(height: np.ndarray, target: float) -> np.ndarray:
    """Monotone transform of heights to a target skewness, keeping mean and rms.

    ``g`` = standardised heights; ``y = exp(s g)`` for positive and ``y = -exp(-s g)`` for
    negative target skewness (both increasing in ``g``, so the ordering of heights is kept),
    with ``s`` found by bisection on the sample skewness; ``y`` is rescaled to the original mean
    and rms. The transform alters the spectrum somewhat (mainly the large-scale part).

    Parameters
    ----------
    height : numpy.ndarray
        Heights [m].
    target : float
        Wanted sample skewness [-], |target| <= 3.

    Returns
    -------
    numpy.ndarray
        Transformed heights [m].
    """
    h = np.asarray(height, dtype=float)
    mean, std = h.mean(), h.std()
    g = (h - mean) / std
    if target == 0:
        return h.copy()
    sign = 1.0 if target > 0 else -1.0
    sub = g.ravel()[:: max(1, g.size // 200_000)]  # bisection on a subsample, final value on all

    def transform(s, x):
        y = sign * np.exp(sign * s * x)
        return (y - y.mean()) / y.std()

    def f(s):
        return skewness(transform(s, sub)) - target

    s = brentq(f, 1e-6, 5.0, xtol=1e-10)
    return mean + std * transform(s, g)


def generate_spectral(params: SpectralParameters, step: float, rng: np.random.Generator) -> np.ndarray:
    """Generate a self-affine field (optionally skewed) from :class:`SpectralParameters`.

    Parameters
    ----------
    params : SpectralParameters
        Generator parameters.
    step : float
        Grid step [m].
    rng : numpy.random.Generator
        Source of randomness.

    Returns
    -------
    numpy.ndarray
        Heights [m] indexed ``[x, y]``.
    """
    shape = _grid_shape(params.field_size, step)
    h = self_affine_field(shape, step, params.rms_height, params.hurst, params.rolloff_wavelength, rng,
                          params.short_cutoff)
    if params.skewness is not None:
        h = skew_transform(h, params.skewness)
    return h


def generate_iso10844(params: Iso10844Parameters, step: float, rng: np.random.Generator) -> np.ndarray:
    """Generate an aggregate-based ISO 10844-like road surface.

    Recipe (SPEC section 3): a self-affine mortar base at mean level ``-mortar_depth``; stones with
    log-uniform major diameter, uniform ellipticity and orientation, centres uniformly distributed
    (Poisson) over the field enlarged by the largest stone radius so that the edges are not
    depleted; each stone is a paraboloid cap ``z = t - cap_height_ratio d rho^2`` inside its
    ellipse (``rho`` = normalised elliptic radius), with top ``t ~ N(0, top_scatter)`` (stones
    rolled to a near-common level); surface = max over stones and mortar; plus micro-texture.

    Each stone is evaluated on its bounding window only, so the memory use stays O(field); all
    random numbers are drawn in a fixed order from ``rng``, so the same seed gives bit-identical
    heights.

    Parameters
    ----------
    params : Iso10844Parameters
        Generator parameters.
    step : float
        Grid step [m].
    rng : numpy.random.Generator
        Source of randomness.

    Returns
    -------
    numpy.ndarray
        Heights [m] indexed ``[x, y]``; the common stone-top level is z = 0.
    """
    p = params
    nx, ny = _grid_shape(p.field_size, step)
    lx, ly = nx * step, ny * step
    logger.info("iso10844: generating %d x %d samples (%.1f x %.1f mm, step %.2f um)", nx, ny,
                lx * 1e3, ly * 1e3, step * 1e6)

    d_lo, d_hi = p.stone_diameter
    e_lo, e_hi = p.stone_ellipticity
    # Mean plan area of one stone ellipse pi/4 d^2 e with d log-uniform and e uniform.
    mean_d2 = (d_hi**2 - d_lo**2) / (2 * math.log(d_hi / d_lo)) if d_hi > d_lo else d_lo**2
    mean_area = math.pi / 4 * mean_d2 * 0.5 * (e_lo + e_hi)
    margin = d_hi / 2
    ext_area = (lx + 2 * margin) * (ly + 2 * margin)
    n_stones = int(round(p.stone_coverage * ext_area / mean_area))

    # All random draws in one fixed order.
    diam = np.exp(rng.uniform(math.log(d_lo), math.log(d_hi), n_stones))
    ellip = rng.uniform(e_lo, e_hi, n_stones)
    theta = rng.uniform(0.0, np.pi, n_stones)
    cx = rng.uniform(-margin, lx + margin, n_stones)
    cy = rng.uniform(-margin, ly + margin, n_stones)
    top = p.top_scatter * rng.standard_normal(n_stones)
    if p.roller_level is not None:
        top = np.minimum(top, p.roller_level)

    surf = self_affine_field((nx, ny), step, p.mortar_rms, p.mortar_hurst, p.mortar_rolloff, rng, p.mortar_cutoff)
    surf -= p.mortar_depth
    logger.info("iso10844: mortar done; placing %d stones", n_stones)

    # sample centres at (i + 1/2) step
    report = max(1, n_stones // 5)
    for k in range(n_stones):
        a = 0.5 * diam[k]
        b = a * ellip[k]
        i0 = max(0, int(math.floor((cx[k] - a) / step - 0.5)))
        i1 = min(nx, int(math.ceil((cx[k] + a) / step - 0.5)) + 1)
        j0 = max(0, int(math.floor((cy[k] - a) / step - 0.5)))
        j1 = min(ny, int(math.ceil((cy[k] + a) / step - 0.5)) + 1)
        if i0 >= i1 or j0 >= j1:
            continue
        x = (np.arange(i0, i1) + 0.5) * step - cx[k]
        y = (np.arange(j0, j1) + 0.5) * step - cy[k]
        c, s = math.cos(theta[k]), math.sin(theta[k])
        u = (x[:, None] * c + y[None, :] * s) / a
        v = (-x[:, None] * s + y[None, :] * c) / b
        rho2 = u * u + v * v
        cap = np.where(rho2 <= 1.0, top[k] - p.cap_height_ratio * diam[k] * rho2, -np.inf)
        window = surf[i0:i1, j0:j1]
        np.maximum(window, cap, out=window)
        if (k + 1) % report == 0:
            logger.info("iso10844: %d/%d stones placed", k + 1, n_stones)

    surf += self_affine_field((nx, ny), step, p.microtexture_rms, p.microtexture_hurst, p.microtexture_rolloff, rng)
    return surf


# ---------------------------------------------------------------------------------------------
# Elements and the contact patch
# ---------------------------------------------------------------------------------------------
def element_samples(height: np.ndarray, samples_per_element: int, flat: bool = False) -> np.ndarray:
    """View of a height grid as elements: ``[ex, ey, n, n]`` (or ``[ex, ey, n * n]`` with ``flat``).

    Element ``(i, j)`` holds samples ``[i n:(i+1) n, j n:(j+1) n]``. Samples beyond the last whole
    element are ignored. No data are copied for C-contiguous input without ``flat``; with ``flat``
    the samples of each element are in row-major (C) order inside the element, ``p = a n + b``
    for sample ``(i n + a, j n + b)`` (a copy). This is the one element-slicing helper of the
    package: the surface stage (element peaks) and the springs stage (element contact areas)
    both use it.

    Parameters
    ----------
    height : numpy.ndarray
        Heights [m], indexed ``[x, y]``.
    samples_per_element : int
        Samples per element edge ``n``.
    flat : bool
        Return ``(nx // n, ny // n, n * n)`` instead.

    Returns
    -------
    numpy.ndarray
        Array of shape ``(nx // n, ny // n, n, n)`` (or ``(nx // n, ny // n, n * n)``).
    """
    h = np.asarray(height)
    n = int(samples_per_element)
    if h.ndim != 2:
        raise ValueError(f"element_samples: height must be 2-D, got shape {h.shape}")
    if n < 1 or n != samples_per_element:
        raise ValueError(
            f"element_samples: samples_per_element must be a positive integer, got {samples_per_element!r}"
        )
    ex, ey = h.shape[0] // n, h.shape[1] // n
    if ex == 0 or ey == 0:
        raise ValueError(f"element_samples: grid {h.shape} is smaller than one element of {n} x {n} samples")
    el = h[: ex * n, : ey * n].reshape(ex, n, ey, n).swapaxes(1, 2)
    return el.reshape(ex, ey, n * n) if flat else el


def element_peaks(height: np.ndarray, samples_per_element: int, step: float):
    """Matching point of every element: its highest sample and that sample's position.

    Parameters
    ----------
    height : numpy.ndarray
        Heights [m] indexed ``[x, y]``, cell-centred samples (sample i at ``(i + 1/2) step``).
    samples_per_element : int
        Samples per element edge.
    step : float
        Sample step [m].

    Returns
    -------
    z1, peak_x, peak_y : numpy.ndarray
        Peak heights [m] and positions [m], each of shape ``(ex, ey)``. Ties go to the first
        sample in C order.
    """
    n = int(samples_per_element)
    el = element_samples(height, n)
    ex, ey = el.shape[:2]
    flat = el.reshape(ex, ey, n * n)
    idx = flat.argmax(axis=2)
    z1 = np.take_along_axis(flat, idx[..., None], axis=2)[..., 0]
    ii, jj = np.divmod(idx, n)
    peak_x = (np.arange(ex)[:, None] * n + ii + 0.5) * step
    peak_y = (np.arange(ey)[None, :] * n + jj + 0.5) * step
    return z1, peak_x, peak_y


def select_patch(
    height: np.ndarray, samples_per_element: int, step: float, selection: PatchSelection, preset: str = ""
) -> tuple[int, int, float]:
    """Choose the patch origin (sample indices) by the rule in the module docstring.

    Parameters
    ----------
    height : numpy.ndarray
        Field heights [m], ``[x, y]``.
    samples_per_element : int
        Samples per element edge.
    step : float
        Sample step [m].
    selection : PatchSelection
        Rule and parameters.
    preset : str
        Surface preset name; when given, the error of the contact-fraction rule names the keys to set
        as full key paths (``surfaces.<preset>.patch_selection``, ``surfaces.<preset>.origin``).

    Returns
    -------
    i0, j0 : int
        First sample of the patch in x and y.
    fraction : float
        Fraction of the patch's element peaks within ``selection.fraction_depth`` of its top.

    Raises
    ------
    ValueError
        If the patch does not fit in the field, or no candidate's fraction lies in
        ``selection.fraction_range``.
    """
    n = int(samples_per_element)
    px, py = (int(v) for v in selection.patch_elements)
    nx, ny = height.shape
    if px * n > nx or py * n > ny:
        raise ValueError(
            f"patch of {px} x {py} elements ({px * n} x {py * n} samples) is larger than the field "
            f"({nx} x {ny} samples, {nx * step * 1e3:.2f} x {ny * step * 1e3:.2f} mm)"
        )

    def fraction_at(i0, j0):
        z1, _, _ = element_peaks(height[i0 : i0 + px * n, j0 : j0 + py * n], n, step)
        return float(peak_fraction_within(z1, selection.fraction_depth))

    if selection.origin is not None:
        i0 = int(round(selection.origin[0] / step))
        j0 = int(round(selection.origin[1] / step))
        if i0 + px * n > nx or j0 + py * n > ny:
            raise ValueError(
                f"patch at origin {list(selection.origin)} m ({px} x {py} elements) extends beyond the field "
                f"({nx * step:.6g} x {ny * step:.6g} m)"
            )
        return i0, j0, fraction_at(i0, j0)

    z1_all, _, _ = element_peaks(height, n, step)
    ex, ey = z1_all.shape
    cand_i = np.arange(ex - px + 1)
    cand_j = np.arange(ey - py + 1)
    dist2 = (cand_i[:, None] + 0.5 * px - 0.5 * ex) ** 2 + (cand_j[None, :] + 0.5 * py - 0.5 * ey) ** 2
    if selection.rule == "centre":
        flat = np.argmin(dist2)  # argmin returns the first minimum: smallest (x, y) index on ties
        ci, cj = np.unravel_index(flat, dist2.shape)
        return int(ci) * n, int(cj) * n, fraction_at(int(ci) * n, int(cj) * n)

    windows = np.lib.stride_tricks.sliding_window_view(z1_all, (px, py))
    top = windows.max(axis=(2, 3))
    count = np.zeros(top.shape, dtype=np.int64)
    # Row by row keeps the boolean temporary small for large fields.
    for i in range(windows.shape[0]):
        count[i] = np.count_nonzero(windows[i] >= top[i, :, None, None] - selection.fraction_depth, axis=(1, 2))
    frac = count / float(px * py)
    miss = np.abs(frac - selection.target_fraction)
    order = np.lexsort((dist2.ravel(), miss.ravel()))  # primary: miss, secondary: distance, then index
    ci, cj = np.unravel_index(order[0], miss.shape)
    best = float(frac[ci, cj])
    lo, hi = selection.fraction_range
    if not lo <= best <= hi:
        key = f"surfaces.{preset}." if preset else ""
        raise ValueError(
            f"{key}patch_selection = 'contact_fraction': no {px} x {py}-element patch has {lo:.0%}-{hi:.0%} "
            f"of its element peaks within {selection.fraction_depth * 1e3:g} mm of its top (closest to the "
            f"target {selection.target_fraction:.0%}: {best:.1%}; range over all {frac.size} candidates "
            f"{frac.min():.1%}-{frac.max():.1%}). A small scan often has no such patch: set '{key}patch_selection: centre' (the patch nearest the field centre) or "
            f"'{key}origin: [x, y]' (m, the patch's corner), or widen '{key}fraction_range'"
        )
    logger.info("patch: %d candidates, chose element origin (%d, %d) with %.1f %% of peaks within %.3g mm",
                frac.size, ci, cj, 100 * best, selection.fraction_depth * 1e3)
    return int(ci) * n, int(cj) * n, best


# ---------------------------------------------------------------------------------------------
# Config and the stage function
# ---------------------------------------------------------------------------------------------
def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)


def _preset_params(cls, name: str, spec: Mapping, common: Mapping) -> Any:
    """Build a generator dataclass from the preset, naming the offending key on bad input."""
    kwargs = {}
    allowed = {f.name for f in fields(cls)}
    for key, value in spec.items():
        if key in common:
            continue
        if key not in allowed:
            raise ValueError(
                f"surfaces.{name}.{key}: unknown key for generator {spec.get('generator')!r} "
                f"(allowed: {sorted(set(common) | allowed)})"
            )
        default = next(f.default for f in fields(cls) if f.name == key)
        if isinstance(default, tuple) or (key == "field_size" and value is not None):
            if not isinstance(value, (list, tuple)) or len(value) != 2 or not all(_is_number(v) for v in value):
                raise ValueError(f"surfaces.{name}.{key}: expected a pair of numbers, got {value!r}")
            value = tuple(float(v) for v in value)
        elif value is not None and not _is_number(value):
            raise ValueError(f"surfaces.{name}.{key}: expected a number, got {value!r}")
        elif value is None and default is not None:
            raise ValueError(f"surfaces.{name}.{key}: a value is required (default {default!r})")
        kwargs[key] = value
    try:
        return cls(**kwargs)
    except (TypeError, ValueError) as exc:
        key = next((k for k in kwargs if str(exc).startswith(k)), None)
        where = f"surfaces.{name}.{key}" if key else f"surfaces.{name}"
        raise ValueError(f"{where}: {exc}") from None


def _common(name: str, spec: Mapping) -> dict[str, Any]:
    c = {k: spec.get(k, v) for k, v in COMMON_KEYS.items()}
    es = c["element_size"]
    if not isinstance(es, (int, float)) or not 1e-5 <= es <= 1e-1:
        raise ValueError(f"surfaces.{name}.element_size: expected a length in m (1e-5..0.1), got {es!r}")
    spe = c["samples_per_element"]
    if isinstance(spe, bool) or not isinstance(spe, (int, np.integer)) or spe < 2:
        raise ValueError(f"surfaces.{name}.samples_per_element: expected an integer >= 2, got {spe!r}")
    seed = c["seed"]
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"surfaces.{name}.seed: expected a non-negative integer, got {seed!r}")
    pe = c["patch_elements"]
    if not isinstance(pe, (list, tuple)) or len(pe) != 2:
        raise ValueError(f"surfaces.{name}.patch_elements: expected [nx, ny], got {pe!r}")
    try:
        c["selection"] = PatchSelection(
            patch_elements=tuple(pe),
            rule=c["patch_selection"],
            target_fraction=float(c["target_fraction"]),
            fraction_range=tuple(float(v) for v in c["fraction_range"]),
            fraction_depth=float(c["fraction_depth"]),
            origin=None if c["origin"] is None else tuple(float(v) for v in c["origin"]),
        )
    except (TypeError, ValueError) as exc:
        keys = ("patch_selection", "patch_elements", "fraction_range", "target_fraction", "fraction_depth", "origin")
        key = next((k for k in keys if k in str(exc)), None)
        raise ValueError(f"surfaces.{name}{'.' + key if key else ''}: {exc}") from None
    return c


def prepare_surface(name: str, spec: Mapping, base_dir: str | Path = ".") -> xr.Dataset:
    """Road surface stage: heights of the contact patch, element peaks and texture statistics.

    Parameters
    ----------
    name : str
        Preset name (``surfaces.<name>``), used in error messages and stored as an attribute.
    spec : mapping
        The preset: common keys (:data:`COMMON_KEYS`) and generator keys
        (:class:`Iso10844Parameters`, :class:`SpectralParameters` or
        :data:`tyreroad.scans.FILE_KEYS`).
    base_dir : path-like
        Directory against which a relative scan ``path`` is resolved.

    Returns
    -------
    xarray.Dataset
        The surface dataset of docs/data_contracts.md (see :func:`surface_dataset`).
    """
    if not isinstance(spec, Mapping):
        raise ValueError(f"surfaces.{name}: expected a mapping of settings, got {type(spec).__name__}")
    generator = spec.get("generator")
    if generator not in ("iso10844", "spectral", "file", "flat"):
        raise ValueError(
            f"surfaces.{name}.generator: expected 'iso10844', 'spectral', 'file' or 'flat', got {generator!r}"
        )
    if generator == "flat" and "patch_selection" not in spec:
        spec = {**spec, "patch_selection": "centre"}
    c = _common(name, spec)
    n = int(c["samples_per_element"])
    step = float(c["element_size"]) / n
    selection: PatchSelection = c["selection"]
    source = generator
    if generator == "iso10844":
        params = _preset_params(Iso10844Parameters, name, spec, COMMON_KEYS)
        rng = np.random.default_rng(int(c["seed"]))
        field_h = generate_iso10844(params, step, rng)
    elif generator == "spectral":
        params = _preset_params(SpectralParameters, name, spec, COMMON_KEYS)
        rng = np.random.default_rng(int(c["seed"]))
        logger.info("spectral: generating field of %.1f x %.1f mm", *(1e3 * v for v in params.field_size))
        field_h = generate_spectral(params, step, rng)
    elif generator == "flat":
        params = _preset_params(FlatParameters, name, spec, COMMON_KEYS)
        px, py = (int(v) for v in selection.patch_elements)
        shape = (px * n, py * n) if params.field_size is None else _grid_shape(params.field_size, step)
        field_h = np.zeros(shape)
    else:
        scan_spec = scans.scan_spec_from_config(name, spec, COMMON_KEYS)
        scan = scans.read_scan(scan_spec, base_dir=base_dir)
        field_h = scans.to_element_grid(scan, step, selection.patch_elements, n)
        source = str(scan.path)
        try:
            return surface_dataset(name, field_h, step, n, selection, source=source)
        except ValueError as exc:
            hint = levelled_scan_hint(name, scan_spec, base_dir, step, n, selection, str(exc))
            if hint:
                raise ValueError(f"{exc}. {hint}") from None
            raise
    return surface_dataset(name, field_h, step, n, selection, source=source)


def levelled_scan_hint(name: str, scan_spec: "scans.ScanSpec", base_dir: str | Path, step: float, n: int,
                       selection: PatchSelection, message: str) -> str:
    """Whether a scan that failed the contact-fraction rule after ``detrend: plane`` passes it as read.

    Removing the least-squares plane of a small, already levelled scan (e.g. a patch exported from a
    study) tilts its element peaks: the default patch exported and read back has 51 % of its peaks
    within 0.15 mm of the top as written, 1.5 % after the plane is removed. The hint tells the user
    so, with the fraction the heights as read would give.

    Parameters
    ----------
    name : str
        Surface preset name.
    scan_spec : tyreroad.scans.ScanSpec
        The preset's scan settings.
    base_dir : path-like
        Directory of relative scan paths.
    step : float
        Element grid step [m].
    n : int
        Samples per element edge.
    selection : PatchSelection
        The preset's patch selection.
    message : str
        The selection error; only a contact-fraction failure gets a hint.

    Returns
    -------
    str
        The hint ('' when the detrending is not the cause, or the scan is not plane-detrended).
    """
    if scan_spec.detrend != "plane" or "patch_selection = 'contact_fraction'" not in message:
        return ""
    from dataclasses import replace

    raw = scans.read_scan(replace(scan_spec, detrend="none"), base_dir=base_dir)
    try:
        _, _, frac = select_patch(scans.to_element_grid(raw, step, selection.patch_elements, n), n, step, selection)
    except ValueError:
        return ""
    return (f"The plane removal is the cause (detrend: plane, the default): the heights as they are in the file "
            f"have a patch with {frac:.1%}. If they are already levelled (e.g. a patch exported from a study), "
            f"set 'surfaces.{name}.detrend: none'")


def surface_dataset(
    name: str,
    field_height: np.ndarray,
    step: float,
    samples_per_element: int,
    selection: PatchSelection,
    source: str = "",
) -> xr.Dataset:
    """Texture statistics of a field, patch selection and the surface dataset of docs/data_contracts.md.

    Parameters
    ----------
    name : str
        Surface preset name.
    field_height : numpy.ndarray
        Field heights [m], ``[x, y]``, at ``step``.
    step : float
        Sample step [m] (``element_size / samples_per_element``).
    samples_per_element : int
        Samples per element edge.
    selection : PatchSelection
        Patch size and selection rule.
    source : str
        Generator name or scan file, stored as an attribute.

    Returns
    -------
    xarray.Dataset
        Variables height, z1, peak_x, peak_y, element_x, element_y, mpd, rms_height, skewness,
        texture_level, peak_fraction_within; attributes element_size, samples_per_element,
        scan_step, surface, patch origin.
    """
    n = int(samples_per_element)
    element_size = step * n
    h = np.asarray(field_height, dtype=float)
    if not np.all(np.isfinite(h)):
        raise ValueError(f"surface {name!r}: field heights contain NaN or inf")
    logger.info("surface %s: texture statistics of the %d x %d field", name, *h.shape)
    length_x = h.shape[0] * step
    baseline = min(MPD_BASELINE, length_x)
    if baseline < MPD_BASELINE:
        logger.warning("surface %s: field is %.1f mm long in x; MPD uses a %.1f mm baseline instead of 100 mm",
                       name, length_x * 1e3, baseline * 1e3)
    mpd = mean_profile_depth(h, step, baseline)
    rms = rms_height(h)
    skew = skewness(h) if rms > 0 else float("nan")  # a flat road (generator flat) has no skewness
    wl, level = texture_level_spectrum(h, step)

    i0, j0, frac = select_patch(h, n, step, selection, preset=name)
    px, py = (int(v) for v in selection.patch_elements)
    patch = np.ascontiguousarray(h[i0 : i0 + px * n, j0 : j0 + py * n])
    z1, peak_x, peak_y = element_peaks(patch, n, step)
    fractions = peak_fraction_within(z1, PEAK_DEPTHS)
    logger.info("surface %s: MPD %.3f mm, rms %.3f mm, skewness %.2f; patch origin (%.2f, %.2f) mm, "
                "peaks within 0.05/0.10/0.15 mm: %s", name, mpd * 1e3, rms * 1e3, skew, i0 * step * 1e3,
                j0 * step * 1e3, ", ".join(f"{f:.1%}" for f in fractions))

    x = (np.arange(px * n) + 0.5) * step
    y = (np.arange(py * n) + 0.5) * step

    def meta(units, long_name, **extra):
        return {"units": units, "long_name": long_name, **extra}

    ds = xr.Dataset(
        data_vars={
            "height": (("x", "y"), patch, meta("m", "road height of the contact patch (z towards the tread)")),
            "z1": (("ex", "ey"), z1, meta("m", "element matching height (highest sample in the element)")),
            "peak_x": (("ex", "ey"), peak_x, meta("m", "x position of the element's highest sample")),
            "peak_y": (("ex", "ey"), peak_y, meta("m", "y position of the element's highest sample")),
            "element_x": (("ex",), (np.arange(px) + 0.5) * element_size, meta("m", "x of element centres")),
            "element_y": (("ey",), (np.arange(py) + 0.5) * element_size, meta("m", "y of element centres")),
            "mpd": ((), mpd, meta("m", "mean profile depth of the field (ISO 13473-1, profiles along x)",
                                  baseline=baseline)),
            "rms_height": ((), rms, meta("m", "rms height of the field")),
            "skewness": ((), skew, meta("1", "skewness of the field heights")),
            "texture_level": (("band",), level, io.level_attrs(
                "1/3-octave texture level of the field (ISO 13473-4 style, profiles along x)", 1e-6, "m")),
            "peak_fraction_within": (("depth",), fractions, meta(
                "1", "fraction of the patch's element peaks within depth of its highest peak")),
        },
        coords={
            "x": ("x", x, meta("m", "x of sample centres from the patch origin")),
            "y": ("y", y, meta("m", "y of sample centres from the patch origin")),
            "ex": ("ex", np.arange(px), meta("1", "element index in x")),
            "ey": ("ey", np.arange(py), meta("1", "element index in y")),
            "wavelength": ("band", wl, meta("m", "1/3-octave band centre wavelength")),
            "depth": ("depth", np.asarray(PEAK_DEPTHS), meta("m", "depth below the patch's highest element peak")),
        },
        attrs={
            "surface": name,
            "source": source,
            "element_size": element_size,
            "samples_per_element": n,
            "scan_step": step,
            "patch_origin_x": i0 * step,
            "patch_origin_y": j0 * step,
            "field_size_x": h.shape[0] * step,
            "field_size_y": h.shape[1] * step,
            "patch_selection": "origin" if selection.origin is not None else selection.rule,
            "selected_fraction": frac,
        },
    )
    return ds
