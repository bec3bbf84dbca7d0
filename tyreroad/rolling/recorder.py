"""Recording a rolling pass: the totals of every step and element force maps at a few steps."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..stability import StabilityRecord
from .geometry import RollingPass

__all__ = ["RollingResult", "RollingRecorder"]


@dataclass(frozen=True)
class RollingResult:
    """Step series of one rolling pass.

    Attributes
    ----------
    time, x_c : numpy.ndarray
        t_n [s] and the contact centre [m], shape (n,).
    force : numpy.ndarray
        Total contact force [N].
    contact_count : numpy.ndarray
        Elements with F_e > 0.
    moment : numpy.ndarray
        sum_e F_e (x_e - x_c) [N m]; the belt power is v / R times it.
    pressure_centre : numpy.ndarray
        sum_e F_e x_e / F [m] (NaN without contact).
    snapshot_step : numpy.ndarray
        Steps of the stored element force maps.
    snapshot_force : numpy.ndarray
        F_e at those steps [N], shape (n_snapshots, nx, ny).
    newton_iterations, krylov_iterations : numpy.ndarray
        Per step.
    residual : numpy.ndarray
        Final max|R| per step [m].
    max_spring_stiffness : numpy.ndarray
        The stiffest tangent spring of each step [N/m].
    stability : tyreroad.stability.StabilityRecord or None
        Dynamic passes from the stage datasets: the kernel's fs/2 limit and the alternation.
    element_force : numpy.ndarray or None
        F_e of every step [N], shape (n, nx, ny), when the recorder was built with ``record_forces=True``
        (the input of :func:`tyreroad.belt_vibration.belt_velocity_at_points`); None otherwise.
    contact_extent : numpy.ndarray or None
        Span of the contact [elements along x, y] per step, shape (n, 2): of the elements with a positive
        force or spring stiffness (0 without contact); what a kernel's margin window must cover.
    """

    time: np.ndarray
    x_c: np.ndarray
    force: np.ndarray
    contact_count: np.ndarray
    moment: np.ndarray
    pressure_centre: np.ndarray
    snapshot_step: np.ndarray
    snapshot_force: np.ndarray
    newton_iterations: np.ndarray
    krylov_iterations: np.ndarray
    residual: np.ndarray
    max_spring_stiffness: np.ndarray
    stability: StabilityRecord | None = None
    element_force: np.ndarray | None = None
    contact_extent: np.ndarray | None = None

    def largest_contact_extent(self) -> tuple[tuple[int, int], int]:
        """((x, y) [elements], step): the largest spans of the contact along x and along y over the pass (each
        its own maximum) and the step where the span along x is largest."""
        if self.contact_extent is None or not len(self.contact_extent):
            return (0, 0), 0
        n = int(np.lexsort((self.contact_extent[:, 1], self.contact_extent[:, 0]))[-1])
        return (int(self.contact_extent[n, 0]), int(self.contact_extent[:, 1].max())), n


class RollingRecorder:
    """Keeps the totals of every step and the element forces at a few steps only.

    A pass of 150 x 20 elements over ~1800 steps would hold ~130 MB per field if every step's
    element fields were kept; the march only needs an object with ``store`` and ``result``
    (and ``contact_count`` for its log).

    Parameters
    ----------
    loading : RollingPass
        The pass (its lever arms x_e - x_c).
    snapshot_steps : sequence of int
        Steps whose element forces are kept.
    record_forces : bool
        Also keep the element forces of every step (n_steps x nx x ny float64: 48 MB for 150 x 20 elements and
        2000 steps), for the belt vibration (:mod:`tyreroad.belt_vibration`); default False.
    """

    def __init__(self, loading: RollingPass, snapshot_steps: Sequence[int], record_forces: bool = False):
        n = loading.n_steps
        self.loading = loading
        self.shape = loading.shape
        self.force = np.zeros(n)
        self.moment = np.zeros(n)
        self.first_moment = np.zeros(n)
        self.contact_count = np.zeros(n, dtype=np.int64)
        self.newton_iterations = np.zeros(n, dtype=np.int64)
        self.krylov_iterations = np.zeros(n, dtype=np.int64)
        self.residual = np.zeros(n)
        self.max_spring_stiffness = np.zeros(n)
        self.contact_extent = np.zeros((n, 2), dtype=np.int64)
        self.snapshot_steps = np.asarray(sorted(set(int(s) for s in snapshot_steps)), dtype=np.int64)
        self.snapshots = np.zeros((self.snapshot_steps.size, loading.shape[0] * loading.shape[1]))
        self.element_forces = np.zeros((n, loading.shape[0] * loading.shape[1])) if record_forces else None

    #: the march need not linearise the states of a pass (no tangent is kept)
    wants_tangent = False

    def store(self, n: int, step, displacement: np.ndarray, tangent=None) -> None:
        """Record the converged ``step`` (a :class:`tyreroad.newton.StepResult`) of step n."""
        f = step.force
        lever = self.loading.lever(n)
        self.force[n] = f.sum()
        self.moment[n] = f @ lever
        self.contact_count[n] = np.count_nonzero(f)
        self.newton_iterations[n] = step.newton_iterations
        self.krylov_iterations[n] = step.krylov_iterations
        self.residual[n] = step.residual
        self.max_spring_stiffness[n] = float(np.max(step.stiffness, initial=0.0))
        engaged = np.flatnonzero((f > 0) | (np.asarray(step.stiffness) > 0))
        if engaged.size:
            ix, iy = np.divmod(engaged, self.shape[1])
            self.contact_extent[n] = (ix.max() - ix.min() + 1, iy.max() - iy.min() + 1)
        where = np.flatnonzero(self.snapshot_steps == n)
        if where.size:
            self.snapshots[where[0]] = f
        if self.element_forces is not None:
            self.element_forces[n] = f

    def result(self, loading: RollingPass, n_steps: int | None = None) -> RollingResult:
        n = self.force.size if n_steps is None else n_steps
        with np.errstate(invalid="ignore", divide="ignore"):
            centre = np.where(self.force[:n] > 0, loading.x_c[:n] + self.moment[:n] / self.force[:n], np.nan)
        keep = self.snapshot_steps < n
        return RollingResult(
            time=np.asarray(loading.time, dtype=float)[:n] if loading.time is not None else np.full(n, np.nan),
            x_c=loading.x_c[:n].copy(),
            force=self.force[:n].copy(),
            contact_count=self.contact_count[:n].copy(),
            moment=self.moment[:n].copy(),
            pressure_centre=centre,
            snapshot_step=self.snapshot_steps[keep],
            snapshot_force=self.snapshots[keep].reshape((-1,) + tuple(self.shape)),
            newton_iterations=self.newton_iterations[:n].copy(),
            krylov_iterations=self.krylov_iterations[:n].copy(),
            residual=self.residual[:n].copy(),
            max_spring_stiffness=self.max_spring_stiffness[:n].copy(),
            element_force=(None if self.element_forces is None
                           else self.element_forces[:n].reshape((n,) + tuple(self.shape)).copy()),
            contact_extent=self.contact_extent[:n].copy(),
        )
