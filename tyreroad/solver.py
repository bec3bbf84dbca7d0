"""Contact solver settings (config section ``solver``) and the rules that follow from them alone.

Kept free of the numerical modules so that planning (:mod:`tyreroad.config`, :mod:`tyreroad.cluster`)
can ask which path a run takes without importing numba.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping

from . import checks

__all__ = ["FFT_THRESHOLD", "SolverSettings"]

#: Patches with more elements than this use the FFT / Newton-Krylov path when ``method="auto"``:
#: the paper's 20 x 20 patch keeps the exact dense path.
FFT_THRESHOLD = 400


@dataclass(frozen=True)
class SolverSettings:
    """Contact solver settings (config section ``solver``).

    Parameters
    ----------
    tolerance : float
        Newton convergence criterion on max_e |R_e| [m] (default 1e-12).
    max_iterations : int
        Newton iterations allowed per step before the run stops with an error (default 50).
    d_max : float
        Final indentation of a run [m] (default 2.5e-4).
    quasistatic_step : float
        Indentation step of quasi-static runs [m] (default 1e-5: K(d) comes from the stored tangent
        of each state, exact between contact-set changes, so the grid may be coarse).
    method : {"auto", "dense", "fft"}
        History sum and step solver. ``dense``: offset-table history and a direct solve of the
        Jacobian of the loaded elements (exact, the reference; O(M^2 L) per step). ``fft``: 2-D FFT
        history sums and a matrix-free Newton-Krylov solve (:mod:`tyreroad.convolution`;
        O(M log M L) per step). ``auto`` (default) uses ``fft`` above ``FFT_THRESHOLD`` elements and
        for dynamic runs longer than the kernel's kept lags.
    preconditioner_block : int
        Tile edge [elements] of the block-Jacobi preconditioner of the ``fft`` path (default 4).
    long_memory : bool
        Add the kernel's tail beyond the kept lags (SPEC 9, :mod:`tyreroad.memory`) to runs longer
        than the kept lags (default True). Off, such a run is an error naming the lags and steps.
    krylov_forcing : float
        Largest inexact-Newton forcing term of the ``fft`` path, 0 < eta < 1 (default 1e-6): the
        Krylov solver (conjugate gradients, GMRES for kernels that are not even) solves each Newton
        correction to at most this fraction of ||R||_2
        (:class:`tyreroad.newton.FFTSubstrate`).
    stability : {"refuse", "warn"}
        What a dynamic run does when the stiffest spring of its tables exceeds the kernel's critical
        stiffness (the greens file's stability margin, :mod:`tyreroad.margin`): ``refuse`` (default) stops
        before the first step with an error naming the stiffness, the margin and the cure; ``warn`` runs
        and records it (the seed's construction beside the default: what the paper's method gives).
    """

    tolerance: float = 1e-12
    max_iterations: int = 50
    d_max: float = 2.5e-4
    quasistatic_step: float = 1e-5
    method: str = "auto"
    preconditioner_block: int = 4
    long_memory: bool = True
    krylov_forcing: float = 1e-6
    stability: str = "refuse"

    def resolved_method(self, n_elements: int, n_steps: int | None = None, n_lags: int | None = None) -> str:
        """``dense`` or ``fft`` for a patch of ``n_elements`` elements (and a run of ``n_steps`` steps
        on a kernel of ``n_lags`` lags): ``auto`` takes the FFT path above ``FFT_THRESHOLD`` elements
        and for dynamic runs longer than the kept lags, where the dense lag sum dominates (a 20 x 20
        load-unload cycle of 755 steps: 12.7 s dense, 3.8 s FFT, forces equal to 4e-14; 38 s dense before the
        dense lag sum's loop order changed in session 24)."""
        if self.method == "auto":
            long_run = n_steps is not None and n_lags is not None and n_lags > 1 and n_steps > n_lags
            return "fft" if n_elements > FFT_THRESHOLD or long_run else "dense"
        return self.method

    def __post_init__(self) -> None:
        if self.method not in ("auto", "dense", "fft"):
            raise ValueError(f"solver.method: expected 'auto', 'dense' or 'fft', got {self.method!r}")
        if self.stability not in ("refuse", "warn"):
            raise ValueError(f"solver.stability: expected 'refuse' or 'warn', got {self.stability!r}")
        if not isinstance(self.long_memory, bool):
            raise ValueError(f"solver.long_memory: expected true or false, got {self.long_memory!r}")
        for key in ("tolerance", "d_max", "quasistatic_step"):
            checks.real(f"solver.{key}", getattr(self, key), positive=True)
        if not 0.0 < checks.real("solver.krylov_forcing", self.krylov_forcing) < 1.0:
            raise ValueError(f"solver.krylov_forcing: expected 0 < eta < 1, got {self.krylov_forcing!r}")
        for key in ("max_iterations", "preconditioner_block"):
            value = getattr(self, key)
            if isinstance(value, float):  # only from_config may turn 4.0 into 4
                raise ValueError(f"solver.{key}: expected an integer >= 1, got {value!r}")
            checks.integer(f"solver.{key}", value)
        if self.quasistatic_step > self.d_max:
            raise ValueError(
                f"solver.quasistatic_step: expected <= solver.d_max = {self.d_max:g} m, "
                f"got {self.quasistatic_step:g} m"
            )

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "SolverSettings":
        """Build from the ``solver`` config section; missing keys take the defaults.

        Raises
        ------
        ValueError
            Naming ``solver.<key>`` for unknown keys and for values of the wrong type or range.
        """
        section = dict(section or {})
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(section) - known)
        if unknown:
            raise ValueError(
                f"solver.{unknown[0]}: unknown key (expected one of {', '.join(sorted(known))})"
            )
        values = dict(section)
        for key in ("tolerance", "d_max", "quasistatic_step", "krylov_forcing"):
            if key in values:
                values[key] = checks.real(f"solver.{key}", values[key], positive=True)
        for key in ("max_iterations", "preconditioner_block"):
            if key in values:
                values[key] = checks.integer(f"solver.{key}", values[key])
        return cls(**values)
