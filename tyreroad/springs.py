"""Nonlinear contact springs of the road elements (SPEC section 4).

The small-scale roughness inside one road element (c x c, about 26 x 26 scan samples) is lumped
into one nonlinear spring between the element's matching point (its highest sample z1) and the
tread layer. Its compression zeta is how far the layer surface has passed below z1; the spring
force is F(zeta) = integral_0^zeta k(x) dx with the stiffness k built from the geometric overlap
area

    A(zeta) = dx^2 * #{p : z1 - z_p <= zeta}                                   (SPEC 4)

of the element's samples z_p (dx = scan step). Models (config ``springs.model``):

``single_punch`` (default)
    The whole overlap is one equivalent flat rigid circular punch of radius a = sqrt(A / pi)
    pressed into the elastic layer: k = 2 E_s* kappa(a / h, nu) a, E_s* = E_s / (1 - nu^2).
``sum_of_spots``
    Every connected contact spot i (4-connectivity: samples sharing an edge, not only a corner,
    belong to the same spot) is its own punch: k = sum_i 2 E_s* kappa(a_i / h, nu) a_i. Spots
    that merge as zeta grows lose stiffness (sqrt(A1 + A2) < sqrt(A1) + sqrt(A2)), so this k is
    not monotonic; F stays non-decreasing because k >= 0.
``linear``
    Constant stiffness (classic bedding spring) for zeta > 0.
``hard``
    Hard contact: a linear penalty spring of ``hard_stiffness`` (default 1e10 N/m) for zeta > 0, so stiff that
    its compliance 1 / k is ~3e-6 of the layer's static self-compliance g(0) ~ 3.2e-5 m/N (the springs file
    states 1 / k, the contact run's log the ratio to the greens file's g(0)). Far past every single-stage
    kernel's stability limit: dynamic runs need ``greens.construction: radau`` (the configuration refuses
    anything else).

Time dependence (config ``springs.rheology``): ``elastic`` (default) uses these tables at every rate;
``qlv`` lets the force relax with the tread's modulus, F = int R(t - tau) dF(zeta(tau)), R = E(t) / E_s
(quasi-linear viscoelasticity, :mod:`tyreroad.qlv`; the tables stay the elastic F and k).

The interaction between the punches of one element and between elements is not included in k:
it is carried by the layer's Green's functions in the contact solver.

kappa(lambda, nu) is the stiffness factor of a flat rigid punch of radius a on a layer of
thickness h bonded to a rigid base (Hayes et al. 1972), found from the Fredholm equation of the
second kind

    phi(s) + (lambda / pi) int_0^1 phi(t) [m(lambda (t - s)) + m(lambda (t + s))] dt = 1,
    kappa = int_0^1 phi(t) dt,   m(v) = int_0^inf (L(eta) - 1) cos(eta v) d eta,

with L the static layer factor (:func:`tyreroad.layer.static_layer_factor`); the punch is
frictionless (no shear traction on the layer surface, as in the layer compliance). The equation is the
one of SPEC 4 without any extra factor: writing the punch pressure's Hankel transform as
P(k) = int_0^a g(t) cos(kt) dt and the layer compliance as 2 L(kh) / (E* k), Abel inversion of
the displacement condition gives the equation above with g = (E* delta / pi) phi, and the total
force 2 pi P(0) = 2 E* a delta kappa. It reproduces Hayes' table to better than 0.3 % (tests).

Interpolation contract (shared with the contact solver, docs/data_contracts.md): for zeta <= 0, k = F = 0;
on the uniform grid zeta_j = j * zeta_step the stiffness is piecewise linear between the table
values; F is the exact integral of that piecewise-linear k, so the tabulated F is the cumulative
trapezoid of k; beyond the last grid point k stays at its last value and F grows linearly.
Because the table includes zeta = 0 with the peak sample already in contact, k jumps from 0 to
k(0) at zeta = 0+ (F is continuous).

Table precision (config ``springs.table_precision``). ``float64`` (default) stores k and F in
double precision. ``float32`` rounds k to single precision (relative <= u = 2^-24 = 6.0e-8) and
keeps the contract exact for the rounded k: F is never interpolated from single precision. The
springs file holds A, k and F as float32 (F the float32 rounding of the double-precision
cumulative trapezoid of the rounded k), and the contact solver's table (:meth:`SpringTable.checked`)
keeps k as float32 and F only at every ``ANCHOR_BLOCK``-th grid point, in float64; inside a block
F_j is the anchor plus the trapezoid sum of the float32 k, summed in float64 at evaluation. So F
is the integral of the piecewise-linear float32 k to double-precision rounding, continuous across
grid points, and k = dF/dzeta as Newton needs. What it costs in F: k's rounding only, at most u of
each spring's F and k (benchmarks/bench_table_precision.py: total force and K(d) within 6e-9 of
float64 on the default 20 x 20 patch and on 150 x 200, same Newton iterations and residuals).
Memory per spring and grid point: 16 B (float64), 4 + 8 / ANCHOR_BLOCK = 4.5 B (float32); one
evaluation costs about 2.7x the float64 one (0.7 vs 0.26 ms for 30 000 springs, ~1 % of a run).
Storing F itself as float32 (8 B per point) was measured and not taken: its rounding makes F jump
at the grid points by up to u F, i.e. the Newton residual by up to 2.7e-11 m below d_max = 0.25 mm
(at a quarter of those grid points by more than twice the 1e-12 m tolerance; a root that falls
into such a jump cannot converge); the benchmark's runs converged but stopped at |R| = 3.7e-13 m
instead of 3e-17 m. Two-point tables (constant k, model ``linear``) are kept in float64 at either
precision (32 B per spring).

References
----------
Hayes, W. C., Keer, L. M., Herrmann, G., & Mockros, L. F. (1972). A mathematical analysis for
indentation tests of articular cartilage. J. Biomech. 5(5), 541-551.
doi:10.1016/0021-9290(72)90010-3
The seed study: :data:`tyreroad.SEED_REFERENCE`.
"""

from __future__ import annotations

import functools
import logging
import math
import time
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
import xarray as xr
from numba import njit
from scipy.interpolate import CubicSpline

from . import checks
from .layer import static_layer_factor
from .surface import element_samples

logger = logging.getLogger(__name__)

__all__ = [
    "SPRING_MODELS",
    "SpringModel",
    "SpringTable",
    "punch_factor",
    "punch_stiffness",
    "resolve_spring_modulus",
    "contact_counts",
    "element_springs",
    "evaluate",
    "linear_tables",
    "TABLE_PRECISIONS",
    "SPRING_RHEOLOGIES",
    "ANCHOR_BLOCK",
]

SPRING_MODELS = ("single_punch", "sum_of_spots", "linear", "hard")
#: Precisions of the spring tables (config ``springs.table_precision``).
TABLE_PRECISIONS = ("float64", "float32")
#: Grid points per float64 force anchor of a float32 table (module docstring): F_j is summed from
#: at most ANCHOR_BLOCK - 1 stiffness values at evaluation; 8 B / 16 = 0.5 B per grid point.
ANCHOR_BLOCK = 16

#: Largest punch radius / layer thickness ratio kappa is computed for. Beyond it the punch is
#: much wider than the layer is thick and the Nystrom and kernel resolutions below would need
#: raising; a road element against a tread layer is far below it (a/h <= 0.06 for 1 mm elements
#: on a 10 mm layer).
MAX_PUNCH_RATIO = 16.0

# (L - 1) decays like eta^2 exp(-2 eta); at eta = 30 it is below 1e-23, far below round-off of m.
_ETA_MAX = 30.0
_ETA_PANELS = 120  # panel width 0.25: at most 8 rad of cos(eta v) per panel for v <= 32
_ETA_ORDER = 20
_V_STEP = 2.0e-3  # cubic-spline step of m(v); interpolation error ~ 1e-12
_ZETA_POINTS_MAX = 100_001

_DEFAULTS: dict[str, Any] = {
    "model": "single_punch",
    "zeta_max": 1.0e-3,
    "zeta_step": 1.0e-6,
    "modulus": "quasi_static",
    "linear_stiffness": 1.0e5,
    "hard_stiffness": 1.0e10,
    "table_precision": "float64",
    "rheology": "elastic",
}
#: Values of ``springs.rheology`` (the springs' time dependence; :mod:`tyreroad.qlv`).
SPRING_RHEOLOGIES = ("elastic", "qlv")


# --------------------------------------------------------------------------------------------
# kappa(lambda, nu): flat punch on a bonded layer
# --------------------------------------------------------------------------------------------
def _gauss_legendre(a: float, b: float, panels: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(a, b, panels + 1)
    half = 0.5 * np.diff(edges)
    nodes = (edges[:-1, None] + (x[None, :] + 1.0) * half[:, None]).ravel()
    weights = (w[None, :] * half[:, None]).ravel()
    return nodes, weights


def _kernel_m_direct(v, poisson: float) -> np.ndarray:
    """m(v) = int_0^inf (L(eta) - 1) cos(eta v) d eta by composite Gauss-Legendre quadrature."""
    v = np.abs(np.asarray(v, dtype=float))
    eta, w = _gauss_legendre(0.0, _ETA_MAX, _ETA_PANELS, _ETA_ORDER)
    f = (static_layer_factor(eta, poisson) - 1.0) * w
    out = np.empty(v.size)
    flat = v.ravel()
    for start in range(0, flat.size, 2048):  # bound the (v, eta) matrix to ~40 MB
        out[start : start + 2048] = np.cos(np.outer(flat[start : start + 2048], eta)) @ f
    return out.reshape(v.shape)


@functools.lru_cache(maxsize=32)
def _kernel_m_spline(poisson: float, v_max: float) -> CubicSpline:
    """Cubic spline of the even function m(v) on [0, v_max] (m'(0) = 0 imposed)."""
    v = np.linspace(0.0, v_max, int(round(v_max / _V_STEP)) + 1)
    return CubicSpline(v, _kernel_m_direct(v, poisson), bc_type=((1, 0.0), "not-a-knot"))


def _kernel_m(v, poisson: float) -> np.ndarray:
    """m(v) from the cached spline; v may have any sign (m is even)."""
    v = np.abs(np.asarray(v, dtype=float))
    v_top = float(np.max(v, initial=0.0))
    # v_max in powers of two keeps the cache small while serving any argument range
    v_max = 4.0 * 2.0 ** max(0, math.ceil(math.log2(max(v_top, 1e-300) / 4.0)))
    return _kernel_m_spline(float(poisson), v_max)(v)


def _nystrom_points(ratio_max: float) -> int:
    # m(lambda (t - s)) varies on a scale 1/lambda in t; 32 nodes give 1e-13 up to lambda = 1.
    return 32 + 16 * int(math.ceil(ratio_max))


def _punch_factor_direct(ratios: np.ndarray, poisson: float) -> np.ndarray:
    """Solve the Hayes equation by Gauss-Legendre Nystrom for each ratio (1-D array, > 0)."""
    n = _nystrom_points(float(ratios.max()))
    t, w = np.polynomial.legendre.leggauss(n)
    t = 0.5 * (t + 1.0)
    w = 0.5 * w
    lam = ratios[:, None, None]
    kern = _kernel_m(lam * (t[None, :] - t[:, None])[None], poisson) + _kernel_m(
        lam * (t[None, :] + t[:, None])[None], poisson
    )
    mats = np.eye(n)[None] + (lam / np.pi) * kern * w[None, None, :]
    phi = np.linalg.solve(mats, np.ones((ratios.size, n, 1)))[..., 0]
    return phi @ w


def punch_factor(ratio, poisson: float) -> np.ndarray:
    """Stiffness factor kappa of a flat rigid circular punch on a bonded elastic layer.

    The normal stiffness of a flat rigid punch of radius a on an elastic layer of thickness h
    bonded to a rigid base is K = 2 E* a kappa(a/h, nu), E* = E / (1 - nu^2); kappa = 1 for a
    half-space (a/h = 0). kappa is found by a Gauss-Legendre Nystrom solution of the Fredholm
    equation of Hayes et al. (module docstring), with the kernel m(v) from a composite
    Gauss-Legendre cosine quadrature of L - 1 on [0, 30] (cubic spline in v, cached per nu).
    Each distinct ratio is solved directly (no interpolation in a/h): about 0.1 s for the 677
    areas of a 26 x 26-sample element at a/h <= 1, plus about 0.1 s once per nu for the kernel.

    Parameters
    ----------
    ratio : array_like
        Punch radius over layer thickness a/h [-], 0 <= a/h <= MAX_PUNCH_RATIO (16).
        0 (also from h = inf) gives the half-space value 1.
    poisson : float
        Poisson's ratio nu [-], 0 <= nu <= 0.5.

    Returns
    -------
    numpy.ndarray
        kappa [-], same shape as ``ratio``.

    References
    ----------
    Hayes, W. C., Keer, L. M., Herrmann, G., & Mockros, L. F. (1972). A mathematical analysis
    for indentation tests of articular cartilage. J. Biomech. 5(5), 541-551.
    doi:10.1016/0021-9290(72)90010-3
    """
    nu = checks.poisson_ratio(poisson, allow_half=True)
    lam = np.asarray(ratio, dtype=float)
    if not np.all(np.isfinite(lam)) or np.any(lam < 0):
        raise ValueError(f"punch_factor: ratio a/h must be finite and >= 0, got min {np.min(lam)}")
    if np.any(lam > MAX_PUNCH_RATIO):
        raise ValueError(
            f"punch_factor: ratio a/h = {np.max(lam):g} exceeds {MAX_PUNCH_RATIO:g} "
            "(punch far wider than the layer is thick; not supported)"
        )
    out = np.ones(lam.shape)
    positive = lam > 0
    if np.any(positive):
        unique, inverse = np.unique(lam[positive], return_inverse=True)
        values = np.empty(unique.size)
        # batches bound the (ratio, n, n) kernel arrays to ~2e6 entries
        batch = max(1, 2_000_000 // _nystrom_points(float(unique[-1])) ** 2)
        for start in range(0, unique.size, batch):
            values[start : start + batch] = _punch_factor_direct(unique[start : start + batch], nu)
        out[positive] = values[inverse]
    return out


# --------------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SpringModel:
    """The element spring model of the study (config section ``springs``).

    Attributes
    ----------
    model : str
        ``single_punch`` (default), ``sum_of_spots``, ``linear`` or ``hard``.
    zeta_max : float
        Upper end of the compression grid [m], >= 1 mm (SPEC 4). Default 1e-3.
    zeta_step : float
        Step of the compression grid [m], <= 1 um (SPEC 4); zeta_max must be an integer
        multiple of it. Default 1e-6.
    modulus : str or float
        Spring modulus E_s: ``'quasi_static'`` (the material's quasi-static modulus, the default)
        or a value [Pa].
    linear_stiffness : float
        Stiffness of model ``linear`` [N/m]. Default 1e5.
    hard_stiffness : float
        Penalty stiffness of model ``hard`` (hard contact) [N/m]. Default 1e10.
    table_precision : str
        ``'float64'`` (default) or ``'float32'``: the precision of the stiffness tables (module
        docstring: float32 rounds k to 6e-8 relative and keeps F its exact integral).
    rheology : str
        ``'elastic'`` (default: the tables' modulus at every frequency, the seed's assumption) or
        ``'qlv'``: the spring force relaxes with the tread's own modulus, F = int R(t - tau) dF_el,
        R = E(t) / E_s (quasi-linear viscoelasticity, :mod:`tyreroad.qlv`).
    """

    model: str = _DEFAULTS["model"]
    zeta_max: float = _DEFAULTS["zeta_max"]
    zeta_step: float = _DEFAULTS["zeta_step"]
    modulus: str | float = _DEFAULTS["modulus"]
    linear_stiffness: float = _DEFAULTS["linear_stiffness"]
    hard_stiffness: float = _DEFAULTS["hard_stiffness"]
    table_precision: str = _DEFAULTS["table_precision"]
    rheology: str = _DEFAULTS["rheology"]

    def __post_init__(self) -> None:
        s = "springs"
        if not isinstance(self.rheology, str) or self.rheology not in SPRING_RHEOLOGIES:
            raise ValueError(
                f"{s}.rheology = {self.rheology!r}: expected one of {', '.join(SPRING_RHEOLOGIES)} (elastic: the "
                "springs keep their table modulus at every frequency; qlv: the spring force relaxes with the "
                "tread's modulus)"
            )
        if self.model not in SPRING_MODELS:
            raise ValueError(f"{s}.model must be one of {', '.join(SPRING_MODELS)}; got {self.model!r}")
        if not isinstance(self.table_precision, str) or self.table_precision not in TABLE_PRECISIONS:
            raise ValueError(
                f"{s}.table_precision = {self.table_precision!r}: expected one of {', '.join(TABLE_PRECISIONS)}"
            )
        zmax = checks.real(f"{s}.zeta_max", self.zeta_max, positive=True)
        step = checks.real(f"{s}.zeta_step", self.zeta_step, positive=True)
        if zmax < 1.0e-3 * (1 - 1e-12):
            raise ValueError(f"{s}.zeta_max must be >= 1e-3 m (SPEC 4), got {zmax:g} m")
        if step > 1.0e-6 * (1 + 1e-12):
            raise ValueError(f"{s}.zeta_step must be <= 1e-6 m (SPEC 4), got {step:g} m")
        ratio = zmax / step
        if abs(ratio - round(ratio)) > 1e-6 * ratio:
            raise ValueError(
                f"{s}.zeta_max ({zmax:g} m) must be an integer multiple of {s}.zeta_step ({step:g} m)"
            )
        if round(ratio) + 1 > _ZETA_POINTS_MAX:
            raise ValueError(
                f"{s}.zeta_max / {s}.zeta_step gives {round(ratio) + 1} grid points; at most "
                f"{_ZETA_POINTS_MAX} are allowed (memory: 3 tables x elements x points)"
            )
        if isinstance(self.modulus, str):
            if self.modulus != "quasi_static":
                raise ValueError(
                    f"{s}.modulus must be 'quasi_static' or a number in Pa, got {self.modulus!r}"
                )
        else:
            object.__setattr__(self, "modulus", checks.real(f"{s}.modulus", self.modulus, positive=True))
        object.__setattr__(self, "zeta_max", zmax)
        object.__setattr__(self, "zeta_step", step)
        object.__setattr__(self, "linear_stiffness", checks.real(f"{s}.linear_stiffness", self.linear_stiffness, positive=True))
        object.__setattr__(self, "hard_stiffness",
                           checks.real(f"{s}.hard_stiffness", self.hard_stiffness, positive=True))

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "SpringModel":
        """Build from the ``springs`` config section; missing keys take the documented defaults.

        Raises
        ------
        ValueError, TypeError
            Naming ``springs.<key>`` for an unknown key or an invalid value.
        """
        section = dict(section or {})
        unknown = sorted(set(section) - set(_DEFAULTS))
        if unknown:
            raise ValueError(f"springs: unknown key(s) {unknown}; expected {sorted(_DEFAULTS)}")
        return cls(**{**_DEFAULTS, **section})

    @property
    def n_zeta(self) -> int:
        """Number of points of the compression grid [-]."""
        return int(round(self.zeta_max / self.zeta_step)) + 1

    def zeta_grid(self) -> np.ndarray:
        """The uniform compression grid 0, zeta_step, ..., zeta_max [m]."""
        return np.arange(self.n_zeta) * self.zeta_step


def resolve_spring_modulus(spring_model: SpringModel, quasi_static_modulus: float) -> float:
    """The spring modulus E_s [Pa] of a material.

    Parameters
    ----------
    spring_model : SpringModel
        The study's spring model; ``modulus`` is ``'quasi_static'`` or a value [Pa].
    quasi_static_modulus : float
        The material's quasi-static modulus [Pa] (``Material.quasi_static_modulus``).

    Returns
    -------
    float
        ``quasi_static_modulus`` when ``spring_model.modulus == 'quasi_static'`` (the default:
        the springs represent the slow, local deformation of the asperity tips), else the
        configured value [Pa].
    """
    if not isinstance(spring_model, SpringModel):
        raise TypeError(f"spring_model must be a SpringModel, got {type(spring_model).__name__}")
    if spring_model.modulus == "quasi_static":
        return checks.real("material.quasi_static_modulus", quasi_static_modulus, positive=True)
    return float(spring_model.modulus)


# --------------------------------------------------------------------------------------------
# Interpolation contract
# --------------------------------------------------------------------------------------------
@njit(cache=True)
def _spring_eval(zeta, rows, stiffness, force, zeta_step, f_out, k_out):  # pragma: no cover - numba
    """F and k of the spring of table row ``rows[i]`` at compression ``zeta[i]`` (the contract)."""
    n_zeta = stiffness.shape[1]
    last = n_zeta - 1
    zeta_last = last * zeta_step
    for i in range(zeta.size):
        m = rows[i]
        z = zeta[i]
        if z <= 0.0:
            f_out[i] = 0.0
            k_out[i] = 0.0
        elif z >= zeta_last:
            k = stiffness[m, last]
            k_out[i] = k
            f_out[i] = force[m, last] + k * (z - zeta_last)
        else:
            u = z / zeta_step
            j = int(u)
            if j > last - 1:
                j = last - 1
            t = u - j
            k0 = stiffness[m, j]
            slope = stiffness[m, j + 1] - k0
            k_out[i] = k0 + slope * t
            f_out[i] = force[m, j] + zeta_step * t * (k0 + 0.5 * slope * t)


def evaluate(zeta, zeta_step: float, stiffness_table, force_table) -> tuple[np.ndarray, np.ndarray]:
    """Spring force and stiffness at arbitrary compressions (the interpolation contract).

    Parameters
    ----------
    zeta : array_like
        Spring compressions [m]; broadcast against the leading dimensions of the tables.
    zeta_step : float
        Step of the uniform table grid zeta_j = j * zeta_step [m].
    stiffness_table : array_like
        k on the grid [N/m], shape (..., n_zeta), n_zeta >= 2.
    force_table : array_like
        F on the grid [N], same shape; must be the cumulative trapezoid of ``stiffness_table``
        (as :func:`element_springs` writes it) for F to be the integral of k.

    Returns
    -------
    force : numpy.ndarray
        F(zeta) [N]: 0 for zeta <= 0; F_j + dz (k_j t + (k_{j+1} - k_j) t^2 / 2) inside cell j
        (t = zeta / dz - j); F_last + k_last (zeta - zeta_last) beyond the grid.
    stiffness : numpy.ndarray
        k(zeta) = dF/dzeta [N/m]: 0 for zeta <= 0, linear inside a cell, k_last beyond the grid.
        Shape of both: broadcast of ``zeta`` with ``stiffness_table.shape[:-1]``.
    """
    step = checks.real("evaluate: zeta_step", zeta_step, positive=True)
    k_tab = np.asarray(stiffness_table, dtype=float)
    f_tab = np.asarray(force_table, dtype=float)
    if k_tab.shape != f_tab.shape or k_tab.ndim < 1 or k_tab.shape[-1] < 2:
        raise ValueError(
            f"evaluate: stiffness_table {k_tab.shape} and force_table {f_tab.shape} must have the same "
            "shape (..., n_zeta) with n_zeta >= 2"
        )
    z = np.asarray(zeta, dtype=float)
    if np.any(np.isnan(z)):
        raise ValueError("evaluate: zeta contains NaN")
    lead = k_tab.shape[:-1]
    shape = np.broadcast_shapes(z.shape, lead)
    rows = np.broadcast_to(np.arange(math.prod(lead)).reshape(lead), shape).ravel()
    z_flat = np.ascontiguousarray(np.broadcast_to(z, shape).ravel())
    n = k_tab.shape[-1]
    f_out = np.empty(z_flat.size)
    k_out = np.empty(z_flat.size)
    _spring_eval(z_flat, rows, np.ascontiguousarray(k_tab.reshape(-1, n)),
                 np.ascontiguousarray(f_tab.reshape(-1, n)), step, f_out, k_out)
    return f_out.reshape(shape), k_out.reshape(shape)


def linear_tables(n_springs: int, stiffness, zeta_step: float = 1.0e-6) -> tuple[np.ndarray, np.ndarray]:
    """Two-point tables of linear springs F = k zeta (zeta > 0), for the contact solver.

    Under the interpolation contract k stays at its last value beyond the grid and F grows
    linearly, so the points zeta = 0 and zeta_step give F = k zeta at every compression: a
    linear spring costs 2 table points, not a 1 mm grid. Stiff springs (k >> 1 / G0_self, e.g.
    1e10 N/m against G0_self ~ 3e-5 m/N for 1 mm elements of a 25 MPa tread) are the solver's
    hard (rigid) contact: the stiff limit, with a relative force error ~ 1 / (k G0_self).

    Parameters
    ----------
    n_springs : int
        Number of springs M.
    stiffness : float or array_like
        k [N/m], > 0, one value or one per spring (shape (M,)).
    zeta_step : float
        Grid step [m] (any positive value gives the same springs).

    Returns
    -------
    stiffness, force : numpy.ndarray
        k [N/m] and F [N] on zeta = 0, zeta_step, shape (M, 2).
    """
    n = checks.integer("n_springs", n_springs)
    step = checks.real("zeta_step", zeta_step, positive=True)
    k = np.broadcast_to(np.asarray(stiffness, dtype=float), (n,))
    if not np.all(np.isfinite(k)) or np.any(k <= 0):
        raise ValueError("linear_tables: stiffness must be finite and > 0 [N/m]")
    k_tab = np.repeat(k[:, None], 2, axis=1)
    f_tab = np.zeros((n, 2))
    f_tab[:, 1] = 0.5 * step * (k + k)
    return k_tab, f_tab


@njit(cache=True)
def _spring_eval_anchored(zeta, rows, stiffness, anchors, zeta_step, f_out, k_out):  # pragma: no cover - numba
    """:func:`_spring_eval` for a float32 k table with float64 force anchors every ANCHOR_BLOCK points.

    F_j = anchor_b + dz (k_j0 / 2 + k_{j0+1} + ... + k_{j-1} + k_j / 2), j0 = b ANCHOR_BLOCK <= j,
    summed in float64. ANCHOR_BLOCK is a compile-time constant (a power of two: j // ANCHOR_BLOCK
    is a shift), which measured 2-4x faster than a block size passed as an argument.
    """
    last = stiffness.shape[1] - 1
    zeta_last = last * zeta_step
    for i in range(zeta.size):
        m = rows[i]
        z = zeta[i]
        if z <= 0.0:
            f_out[i] = 0.0
            k_out[i] = 0.0
            continue
        if z >= zeta_last:
            j = last
            t = 0.0
            k0 = np.float64(stiffness[m, last])
            slope = 0.0
        else:
            u = z / zeta_step
            j = int(u)
            if j > last - 1:
                j = last - 1
            t = u - j
            k0 = np.float64(stiffness[m, j])
            slope = np.float64(stiffness[m, j + 1]) - k0
        b = j // ANCHOR_BLOCK
        j0 = b * ANCHOR_BLOCK
        f = anchors[m, b]
        if j > j0:
            acc = 0.5 * (np.float64(stiffness[m, j0]) + k0)
            for q in range(j0 + 1, j):
                acc += np.float64(stiffness[m, q])
            f += zeta_step * acc
        if z >= zeta_last:
            k_out[i] = k0
            f_out[i] = f + k0 * (z - zeta_last)
        else:
            k_out[i] = k0 + slope * t
            f_out[i] = f + zeta_step * t * (k0 + 0.5 * slope * t)


@njit(cache=True)
def _check_tables(k, f, step, block, anchors):  # pragma: no cover - numba
    """One pass over (M, n) tables without temporaries (k and f float64 or float32).

    Returns (status, mismatch, scale, constant): status 0 ok, 1 non-finite, 2 negative k;
    mismatch = max |F - cumulative trapezoid of k| [N], scale = max |cumulative trapezoid| [N];
    constant = every row has one k value (a linear spring). The trapezoid is summed in float64.
    With ``block`` > 0 the trapezoid at every block-th grid point is written to ``anchors``
    (M, (n - 1) // block + 1).
    """
    half = 0.5 * step
    mismatch = 0.0
    scale = 0.0
    constant = True
    for m in range(k.shape[0]):
        acc = 0.0
        k_prev = 0.0
        k_first = np.float64(k[m, 0])
        for j in range(k.shape[1]):
            kj = np.float64(k[m, j])
            fj = np.float64(f[m, j])
            if not (np.isfinite(kj) and np.isfinite(fj)):
                return 1, mismatch, scale, constant
            if kj < 0.0:
                return 2, mismatch, scale, constant
            if j > 0:
                acc += half * (kj + k_prev)
                if kj != k_first:
                    constant = False
            k_prev = kj
            if block > 0 and j % block == 0:
                anchors[m, j // block] = acc
            d = abs(fj - acc)
            if d > mismatch:
                mismatch = d
            if acc > scale:
                scale = acc
    return 0, mismatch, scale, constant


#: Relative tolerance of the force-table check: float64 tables, and float32 ones (F rounded to
#: 2^-24 relative, and the float32 k's trapezoid against a float64 one: 2 eps32 in all).
_MISMATCH_RTOL = {np.dtype(np.float64): 1e-9, np.dtype(np.float32): 2.0 * float(np.finfo(np.float32).eps)}


def _table_array(values) -> np.ndarray:
    """float32 arrays stay float32 (no copy); anything else becomes float64."""
    a = np.asarray(values)
    if a.dtype != np.float32:
        a = np.asarray(a, dtype=float)
    return a


@dataclass(frozen=True)
class SpringTable:
    """Spring tables of a set of elements on one uniform compression grid.

    Attributes
    ----------
    zeta_step : float
        Grid step [m]; the grid is zeta_j = j * zeta_step, j = 0 .. n_zeta - 1.
    stiffness : numpy.ndarray
        k [N/m], shape (..., n_zeta); float64, or float32 for an anchored table.
    force : numpy.ndarray
        F [N], the cumulative trapezoid of ``stiffness``: shape (..., n_zeta) (``block`` = 0), or,
        for an anchored table (``block`` > 0, float32 k, made by :meth:`checked`), float64 F at
        every block-th grid point, shape (M, (n_zeta - 1) // block + 1).
    block : int
        0 for a full force table, else the grid points per force anchor (:data:`ANCHOR_BLOCK`).
    """

    zeta_step: float
    stiffness: np.ndarray
    force: np.ndarray
    block: int = 0

    def __post_init__(self) -> None:
        if self.block not in (0, ANCHOR_BLOCK):
            raise ValueError(f"SpringTable.block must be 0 or ANCHOR_BLOCK = {ANCHOR_BLOCK}, got {self.block!r}")
        if self.block and self.stiffness.dtype != np.float32:
            raise ValueError(f"SpringTable: an anchored table holds float32 stiffness, got {self.stiffness.dtype}")

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> "SpringTable":
        """Tables of a springs dataset, shape (ex, ey, zeta), in the dataset's dtype (float64 or float32)."""
        zeta = ds["zeta"].values
        if zeta.size < 2 or zeta[0] != 0.0 or not np.allclose(np.diff(zeta), zeta[1] - zeta[0], rtol=1e-9, atol=0):
            raise ValueError("springs dataset: zeta must be a uniform grid starting at 0")
        step = float(zeta[1] - zeta[0])
        k = ds["stiffness"].transpose("ex", "ey", "zeta").values
        f = ds["force"].transpose("ex", "ey", "zeta").values
        return cls(step, k, f)

    @classmethod
    def checked(cls, stiffness, force, zeta_step, n_elements: int) -> "SpringTable":
        """Validated tables of ``n_elements`` springs as C-contiguous (M, n_zeta) arrays.

        Parameters
        ----------
        stiffness, force : array_like
            k [N/m] and F [N] on zeta_j = j * zeta_step, shape (M, n_zeta) or (nx, ny, n_zeta).
            A float32 ``stiffness`` gives an anchored float32 table (module docstring); ``force``
            may then be float32 or float64.
        zeta_step : float
            Grid step [m].
        n_elements : int
            M, the number of springs expected.

        Raises
        ------
        ValueError
            For a wrong shape, non-finite or negative values, or a force table that is not the
            cumulative trapezoid of the stiffness (the Newton Jacobian would not be dF/dzeta):
            relative tolerance 1e-9 of the largest force for a float64 k (F is then read as
            float64), 2 eps32 = 2.4e-7 for a float32 k.

        Notes
        -----
        The checks run in one compiled pass without full-size temporaries, and the tables are not
        copied when they are already C-contiguous float64, or float32 (stiffness). A float32
        stiffness table is kept as it is, and the force as float64 anchors every
        :data:`ANCHOR_BLOCK` grid points computed in the same pass from the float32 k, so F is
        the exact integral of the stored k (the given F only has to agree with it to 2 eps32).
        Tables with one constant k per row (model ``linear``) are kept as their first two grid
        points in float64, which give the same F and k at every zeta under the interpolation
        contract: 32 B per spring instead of 16 n_zeta B.
        """
        step = checks.real("zeta_step", zeta_step, positive=True)
        k_tab = _table_array(stiffness)
        # F is read as given only for a float32 k (checked, then rebuilt from k); else float64
        f_tab = _table_array(force) if k_tab.dtype == np.float32 else np.asarray(force, dtype=float)
        if k_tab.shape != f_tab.shape:
            raise ValueError(f"spring tables: stiffness {k_tab.shape} and force {f_tab.shape} differ in shape")
        if k_tab.ndim == 3:
            k_tab = k_tab.reshape(-1, k_tab.shape[-1])
            f_tab = f_tab.reshape(-1, f_tab.shape[-1])
        if k_tab.ndim != 2 or k_tab.shape[0] != n_elements or k_tab.shape[1] < 2:
            raise ValueError(
                f"spring tables: expected shape ({n_elements}, n_zeta) or (nx, ny, n_zeta) with n_zeta >= 2, "
                f"got {np.shape(stiffness)}"
            )
        k_tab = np.ascontiguousarray(k_tab)
        f_tab = np.ascontiguousarray(f_tab)
        single = k_tab.dtype == np.float32
        block = ANCHOR_BLOCK if single else 0
        n_zeta = k_tab.shape[1]
        anchors = np.empty((k_tab.shape[0], (n_zeta - 1) // block + 1) if single else (0, 0))
        status, mismatch, scale, constant = _check_tables(k_tab, f_tab, step, block, anchors)
        if status == 1:
            raise ValueError("spring tables: stiffness/force contain NaN or infinite values")
        if status == 2:
            raise ValueError("spring tables: stiffness must be >= 0 [N/m]")
        scale = max(scale, np.finfo(float).tiny)
        rtol = max(_MISMATCH_RTOL[k_tab.dtype], _MISMATCH_RTOL[f_tab.dtype])
        if mismatch > rtol * scale:
            raise ValueError(
                "spring tables: force is not the cumulative trapezoid of stiffness on the zeta grid "
                f"(max mismatch {mismatch:.3e} N, {mismatch / scale:.2e} of the largest force; "
                f"tolerance {rtol:.1e} for {k_tab.dtype}/{f_tab.dtype} tables)"
            )
        if constant and n_zeta > 2:
            # constant k on every row (model ``linear``): under the interpolation contract the first
            # two grid points give the same F and k at every zeta (beyond the grid k stays, F grows
            # linearly), so the solver keeps 2 points per spring instead of n_zeta
            if single:
                k2 = k_tab[:, :2].astype(float)
                return cls(step, k2, _cumulative_trapezoid(k2, step))
            return cls(step, k_tab[:, :2].copy(), f_tab[:, :2].copy())
        if single:
            return cls(step, k_tab, anchors, block)
        return cls(step, k_tab, f_tab)

    @property
    def n_springs(self) -> int:
        """Number of springs (product of the leading table dimensions)."""
        return math.prod(self.stiffness.shape[:-1])

    @property
    def nbytes(self) -> int:
        """Memory of the stiffness and force arrays [B]."""
        return int(self.stiffness.nbytes + self.force.nbytes)

    def force_table(self) -> np.ndarray:
        """F [N] on every grid point, float64, shape of ``stiffness`` (computed for anchored tables)."""
        if not self.block:
            return np.asarray(self.force, dtype=float)
        return _cumulative_trapezoid(self.stiffness.astype(float), self.zeta_step)

    def _eval_flat(self, zeta, rows, force_out, stiffness_out) -> None:
        if self.block:
            _spring_eval_anchored(zeta, rows, self.stiffness, self.force, self.zeta_step, force_out, stiffness_out)
        else:
            _spring_eval(zeta, rows, self.stiffness, self.force, self.zeta_step, force_out, stiffness_out)

    def evaluate(self, zeta) -> tuple[np.ndarray, np.ndarray]:
        """(F [N], k [N/m]) at compressions ``zeta`` [m]; see :func:`evaluate`."""
        if not self.block:
            return evaluate(zeta, self.zeta_step, self.stiffness, self.force)
        z = np.asarray(zeta, dtype=float)
        if np.any(np.isnan(z)):
            raise ValueError("evaluate: zeta contains NaN")
        lead = self.stiffness.shape[:-1]
        shape = np.broadcast_shapes(z.shape, lead)
        rows = np.ascontiguousarray(np.broadcast_to(np.arange(math.prod(lead)).reshape(lead), shape).ravel())
        z_flat = np.ascontiguousarray(np.broadcast_to(z, shape).ravel())
        f_out = np.empty(z_flat.size)
        k_out = np.empty(z_flat.size)
        self._eval_flat(z_flat, rows, f_out, k_out)
        return f_out.reshape(shape), k_out.reshape(shape)

    def evaluate_into(self, zeta: np.ndarray, force_out: np.ndarray, stiffness_out: np.ndarray) -> None:
        """F and k of every spring at ``zeta`` [m], shape (M,), written into the given (M,) float64 arrays.

        The allocation-free form used inside Newton iterations; the tables must be (M, n_zeta)
        and C-contiguous (as :meth:`checked` makes them). Anchored float32 tables are read as they
        are (no float64 copy); the arithmetic is float64.
        """
        self._eval_flat(zeta, self._rows, force_out, stiffness_out)

    def contact_stiffness(self) -> np.ndarray:
        """k(0+) of every spring [N/m], shape (M,): the stiffness just after first contact."""
        return self.stiffness.reshape(-1, self.stiffness.shape[-1])[:, 0]

    @functools.cached_property
    def _rows(self) -> np.ndarray:
        return np.arange(self.n_springs)


# --------------------------------------------------------------------------------------------
# Element springs
# --------------------------------------------------------------------------------------------
def contact_counts(depth: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """Number of samples in contact, #{p : depth_p <= zeta_j}, for every element and grid point.

    Parameters
    ----------
    depth : numpy.ndarray
        z1 - z_p per element [m], shape (..., n_samples), >= 0.
    zeta : numpy.ndarray
        Increasing compression grid [m], shape (n_zeta,).

    Returns
    -------
    numpy.ndarray
        int64 counts, shape (..., n_zeta).
    """
    lead = depth.shape[:-1]
    d = depth.reshape(-1, depth.shape[-1])
    nz = zeta.size
    # grid index at which each sample comes into contact (nz: never on the grid)
    j = np.searchsorted(zeta, d, side="left")
    flat = (np.arange(d.shape[0])[:, None] * (nz + 1) + j).ravel()
    hist = np.bincount(flat, minlength=d.shape[0] * (nz + 1)).reshape(d.shape[0], nz + 1)
    return np.cumsum(hist[:, :nz], axis=1).reshape(lead + (nz,))


@njit(cache=True)
def _find(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        nxt = parent[i]
        parent[i] = root
        i = nxt
    return root


@njit(cache=True)
def _spot_stiffness(order, grid_index, n, n_zeta, k_of_count):
    """Sum of punch stiffnesses of the 4-connected contact spots on the compression grid.

    Samples are added in order of increasing depth (``order``: flat sample indices, row-major
    n x n; ``grid_index``: the grid point at which each comes into contact, non-decreasing);
    spots are merged by union-find, and the total k = sum_spots k_of_count[size] is updated at
    every addition. Output (n_elements, n_zeta) [N/m].
    """
    n_el = order.shape[0]
    n_samples = order.shape[1]
    out = np.zeros((n_el, n_zeta))
    parent = np.empty(n_samples, dtype=np.int64)
    size = np.zeros(n_samples, dtype=np.int64)
    active = np.zeros(n_samples, dtype=np.bool_)
    di = np.array([-1, 1, 0, 0])
    dj = np.array([0, 0, -1, 1])
    for e in range(n_el):
        for p in range(n_samples):
            parent[p] = p
            size[p] = 0
            active[p] = False
        total = 0.0
        q = 0
        for jz in range(n_zeta):
            while q < n_samples and grid_index[e, q] <= jz:
                p = order[e, q]
                active[p] = True
                size[p] = 1
                total += k_of_count[1]
                pi = p // n
                pj = p - pi * n
                for s in range(4):
                    ni = pi + di[s]
                    nj = pj + dj[s]
                    if ni < 0 or ni >= n or nj < 0 or nj >= n:
                        continue
                    nb = ni * n + nj
                    if not active[nb]:
                        continue
                    ra = _find(parent, p)
                    rb = _find(parent, nb)
                    if ra == rb:
                        continue
                    total -= k_of_count[size[ra]] + k_of_count[size[rb]]
                    if size[ra] < size[rb]:
                        ra, rb = rb, ra
                    parent[rb] = ra
                    size[ra] += size[rb]
                    total += k_of_count[size[ra]]
                q += 1
            out[e, jz] = total
    return out


def punch_stiffness(area, spring_modulus: float, poisson: float, thickness: float) -> np.ndarray:
    """Stiffness of a flat rigid circular punch of the given area on the bonded layer.

    k = 2 E_s* kappa(a / h, nu) a with a = sqrt(A / pi) and E_s* = E_s / (1 - nu^2).

    Parameters
    ----------
    area : array_like
        Punch (contact) area A [m2], >= 0.
    spring_modulus : float
        Young's modulus of the layer used for the springs E_s [Pa].
    poisson : float
        Poisson's ratio nu [-].
    thickness : float
        Layer thickness h [m]; ``numpy.inf`` gives the half-space value k = 2 E_s* a.

    Returns
    -------
    numpy.ndarray
        k [N/m], same shape as ``area``.

    References
    ----------
    Hayes, W. C., Keer, L. M., Herrmann, G., & Mockros, L. F. (1972). J. Biomech. 5(5), 541-551.
    doi:10.1016/0021-9290(72)90010-3
    """
    e_s = checks.real("punch_stiffness.spring_modulus", spring_modulus, positive=True)
    nu = checks.poisson_ratio(poisson, allow_half=True)
    h = checks.real("thickness", thickness, positive=True, finite=False)
    area = np.asarray(area, dtype=float)
    if not np.all(np.isfinite(area)) or np.any(area < 0):
        raise ValueError("punch_stiffness: area must be finite and >= 0")
    radius = np.sqrt(area / np.pi)
    ratio = radius / h if math.isfinite(h) else np.zeros_like(radius)
    return 2.0 * e_s / (1.0 - nu * nu) * punch_factor(ratio, nu) * radius


def _cumulative_trapezoid(k: np.ndarray, step: float) -> np.ndarray:
    f = np.zeros_like(k)
    np.cumsum(0.5 * step * (k[..., 1:] + k[..., :-1]), axis=-1, out=f[..., 1:])
    return f


def _check_surface(surface_ds: xr.Dataset) -> tuple[np.ndarray, int, float]:
    if "height" not in surface_ds:
        raise KeyError("element_springs: surface dataset has no variable 'height'")
    height = surface_ds["height"]
    if set(height.dims) != {"x", "y"}:
        raise ValueError(f"element_springs: surface 'height' must have dims (x, y), got {height.dims}")
    height = height.transpose("x", "y").values.astype(float)
    for key in ("samples_per_element", "scan_step"):
        if key not in surface_ds.attrs:
            raise KeyError(f"element_springs: surface dataset lacks attribute '{key}'")
    n = surface_ds.attrs["samples_per_element"]
    if isinstance(n, (bool, np.bool_)) or int(n) != n or int(n) < 1:
        raise ValueError(
            f"element_springs: surface attribute samples_per_element must be a positive integer, got {n!r}"
        )
    n = int(n)
    step = float(surface_ds.attrs["scan_step"])
    if not math.isfinite(step) or step <= 0:
        raise ValueError(f"element_springs: surface attribute scan_step must be > 0 m, got {step!r}")
    if "element_size" in surface_ds.attrs:
        c = float(surface_ds.attrs["element_size"])
        if abs(n * step - c) > 1e-6 * c:
            raise ValueError(
                f"element_springs: element_size {c:g} m != samples_per_element {n} x scan_step {step:g} m"
            )
    if height.shape[0] % n or height.shape[1] % n or height.size == 0:
        raise ValueError(
            f"element_springs: height shape {height.shape} is not a whole number of {n} x {n}-sample elements"
        )
    if not np.all(np.isfinite(height)):
        bad = np.count_nonzero(~np.isfinite(height))
        raise ValueError(f"element_springs: surface height has {bad} non-finite samples")
    return height, n, step


def element_springs(
    surface_ds: xr.Dataset,
    spring_model: SpringModel,
    modulus: float,
    poisson: float,
    thickness: float,
) -> xr.Dataset:
    """Contact area, stiffness and force tables of every element of a road patch.

    Parameters
    ----------
    surface_ds : xarray.Dataset
        Surface dataset (docs/data_contracts.md): ``height[x, y]`` [m] of the patch's fine samples and
        attributes ``samples_per_element`` (n), ``scan_step`` [m] (and ``element_size`` [m],
        checked against n * scan_step when present). Element (i, j) holds the samples
        [i n:(i+1) n, j n:(j+1) n]; its matching height z1 is its highest sample.
    spring_model : SpringModel
        Model and compression grid.
    modulus : float
        Spring modulus E_s [Pa] (already resolved, see :func:`resolve_spring_modulus`).
    poisson : float
        Poisson's ratio of the layer nu [-].
    thickness : float
        Layer thickness h [m]; ``numpy.inf`` gives the half-space (kappa = 1).

    Returns
    -------
    xarray.Dataset
        Coordinates zeta [m] (uniform from 0), ex, ey; variables area[ex, ey, zeta] [m2],
        stiffness[ex, ey, zeta] [N/m], force[ex, ey, zeta] [N] (float64, or float32 for
        ``table_precision = 'float32'``); attributes spring_modulus [Pa], poisson, thickness [m],
        model, zeta_step [m], table_precision, connectivity (sum_of_spots).

    Notes
    -----
    Contact of sample p at grid point j is decided as z1 - z_p <= zeta_j. The area is counted
    for all elements and grid points at once from the grid index at which each sample comes into
    contact (a histogram and a cumulative sum); ``single_punch`` then needs kappa only for the
    n^2 + 1 possible areas. ``sum_of_spots`` adds the samples of an element in order of depth
    and merges spots with union-find (compiled), O(n^2 + n_zeta) per element; both take well
    under a second for a 20 x 20 patch of 26 x 26-sample elements on a 1001-point grid.
    """
    if not isinstance(spring_model, SpringModel):
        raise TypeError(f"spring_model must be a SpringModel, got {type(spring_model).__name__}")
    e_s = checks.real("element_springs.modulus", modulus, positive=True)
    nu = checks.poisson_ratio(poisson, allow_half=True)
    h = checks.real("thickness", thickness, positive=True, finite=False)
    height, n, dx = _check_surface(surface_ds)
    t0 = time.perf_counter()

    zeta = spring_model.zeta_grid()
    samples = element_samples(height, n, flat=True)
    n_ex, n_ey = samples.shape[:2]
    depth = samples.max(axis=-1, keepdims=True) - samples
    counts = contact_counts(depth, zeta)
    sample_area = dx * dx
    area = counts * sample_area
    logger.info(
        "element springs: %d x %d elements of %d x %d samples, %d grid points, model %s",
        n_ex, n_ey, n, n, zeta.size, spring_model.model,
    )

    attrs: dict[str, Any] = {}
    if spring_model.model not in ("linear", "hard"):
        # an area is always a whole number of samples: kappa is needed for n^2 + 1 values only
        k_of_count = punch_stiffness(np.arange(n * n + 1) * sample_area, e_s, nu, h)
    if spring_model.model == "single_punch":
        stiffness = k_of_count[counts]
    elif spring_model.model == "sum_of_spots":
        flat_depth = depth.reshape(n_ex * n_ey, n * n)
        order = np.argsort(flat_depth, axis=1, kind="stable")
        grid_index = np.searchsorted(zeta, np.take_along_axis(flat_depth, order, axis=1), side="left")
        stiffness = _spot_stiffness(order.astype(np.int64), grid_index.astype(np.int64), n, zeta.size, k_of_count)
        stiffness = stiffness.reshape(n_ex, n_ey, zeta.size)
        attrs["connectivity"] = "4 (samples sharing an edge form one spot)"
    elif spring_model.model == "hard":
        # the ratio of 1 / k to the layer's static self-compliance g(0) is logged by the contact run, which reads
        # g(0) from the greens file (the springs stage does not run the greens code)
        k_hard = spring_model.hard_stiffness
        stiffness = np.full((n_ex, n_ey, zeta.size), k_hard)
        attrs.update(hard_stiffness=k_hard, penalty_compliance=1.0 / k_hard)
        logger.info("element springs: hard contact, linear penalty springs of %.3g N/m (compliance 1/k = %.3g m/N)",
                    k_hard, 1.0 / k_hard)
    else:
        stiffness = np.full((n_ex, n_ey, zeta.size), spring_model.linear_stiffness)
        attrs["linear_stiffness"] = spring_model.linear_stiffness
    if spring_model.table_precision == "float32":
        # k rounded once; F is the float64 trapezoid of the rounded k, then stored as float32 (the
        # solver rebuilds it from k, see SpringTable.checked); A = count dx^2 rounds to 6e-8 too
        stiffness = stiffness.astype(np.float32)
        force = _cumulative_trapezoid(stiffness.astype(float), spring_model.zeta_step).astype(np.float32)
        area = area.astype(np.float32)
    else:
        force = _cumulative_trapezoid(stiffness, spring_model.zeta_step)

    ex = surface_ds["ex"].values if "ex" in surface_ds.coords else np.arange(n_ex)
    ey = surface_ds["ey"].values if "ey" in surface_ds.coords else np.arange(n_ey)
    if ex.size != n_ex or ey.size != n_ey:
        raise ValueError(
            f"element_springs: surface coords ex/ey have sizes {ex.size}/{ey.size}, "
            f"height holds {n_ex} x {n_ey} elements"
        )
    dims = ("ex", "ey", "zeta")
    ds = xr.Dataset(
        {
            "area": (dims, area, {"units": "m2", "long_name": "geometric contact (overlap) area A(zeta)"}),
            "stiffness": (dims, stiffness, {"units": "N/m", "long_name": "element spring stiffness k(zeta)"}),
            "force": (dims, force, {"units": "N", "long_name": "element spring force F(zeta)"}),
        },
        coords={
            "zeta": ("zeta", zeta, {"units": "m", "long_name": "spring compression"}),
            "ex": ("ex", ex, {"units": "1", "long_name": "element index in x"}),
            "ey": ("ey", ey, {"units": "1", "long_name": "element index in y"}),
        },
        attrs={
            "spring_modulus": e_s,
            "spring_modulus_units": "Pa",
            "poisson": nu,
            "thickness": h,
            "thickness_units": "m",
            "model": spring_model.model,
            "zeta_step": spring_model.zeta_step,
            "table_precision": spring_model.table_precision,
            **attrs,
        },
    )
    logger.info("element springs done in %.2f s", time.perf_counter() - t0)
    return ds
