r"""Patterned treads (issue 27): tread blocks separated by grooves, the contact patch placed on them.

A pattern is a periodic grid of rectangular tread blocks, ``block_length`` along x (the rolling
direction) by ``block_width`` along y, separated by grooves of ``groove_width`` in both directions and
``groove_depth`` deep. Pattern coordinates put a block's corner at the origin: along x, period
p_x = block_length + groove_width, the block occupies [0, block_length) of each period and the groove
[block_length, p_x) (likewise along y). The contact patch (nx x ny elements of size c) is placed with its
corner at ``origin`` = (o_x, o_y) [m] in pattern coordinates: patch element (i, j) has its centre at
(o_x + (i + 1/2) c, o_y + (j + 1/2) c). Block sizes, groove width and origin are whole multiples of c, so
every element lies either wholly on a block or wholly over a groove.

What a patch element over a groove means: the groove floor is ``groove_depth`` (millimetres) behind the
surface, far beyond any indentation of the study (d_max = 0.25 mm), so the road never touches it: the
element is **never in contact** -- its spring is inactive (zero force and stiffness tables,
:func:`groove_springs`), it carries no force, and it is reported (the ``grooved`` mask of the contact
file, the grooved fraction of the patch in the pattern study).

Influence. Blocks interact only through what a block's cell model holds (``tyreroad.fe_pattern``: one
block on the rigid belt, grooves to the belt or an undertread with symmetry rollers at the cell boundary),
so the patch's influence matrix is **block diagonal**, the same N x N table G_b for every block
(N = n_x n_y elements of one block, numbered row-major over x then y from the block's corner):

    G[e, m] = G_b[l(e), l(m)]  if e and m lie on the same block, else 0,

with l(e) the element's index inside its block. A block cut by the patch edge keeps the rows and columns
of its elements inside the patch (the road outside the patch is not modelled: those elements carry no
force, as for the slick tread). Memory: one N x N table, independent of the number of blocks (a dense
patch matrix would need M^2 for M = nx ny elements; :func:`influence_memory`).

:class:`PatchInfluence` is that operator (apply, dense blocks, the contact-set stiffness),
:class:`PatternSubstrate` the contact solver's substrate on it (the Newton corrections and the quasi-static
tangent decouple block by block), and :class:`PatternKernel` the :class:`tyreroad.kernel.LayerKernel`
subclass that hands the march a dense, non-Toeplitz static G_0 (quasi-static mode only).

Block influence table. The FE cell model (``tyreroad.fe_pattern.block_static_influence``, written
separately) gives (element_centres_xy (N, 2) [m], G (N, N) [m/N]). Until it is merged the stage uses the
stand-in :func:`tyreroad.pattern_stage.standin_block_influence`: the flat layer's static element kernel restricted to the block's
elements, G_b[i, j] = g_static(x_i - x_j, y_i - y_j) -- a block with no edge effect (the layer under a
block is laterally infinite and continuous under the grooves). With the stand-in, a pattern changes the
contact only through the grooves (elements removed from contact) and the cut coupling between blocks.

Dynamic runs on a pattern are not built: :meth:`PatternKernel.collaborators` refuses a dynamic run.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np
import scipy.linalg
import xarray as xr

from . import checks
from .influence import Tangent, contact_set_solve
from .kernel import LayerKernel
from .newton import StepConvergenceError

logger = logging.getLogger(__name__)

__all__ = [
    "SLICK",
    "PATTERN_INFLUENCES",
    "PatternGeometry",
    "PatchLayout",
    "place_pattern",
    "PatchInfluence",
    "PatternSubstrate",
    "StaticHistory",
    "PatternKernel",
    "groove_springs",
    "influence_memory",
    "check_pattern_config",
    "check_pattern_springs",
    "kernel_from_pattern_greens",
    "run_inputs",
    "solve_pattern_run",
    "pattern_contact_dataset",
    "pattern_study",
]

#: The name of the slick (unpatterned) tread in the pattern study's file names and case labels.
SLICK = "slick"
#: Where a block's influence table comes from (config ``pattern.influence``): ``fe``, the FE cell model
#: (:func:`tyreroad.pattern_stage.fe_block_influence`, ``tyreroad.fe_pattern``); ``standin``, the analytic
#: layer kernel restricted to the block (:func:`tyreroad.pattern_stage.standin_block_influence`, no edge effect).
PATTERN_INFLUENCES = ("fe", "standin")

#: Relative tolerance for "a whole multiple of the element size".
_GRID_RTOL = 1e-9


# --------------------------------------------------------------------------------------------
# Geometry and placement
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PatternGeometry:
    """A periodic tread pattern: rectangular blocks separated by grooves (module docstring).

    Minimal geometry of this module; ``tyreroad.fe_pattern`` has the FE model's own dataclass, to be
    unified with this one at merge (same field names and units).

    Parameters
    ----------
    name : str
        Preset name (``pattern.presets``).
    block_length : float
        Block size along x, the rolling direction [m].
    block_width : float
        Block size along y [m].
    groove_width : float
        Groove width, the same along x and y [m] (0: a degenerate pattern of touching blocks).
    groove_depth : float
        Groove depth from the tread surface [m] (not above the tread thickness).
    element_size : float
        Contact element size c [m]; block sizes and groove width are whole multiples of it.
    """

    name: str
    block_length: float
    block_width: float
    groove_width: float
    groove_depth: float
    element_size: float = 1.0e-3

    def __post_init__(self) -> None:
        c = checks.real("element_size", self.element_size, positive=True)
        pre = f"pattern.presets.{self.name}"
        checks.whole_multiple(f"{pre}.block_length", self.block_length, c)
        checks.whole_multiple(f"{pre}.block_width", self.block_width, c)
        checks.whole_multiple(f"{pre}.groove_width", self.groove_width, c, allow_zero=True)
        if not (math.isfinite(float(self.groove_depth)) and float(self.groove_depth) >= 0):
            raise ValueError(f"{pre}.groove_depth = {self.groove_depth!r} m: expected a depth >= 0 [m]")

    @classmethod
    def from_config(cls, name: str, preset: Mapping[str, Any], element_size: float) -> "PatternGeometry":
        """From one ``pattern.presets.<name>`` mapping (block_length, block_width, groove_width, groove_depth [m])."""
        return cls(name, float(preset["block_length"]), float(preset["block_width"]), float(preset["groove_width"]),
                   float(preset["groove_depth"]), float(element_size))

    @classmethod
    def from_attrs(cls, attrs: Mapping[str, Any]) -> "PatternGeometry":
        """From the attributes a pattern file records (pattern, block_length, block_width, groove_width,
        groove_depth, element_size): the greens and modes files of :mod:`tyreroad.pattern_stage`."""
        return cls(str(attrs["pattern"]), float(attrs["block_length"]), float(attrs["block_width"]),
                   float(attrs["groove_width"]), float(attrs["groove_depth"]), float(attrs["element_size"]))

    @property
    def block_elements(self) -> tuple[int, int]:
        """(n_x, n_y), elements of one block."""
        c = self.element_size
        return round(self.block_length / c), round(self.block_width / c)

    @property
    def groove_elements(self) -> int:
        """Groove width in elements."""
        return round(self.groove_width / self.element_size)

    @property
    def period_elements(self) -> tuple[int, int]:
        """(p_x, p_y), the pattern's period in elements."""
        n_x, n_y = self.block_elements
        return n_x + self.groove_elements, n_y + self.groove_elements

    def element_centres(self) -> np.ndarray:
        """Centres (x, y) [m] of one block's elements, row-major over x then y, shape (N, 2)."""
        n_x, n_y = self.block_elements
        ix, iy = np.divmod(np.arange(n_x * n_y), n_y)
        return np.stack([(ix + 0.5) * self.element_size, (iy + 0.5) * self.element_size], axis=1)

    def config(self) -> dict[str, float]:
        """The preset as config (SI units)."""
        return {"block_length": self.block_length, "block_width": self.block_width,
                "groove_width": self.groove_width, "groove_depth": self.groove_depth}


@dataclass(frozen=True, eq=False)
class PatchLayout:
    """A contact patch placed on a pattern (:func:`place_pattern`).

    Attributes
    ----------
    geometry : PatternGeometry
    shape : tuple of int
        Patch (nx, ny) [elements].
    origin : tuple of float
        The patch corner in pattern coordinates [m].
    grooved : numpy.ndarray
        bool (nx, ny): the element lies over a groove (never in contact).
    block_index : numpy.ndarray
        int (nx, ny): which block of the patch the element belongs to (0, 1, ... in C order of first
        appearance), -1 over a groove.
    local_index : numpy.ndarray
        int (nx, ny): the element's index in its block's table (row-major over x then y from the
        block's corner), -1 over a groove.
    blocks : tuple of (numpy.ndarray, numpy.ndarray)
        Per block: the flat patch indices of its elements and their local indices (same order).
    """

    geometry: PatternGeometry
    shape: tuple[int, int]
    origin: tuple[float, float]
    grooved: np.ndarray
    block_index: np.ndarray
    local_index: np.ndarray
    blocks: tuple = field(repr=False)

    @property
    def grooved_fraction(self) -> float:
        """Fraction of the patch's elements over a groove [1]."""
        return float(np.mean(self.grooved))

    def whole_blocks(self) -> int:
        """Blocks lying wholly inside the patch."""
        n_block = math.prod(self.geometry.block_elements)
        return sum(1 for idx, _ in self.blocks if idx.size == n_block)


def place_pattern(geometry: PatternGeometry, shape: Sequence[int], origin: Sequence[float] = (0.0, 0.0)) -> PatchLayout:
    """Place an nx x ny patch with its corner at ``origin`` [m] on the pattern.

    Parameters
    ----------
    geometry : PatternGeometry
        The pattern.
    shape : (int, int)
        Patch elements (nx, ny).
    origin : (float, float)
        Patch corner in pattern coordinates [m], whole multiples of the element size (any sign:
        the pattern is periodic).

    Returns
    -------
    PatchLayout

    Raises
    ------
    ValueError
        For an origin that is not on the element grid (naming ``pattern.patch_origin``).
    """
    nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
    c = geometry.element_size
    o = []
    for k, v in enumerate(origin):
        n = round(float(v) / c)
        if not math.isfinite(float(v)) or abs(n * c - float(v)) > _GRID_RTOL * max(abs(float(v)), c):
            raise ValueError(f"pattern.patch_origin[{k}] = {v!r} m: expected a whole multiple of the element size "
                             f"{c:g} m")
        o.append(n)
    n_bx, n_by = geometry.block_elements
    p_x, p_y = geometry.period_elements
    gx = o[0] + np.arange(nx)  # pattern element index of each patch column
    gy = o[1] + np.arange(ny)
    wx, wy = np.mod(gx, p_x), np.mod(gy, p_y)  # position within the period
    bx, by = np.floor_divide(gx, p_x), np.floor_divide(gy, p_y)  # which period
    grooved = (wx[:, None] >= n_bx) | (wy[None, :] >= n_by)
    local = np.where(grooved, -1, wx[:, None] * n_by + wy[None, :])
    block_key = np.where(grooved, -1, (bx[:, None] - bx.min()) * (by.max() - by.min() + 1) + (by[None, :] - by.min()))
    block_index = -np.ones((nx, ny), dtype=np.int64)
    blocks = []
    flat_key, flat_local = block_key.ravel(), local.ravel()
    for key in np.unique(flat_key[flat_key >= 0]):
        members = np.flatnonzero(flat_key == key)
        block_index.ravel()[members] = len(blocks)
        blocks.append((members, flat_local[members].astype(np.int64)))
    return PatchLayout(geometry, (nx, ny), (o[0] * c, o[1] * c), grooved, block_index, local.astype(np.int64),
                       tuple(blocks))


# --------------------------------------------------------------------------------------------
# The patch's influence and the contact substrate on it
# --------------------------------------------------------------------------------------------
def influence_memory(layout: PatchLayout) -> dict[str, int]:
    """Bytes of the influence tables: the block table (what is stored) against a dense patch matrix.

    Returns
    -------
    dict
        ``block_table`` N^2 x 8 B, ``dense_patch`` M^2 x 8 B (M = nx ny), ``offset_table`` (2 nx - 1)(2 ny - 1) x 8 B
        (the slick tread's translation-invariant table) [B].
    """
    n = math.prod(layout.geometry.block_elements)
    nx, ny = layout.shape
    return {"block_table": 8 * n * n, "dense_patch": 8 * (nx * ny) ** 2, "offset_table": 8 * (2 * nx - 1) * (2 * ny - 1)}


class PatchInfluence:
    """v -> G v for the block-diagonal patch influence of a pattern (module docstring).

    Parameters
    ----------
    layout : PatchLayout
        The patch on the pattern.
    block_table : array_like
        G_b [m/N], shape (N, N), N = the block's elements: real (static) or complex (the block's FRF at one
        frequency, :mod:`tyreroad.pattern_spectrum`).

    Attributes
    ----------
    g_self : float
        The largest diagonal entry of G_b [m/N] (the block's corner and edge elements differ with an FE table).
    """

    def __init__(self, layout: PatchLayout, block_table):
        g = np.asarray(block_table)
        g = g.astype(complex if np.iscomplexobj(g) else float)
        if g.ndim != 2 or not np.all(np.isfinite(g)):
            raise ValueError(f"block_table: expected a finite 2-D array, got shape {g.shape}")
        n = math.prod(layout.geometry.block_elements)
        if g.shape != (n, n):
            raise ValueError(f"block_table: expected shape ({n}, {n}) for a {layout.geometry.block_elements} block of "
                             f"pattern {layout.geometry.name!r}, got {g.shape}")
        self.layout = layout
        self.shape = layout.shape
        self.table = g
        self.complex = bool(np.iscomplexobj(g))
        self.g_self = g[np.argmax(np.abs(np.diag(g)))] if self.complex else float(np.max(np.diag(g)))
        self.even = bool(np.array_equal(g, g.T))
        # per block: patch indices and the block table restricted to them (a cut block keeps its inside part)
        self._blocks = [(idx, loc, np.ascontiguousarray(g[np.ix_(loc, loc)])) for idx, loc in layout.blocks]

    def apply(self, values: np.ndarray) -> np.ndarray:
        """G v; v flat (M,) or a field (nx, ny); the result has v's shape (zero over grooves)."""
        v = np.asarray(values)
        flat = v.reshape(-1)
        out = np.zeros(flat.shape, dtype=np.result_type(flat.dtype, float))
        for idx, _, gb in self._blocks:
            out[idx] = gb @ flat[idx]
        return out.reshape(v.shape)

    __call__ = apply

    def matrix(self) -> np.ndarray:
        """The dense M x M matrix G [m/N] (tests and small patches only: M^2 memory)."""
        m = math.prod(self.shape)
        out = np.zeros((m, m), dtype=self.table.dtype)
        for idx, _, gb in self._blocks:
            out[np.ix_(idx, idx)] = gb
        return out

    def block(self, active) -> np.ndarray:
        """G[active, active] [m/N] (zero between elements of different blocks)."""
        active = np.asarray(active, dtype=np.int64)
        bi = self.layout.block_index.ravel()[active]
        li = self.layout.local_index.ravel()[active]
        out = self.table[np.ix_(np.maximum(li, 0), np.maximum(li, 0))].copy()
        out[(bi[:, None] != bi[None, :]) | (bi[:, None] < 0)] = 0.0
        return out

    def stiffness(self, stiffness):
        """K = 1^T [G_C + diag(1/k)]^-1 1 [N/m]: the sum over blocks of their contact sets' stiffness (complex
        K* for a complex table, the block's FRF at one frequency)."""
        k = np.asarray(stiffness, dtype=float).ravel()
        total = 0.0
        for idx, _, gb in self._blocks:
            ka = k[idx]
            act = np.flatnonzero(ka)
            if act.size:
                total += contact_set_solve(gb[np.ix_(act, act)], np.sqrt(ka[act]))
        return complex(total) if self.complex else float(total)


class PatternSubstrate:
    """The contact solver's substrate (:mod:`tyreroad.newton`) on a block-diagonal G_0.

    The Newton correction (I + G_0 diag(k)) delta = -r decouples by block: on each block's loaded set A,
    (I + G_AA K_A) delta_A = -r_A (for a symmetric G_b in the symmetric positive definite form
    (I + S G_AA S) S delta_A = -S r_A, S = K_A^(1/2), by Cholesky; LU otherwise), then delta_I = -r_I - G_IA K_A delta_A for the block's other
    elements; grooved elements (never loaded) keep delta = -r. Cost per correction: the sum of the blocks'
    (N_A)^3 instead of (sum N_A)^3.

    Parameters
    ----------
    influence : PatchInfluence
        G_0.
    """

    def __init__(self, influence: PatchInfluence):
        if not isinstance(influence, PatchInfluence):
            raise TypeError(f"influence: expected PatchInfluence, got {type(influence).__name__}")
        self.influence = influence

    def instant(self, force: np.ndarray) -> np.ndarray:
        """G_0 F [m]."""
        return self.influence.apply(force)

    def begin_step(self) -> None:
        """Nothing to reset: every correction is exact."""

    def correction(self, stiffness: np.ndarray, residual: np.ndarray, polish: bool) -> tuple[np.ndarray, int]:
        """Exact solution of (I + G_0 diag(k)) delta = -r, block by block; no Krylov products."""
        delta = -np.asarray(residual, dtype=float).copy()
        for idx, _, gb in self.influence._blocks:
            kb = stiffness[idx]
            act = np.flatnonzero(kb)
            if act.size == 0:
                continue
            ka = kb[act]
            s = np.sqrt(ka) if np.all(ka > 0) else None
            try:
                if s is not None and self.influence.even:
                    # symmetric form: (I + S G S) (S delta) = S rhs, S = diag(sqrt(k)) -- Cholesky, half an LU
                    a = gb[np.ix_(act, act)] * s[:, None]
                    a *= s[None, :]
                    a[np.diag_indices_from(a)] += 1.0
                    da = scipy.linalg.solve(a, s * delta[idx[act]], assume_a="pos", check_finite=False) / s
                else:
                    a = gb[np.ix_(act, act)] * ka[None, :]
                    a[np.diag_indices_from(a)] += 1.0
                    da = scipy.linalg.solve(a, delta[idx[act]], check_finite=False)
            except scipy.linalg.LinAlgError:
                raise StepConvergenceError("Newton Jacobian I + G0 diag(k) is singular on a tread block", float("nan"),
                                           0) from None
            delta[idx] -= gb[:, act] @ (ka * da)
            delta[idx[act]] = da
        return delta, 0

    def tangent(self, stiffness: np.ndarray) -> Tangent:
        """dF/dd of a solved quasi-static state: the sum of the blocks' contact-set stiffness (no predictor)."""
        k = np.asarray(stiffness, dtype=float).ravel()
        return Tangent(self.influence.stiffness(k), k.copy())


class StaticHistory:
    """The history of a static kernel: no displacement from earlier steps (:class:`tyreroad.history.History`)."""

    def __init__(self, n_elements: int):
        self._zeros = np.zeros(checks.integer("n_elements", n_elements))

    def displacement(self, n: int) -> np.ndarray:
        """h[n] = 0 [m]."""
        return self._zeros

    def record(self, n: int, force: np.ndarray) -> None:
        """Nothing to keep."""


@dataclass(frozen=True, eq=False)
class PatternKernel(LayerKernel):
    """A patterned tread's static layer response: a :class:`tyreroad.kernel.LayerKernel` whose G_0 is the
    block-diagonal :class:`PatchInfluence` (not an offset table). Quasi-static mode only.

    Build it with :meth:`from_block`; ``lags`` holds only the block's self-compliance (the kernel has no
    offset table), and the methods that would read one are overridden.
    """

    influence: PatchInfluence | None = field(default=None, repr=False)

    @classmethod
    def from_block(cls, layout: PatchLayout, block_table, name: str = "pattern") -> "PatternKernel":
        """The kernel of a patch placed on a pattern (``layout``) with block table G_b (N, N) [m/N]."""
        influence = PatchInfluence(layout, block_table)
        return cls(np.full((1, 1, 1), influence.g_self), True, element_size=layout.geometry.element_size,
                   name=name, influence=influence)

    @property
    def layout(self) -> PatchLayout:
        """The patch on the pattern."""
        return self.influence.layout

    def table(self, shape) -> np.ndarray:
        raise TypeError(f"{self.name}: a patterned tread's influence is not translation invariant; it has no "
                        "offset table (use its PatchInfluence)")

    def collaborators(self, shape, settings, workers: int = 1, n_steps: int | None = None):
        """The :class:`PatternSubstrate` and a zero history (every step a static state).

        Raises
        ------
        ValueError
            For a patch shape other than the layout's.
        """
        if tuple(shape) != tuple(self.influence.shape):
            raise ValueError(f"{self.name}: the run's patch {tuple(shape)} differs from the patch placed on the "
                             f"pattern {tuple(self.influence.shape)}")
        return PatternSubstrate(self.influence), StaticHistory(math.prod(shape))

    def frequency_response(self, frequencies, shape) -> np.ndarray:
        raise NotImplementedError(f"{self.name}: a patterned tread has no offset-table frequency response; "
                                  "use frequency_influences")

    own_frequency_response = frequency_response

    def frequency_influences(self, frequencies, shape, workers: int = 1) -> list:
        """The static G_0 at every frequency (a static kernel)."""
        return [self.influence for _ in np.atleast_1d(frequencies)]


def groove_springs(springs, grooved):
    """The spring tables with the grooved elements' springs inactive (zero force and stiffness).

    Parameters
    ----------
    springs : tyreroad.springs.SpringTable
        One spring per patch element.
    grooved : numpy.ndarray
        bool (nx, ny) or (M,).

    Returns
    -------
    tyreroad.springs.SpringTable
        A checked copy.
    """
    from .springs import SpringTable

    mask = np.asarray(grooved, dtype=bool).ravel()
    k = np.array(springs.stiffness, dtype=springs.stiffness.dtype).reshape(mask.size, -1)
    f = np.array(springs.force, dtype=float).reshape(mask.size, -1)
    k[mask] = 0.0
    f[mask] = 0.0
    return SpringTable.checked(k, f, springs.zeta_step, mask.size)


def kernel_from_pattern_greens(greens: xr.Dataset, shape, origin=(0.0, 0.0)) -> LayerKernel:
    """The static kernel of a pattern greens file on a patch of ``shape`` placed at ``origin`` [m]: a
    :class:`PatternKernel` for a pattern, the offset-table :class:`LayerKernel` for the slick tread."""
    name = f"{greens.attrs.get('material', 'kernel')}/{greens.attrs.get('pattern')}"
    c = float(greens.attrs["element_size"])
    if str(greens.attrs.get("kind")) == "slick":
        return LayerKernel.quasistatic(greens["g_static"].transpose("dx", "dy").values, c, name)
    layout = place_pattern(PatternGeometry.from_attrs(greens.attrs), shape, origin)
    return PatternKernel.from_block(layout, greens["influence"].transpose("element", "source").values, name)


# --------------------------------------------------------------------------------------------
# Runs and the study
# --------------------------------------------------------------------------------------------
def run_inputs(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, origin=(0.0, 0.0)):
    """What a run on a pattern (or the slick) greens file reads: (z1 [m] (nx, ny), the static kernel on the patch
    placed at ``origin`` [m], the checked spring tables, one per patch element; grooved springs still active)."""
    from .springs import SpringTable

    z1 = surface["z1"].transpose("ex", "ey").values
    kernel = kernel_from_pattern_greens(greens, z1.shape, origin)
    kernel.check_element_size(surface.attrs.get("element_size"))
    table = SpringTable.from_dataset(springs)
    return z1, kernel, SpringTable.checked(table.stiffness, table.force, table.zeta_step, z1.size)


def solve_pattern_run(surface: xr.Dataset, springs: xr.Dataset, greens: xr.Dataset, settings,
                      origin=(0.0, 0.0), threads: int = 1, grooves: xr.Dataset | None = None):
    """A quasi-static indentation run on a patterned (or, for a slick greens file, the slick) tread.

    The uniform indentation grid of ``settings.quasistatic_step`` up to ``settings.d_max`` as the study's
    quasi-static runs (:func:`tyreroad.contact.solve_run`); the grooved elements' springs are inactive.

    ``grooves`` (a pattern greens dataset) with the slick greens file: the **grooves-only** run, the slick layer
    (full coupling between all elements) with the springs over that pattern's grooves inactive. Beside the
    pattern run it splits the change against slick into the elements the grooves remove and what the block
    influence changes (the cut coupling between blocks; with the FE tables, the blocks' edges too).

    Returns
    -------
    result : tyreroad.contact.ContactResult
    grooved : numpy.ndarray
        bool (nx, ny) (all False for the slick tread).
    elapsed : float
        Wall time of the run (the march) [s].
    """
    from .contact import run_loading_path
    from .loading import IndentationPath

    z1, kernel, table = run_inputs(surface, springs, greens, origin)
    if grooves is not None:
        if isinstance(kernel, PatternKernel):
            raise ValueError("grooves: a grooves-only run is on the slick layer; expected the slick greens file")
        grooved = kernel_from_pattern_greens(grooves, z1.shape, origin).layout.grooved
    else:
        grooved = kernel.layout.grooved if isinstance(kernel, PatternKernel) else np.zeros(z1.shape, dtype=bool)
    if grooved.any():
        table = groove_springs(table, grooved)
    from .loading import uniform_indentation_grid

    d = uniform_indentation_grid(settings.d_max, settings.quasistatic_step)
    start = time.perf_counter()
    result = run_loading_path(IndentationPath(z1, d), table, kernel, settings, threads)
    elapsed = time.perf_counter() - start
    logger.info("%s: %d quasi-static states in %.3g s, F(d_max) = %.5g N", kernel.name, d.size, elapsed,
                result.force[-1])
    return result, grooved, elapsed


def pattern_contact_dataset(result, grooved, elapsed: float, surface_name: str, material_name: str,
                            pattern_name: str, solver_path: str, variant: str = "", mode: str = "quasistatic",
                            acceleration: float = 0.0) -> xr.Dataset:
    """The contact file of a pattern run: the study's contact dataset plus the ``grooved`` mask, the pattern's
    name, the ``variant`` ('' or 'grooves-only', :func:`solve_pattern_run`; 'modal', the runs of
    :mod:`tyreroad.pattern_dynamic`) and the run's wall time."""
    from .contact import contact_dataset

    ds = contact_dataset(result, mode, acceleration, surface_name, material_name)
    ds["grooved"] = (("ex", "ey"), np.asarray(grooved, dtype=np.int8),
                     {"units": "1", "long_name": "element over a groove (1: never in contact, spring inactive)"})
    ds.attrs.update({"pattern": pattern_name, "variant": variant, "run_time_s": float(elapsed),
                     "solver_path": solver_path})
    return ds


def run_on_grid(ds: xr.Dataset, src: str, study_settings) -> tuple[dict, float]:
    """A pattern run's K(d) on the study's common grid and its K_sat, with the study's definitions
    (:func:`tyreroad.study.native_samples`, :func:`tyreroad.study.case_on_grid`,
    :func:`tyreroad.study.saturated_stiffness`; the settings' surface is the run's)."""
    from .study import case_on_grid, native_samples, saturated_stiffness

    settings = dataclasses.replace(study_settings, surface=str(ds.attrs["surface"]))
    grid = case_on_grid(native_samples(ds, src, settings), settings)
    return grid, saturated_stiffness(settings.grid, grid["stiffness"], settings.saturation_range)


def _variable(dims, values, units, long_name) -> xr.Variable:
    return xr.Variable(dims, values, {"units": units, "long_name": long_name})


def grid_variables(rows: Sequence[Mapping[str, Any]]) -> dict[str, xr.Variable]:
    """``force``, ``stiffness``, ``contact_fraction`` (case, indentation) and ``saturated_stiffness`` (case) of study
    rows (each with the ``grid`` and ``k_sat`` of :func:`run_on_grid`)."""
    return {
        "force": _variable(("case", "indentation"), np.array([r["grid"]["force"] for r in rows]), "N",
                           "total contact force"),
        "stiffness": _variable(("case", "indentation"), np.array([r["grid"]["stiffness"] for r in rows]), "N/m",
                               "contact stiffness K = dF/dd"),
        "contact_fraction": _variable(("case", "indentation"), np.array([r["grid"]["contact_fraction"] for r in rows]),
                                      "1", "fraction of the patch's elements in contact"),
        "saturated_stiffness": _variable(("case",), np.array([r["k_sat"] for r in rows]), "N/m",
                                         "K_sat, median of K over study.saturation_range"),
    }


def pattern_study(contacts: Sequence[xr.Dataset], greens: Sequence[xr.Dataset], study_settings) -> xr.Dataset:
    """K(d) and K_sat of every pattern run beside the slick tread's, with the study's definitions.

    K(d) and K_sat are those of :mod:`tyreroad.study` (:func:`tyreroad.study.native_samples`,
    :func:`tyreroad.study.case_on_grid`, :func:`tyreroad.study.saturated_stiffness`: the tangent dF/dd of each
    static state on the common grid, K_sat the median over ``study.saturation_range``).

    Parameters
    ----------
    contacts : sequence of xarray.Dataset
        Pattern contact files (:func:`pattern_contact_dataset`), the slick one of each material among them.
    greens : sequence of xarray.Dataset
        Pattern greens files (:func:`pattern_greens_dataset`, :func:`slick_greens_dataset`) of the same cases.
    study_settings : tyreroad.study.StudySettings
        The common grid and the saturation range (its ``surface`` is replaced by the runs').

    Returns
    -------
    xarray.Dataset
        Dim ``case`` (``<material>/<pattern>``, ``<material>/<pattern>/grooves-only``) and ``indentation``: ``force``, ``stiffness``,
        ``contact_fraction``, ``saturated_stiffness``, ``slick_change`` (K_sat / K_sat(slick) - 1),
        ``grooved_fraction``, ``influence_bytes``, ``dense_patch_bytes``, ``greens_time``, ``contact_time``.
    """
    greens_of = {(str(g.attrs["material"]), str(g.attrs["pattern"])): g for g in greens}
    rows = []
    for i, ds in enumerate(contacts):
        material, pattern = str(ds.attrs["material"]), str(ds.attrs["pattern"])
        variant = str(ds.attrs.get("variant", ""))
        src = str(ds.encoding.get("source", f"pattern contact #{i}"))
        grid, k_sat = run_on_grid(ds, src, study_settings)
        table = SLICK if variant else pattern  # a grooves-only run is on the slick layer's table
        if (material, table) not in greens_of:
            raise ValueError(f"{src}: no pattern greens file for material {material!r}, pattern {table!r}")
        g = greens_of[(material, table)]
        n_el = int(ds.sizes["ex"] * ds.sizes["ey"])
        rows.append({"material": material, "pattern": pattern, "variant": variant, "grid": grid, "k_sat": k_sat,
                     "grooved": float(ds["grooved"].mean()) if "grooved" in ds else 0.0,
                     "bytes": int(g.attrs["influence_bytes"]), "dense": 8 * n_el * n_el,
                     "greens_time": float(g.attrs["compute_time_s"]), "contact_time": float(ds.attrs["run_time_s"]),
                     "path": str(ds.attrs.get("solver_path", ""))})
    slick = {r["material"]: r["k_sat"] for r in rows if r["pattern"] == SLICK and not r["variant"]}
    missing = sorted({r["material"] for r in rows} - set(slick))
    if missing:
        raise ValueError(f"pattern study: no slick run for material(s) {missing}")

    var = _variable
    grid_d = study_settings.grid
    data = {
        **grid_variables(rows),
        "slick_change": var(("case",), np.array([r["k_sat"] / slick[r["material"]] - 1.0 for r in rows]), "1",
                            "K_sat / K_sat of the slick tread - 1"),
        "grooved_fraction": var(("case",), np.array([r["grooved"] for r in rows]), "1",
                                "fraction of the patch's elements over a groove"),
        "influence_bytes": var(("case",), np.array([r["bytes"] for r in rows], dtype=np.int64), "B",
                               "memory of the stored influence table (block N x N, or the slick offset table)"),
        "dense_patch_bytes": var(("case",), np.array([r["dense"] for r in rows], dtype=np.int64), "B",
                                 "memory a dense patch influence matrix M x M would need"),
        "greens_time": var(("case",), np.array([r["greens_time"] for r in rows]), "s",
                           "compute time of the influence table (pattern greens stage)"),
        "contact_time": var(("case",), np.array([r["contact_time"] for r in rows]), "s",
                            "wall time of the quasi-static contact march"),
    }
    coords = {
        "case": ("case", ["/".join(filter(None, (r["material"], r["pattern"], r["variant"]))) for r in rows],
                 {"units": "1", "long_name": "case label material/pattern[/variant]"}),
        "variant": ("case", [r["variant"] for r in rows], {"units": "1", "long_name": "run variant ('' or "
                    "grooves-only: the slick layer with the pattern's grooved springs inactive)"}),
        "material": ("case", [r["material"] for r in rows], {"units": "1", "long_name": "tread material preset"}),
        "pattern": ("case", [r["pattern"] for r in rows], {"units": "1", "long_name": "pattern preset (slick: none)"}),
        "solver_path": ("case", [r["path"] for r in rows], {"units": "1", "long_name": "substrate of the contact run"}),
        "indentation": ("indentation", grid_d, {"units": "m", "long_name": "indentation d"}),
    }
    notes = sorted({str(g.attrs["influence_note"]) for g in greens if "influence_note" in g.attrs})
    return xr.Dataset(data, coords=coords, attrs={
        "influence_note": "; ".join(notes) or "slick tread only",
        "saturation_range_m": np.asarray(study_settings.saturation_range, dtype=float),
        "stiffness_method": "as results/study.nc: tangent dF/dd of each static state, cubic Hermite onto the grid, "
                            "K_sat = median over the saturation range"})


#: Stiffest linear spring [N/m] of dynamic pattern runs that converges at a first impact on whole 20 mm blocks
#: (1e6 measured to converge, 1e8 not: docs/pattern.md, "Limitation").
PATTERN_DYNAMIC_MAX_LINEAR = 1.0e6


def check_pattern_springs(config: Mapping[str, Any]) -> None:
    """Refuse viscoelastic (QLV) springs for pattern runs (they run elastic spring tables), and for dynamic pattern
    runs springs stiffer than :data:`PATTERN_DYNAMIC_MAX_LINEAR` (hard contact).

    Called at planning time when the pattern study is on (``pattern.study``) and when a pattern job is planned
    (the named target ``pattern``), so that overlays with QLV springs still plan the rest of the study.
    """
    rheology = (config.get("springs", {}) or {}).get("rheology", "elastic")
    if rheology != "elastic":
        raise ValueError(f"springs.rheology = {rheology!r}: expected 'elastic' for the pattern study (its runs use "
                         "the elastic spring tables on a static block kernel; QLV springs on a pattern are not built)")
    section = config.get("pattern") or {}
    modes = list(section.get("modes", ["quasistatic"]))
    if "dynamic" in modes:
        springs = config.get("springs", {}) or {}
        model = springs.get("model", "single_punch")
        k_lin = float(springs.get("linear_stiffness", 0.0)) if model == "linear" else 0.0
        if model == "hard" or k_lin > PATTERN_DYNAMIC_MAX_LINEAR:
            what = ("springs.model = 'hard'" if model == "hard"
                    else f"springs.linear_stiffness = {k_lin:g} N/m with springs.model = 'linear'")
            raise ValueError(f"{what} with pattern.modes = {modes!r}: expected springs up to "
                             f"{PATTERN_DYNAMIC_MAX_LINEAR:g} N/m for dynamic pattern runs (on whole blocks the stage "
                             "forces of a first impact change sign within a step and the Newton driver cycles between "
                             "the stages' contact sets; docs/pattern.md), or pattern.modes: [quasistatic]")


def check_pattern_config(config: Mapping[str, Any]) -> None:
    """The planning-time checks of the ``pattern`` section (called by :func:`tyreroad.config.check_config`).

    Every preset is a valid geometry on the pattern surface's element grid (block sizes and groove width whole
    multiples of the element size), no groove is deeper than the tread of a pattern material, the patch origin
    is on the element grid, and the patch holds at least one whole block of every preset.

    Raises
    ------
    ValueError
        Naming the key, the value and what was expected.
    """
    section = config.get("pattern") or {}
    presets = section.get("presets") or {}
    modes = list(section.get("modes", ["quasistatic"]))
    if "quasistatic" not in modes or not set(modes) <= {"quasistatic", "dynamic"} or len(set(modes)) != len(modes):
        raise ValueError(f"pattern.modes = {modes!r}: expected ['quasistatic'] or ['quasistatic', 'dynamic'] (the "
                         "quasi-static runs are the pattern study's base; dynamic adds runs on the block's modal form)")
    if presets and section.get("study", False):
        check_pattern_springs(config)
    if not presets:
        if section.get("study", False):
            raise ValueError("pattern.study = True: expected at least one preset in pattern.presets")
        return
    surface = section.get("surface")
    if surface not in config["surfaces"]:
        raise ValueError(f"pattern.surface = {surface!r}: expected a preset in surfaces (have: "
                         f"{', '.join(sorted(config['surfaces']))})")
    spec = config["surfaces"][surface]
    c = float(spec.get("element_size", 1e-3))
    shape = tuple(int(n) for n in spec.get("patch_elements", (20, 20)))
    origin = tuple(section.get("patch_origin", (0.0, 0.0)))
    if SLICK in presets:
        raise ValueError(f"pattern.presets.{SLICK}: the name {SLICK!r} is the unpatterned reference; expected "
                         "another preset name")
    from .material import material_from_config

    for i, material in enumerate(section.get("materials", [])):
        if material not in config["materials"]:
            raise ValueError(f"pattern.materials[{i}] = {material!r}: expected a preset in materials")
    if "dynamic" in modes and presets:
        if section.get("influence", "fe") != "fe":
            raise ValueError(f"pattern.modes = {modes!r} with pattern.influence = {section.get('influence')!r}: "
                             "expected influence 'fe' (the dynamic kernel is the FE block's modal form)")
        from .material import material_from_config as _mat

        variants = list((section.get("dynamic") or {}).get("variants", []))
        for i, name in enumerate(variants):
            if name not in config["materials"]:
                raise ValueError(f"pattern.dynamic.variants[{i}] = {name!r}: expected a preset in materials")
        names = list(section.get("materials", [])) + [v for v in variants if v not in section.get("materials", [])]
        mats = [_mat(n, config["materials"]) for n in names]
        for n, m in zip(names[1:], mats[1:]):
            if not (math.isclose(m.thickness, mats[0].thickness, rel_tol=1e-12)
                    and math.isclose(m.poisson, mats[0].poisson, rel_tol=1e-12)):
                raise ValueError(f"pattern materials and dynamic variants: {n!r} (thickness {m.thickness:g} m, poisson "
                                 f"{m.poisson:g}) "
                                 f"differs from {names[0]!r} (thickness {mats[0].thickness:g} m, poisson "
                                 f"{mats[0].poisson:g}); expected one thickness and Poisson's ratio for dynamic "
                                 "pattern runs (one modal form per pattern serves them all)")
    for name, preset in presets.items():
        geometry = PatternGeometry.from_config(name, preset, c)
        if geometry.groove_elements < 1:
            raise ValueError(f"pattern.presets.{name}.groove_width = {geometry.groove_width!r} m: expected at least "
                             f"one element ({c:g} m)")
        for material in section.get("materials", []):
            h = material_from_config(material, config["materials"]).thickness
            if not geometry.groove_depth <= h:
                raise ValueError(f"pattern.presets.{name}.groove_depth = {geometry.groove_depth!r} m: expected a depth "
                                 f"not above the tread thickness of material {material!r} ({h:g} m)")
        layout = place_pattern(geometry, shape, origin)
        if layout.whole_blocks() < 1:
            n_x, n_y = geometry.block_elements
            raise ValueError(
                f"pattern.patch_origin = {list(origin)!r} m: the patch of surfaces.{surface}.patch_elements = "
                f"{list(shape)} holds no whole {n_x} x {n_y}-element block of pattern {name!r}; expected a patch "
                f"(and origin) that holds at least one whole block")
    spectrum = section.get("stiffness_spectrum") or {}
    for i, name in enumerate(spectrum.get("patterns", [])):
        if name not in presets:
            raise ValueError(f"pattern.stiffness_spectrum.patterns[{i}] = {name!r}: expected a preset in pattern.presets "
                             f"({', '.join(sorted(presets))})")
    if spectrum.get("patterns") and section.get("influence", "fe") != "fe":
        raise ValueError(f"pattern.stiffness_spectrum.patterns = {spectrum['patterns']!r} with pattern.influence = "
                         f"{section.get('influence')!r}: expected influence 'fe' (K*(f) needs the FE block's FRF)")
    preloads = [float(d) for d in spectrum.get("preloads", [1.0e-4])]
    if any(b <= a for a, b in zip(preloads, preloads[1:])):
        raise ValueError(f"pattern.stiffness_spectrum.preloads = {preloads!r}: expected increasing preloads [m]")
    d_max = float(config["solver"]["d_max"])
    if preloads and preloads[-1] > d_max:
        raise ValueError(f"pattern.stiffness_spectrum.preloads = {preloads!r} m: expected preloads up to solver.d_max "
                         f"= {d_max:g} m (the springs' tables end there)")
    f_min, f_max = float(spectrum.get("f_min", 10.0)), float(spectrum.get("f_max", 5000.0))
    if not f_min < f_max:
        raise ValueError(f"pattern.stiffness_spectrum.f_max = {f_max:g} Hz: expected above f_min = {f_min:g} Hz")
