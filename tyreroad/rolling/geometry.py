"""Geometry of a rolling pass and the belt as a loading (SPEC 12).

The belt's undeformed surface z2_e(t) = z_top - d0 + (x_e - x_c(t))^2 / (2 R) (parabolic
approximation of the circle) along the contact centres x_c of a pass; :class:`RollingPass` is a
loading of :mod:`tyreroad.loading`'s protocol, marched by :func:`tyreroad.contact.run_loading_path`.
"""

from __future__ import annotations

import math

import numpy as np

from .. import checks
from ..contact import MODES
from .settings import RollingSettings

__all__ = ["contact_half_length", "pass_limits", "pass_positions", "RollingPass"]


def contact_half_length(radius: float, d0: float) -> float:
    """Geometric contact half-length a = sqrt(2 R d0) [m] of the belt on the highest peaks."""
    return math.sqrt(2.0 * radius * d0)


def pass_limits(settings: RollingSettings, d0: float, element_x: np.ndarray, element_size: float) -> tuple[float, float]:
    """(x_start, x_end) [m] of the pass: the configured ones, or a + entry_margin elements outside the strip."""
    if settings.x_start is not None:
        return float(settings.x_start), float(settings.x_end)
    a = contact_half_length(settings.radius, d0)
    reach = a + settings.entry_margin * element_size
    return float(element_x[0] - reach), float(element_x[-1] + reach)


def pass_positions(mode: str, speed: float, x_start: float, x_end: float, sample_rate: float,
                   quasistatic_step: float) -> tuple[np.ndarray, np.ndarray]:
    """(t [s], x_c [m]) of a pass.

    Dynamic: t_n = n / fs, x_c = x_start + v t_n up to the first x_c >= x_end. Quasi-static: x_c on
    the grid x_start + k * quasistatic_step (independent of v) up to the first >= x_end, and
    t = (x_c - x_start) / v.
    """
    v = checks.real("speed", speed, positive=True)
    length = x_end - x_start
    if mode == "dynamic":
        dx = v / checks.real("sample_rate", sample_rate, positive=True)
    elif mode == "quasistatic":
        dx = checks.real("quasistatic_step", quasistatic_step, positive=True)
    else:
        raise ValueError(f"mode: expected one of {MODES}, got {mode!r}")
    n_last = math.ceil(length / dx * (1.0 - 1e-12))
    k = np.arange(n_last + 1)
    x_c = x_start + k * dx
    time = k / sample_rate if mode == "dynamic" else (x_c - x_start) / v
    return time, x_c


class RollingPass:
    """The belt of a rolling tyre as a loading (:mod:`tyreroad.loading` protocol).

    Free compression of spring e at step n: gap0_e + d0 - (x_e - x_c[n])^2 / (2 R), the road
    height above the undeformed tread surface z2_e[n] = z_top - d0 + (x_e - x_c[n])^2 / (2 R).

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    element_x : array_like
        x of the element centres [m], shape (nx,).
    radius : float
        Tyre radius R [m].
    d0 : float
        Indentation of the belt below the highest peak [m].
    x_c : array_like
        Contact centre x_c[n] [m], one per step.
    time : array_like, optional
        t_n [s].
    speed : float, optional
        v [m/s] (for the belt's velocity dz2/dt); None for static states without a time axis.
    """

    def __init__(self, z1, element_x, radius: float, d0: float, x_c, time=None, speed: float | None = None):
        z1 = checks.finite_array("z1", z1, ndim=2)
        if z1.size == 0:
            raise ValueError("z1: expected a finite 2-D array of element heights [m], got an empty array")
        self.shape = z1.shape
        ex = checks.finite_array("element_x", element_x, ndim=1)
        if ex.size != z1.shape[0]:
            raise ValueError(f"element_x: expected {z1.shape[0]} values (one per element along x), got {ex.size}")
        self.radius = checks.real("radius", radius, positive=True)
        self.d0 = checks.real("d0", d0, positive=True)
        self.x_c = checks.finite_array("x_c", x_c, ndim=1)
        if self.x_c.size == 0:
            raise ValueError("x_c: expected at least one step [m]")
        self.n_steps = self.x_c.size
        if time is not None:
            time = checks.finite_array("time", time, ndim=1)
            if time.size != self.n_steps:
                raise ValueError(f"time: expected {self.n_steps} values (one per step), got {time.size}")
        self.time = time
        self.speed = None if speed is None else checks.real("speed", speed, positive=True)
        self.element_x = ex
        # per element, flattened like z1.ravel(): x of its column
        self._x = np.repeat(ex, z1.shape[1])
        self._base = z1.ravel() - z1.max() + self.d0

    def undeformed_surface(self, n: int) -> np.ndarray:
        """z2_e[n] - z_top [m], shape (M,): the tread surface below the highest peak."""
        return -self.d0 + (self._x - self.x_c[n]) ** 2 / (2.0 * self.radius)

    def free_compression(self, n: int) -> np.ndarray:
        """z1_e - z2_e[n] [m], shape (M,)."""
        return self._base - (self._x - self.x_c[n]) ** 2 / (2.0 * self.radius)

    def rest_compression(self) -> np.ndarray:
        """The free compression at the first x_c (the pass starts out of contact)."""
        return self.free_compression(0)

    def describe(self, n: int) -> str:
        """``x_c = ... m`` of step n."""
        return f"x_c = {self.x_c[n]:.6e} m"

    def prescribed(self) -> dict[str, tuple[np.ndarray, str, str]]:
        """The contact centre x_c[n] (the z2 field follows from it, :meth:`undeformed_surface`)."""
        return {"x_c": (self.x_c.copy(), "m", "contact centre x_c (the belt's lowest point)")}

    def done(self, n: int, force: np.ndarray) -> bool:
        """A pass runs to its last step."""
        return False

    def unfinished(self, n: int) -> str | None:
        """Nothing is required of the last step (the run checks that the contact has left the strip)."""
        return None

    def lever(self, n: int) -> np.ndarray:
        """x_e - x_c[n] [m], shape (M,)."""
        return self._x - self.x_c[n]
