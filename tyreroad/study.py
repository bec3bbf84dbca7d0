"""Aggregation of the contact runs into the study dataset ``results/study.nc`` (SPEC section 7).

Every contact run (one surface, one material, one mode, one acceleration) gives the total contact
force F(d) at its native indentation samples: a uniform grid for quasi-static runs, d_n = a (n dt)^2 / 2
for dynamic runs. The study dataset puts all runs on one common indentation grid 0 ... d_max
(step ``study.indentation_step``) so that they can be compared point by point.

Choices (the specification leaves them open):

* The contact stiffness K = dF/dd is computed **on the native samples** with the second-order
  three-point formula for unequal spacing (one-sided second-order formulas at the two ends) and
  only then interpolated linearly onto the common grid. Differentiating the already interpolated
  force would give a piecewise-constant K with jumps at every native sample.
* Quasi-static runs carry the tangent stiffness of every solved state (``tangent_stiffness``,
  dF/dd = 1^T [G0|C + diag(1/k)]^-1 1, exact between contact-set changes; :mod:`tyreroad.stiffness`),
  so they may step coarsely (``solver.quasistatic_step``, default 10 um). For such a run K at the
  native samples *is* the tangent, and F and K go onto the common grid through the cubic Hermite
  interpolant of (d, F, dF/dd) and its derivative (:func:`hermite_on_grid`): K = dF/dd holds on the
  grid as well, and F is interpolated to fourth order instead of second. The backing force of a
  quasi-static run equals the surface force and is treated the same way. The contact fraction on
  the grid counts the elements whose compression, linear in d between two solved states, is
  positive (so the count between coarse samples moves element by element, not linearly).
  ``stiffness_from_tangent`` (per case) records which cases did.
* Interpolation onto the common grid is linear (``numpy.interp``). Grid points outside a run's
  native range (beyond a rounding tolerance) are NaN, never extrapolated. A run that stops short of
  d_max by more than its last native step is an error.
* K_sat is the median of the *common-grid* K over ``study.saturation_range`` (inclusive), so every
  case is weighted uniformly in d whatever its native sampling.
* The contact fraction is ``contact_count`` divided by the number of elements of the patch.
* The stiffness of the force at the rigid backing is computed the same way (``backing_stiffness``).
* The native samples are kept too (``native_*`` variables, NaN-padded along ``sample``) so that
  checks that depend on the sampling (claim 9 of the report) can be made from the study file.
* Non-monotone indentation paths (load-unload cycles, holds): F is not a function of d there
  (hysteresis), so K(d) and everything on the common grid are defined on the **initial loading
  branch**, from the first step up to the first maximum of d (:func:`loading_branch`); a hold ends
  the branch like an unloading. The seed's runs are monotone: one branch, every sample used.
  ``run_samples`` records the run's full length.
* Equivalent quasi-static stiffness (the seed's practical conclusion: damping can be approximated by
  a stiffer quasi-static model tuned per acceleration). The quasi-static force scales exactly with a
  common modulus factor s of layer and springs, so per case ``equivalent_modulus_scale`` is the
  least-squares s of K(d) against s K_QS(d) of the same material over ``EQUIVALENT_RANGE``
  (0.05-0.25 mm, clipped to d_max) and ``equivalent_misfit`` the remaining relative RMS misfit
  (:func:`equivalent_modulus_scale`).

Cases are labelled ``"<material>/<mode>/<accel:g>"`` (e.g. ``"tread/dynamic/500"``,
``"tread/quasistatic/0"``) and carry the coordinates ``material``, ``mode`` and ``accel`` along
``case``. Selection by those coordinates goes through the ``study`` dataset accessor::

    ds = open_study("results/study.nc")
    ref = ds.study.sel_case(material="tread", mode="dynamic", accel=500)
    dyn = ds.study.select(material="tread", mode="dynamic")

An accessor was preferred to a ``set_xindex`` multi-index on ``case``: a multi-index cannot be
written to netCDF as it is (it has to be reset before writing and rebuilt after reading), and it
replaces the readable ``case`` labels, whereas the accessor works identically on an in-memory and a
re-read dataset.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
import xarray as xr
from scipy.interpolate import CubicHermiteSpline

from . import io
from .contact import MODES

logger = logging.getLogger(__name__)

__all__ = [
    "StudySettings",
    "case_label",
    "expected_cases",
    "contact_stiffness",
    "saturated_stiffness",
    "interp_on_grid",
    "hermite_on_grid",
    "loading_branch",
    "equivalent_modulus_scale",
    "native_samples",
    "case_on_grid",
    "aggregate",
    "open_study",
    "variant_members",
    "StudyAccessor",
]

#: Defaults of the optional ``study`` keys (the same as in the config schema).
DEFAULT_INDENTATION_STEP = 1.0e-6
DEFAULT_SATURATION_RANGE = (1.8e-4, 2.5e-4)

#: ``loadings`` (which loading presets run for which materials) is read by the workflow and
#: aggregated by :mod:`tyreroad.hysteresis`, not by the seed study's aggregation.
_STUDY_KEYS = {"surface", "reference_material", "materials", "accelerations", "indentation_step", "saturation_range",
               "loadings", "compare_constructions", "claim6"}


def case_label(material: str, mode: str, accel: float) -> str:
    """Label of one study case: ``"<material>/<mode>/<accel:g>"``; quasi-static runs have accel 0."""
    return f"{material}/{mode}/{float(accel):g}"


@dataclass(frozen=True)
class StudySettings:
    """What the study aggregates and how (config section ``study`` plus ``solver.d_max``).

    Attributes
    ----------
    surface : str
        Surface preset of the study.
    reference_material : str
        Material the variants are compared with (figures 5-8, claims); one of ``materials``.
    materials : tuple of str
        Materials of the study; each has one quasi-static run and one dynamic run per acceleration.
    accelerations : tuple of float
        Indentation accelerations of the dynamic runs [m/s^2], ascending.
    indentation_step : float
        Step of the common indentation grid [m].
    saturation_range : tuple of float
        (d_lo, d_hi) over which K_sat is the median of K [m].
    d_max : float
        Final indentation of the runs and end of the common grid [m].
    """

    surface: str
    reference_material: str
    materials: tuple[str, ...]
    accelerations: tuple[float, ...]
    indentation_step: float
    saturation_range: tuple[float, float]
    d_max: float

    def __post_init__(self) -> None:
        if not isinstance(self.surface, str) or not self.surface:
            raise ValueError(f"study.surface must be a non-empty preset name, got {self.surface!r}")
        if not self.materials or not all(isinstance(m, str) and m for m in self.materials):
            raise ValueError(f"study.materials must be a non-empty list of preset names, got {self.materials!r}")
        if len(set(self.materials)) != len(self.materials):
            raise ValueError(f"study.materials has duplicates: {list(self.materials)!r}")
        if self.reference_material not in self.materials:
            raise ValueError(
                f"study.reference_material {self.reference_material!r} is not one of study.materials "
                f"{list(self.materials)!r}"
            )
        acc = np.asarray(self.accelerations, dtype=float)
        if acc.size == 0 or not np.all(np.isfinite(acc)) or np.any(acc <= 0):
            raise ValueError(f"study.accelerations must be a non-empty list of positive numbers [m/s^2], got {self.accelerations!r}")
        if len({case_label("", "dynamic", a) for a in acc}) != acc.size:
            raise ValueError(f"study.accelerations has duplicates (as '{{:g}}' labels): {self.accelerations!r}")
        if not (math.isfinite(self.d_max) and self.d_max > 0):
            raise ValueError(f"solver.d_max must be a positive number [m], got {self.d_max!r}")
        step = self.indentation_step
        if not (math.isfinite(step) and 0 < step < self.d_max):
            raise ValueError(f"study.indentation_step must be in (0, solver.d_max = {self.d_max:g}) [m], got {step!r}")
        n = round(self.d_max / step)
        if abs(n * step - self.d_max) > 1e-9 * self.d_max:
            raise ValueError(
                f"study.indentation_step = {step:g} m must divide solver.d_max = {self.d_max:g} m into whole steps"
            )
        lo, hi = self.saturation_range
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi <= self.d_max * (1 + 1e-12)):
            raise ValueError(
                f"study.saturation_range must be [d_lo, d_hi] with 0 < d_lo < d_hi <= solver.d_max = "
                f"{self.d_max:g} [m], got {list(self.saturation_range)!r}"
            )

    @classmethod
    def from_config(cls, study: Mapping[str, Any], d_max: float) -> "StudySettings":
        """Build from the config section ``study`` and ``solver.d_max`` [m].

        ``indentation_step`` and ``saturation_range`` default to the schema's defaults
        (1e-6 m and [1.8e-4, 2.5e-4] m) when absent.

        Raises
        ------
        ValueError
            Naming ``study.<key>`` for a missing, unknown or invalid key.
        """
        if not isinstance(study, Mapping):
            raise ValueError(f"config section 'study' must be a mapping, got {type(study).__name__}")
        unknown = set(study) - _STUDY_KEYS
        if unknown:
            raise ValueError(f"unknown key(s) in config section 'study': {', '.join(sorted('study.' + k for k in unknown))}")
        for key in ("surface", "reference_material", "materials", "accelerations"):
            if key not in study:
                raise ValueError(f"config key study.{key} is missing")
        materials = study["materials"]
        if isinstance(materials, str) or not isinstance(materials, Sequence):
            raise ValueError(f"study.materials must be a list of preset names, got {materials!r}")
        accelerations = study["accelerations"]
        if isinstance(accelerations, str) or not isinstance(accelerations, Sequence):
            raise ValueError(f"study.accelerations must be a list of numbers [m/s^2], got {accelerations!r}")
        try:
            acc = tuple(sorted(float(a) for a in accelerations))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"study.accelerations must be numbers [m/s^2], got {accelerations!r}") from exc
        sat = study.get("saturation_range", DEFAULT_SATURATION_RANGE)
        if isinstance(sat, str) or not isinstance(sat, Sequence) or len(sat) != 2:
            raise ValueError(f"study.saturation_range must be a pair [d_lo, d_hi] [m], got {sat!r}")
        try:
            step = float(study.get("indentation_step", DEFAULT_INDENTATION_STEP))
            sat_pair = (float(sat[0]), float(sat[1]))
        except (TypeError, ValueError) as exc:
            raise ValueError(f"study.indentation_step / study.saturation_range must be numbers [m]: {exc}") from exc
        try:
            d_max_f = float(d_max)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"solver.d_max must be a number [m], got {d_max!r}") from exc
        return cls(
            surface=study["surface"],
            reference_material=study["reference_material"],
            materials=tuple(materials),
            accelerations=acc,
            indentation_step=step,
            saturation_range=sat_pair,
            d_max=d_max_f,
        )

    @property
    def grid(self) -> np.ndarray:
        """The common indentation grid 0, step, ..., d_max [m]."""
        n = round(self.d_max / self.indentation_step)
        return np.arange(n + 1) * self.indentation_step


def expected_cases(settings: StudySettings) -> list[tuple[str, str, float]]:
    """The (material, mode, accel) triples of the study, in the study's order.

    Per material (in ``study.materials`` order): the quasi-static run (accel 0), then the dynamic
    runs by ascending acceleration.
    """
    cases = []
    for material in settings.materials:
        cases.append((material, "quasistatic", 0.0))
        cases.extend((material, "dynamic", float(a)) for a in settings.accelerations)
    return cases


def contact_stiffness(indentation: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Contact stiffness K = dF/dd at the native samples of a run.

    Second-order finite differences on a non-uniform grid: with h1 = d_i - d_{i-1},
    h2 = d_{i+1} - d_i the interior formula is

    K_i = [-h2/(h1 (h1+h2))] F_{i-1} + [(h2-h1)/(h1 h2)] F_i + [h1/(h2 (h1+h2))] F_{i+1},

    exact for quadratic F; at the two ends the one-sided three-point formulas of the same order
    (also exact for quadratics) are used.

    Parameters
    ----------
    indentation : array_like, shape (n,)
        Indentation d, strictly increasing, n >= 3 [m].
    force : array_like, shape (n,)
        Force F(d) [N].

    Returns
    -------
    numpy.ndarray, shape (n,)
        K = dF/dd [N/m].

    References
    ----------
    Fornberg, B. (1988). Generation of finite difference formulas on arbitrarily spaced grids.
    Math. Comp. 51, 699-706. https://doi.org/10.1090/S0025-5718-1988-0935077-0
    """
    d = np.asarray(indentation, dtype=float)
    f = np.asarray(force, dtype=float)
    if d.ndim != 1 or f.shape != d.shape:
        raise ValueError(f"indentation and force must be 1-D of equal length, got shapes {d.shape} and {f.shape}")
    if d.size < 3:
        raise ValueError(f"contact_stiffness needs at least 3 samples, got {d.size}")
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(f))):
        raise ValueError("indentation and force must be finite")
    h = np.diff(d)
    if np.any(h <= 0):
        i = int(np.argmax(h <= 0))
        raise ValueError(f"indentation must be strictly increasing; sample {i + 1} (d = {d[i + 1]:.6g} m) is not")
    k = np.empty_like(f)
    h1, h2 = h[:-1], h[1:]
    k[1:-1] = (-h2 / (h1 * (h1 + h2))) * f[:-2] + ((h2 - h1) / (h1 * h2)) * f[1:-1] + (h1 / (h2 * (h1 + h2))) * f[2:]
    a, b = h[0], h[1]
    k[0] = -(2 * a + b) / (a * (a + b)) * f[0] + (a + b) / (a * b) * f[1] - a / (b * (a + b)) * f[2]
    a, b = h[-2], h[-1]
    k[-1] = b / (a * (a + b)) * f[-3] - (a + b) / (a * b) * f[-2] + (a + 2 * b) / (b * (a + b)) * f[-1]
    return k


def saturated_stiffness(indentation: np.ndarray, stiffness: np.ndarray, saturation_range: Sequence[float]) -> float:
    """K_sat: median of K over d in [d_lo, d_hi] (inclusive; NaN samples ignored) [N/m].

    Raises
    ------
    ValueError
        When no finite sample lies in the range.
    """
    d = np.asarray(indentation, dtype=float)
    k = np.asarray(stiffness, dtype=float)
    lo, hi = float(saturation_range[0]), float(saturation_range[1])
    tol = 1e-9 * max(abs(hi), 1e-300)
    sel = (d >= lo - tol) & (d <= hi + tol) & np.isfinite(k)
    if not np.any(sel):
        raise ValueError(f"no finite stiffness sample in the saturation range [{lo:g}, {hi:g}] m")
    return float(np.median(k[sel]))


def interp_on_grid(grid: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Linear interpolation of samples (x, y) onto ``grid``; NaN outside [x_0, x_end], never extrapolated.

    Parameters
    ----------
    grid : array_like
        Points to interpolate at (e.g. the common indentation grid [m]).
    x : array_like
        Increasing sample positions [m].
    y : array_like
        Sample values (any unit).

    Returns
    -------
    numpy.ndarray
        Values on ``grid``; grid points beyond the samples by more than a rounding tolerance
        (1e-9 of ``|x_end|``) are NaN.
    """
    grid = np.asarray(grid, dtype=float)
    x = np.asarray(x, dtype=float)
    out = np.interp(grid, x, y)
    tol = 1e-9 * max(abs(x[-1]), 1e-300)
    out[(grid < x[0] - tol) | (grid > x[-1] + tol)] = np.nan
    return out


def hermite_on_grid(grid: np.ndarray, x: np.ndarray, y: np.ndarray, dydx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Hermite interpolation of samples (x, y) with slopes dydx onto ``grid``, and its derivative.

    Used for quasi-static runs whose tangent stiffness dF/dd is known at every sample: F on the grid
    is fourth-order accurate between samples and K = dF/dd of the interpolant is continuous and
    equals the tangent at every sample. NaN outside [x_0, x_end] (as :func:`interp_on_grid`).

    Parameters
    ----------
    grid : array_like
        Points to interpolate at [m].
    x : array_like
        Strictly increasing sample positions [m].
    y, dydx : array_like
        Values (e.g. F [N]) and slopes (e.g. K [N/m]) at the samples.

    Returns
    -------
    (numpy.ndarray, numpy.ndarray)
        y and dy/dx on ``grid``.
    """
    grid = np.asarray(grid, dtype=float)
    x = np.asarray(x, dtype=float)
    spline = CubicHermiteSpline(x, np.asarray(y, dtype=float), np.asarray(dydx, dtype=float), extrapolate=True)
    tol = 1e-9 * max(abs(x[-1]), 1e-300)
    inside = (grid >= x[0] - tol) & (grid <= x[-1] + tol)
    at = np.clip(grid, x[0], x[-1])
    value, slope = spline(at), spline(at, 1)
    value[~inside] = np.nan
    slope[~inside] = np.nan
    return value, slope


def loading_branch(indentation: np.ndarray) -> int:
    """Number of samples of the initial loading branch of a prescribed indentation path.

    The branch runs from the first sample up to the first maximum of d: it ends at the last sample
    before d stops increasing (a hold, d[n+1] = d[n], ends it as well as an unloading). K(d) of the
    study is defined on this branch only: on a load-unload cycle F is not a function of d (hysteresis),
    and the seed's claims are about first loading. A monotone path (the seed's d = a t^2/2 and the
    quasi-static ramp) is one branch: every sample is kept.

    Parameters
    ----------
    indentation : array_like, shape (n,)
        Prescribed indentation d at the run's steps [m].

    Returns
    -------
    int
        The branch is ``indentation[:n_branch]``.
    """
    d = np.asarray(indentation, dtype=float)
    stop = np.flatnonzero(np.diff(d) <= 0)
    return int(stop[0] + 1) if stop.size else int(d.size)


#: Indentation range [m] of the equivalent quasi-static stiffness fit (clipped to d_max).
EQUIVALENT_RANGE = (0.05e-3, 0.25e-3)


def equivalent_modulus_scale(
    indentation: np.ndarray, dynamic: np.ndarray, quasistatic: np.ndarray, d_range: Sequence[float] = EQUIVALENT_RANGE
) -> tuple[float, float]:
    """Modulus factor s of the quasi-static model that best matches a dynamic stiffness curve.

    The quasi-static force scales exactly with a common factor s of the layer modulus and the
    spring modulus (the compressions are unchanged, every force is multiplied by s), so a
    "stiffer quasi-static model" is K_qs,s(d) = s K_qs(d). s is the least-squares fit
    s = sum K_dyn K_qs / sum K_qs^2 over the grid points with d in ``d_range`` (inclusive, finite
    values only), and the misfit is RMS(K_dyn - s K_qs) / RMS(K_dyn) over the same points.

    Parameters
    ----------
    indentation : array_like
        Common indentation grid [m].
    dynamic, quasistatic : array_like
        K_dyn(d) and K_qs(d) on that grid [N/m].
    d_range : (float, float)
        Fit range [m].

    Returns
    -------
    (float, float)
        s [1] and the relative RMS misfit [1].

    Raises
    ------
    ValueError
        When no finite point lies in the range.
    """
    d = np.asarray(indentation, dtype=float)
    kd = np.asarray(dynamic, dtype=float)
    kq = np.asarray(quasistatic, dtype=float)
    lo, hi = float(d_range[0]), float(d_range[1])
    tol = 1e-9 * max(abs(hi), 1e-300)
    sel = (d >= lo - tol) & (d <= hi + tol) & np.isfinite(kd) & np.isfinite(kq)
    if not np.any(sel) or not np.any(kq[sel] != 0):
        raise ValueError(f"no finite non-zero quasi-static stiffness in the fit range [{lo:g}, {hi:g}] m")
    kd, kq = kd[sel], kq[sel]
    s = float(np.dot(kd, kq) / np.dot(kq, kq))
    misfit = float(np.sqrt(np.mean((kd - s * kq) ** 2)) / np.sqrt(np.mean(kd**2)))
    return s, misfit


def _source(ds: xr.Dataset, index: int) -> str:
    return str(ds.encoding.get("source", f"contact dataset #{index}"))


def _run_key(ds: xr.Dataset, src: str, settings: StudySettings) -> tuple[str, str, float]:
    for key in ("mode", "material", "surface", "acceleration"):
        if key not in ds.attrs:
            raise ValueError(f"{src}: contact dataset lacks the attribute {key!r}")
    mode = str(ds.attrs["mode"])
    material = str(ds.attrs["material"])
    surface = str(ds.attrs["surface"])
    accel = float(ds.attrs["acceleration"])
    if mode not in MODES:
        raise ValueError(f"{src}: mode {mode!r} is not one of {MODES}")
    if surface != settings.surface:
        raise ValueError(f"{src}: surface {surface!r} differs from study.surface {settings.surface!r}")
    if material not in settings.materials:
        raise ValueError(f"{src}: material {material!r} is not in study.materials {list(settings.materials)!r}")
    if mode == "quasistatic":
        if accel != 0.0:
            raise ValueError(f"{src}: quasi-static run must have acceleration 0, got {accel:g} m/s^2")
    else:
        match = [a for a in settings.accelerations if math.isclose(a, accel, rel_tol=1e-9)]
        if not match:
            raise ValueError(
                f"{src}: acceleration {accel:g} m/s^2 is not in study.accelerations {list(settings.accelerations)!r}"
            )
        accel = match[0]
    return material, mode, accel


def native_samples(ds: xr.Dataset, src: str, settings: StudySettings) -> dict[str, np.ndarray]:
    """The samples of one contact run that the study uses: its initial loading branch, checked.

    Parameters
    ----------
    ds : xarray.Dataset
        A contact dataset (docs/data_contracts.md "Contact dataset", :func:`tyreroad.contact.contact_dataset`).
    src : str
        The run's name in error messages (its file).
    settings : StudySettings
        The study settings (d_max and the common grid).

    Returns
    -------
    dict
        ``indentation`` [m], ``force`` and ``backing_force`` [N], ``contact_fraction`` [1],
        ``stiffness`` and ``backing_stiffness`` at the native samples [N/m] (the stored tangent of a
        quasi-static run, else second-order differences), ``from_tangent`` (0, 1, or 2 when the
        backing force is the surface force), optionally ``grid_contact_fraction`` (on the grid),
        ``n_elements`` and ``run_samples``.

    Raises
    ------
    ValueError
        Naming ``src`` for a missing variable, non-finite values, fewer than 3 loading samples, or
        a run that does not cover 0 ... d_max.
    """
    for name in ("indentation", "force", "backing_force", "contact_count"):
        if name not in ds.variables:
            raise ValueError(f"{src}: contact dataset lacks the variable {name!r}")
    for dim in ("ex", "ey"):
        if dim not in ds.sizes:
            raise ValueError(f"{src}: contact dataset lacks the element dimension {dim!r}")
    n_elements = int(ds.sizes["ex"] * ds.sizes["ey"])
    d = np.asarray(ds["indentation"].values, dtype=float)
    out = {
        "indentation": d,
        "force": np.asarray(ds["force"].values, dtype=float),
        "backing_force": np.asarray(ds["backing_force"].values, dtype=float),
        "contact_fraction": np.asarray(ds["contact_count"].values, dtype=float) / n_elements,
    }
    if "tangent_stiffness" in ds.variables:
        out["tangent"] = np.asarray(ds["tangent_stiffness"].values, dtype=float)
    for name, v in out.items():
        if v.ndim != 1 or v.size != d.size:
            raise ValueError(f"{src}: {name} must be 1-D along 'step' like indentation, got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise ValueError(f"{src}: {name} has non-finite values")
    # K(d) is defined on the initial loading branch (start up to the first maximum of d)
    n_run = d.size
    n_branch = loading_branch(d)
    if n_branch < n_run:
        logger.info(
            "%s: non-monotone indentation; the study uses the initial loading branch, %d of %d steps "
            "(up to d = %.6g m)", src, n_branch, n_run, d[n_branch - 1],
        )
    out = {name: v[:n_branch] for name, v in out.items()}
    d = out["indentation"]
    if d.size < 3:
        raise ValueError(
            f"{src}: the initial loading branch (start up to the first maximum of the indentation) "
            f"needs at least 3 steps, got {d.size} of {n_run}"
        )
    # a run must reach d_max to within its own last step; the remainder is NaN, not extrapolated
    if d[-1] < settings.d_max - (d[-1] - d[-2]) * (1 + 1e-9):
        raise ValueError(
            f"{src}: run's loading branch stops at d = {d[-1]:.6g} m, short of solver.d_max = "
            f"{settings.d_max:.6g} m by more than its last step"
        )
    if d[0] > settings.indentation_step * (1 + 1e-9):
        raise ValueError(f"{src}: run starts at d = {d[0]:.6g} m, beyond the first grid step; expected first contact at d = 0")
    if "tangent" in out:
        # the tangent of each solved (static) state: exact K at the native samples
        out["stiffness"] = out.pop("tangent")
        if "compression" in ds.variables:
            # the contact count between coarse samples: elements whose compression, interpolated
            # linearly between the solved states, is positive
            zeta = np.asarray(ds["compression"].values, dtype=float)[:n_branch].reshape(d.size, -1)
            out["grid_contact_fraction"] = _count_between_states(settings.grid, d, zeta) / n_elements
        same = np.array_equal(out["backing_force"], out["force"])
        out["backing_stiffness"] = out["stiffness"] if same else contact_stiffness(d, out["backing_force"])
        out["from_tangent"] = np.array(2 if same else 1)
    else:
        out["stiffness"] = contact_stiffness(d, out["force"])
        out["backing_stiffness"] = contact_stiffness(d, out["backing_force"])
        out["from_tangent"] = np.array(0)
    out["n_elements"] = np.array(n_elements)
    out["run_samples"] = np.array(n_run)
    out["fs2_limit_indentation"] = np.array(_fs2_limit_indentation(ds, d))
    out["fs2_alternation"] = np.array(float(ds["fs2_alternation"]) if "fs2_alternation" in ds.variables
                                      else float("nan"))
    return out


def _fs2_limit_indentation(ds: xr.Dataset, d: np.ndarray) -> float:
    """d [m] of the first step whose stiffest spring passes the kernel's stability limit (tyreroad.stability):
    its margin over the whole unit circle where the run recorded it, else its fs/2 point; NaN for a run that
    stays below it or has no stability record (quasi-static runs)."""
    if "max_spring_stiffness" not in ds.variables or "nyquist_critical_stiffness" not in ds.variables:
        return float("nan")
    limit = float(ds["nyquist_critical_stiffness"])
    if "margin_critical_stiffness" in ds.variables and not np.isnan(float(ds["margin_critical_stiffness"])):
        limit = float(ds["margin_critical_stiffness"])
    past = np.flatnonzero(np.asarray(ds["max_spring_stiffness"].values)[: d.size] > limit)
    return float(d[past[0]]) if past.size else float("nan")


def case_on_grid(run: Mapping[str, np.ndarray], settings: StudySettings) -> dict[str, np.ndarray]:
    """One run on the common grid: the study's K(d), F(d) and contact fraction.

    Linear interpolation of the native samples (:func:`interp_on_grid`); for a run with a stored
    tangent, F and K (and the backing force when it is the surface force) through the cubic Hermite
    interpolant (:func:`hermite_on_grid`) and the contact fraction counted between the states.

    Parameters
    ----------
    run : mapping
        From :func:`native_samples`.
    settings : StudySettings
        The study settings (the common grid).

    Returns
    -------
    dict
        ``force`` [N], ``stiffness`` [N/m], ``contact_fraction`` [1], ``backing_force`` [N] and
        ``backing_stiffness`` [N/m] on ``settings.grid`` (NaN outside the run).
    """
    grid = settings.grid
    d = run["indentation"]
    out = {name: interp_on_grid(grid, d, run[name]) for name in _GRID_VARIABLES}
    tangent = int(run["from_tangent"])
    if tangent:
        pairs = [("force", "stiffness")] + ([("backing_force", "backing_stiffness")] if tangent == 2 else [])
        for f_name, k_name in pairs:
            out[f_name], out[k_name] = hermite_on_grid(grid, d, run[f_name], run[k_name])
        if "grid_contact_fraction" in run:
            out["contact_fraction"] = run["grid_contact_fraction"]
    return out


#: The variables of a run on the common grid (:func:`case_on_grid`).
_GRID_VARIABLES = ("force", "stiffness", "contact_fraction", "backing_force", "backing_stiffness")


def _count_between_states(grid: np.ndarray, d: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """Number of elements with zeta > 0 at every grid d, zeta_e linear in d between the states (NaN outside)."""
    j = np.clip(np.searchsorted(d, grid, side="right") - 1, 0, d.size - 2)
    t = ((grid - d[j]) / (d[j + 1] - d[j]))[:, None]
    z = (1.0 - t) * zeta[j] + t * zeta[j + 1]
    count = np.count_nonzero(z > 0, axis=1).astype(float)
    tol = 1e-9 * max(abs(d[-1]), 1e-300)
    count[(grid < d[0] - tol) | (grid > d[-1] + tol)] = np.nan
    return count


_ATTRS = {
    "force": ("N", "total contact force on the tread surface"),
    "stiffness": ("N/m", "contact stiffness K = dF/dd (central differences on the native samples, then linear "
                  "interpolation; quasi-static runs: their stored tangent, see stiffness_method)"),
    "contact_fraction": ("1", "fraction of elements in contact (contact_count / number of elements)"),
    "backing_force": ("N", "total force at the rigid backing of the layer"),
    "backing_stiffness": ("N/m", "stiffness dF_backing/dd (central differences on the native samples, then linear interpolation)"),
    "saturated_stiffness": ("N/m", "saturated contact stiffness K_sat: median of K over the saturation range"),
    "saturated_backing_stiffness": ("N/m", "saturated stiffness of the backing force: median over the saturation range"),
    "native_indentation": ("m", "indentation at the run's native samples (NaN-padded)"),
    "native_force": ("N", "total contact force at the native samples (NaN-padded)"),
    "native_stiffness": ("N/m", "contact stiffness at the native samples (NaN-padded; the tangent where "
                         "stiffness_from_tangent = 1)"),
    "native_backing_force": ("N", "backing force at the native samples (NaN-padded)"),
    "native_contact_fraction": ("1", "fraction of elements in contact at the native samples (NaN-padded)"),
    "native_samples": ("1", "number of native samples of the run's initial loading branch (all samples of a monotone run)"),
    "run_samples": ("1", "number of steps of the contact run (more than native_samples for a non-monotone path)"),
    "equivalent_modulus_scale": (
        "1",
        "modulus factor s of the quasi-static model (layer and springs) that best fits this case's K(d): "
        "least squares of K(d) against s K_QS(d) of the same material over the equivalent range (1 for QS cases)",
    ),
    "equivalent_misfit": (
        "1",
        "RMS(K - s K_QS) / RMS(K) over the equivalent range: what the scaled quasi-static model leaves unexplained",
    ),
    "n_elements": ("1", "number of contact elements of the patch"),
    "fs2_limit_indentation": ("m", "indentation at which the stiffest contact spring first passes the time march's "
                              "stability limit k_crit of its kernel: its margin over the unit circle where recorded, else "
                              "its fs/2 point (NaN: never, or a quasi-static run)"),
    "fs2_alternation": ("1", "the contact run's fs/2 alternation of the force over its last fifth, over the mean "
                        "force there (tyreroad.stability; NaN: quasi-static)"),
    "stiffness_from_tangent": (
        "1",
        "1: K at the native samples is the run's stored tangent dF/dd (quasi-static runs), F and K on the "
        "grid by cubic Hermite interpolation; 0: second-order differences of F, linear interpolation",
    ),
}


def _read_runs(contacts, settings: StudySettings) -> dict[tuple[str, str, float], dict[str, np.ndarray]]:
    """The native samples of every contact run, by case key; a case given twice is an error."""
    runs: dict[tuple[str, str, float], dict[str, np.ndarray]] = {}
    for i, item in enumerate(contacts):
        ds = io.read_dataset(item) if isinstance(item, (str, Path)) else item
        src = str(item) if isinstance(item, (str, Path)) else _source(ds, i)
        key = _run_key(ds, src, settings)
        if key in runs:
            raise ValueError(f"{src}: duplicate run for case {case_label(*key)!r}")
        runs[key] = native_samples(ds, src, settings)
        runs[key]["source"] = np.array(src)
    return runs


def aggregate(contacts: Iterable[xr.Dataset | str | Path], settings: StudySettings) -> xr.Dataset:
    """Put all contact runs of the study on one indentation grid (the ``results/study.nc`` content).

    Parameters
    ----------
    contacts : iterable of xarray.Dataset or path-like
        Contact datasets (docs/data_contracts.md "Contact dataset") or their files; exactly one per case of
        :func:`expected_cases` (any order).
    settings : StudySettings
        The study settings.

    Returns
    -------
    xarray.Dataset
        Dims ``case`` and ``indentation`` (the common grid, [m]) and ``sample`` (native samples);
        variables listed in the module docstring. Attribute ``stiffness_method`` states how K was
        computed.

    Raises
    ------
    ValueError
        For a run that does not belong to the study, a duplicate or missing case, or a run that
        does not cover 0 ... d_max.
    """
    runs = _read_runs(contacts, settings)
    expected = expected_cases(settings)
    missing = [case_label(*k) for k in expected if k not in runs]
    if missing:
        raise ValueError(f"study is missing the contact run(s) {', '.join(missing)}")
    n_el = {int(r["n_elements"]) for r in runs.values()}
    if len(n_el) != 1:
        raise ValueError(f"contact runs have different numbers of elements: {sorted(n_el)}")

    grid = settings.grid
    n_case = len(expected)
    n_sample = max(runs[k]["indentation"].size for k in expected)
    grid_vars = {name: np.full((n_case, grid.size), np.nan) for name in _GRID_VARIABLES}
    native_vars = {name: np.full((n_case, n_sample), np.nan) for name in
                   ("indentation", "force", "stiffness", "backing_force", "contact_fraction")}
    k_sat = np.empty(n_case)
    k_sat_b = np.empty(n_case)
    n_native = np.empty(n_case, dtype=np.int64)
    n_run = np.empty(n_case, dtype=np.int64)
    from_tangent = np.zeros(n_case, dtype=np.int8)
    for c, key in enumerate(expected):
        run = runs[key]
        d = run["indentation"]
        for name, values in case_on_grid(run, settings).items():
            grid_vars[name][c] = values
        from_tangent[c] = int(run["from_tangent"]) > 0
        for name in native_vars:
            native_vars[name][c, : d.size] = run[name]
        n_native[c] = d.size
        n_run[c] = int(run["run_samples"])
        k_sat[c] = saturated_stiffness(grid, grid_vars["stiffness"][c], settings.saturation_range)
        k_sat_b[c] = saturated_stiffness(grid, grid_vars["backing_stiffness"][c], settings.saturation_range)
        logger.info("case %s: %d native samples, K_sat = %.4g N/m", case_label(*key), d.size, k_sat[c])

    # equivalent quasi-static stiffness: K_dyn(d) ~ s K_QS(d) of the same material
    eq_range = (EQUIVALENT_RANGE[0], min(EQUIVALENT_RANGE[1], settings.d_max))
    scale = np.empty(n_case)
    misfit = np.empty(n_case)
    for c, (material, mode, accel) in enumerate(expected):
        k_qs = grid_vars["stiffness"][expected.index((material, "quasistatic", 0.0))]
        scale[c], misfit[c] = equivalent_modulus_scale(grid, grid_vars["stiffness"][c], k_qs, eq_range)
        if mode == "dynamic":
            logger.info("case %s: equivalent quasi-static modulus factor s = %.4f, misfit %.2f %%",
                        case_label(material, mode, accel), scale[c], 100 * misfit[c])

    def var(name, dims, values):
        units, long_name = _ATTRS[name]
        return xr.Variable(dims, values, {"units": units, "long_name": long_name})

    data = {name: var(name, ("case", "indentation"), v) for name, v in grid_vars.items()}
    data.update({f"native_{name}": var(f"native_{name}", ("case", "sample"), v) for name, v in native_vars.items()})
    data["native_samples"] = var("native_samples", ("case",), n_native)
    data["run_samples"] = var("run_samples", ("case",), n_run)
    for name in ("fs2_limit_indentation", "fs2_alternation"):  # the runs' stability records (tyreroad.stability)
        data[name] = var(name, ("case",), np.array([float(runs[k][name]) for k in expected]))
    data["equivalent_modulus_scale"] = var("equivalent_modulus_scale", ("case",), scale)
    data["equivalent_misfit"] = var("equivalent_misfit", ("case",), misfit)
    data["saturated_stiffness"] = var("saturated_stiffness", ("case",), k_sat)
    data["saturated_backing_stiffness"] = var("saturated_backing_stiffness", ("case",), k_sat_b)
    data["n_elements"] = var("n_elements", (), np.int64(n_el.pop()))
    data["stiffness_from_tangent"] = var("stiffness_from_tangent", ("case",), from_tangent)
    coords = {
        "case": ("case", [case_label(*k) for k in expected], {"units": "1", "long_name": "case label material/mode/acceleration"}),
        "material": ("case", [k[0] for k in expected], {"units": "1", "long_name": "tread material preset"}),
        "mode": ("case", [k[1] for k in expected], {"units": "1", "long_name": "layer response (dynamic or quasistatic)"}),
        "accel": ("case", np.array([k[2] for k in expected]), {"units": "m/s2", "long_name": "indentation acceleration (0 for quasi-static)"}),
        "indentation": ("indentation", grid, {"units": "m", "long_name": "indentation d"}),
    }
    out = xr.Dataset(data, coords=coords)
    out.attrs.update(
        {
            "surface": settings.surface,
            "reference_material": settings.reference_material,
            "saturation_range_m": np.asarray(settings.saturation_range, dtype=float),
            "d_max_m": settings.d_max,
            "indentation_step_m": settings.indentation_step,
            "equivalent_range_m": np.asarray(eq_range, dtype=float),
            "loading_branch": (
                "K(d) and every variable along indentation/sample use each run's initial loading branch: "
                "from the first step up to the first maximum of the prescribed indentation"
            ),
            "stiffness_method": (
                "K = dF/dd by second-order three-point differences on each run's native (non-uniform) "
                "samples, one-sided at the ends, then linear interpolation onto the common grid; runs with "
                "a stored tangent (quasi-static, stiffness_from_tangent = 1): K = the tangent dF/dd of each "
                "solved state, F and K on the grid by cubic Hermite interpolation; "
                "K_sat = median of the common-grid K over the saturation range"
            ),
        }
    )
    return out


VARIANT_KINDS = ("loss", "density")


def variant_members(variants: Mapping[str, Any], kind: str, materials: Sequence[str], reference: str) -> list[tuple[float, str]]:
    """The (scale, material) members of one variant group, sorted by scale, validated.

    Which material is which variant comes from the material presets (``base: <reference>`` with
    ``loss_scale`` or ``density_scale``), resolved by :func:`tyreroad.pipeline.material_variants`;
    this function only checks that mapping against the study. Material names are never parsed.

    Parameters
    ----------
    variants : mapping
        ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}``; the reference is the
        scale-1 member of each group.
    kind : {"loss", "density"}
        Which group.
    materials : sequence of str
        Materials present in the study.
    reference : str
        The study's reference material.

    Returns
    -------
    list of (float, str)
        Members sorted by scale (loss-factor or density multiplier [1]).

    Raises
    ------
    ValueError
        Naming the group and member when the mapping is malformed or names a material that is not
        in the study, or when the reference is not its scale-1 member.
    """
    if kind not in VARIANT_KINDS:
        raise ValueError(f"variant kind must be one of {VARIANT_KINDS}, got {kind!r}")
    if not isinstance(variants, Mapping) or kind not in variants:
        raise ValueError(f"variants must be a mapping with a {kind!r} group, got {variants!r}")
    members = []
    for item in variants[kind]:
        try:
            scale, name = float(item[0]), str(item[1])
        except (TypeError, ValueError, IndexError) as exc:
            raise ValueError(f"variants.{kind}: member {item!r} is not a [scale, material] pair") from exc
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f"variants.{kind}: scale of {name!r} must be positive, got {scale!r}")
        if name not in materials:
            raise ValueError(f"variants.{kind}: material {name!r} is not in the study {list(materials)!r}")
        members.append((scale, name))
    names = [m[1] for m in members]
    if len(set(names)) != len(names):
        raise ValueError(f"variants.{kind}: duplicate materials {names!r}")
    if (1.0, reference) not in members:
        raise ValueError(f"variants.{kind}: the reference material {reference!r} must be the member with scale 1")
    return sorted(members)


_REQUIRED = ("force", "stiffness", "contact_fraction", "backing_force", "backing_stiffness",
             "saturated_stiffness", "saturated_backing_stiffness")


def open_study(path: str | Path) -> xr.Dataset:
    """Read ``results/study.nc``; select cases through the ``study`` accessor.

    Examples
    --------
    >>> ds = open_study("results/study.nc")                      # doctest: +SKIP
    >>> ds.study.sel_case(material="tread", mode="dynamic", accel=500).saturated_stiffness  # doctest: +SKIP

    Raises
    ------
    ValueError
        When the file is not a study dataset (names the file and the missing variables).
    """
    ds = io.read_dataset(path)
    missing = [n for n in (*_REQUIRED, "material", "mode", "accel") if n not in ds.variables]
    if "case" not in ds.dims or missing:
        raise ValueError(f"{path}: not a tyreroad study dataset (missing: {', '.join(missing) or 'dimension case'})")
    return ds


@xr.register_dataset_accessor("study")
class StudyAccessor:
    """Selection of study cases by material, mode and acceleration (``ds.study``)."""

    def __init__(self, ds: xr.Dataset) -> None:
        self._ds = ds

    def _mask(self, material: str | None, mode: str | None, accel: float | None) -> np.ndarray:
        ds = self._ds
        for name in ("material", "mode", "accel"):
            if name not in ds.coords:
                raise ValueError(f"dataset has no coordinate {name!r} along 'case': not a study dataset")
        mask = np.ones(ds.sizes["case"], dtype=bool)
        if material is not None:
            mask &= ds["material"].values.astype(str) == material
        if mode is not None:
            if mode not in MODES:
                raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
            mask &= ds["mode"].values.astype(str) == mode
        if accel is not None:
            mask &= np.isclose(ds["accel"].values.astype(float), float(accel), rtol=1e-9, atol=0.0)
        return mask

    def labels(self, material: str | None = None, mode: str | None = None, accel: float | None = None) -> list[str]:
        """Case labels matching the given material, mode and acceleration [m/s^2] (None: any)."""
        mask = self._mask(material, mode, accel)
        return [str(c) for c in self._ds["case"].values[mask]]

    def select(self, material: str | None = None, mode: str | None = None, accel: float | None = None) -> xr.Dataset:
        """Sub-dataset of the matching cases (keeps the ``case`` dimension, possibly empty)."""
        return self._ds.isel(case=np.flatnonzero(self._mask(material, mode, accel)))

    def sel_case(self, material: str, mode: str, accel: float | None = None) -> xr.Dataset:
        """The one case of ``material`` and ``mode`` at ``accel`` [m/s^2] (0 or None for quasi-static).

        Raises
        ------
        KeyError
            When there is not exactly one such case (names it and lists the available ones).
        """
        if accel is None:
            if mode != "quasistatic":
                raise KeyError(f"accel is required for mode {mode!r}")
            accel = 0.0
        idx = np.flatnonzero(self._mask(material, mode, accel))
        if idx.size != 1:
            raise KeyError(
                f"no unique study case {case_label(material, mode, accel)!r}; available: "
                f"{', '.join(map(str, self._ds['case'].values))}"
            )
        return self._ds.isel(case=int(idx[0]))
