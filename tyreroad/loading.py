"""Loadings: the prescribed motion of the tread, as the free compression of every spring at step n.

With the layer displacement w_e excluded, spring e would be compressed by z1_e - z2_e[n], the gap
closure that the loading prescribes (SPEC 1, 6). A *loading* is any object with

    ``n_steps``                     number of steps;
    ``time``                        t_n [s], shape (n_steps,), or None for a sequence of static states;
    ``free_compression(n)``         z1_e - z2_e[n] [m], shape (M,);
    ``rest_compression()``          z1_e - z2_e before step 0, at rest (the Newton warm start of step 0);
    ``describe(n)``                 a short text locating step n for messages ("d = 1.2e-04 m");
    ``prescribed()``                what to store with the result, {name: (values, units, long_name)},
                                    each values array with the step as its first axis.

The march loop (:func:`tyreroad.contact.march`) reads nothing else, so a new kind of motion (a
load-unload cycle, a rolling tyre with a z2 field per element) is a new loading, not an edit of
the loop. Heights enter relative to the highest road peak (``gap0 = z1 - max z1``), so that
z1 - z2 = gap0 + d carries no cancellation of absolute heights.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from . import checks

__all__ = [
    "Loading",
    "IndentationPath",
    "constant_acceleration_path",
    "uniform_indentation_grid",
]


class Loading(Protocol):
    """Prescribed motion; see the module docstring."""

    n_steps: int
    time: np.ndarray | None

    def free_compression(self, n: int) -> np.ndarray:  # pragma: no cover - protocol
        ...

    def rest_compression(self) -> np.ndarray:  # pragma: no cover - protocol
        ...

    def describe(self, n: int) -> str:  # pragma: no cover - protocol
        ...

    def prescribed(self) -> dict[str, tuple[np.ndarray, str, str]]:  # pragma: no cover - protocol
        ...


class IndentationPath:
    """A flat tread surface z2(t) = max z1 - d(t): every spring sees the same indentation d[n].

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    indentation : array_like
        d[n] [m], one per step (any sign and order: loading, holding, unloading).
    time : array_like, optional
        t_n [s]; None for a sequence of static states (quasi-static runs).
    """

    def __init__(self, z1, indentation, time=None):
        z1 = checks.finite_array("z1", z1, ndim=2)
        if z1.size == 0:
            raise ValueError("z1: expected a finite 2-D array of element heights [m], got an empty array")
        d = checks.finite_array("indentation", indentation, ndim=1)
        if d.size == 0:
            raise ValueError("indentation: expected at least one step [m]")
        self.shape = z1.shape
        self.gap0 = z1.ravel() - z1.max()
        self.indentation = d
        self.n_steps = d.size
        if time is not None:
            time = checks.finite_array("time", time, ndim=1)
            if time.size != d.size:
                raise ValueError(f"time: expected {d.size} values (one per step), got {time.size}")
        self.time = time

    def free_compression(self, n: int) -> np.ndarray:
        """gap0 + d[n] [m], shape (M,)."""
        return self.gap0 + self.indentation[n]

    def rest_compression(self) -> np.ndarray:
        """gap0 [m]: the surface touching the highest peak (d = 0) before the first step."""
        return self.gap0.copy()

    def describe(self, n: int) -> str:
        """``d = ... m`` of step n."""
        return f"d = {self.indentation[n]:.6e} m"

    def prescribed(self) -> dict[str, tuple[np.ndarray, str, str]]:
        """The indentation path, as stored in the contact file."""
        return {"indentation": (self.indentation.copy(), "m", "indentation d")}


def constant_acceleration_path(sample_rate: float, acceleration: float, d_max: float) -> tuple[np.ndarray, np.ndarray]:
    """The seed's loading: t_n = n / fs and d_n = a t_n^2 / 2 until d reaches d_max.

    Parameters
    ----------
    sample_rate : float
        fs [Hz].
    acceleration : float
        a [m/s^2].
    d_max : float
        Final indentation [m].

    Returns
    -------
    time : numpy.ndarray
        [s], from 0 to the first step with d >= d_max.
    indentation : numpy.ndarray
        [m].
    """
    fs = checks.real("sample_rate", sample_rate, positive=True)
    a = checks.real("acceleration", acceleration, positive=True)
    d_max = checks.real("d_max", d_max, positive=True)
    n_last = math.ceil(fs * math.sqrt(2.0 * d_max / a) * (1.0 - 1e-12))
    time = np.arange(n_last + 1) / fs
    return time, 0.5 * a * time**2


def uniform_indentation_grid(d_max: float, step: float) -> np.ndarray:
    """Indentations 0, dd, 2 dd, ... up to the first point >= d_max [m] (quasi-static runs)."""
    d_max = checks.real("d_max", d_max, positive=True)
    step = checks.real("step", step, positive=True)
    n_last = math.ceil(d_max / step * (1.0 - 1e-12))
    return np.arange(n_last + 1) * step
