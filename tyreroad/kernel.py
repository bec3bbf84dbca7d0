r"""The layer kernel: what the contact solver knows of the tread layer, read once from a greens file.

A :class:`LayerKernel` is the response of the layer surface to the element forces, in the form every
solver piece needs it:

* the **kept lags** g[dx, dy, lag] [m/N] of the discrete impulse response (one lag for a
  quasi-static kernel), and whether the kernel is **static** (a sequence of static states) or
  **dynamic** (sampled at ``sample_rate``) -- stated, never guessed from the table's shape;
* its **memory model** beyond the kept lags (:class:`MemoryModel`; the tread's creep tail,
  :class:`tyreroad.memory.TailModel`, is one), which builds its own history term;
* the **collaborators** of the time march (:meth:`LayerKernel.collaborators`): the substrate, whose
  G_0 (:class:`tyreroad.influence.OffsetInfluence`, dense or FFT) also gives the quasi-static tangent
  and the next step's predictor, and the history of the kept lags plus the memory's;
* its **frequency response** (:meth:`LayerKernel.frequency_response`), the complex offset tables
  G(f) that the contact stiffness K*(f) solves over (the exact element FRF of the material,
  :class:`tyreroad.greens.ElementFRF`, when the kernel is given it, else the transform of the kept
  lags and the memory);
* the **backing force** of a run (the force at the rigid belt).

:meth:`LayerKernel.from_greens` is the one reader of a greens dataset's kernel variables; nothing
downstream opens them. A new kind of kernel (a flexible belt behind the tread, a tread block whose
influence is not translation invariant, another causal construction) is a new memory model, or a
subclass that overrides :meth:`LayerKernel.collaborators` and :meth:`LayerKernel.frequency_response`:
the march, the Newton driver and the stiffness solvers stay as they are.
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass, field
from typing import Any, Callable, Protocol, runtime_checkable

import numpy as np
import xarray as xr

from . import checks
from .convolution import OffsetConvolution, check_offset_kernel
from .history import DenseHistory, FFTHistory, History, HistorySum
from .influence import OffsetInfluence, offset_influences
from .layer import backing_force
from .memory import RetardationSpectrum, TailModel
from .newton import DenseSubstrate, FFTSubstrate, Substrate
from .solver import SolverSettings

logger = logging.getLogger(__name__)

__all__ = ["MemoryModel", "MemorySum", "LayerKernel", "KERNEL_MODES"]

#: The kinds of kernel a greens file holds, by the run mode that uses them.
KERNEL_MODES = ("dynamic", "quasistatic")


@runtime_checkable
class MemoryModel(Protocol):
    """The kernel beyond its kept lags: lags ``delay``, ``delay + 1``, ...

    ``delay``                                  the first lag it covers (= the kept lags L);
    ``history(shape, method, workers)``        a :class:`tyreroad.history.History` that adds its
                                               displacement to the kept lags' (``method`` is the
                                               run's ``dense`` or ``fft`` path);
    ``frequency_response(frequencies, fs)``    its part of the transfer function,
                                               sum_{l >= L} g[dx, dy, l] exp(-i 2 pi f l / fs), as
                                               complex offset tables (n_f, 2 nx - 1, 2 ny - 1) [m/N];
    ``describe()``                             a short text for the log.
    """

    delay: int

    def history(self, shape, method: str, workers: int = 1) -> History:  # pragma: no cover - protocol
        ...

    def frequency_response(self, frequencies, sample_rate: float) -> np.ndarray:  # pragma: no cover - protocol
        ...

    def describe(self) -> str:  # pragma: no cover - protocol
        ...


class MemorySum:
    """Several memory models beyond the same kept lags acting together (the creep tail and a flexible belt's
    recursive filters, :mod:`tyreroad.belt_kernel`): their histories are summed, and so are their transfer
    functions.

    Parameters
    ----------
    models : sequence of MemoryModel
        All with the same ``delay`` (the kept lags L).
    """

    def __init__(self, models):
        self.models = tuple(m for m in models if m is not None)
        if not self.models:
            raise ValueError("MemorySum: expected at least one memory model")
        delays = {int(m.delay) for m in self.models}
        if len(delays) != 1:
            raise ValueError(f"MemorySum: the models start at different lags {sorted(delays)}; expected one delay")
        for m in self.models:
            if not isinstance(m, MemoryModel):
                raise TypeError(f"MemorySum: {type(m).__name__} lacks the MemoryModel protocol")
        self.delay = delays.pop()

    def history(self, shape, method: str, workers: int = 1) -> History:
        """The models' histories summed (:class:`tyreroad.history.HistorySum`)."""
        return HistorySum([m.history(shape, method, workers) for m in self.models])

    def frequency_response(self, frequencies, sample_rate: float) -> np.ndarray:
        """The sum of the models' transfer functions beyond the kept lags, (n_f, X, Y) complex [m/N]."""
        total = None
        for m in self.models:
            part = np.asarray(m.frequency_response(frequencies, sample_rate))
            total = part if total is None else total + part
        return total

    def describe(self) -> str:
        """What the log says of this memory."""
        return " + ".join(m.describe() for m in self.models)

    def part(self, kind: type):
        """The first model of type ``kind`` (None without one)."""
        return next((m for m in self.models if isinstance(m, kind)), None)


@dataclass(frozen=True, eq=False)
class LayerKernel:
    """The layer's element response as the contact solver uses it (see the module docstring).

    Parameters
    ----------
    lags : array_like
        g[dx, dy, lag] [m/N], offsets -(n-1) ... n-1 along each axis (odd lengths; a larger centred
        table serves any smaller patch).
    static : bool
        True: a quasi-static kernel (one lag; every step a static state, with its tangent dF/dd).
    sample_rate : float, optional
        fs [Hz] of a dynamic kernel's lags (for a static kernel, optional: the rate at which its
        study samples time, e.g. a loading preset's path).
    memory : MemoryModel, optional
        The kernel beyond the kept lags (needed by dynamic runs longer than the kept lags).
    element_size : float, optional
        c [m] of the elements the kernel was computed for (checked against the surface's).
    response : optional
        The exact frequency response: any object with ``frequency_response(frequencies, shape)``
        returning complex offset tables [m/N] (:class:`tyreroad.greens.ElementFRF`, the layer's
        element FRF); without it, :meth:`frequency_response` transforms the kept lags and the memory.
    backing : callable, optional
        Total surface force [N] per step -> force at the rigid backing [N] (dynamic kernels;
        a static kernel's backing force is its surface force).
    name : str
        For messages (the material's name).
    critical_stiffness : float, optional
        The stiffest element spring for which the march on this kernel is stable on every contact set
        of its patch [N/m] (inf: every spring; the greens file's stability margin, :mod:`tyreroad.margin`);
        None: not known (a kernel built in code, or a file from before the margin was stored).
    construction : str, optional
        How the kernel was built from the FRF (``greens.construction``), for messages.
    margin_window : (int, int), optional
        The window [elements along x, y] ``critical_stiffness`` holds on, when smaller than the table's patch (a
        rolling strip's contact window, :func:`tyreroad.pipeline.build_greens`): the margin covers every contact
        set inside such a window, and a run checks its contact against it (:meth:`check_contact_extent`);
        None: every contact set of the patch.
    """

    lags: np.ndarray
    static: bool
    sample_rate: float | None = None
    memory: MemoryModel | None = None
    element_size: float | None = None
    response: Any = field(default=None, repr=False)
    backing: Callable[[np.ndarray], np.ndarray] | None = field(default=None, repr=False)
    name: str = "kernel"
    critical_stiffness: float | None = None
    construction: str | None = None
    margin_window: tuple[int, int] | None = None

    def __post_init__(self) -> None:
        g = np.asarray(self.lags, dtype=float)
        if g.ndim != 3 or g.shape[2] < 1:
            raise ValueError(f"{self.name}: expected kernel lags g[dx, dy, lag] with >= 1 lag, got shape {g.shape}")
        if not isinstance(self.static, bool):
            raise TypeError(f"{self.name}: static must be True or False, got {self.static!r}")
        if self.static and g.shape[2] != 1:
            raise ValueError(f"{self.name}: a static kernel has one lag, got {g.shape[2]}")
        if self.static and self.memory is not None:
            raise ValueError(f"{self.name}: a static kernel has no memory beyond its lag")
        if not self.static:
            checks.real(f"{self.name}: sample_rate", self.sample_rate, positive=True)
        if self.memory is not None and not isinstance(self.memory, MemoryModel):
            raise TypeError(f"{self.name}: memory {type(self.memory).__name__} lacks the MemoryModel protocol "
                            "(delay, history, frequency_response, describe)")
        object.__setattr__(self, "lags", g)

    # ---------------------------------------------------------------------------------------
    # construction
    # ---------------------------------------------------------------------------------------
    @classmethod
    def quasistatic(cls, table, element_size: float | None = None, name: str = "kernel") -> "LayerKernel":
        """A static kernel from g_static[dx, dy] [m/N]."""
        g = np.asarray(table, dtype=float)
        if g.ndim != 2:
            raise ValueError(f"{name}: expected g_static[dx, dy], got shape {g.shape}")
        return cls(g[:, :, None], True, element_size=element_size, name=name)

    @classmethod
    def dynamic(cls, lags, sample_rate: float, memory: MemoryModel | None = None, **kwargs) -> "LayerKernel":
        """A dynamic kernel from g[dx, dy, lag] [m/N] sampled at ``sample_rate`` [Hz]."""
        return cls(lags, False, float(sample_rate), memory, **kwargs)

    @classmethod
    def from_greens(cls, greens: xr.Dataset, mode: str, material=None, response=None) -> "LayerKernel":
        """The kernel of a ``mode`` run from a greens dataset (docs/data_contracts.md "Greens dataset").

        Parameters
        ----------
        greens : xarray.Dataset
            A greens file's contents.
        mode : {"dynamic", "quasistatic"}
            ``dynamic``: the time-domain lags ``g`` with the creep tail (when the file has one), or, for a file
            of ``construction = 'radau'``, the stage kernel (:meth:`tyreroad.stage.StageKernel.from_greens`);
            ``quasistatic``: ``g_static``.
        material : tyreroad.material.Material, optional
            The layer's material: the backing force of dynamic runs.
        response : optional
            The exact frequency response (:class:`tyreroad.greens.ElementFRF` of the material;
            kept out of this module so that the contact stages do not run the greens code).
        """
        if mode not in KERNEL_MODES:
            raise ValueError(f"mode: expected one of {KERNEL_MODES}, got {mode!r}")
        name = str(greens.attrs.get("material", getattr(material, "name", "kernel")))
        c = greens.attrs.get("element_size")
        c = None if c is None else float(c)
        fs = float(greens.attrs["sample_rate"])
        if mode == "quasistatic":
            kernel = cls.quasistatic(greens["g_static"].transpose("dx", "dy").values, c, name)
            # the study's sample rate stays with the static kernel: loadings sample time with it
            return cls(kernel.lags, True, fs, element_size=c, response=response, name=name)
        if str(greens.attrs.get("construction")) == "radau":
            # the Radau IIA-3 stage kernel (greens.construction: radau): three unknowns per element and step
            from .stage import StageKernel

            return StageKernel.from_greens(greens, material, response)
        lags = greens["g"].transpose("dx", "dy", "lag").values
        memory = None
        if "tail_compliance" in greens:
            spectrum = RetardationSpectrum(
                float(greens.attrs["glassy_compliance"]),
                np.asarray(greens["retardation_compliance"].values, dtype=float),
                np.asarray(greens["retardation_time"].values, dtype=float),
                float(greens.attrs["creep_fit_error"]),
            )
            r = greens["tail_compliance"].transpose("dx", "dy").values
            memory = TailModel.from_spectrum(r, spectrum, fs, int(greens.sizes["lag"]))
        if int(greens.attrs.get("belt", 0)):
            # a flexible belt behind the tread (tyreroad.belt_stage): its recursive filters beside the tail
            from .belt_kernel import BeltKernel

            belt = BeltKernel.from_dataset(greens).memory(int(greens.sizes["lag"]))
            memory = belt if memory is None else MemorySum([memory, belt])
        backing = None
        if material is not None:
            # the layer's uniform-load transfer at the file's rate, on at least 4096 points
            n_fft = max(int(float(greens.attrs.get("n_fft", 4096))), 4096)
            backing = functools.partial(backing_force, material=material, sample_rate=fs, n_fft=n_fft)
        k_crit = float(greens["critical_stiffness"].values) if "critical_stiffness" in greens else None
        construction = greens.attrs.get("construction")
        window = greens.attrs.get("margin_window")
        return cls(lags, False, fs, memory, c, response, backing, name, k_crit,
                   None if construction is None else str(construction),
                   None if window is None else tuple(int(v) for v in np.atleast_1d(window)))

    # ---------------------------------------------------------------------------------------
    # what the solvers ask
    # ---------------------------------------------------------------------------------------
    @property
    def n_lags(self) -> int:
        """L, the kept lags."""
        return int(self.lags.shape[2])

    def table(self, shape) -> np.ndarray:
        """The kept lags cropped to a patch's offsets, checked finite, shape (2 nx - 1, 2 ny - 1, L)."""
        nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
        return check_offset_kernel(self.lags, nx, ny, f"{self.name} kernel")

    def check_element_size(self, element_size) -> None:
        """Refuse a surface whose element size differs from the kernel's (1e-9 relative)."""
        if element_size is None or self.element_size is None:
            return
        if not math.isclose(float(element_size), self.element_size, rel_tol=1e-9):
            raise ValueError(f"element_size differs: surface {element_size} m, greens {self.element_size} m")

    def check_springs(self, max_stiffness: float, policy: str = "refuse") -> None:
        """Refuse (or, ``policy="warn"``, log) springs stiffer than the kernel's critical stiffness.

        Parameters
        ----------
        max_stiffness : float
            The stiffest tangent any spring of the run can reach [N/m] (its tables' maximum).
        policy : {"refuse", "warn"}
            ``solver.stability``.

        Raises
        ------
        ValueError
            With ``refuse``, naming the stiffness, the margin and what to change.
        """
        if self.static or self.critical_stiffness is None or not max_stiffness > self.critical_stiffness:
            return
        what = (f"{self.name}: the springs of this run reach {max_stiffness:.4g} N/m, past the stability limit of "
                f"the '{self.construction or 'unknown'}' kernel, k_crit = {self.critical_stiffness:.4g} N/m (the greens "
                "file's critical_stiffness: the stability margin over the unit circle); the time march would "
                "alternate at fs/2 and grow")
        if policy == "warn":
            logger.warning("%s; running anyway (solver.stability: warn)", what)
            return
        raise ValueError(f"{what}. Refused before the first step: select a kernel stable for these springs "
                         "(greens.construction: radau is stable for every spring, hard contact included), soften "
                         "the springs, or set solver.stability: warn to run and record it")

    def check_contact_extent(self, extent, policy: str = "refuse", where: str = "") -> None:
        """Refuse (or, ``policy="warn"``, log) a run whose contact left the window its margin holds on.

        Parameters
        ----------
        extent : (int, int)
            The largest extent of the run's contact [elements along x, y]: the span of the elements with a
            positive spring stiffness or force, over all steps.
        policy : {"refuse", "warn"}
            ``solver.stability``.
        where : str
            The step where it was largest, for the message.

        Raises
        ------
        ValueError
            With ``refuse``, naming the extent, the window and what to change.
        """
        if self.static or self.margin_window is None:
            return
        if all(int(e) <= int(w) for e, w in zip(extent, self.margin_window)):
            return
        k_crit = "not stored" if self.critical_stiffness is None else f"{self.critical_stiffness:.4g} N/m"
        what = (f"{self.name}: the contact spans {extent[0]} x {extent[1]} elements{where}, beyond the "
                f"{self.margin_window[0]} x {self.margin_window[1]} window the kernel's stability margin "
                f"(k_crit = {k_crit}) was computed on, so the run's stability is not certified")
        if policy == "warn":
            logger.warning("%s; kept (solver.stability: warn)", what)
            return
        raise ValueError(f"{what}. Refused, no file written: raise rolling.contact_window (elements along x) to "
                         "cover the contact, or set solver.stability: warn to keep such a run and record it")

    def needs_memory(self, n_steps: int | None) -> bool:
        """True for a dynamic run longer than the kept lags (a one-lag dynamic kernel is memoryless)."""
        return not self.static and self.n_lags > 1 and n_steps is not None and n_steps > self.n_lags

    def collaborators(self, shape, settings: SolverSettings, workers: int = 1,
                      n_steps: int | None = None) -> tuple[Substrate, History]:
        """The substrate (G_0, Newton solve, tangent) and the history (kept lags + memory) of a run.

        Parameters
        ----------
        shape : tuple of int
            Patch (nx, ny).
        settings : SolverSettings
            ``resolved_method`` picks the dense or FFT path; ``long_memory``, the FFT solver's
            tolerance, preconditioner tile and forcing.
        workers : int
            FFT workers.
        n_steps : int, optional
            Steps of the run: a dynamic run longer than the kept lags needs the memory.

        Raises
        ------
        ValueError
            If the run needs more memory than the kernel provides (none, or long memory off).
        """
        nx, ny = shape
        g = self.table(shape)
        n_lags = g.shape[2]
        method = settings.resolved_method(nx * ny, n_steps, n_lags)
        needs_memory = self.needs_memory(n_steps)
        if needs_memory and (self.memory is None or not settings.long_memory):
            why = ("solver.long_memory is off" if self.memory is not None
                   else "the kernel has no memory beyond them (a greens file without a tail)")
            raise ValueError(
                f"the run needs {n_steps} steps of memory but the kernel keeps greens.n_lags = {n_lags} lags and "
                f"{why}: switch solver.long_memory on (with a greens file from this version), or raise greens.n_lags "
                f"to >= {n_steps}"
            )
        if method == "fft":
            conv = OffsetConvolution(g, shape, workers=workers)
            logger.info("FFT/Newton-Krylov path: %d x %d elements, %d lags, padded grid %s", nx, ny, n_lags, conv.padded)
            substrate = FFTSubstrate(conv, settings.tolerance, block=settings.preconditioner_block,
                                     eta_max=settings.krylov_forcing)
            history = FFTHistory(conv)
        else:
            substrate = DenseSubstrate(OffsetInfluence(g[:, :, 0], shape))
            history = DenseHistory(g, shape)
        if needs_memory:
            if self.memory.delay != n_lags:
                raise ValueError(f"{self.name}: the memory starts at lag {self.memory.delay}, but the kernel keeps "
                                 f"{n_lags} lags")
            logger.info("long memory: %s", self.memory.describe())
            history = HistorySum([history, self.memory.history(shape, method, workers)])
        return substrate, history

    def march_view(self, loading, springs, recorder):
        """The loading, springs and recorder as the march solves them: as given, one unknown per element
        and step. A kernel with several unknowns per element and step (the Radau IIA stages of
        :class:`tyreroad.stage.StageKernel`) returns views that stack them; the march stays as it is."""
        return loading, springs, recorder

    def frequency_response(self, frequencies, shape) -> np.ndarray:
        """G(dx, dy, f) [m/N] as complex offset tables, shape (n_f, 2 nx - 1, 2 ny - 1).

        The exact response where the kernel has one (a material's element FRF), else the discrete
        transfer function of the kernel itself, sum_l g[l] exp(-i 2 pi f l / fs) over the kept lags
        plus the memory's part; a static kernel's is g_static at every frequency.
        """
        f = np.asarray(frequencies, dtype=float)
        if f.ndim != 1 or np.any(f < 0) or not np.all(np.isfinite(f)):
            raise ValueError("frequencies: expected a 1-D array of finite values >= 0 [Hz]")
        if self.response is not None:
            return np.asarray(self.response.frequency_response(f, tuple(shape)))
        return self.own_frequency_response(f, shape)

    def own_frequency_response(self, frequencies, shape) -> np.ndarray:
        """The discrete transfer function of the kernel the march uses, sum_l g[l] exp(-i 2 pi f l / fs)
        over the kept lags plus the memory's part, as complex offset tables [m/N] (whatever ``response``)."""
        f = np.asarray(frequencies, dtype=float)
        g = self.table(shape)
        if self.static:
            return np.broadcast_to(g[:, :, 0], (f.size,) + g.shape[:2]).astype(complex)
        nx, ny = shape
        z = np.exp(-2j * np.pi * f[:, None] / self.sample_rate * np.arange(g.shape[2])[None, :])
        tables = np.einsum("fl,xyl->fxy", z, g)
        if self.memory is not None:
            cx, cy = (self.lags.shape[0] - 1) // 2, (self.lags.shape[1] - 1) // 2
            tail = self.memory.frequency_response(f, self.sample_rate)
            tables = tables + tail[:, cx - (nx - 1): cx + nx, cy - (ny - 1): cy + ny]
        return tables

    def frequency_influences(self, frequencies, shape, workers: int = 1) -> list:
        """The influence operator G(f) on the patch at each frequency (what K*(f) solves over).

        Translation-invariant kernels give :class:`tyreroad.influence.OffsetInfluence` operators of
        :meth:`frequency_response` (real at f = 0); a kernel that is not translation invariant
        overrides this with operators of its own (``block(active)``, ``apply(v)``, ``g_self``).
        """
        return offset_influences(self.frequency_response(frequencies, shape), frequencies, shape, workers)

    def relaxed(self) -> "LayerKernel":
        """The static kernel of the fully relaxed layer: sum_l g[dx, dy, l] over the kept lags and the
        memory (the sum rule, the transfer function at f = 0).

        For a greens file's layer this is g(omega = 0) with E(omega -> 0); the file's ``g_static``
        uses the quasi-static modulus E_qs, equal to it by default (``quasi_static_modulus``).
        """
        if self.static:
            return self
        table = self.lags.sum(axis=2)
        if self.memory is not None:
            nx, ny = (table.shape[0] + 1) // 2, (table.shape[1] + 1) // 2
            table = table + self.memory.frequency_response(np.zeros(1), self.sample_rate)[0].real[
                : 2 * nx - 1, : 2 * ny - 1]
        return LayerKernel(table[:, :, None], True, self.sample_rate, element_size=self.element_size,
                           response=self.response, name=f"{self.name} (relaxed)")

    def backing_force(self, force) -> np.ndarray:
        """Force at the rigid backing [N] of a run's total surface force [N]."""
        force = np.asarray(force, dtype=float)
        if self.static:
            return force.copy()
        if self.backing is None:
            raise ValueError(f"{self.name}: the backing force of a dynamic run needs the material "
                             "(LayerKernel.from_greens(..., material=...))")
        return self.backing(force)
