"""FE Green's functions of a patterned tread: one tread block on the rigid belt (issue 27, must-show 2).

The pattern cell is one rectangular tread block (length along x, width along y) surrounded by half-grooves.
The block is bonded to the rigid belt (u = 0 at z = h; z into the tread, surface z = 0). With full-depth grooves
(groove depth = h) it stands alone: side faces traction-free. With shallower grooves it stands on an undertread
of thickness h - groove depth that continues under the half-grooves to the cell boundary; block side faces and
groove bottoms are traction-free.

Cell boundary of the undertread (``BlockMesh.undertread_edge``): ``"periodic"`` (default) is the periodic array
of identical blocks, each loaded identically (period block + groove along both axes). Each of the four symmetry
classes below is then also (anti)symmetric about the cell boundary, so the boundary gets the same mirror
condition as the block's own mirror plane in that class (rollers for the even class). ``"free"`` leaves the
undertread's outer edge traction-free (one block on a finite undertread patch). How much the choice matters is
measured in benchmarks/fe_pattern_block.py (see the numbers below).

Influence matrix and conventions
--------------------------------
Surface elements of size c (1 mm) tile the block's top, n_x = block_length / c by n_y = block_width / c;
element (i, j) has its centre at ((i + 1/2) c, (j + 1/2) c) from the block's corner, and the matrix index is
i n_y + j (row-major over x then y, as numpy's ``ravel`` of an [x, y] array). G[p, s] [m/N] is the normal
displacement (+z, into the tread) at the centre of element p for a unit normal force spread uniformly over
element s (greens' convention: force spread over the loaded element, displacement at the field element's centre).
With that convention G is only approximately symmetric on a block (Betti's theorem makes the *element-mean*
displacement reciprocal, not the centre value); ``field="mean"`` returns the element-mean displacement, whose
matrix is symmetric to round-off. Grooves are not surface elements: they are never in contact.

Symmetry: the block and its cell have two mirror planes (x and y through the block centre). A load on element s
is split into its four parts even/odd in x and y; each part is solved on the quarter model with the mirror
plane's condition (even in x: u_x = 0 on x = 0; odd in x: u_y = u_z = 0), one factorisation per class and one
right-hand side per quarter element, and G is recombined from the four quarter responses. Each class matrix is
about a quarter of the full model's, and 4 factorisations of quarter size cost less than one of the full cell
(not run directly at 2 per element: the full 20 mm cell has the size of one 40 mm quarter class, 177 k DOFs,
about 140 s to factor and 7.5 GB; the four 45 k-DOF classes of the 20 mm block take 43 s and 1.4 GB together).
The full model without symmetry (``symmetry=False``) is kept as an independent check of the recombination
(tests: equal to 1e-12 on small blocks, odd and even element counts, with and without undertread).

Mesh (:class:`BlockMesh`): tensor-product hexahedra, ``per_element`` elements laterally per 1 mm surface element
over the whole block top (every top element is loaded, so the top cannot be graded), vertically ``c /
per_element`` at the surface growing by ``growth`` to ``coarse``, a node plane at the groove bottom. Element
and integration from :mod:`tyreroad.fe_layer` (assembly :func:`tyreroad.fe_layer.elasticity_matrices`,
ordering :func:`tyreroad.fe_layer.nested_dissection`, SuperLU as there).

The numbers (accuracy, convergence, edge softening, cost) are in :data:`MEASURED` below and printed by
benchmarks/fe_pattern_block.py.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from tyreroad import checks
from tyreroad.fe_layer import _INTORDER, _scalar_element, axis_nodes, elasticity_matrices, nested_dissection

__all__ = ["TreadPattern", "BlockMesh", "BlockCell", "BlockModes", "block_static_influence", "block_frequency_response",
           "bonded_plate_modulus", "gent_lindley_modulus", "tet_reference_influence", "flat_correction",
           "element_centres"]

log = logging.getLogger(__name__)

MEASURED = """
Measured (tread preset: E_qs 25 MPa, nu 0.49, rho 1100, h 10 mm; benchmarks/fe_pattern_block.py; one core of a
shared 2-core machine, so times are upper bounds).

Mesh choice, against the analytic flat layer (greens.static_element_kernel) at the centre of a 60 mm
free-standing block (2 h from its sides: its centre is the flat layer), centre element loaded, mesh uniform over
4 mm around it and graded beyond; g_FE / g - 1 [%] at offsets (0,0) (1,0) (1,1) (2,0) (3,0):

    per_element  element  depth_fine  DOFs     (0,0)   (1,0)   (1,1)   (2,0)   (3,0)
    1            Hex S2   0           22 k    -26.9   +19.8    +1.3    -8.9    +1.5
    1            Hex S2   2 mm        22 k    -24.1   +22.1    +1.4   -11.1    -3.3
    1            Hex 2    0           43 k    -16.5    -0.1   +14.9    -4.7    +0.9
    2            Hex S2   0           43 k     -2.6    +0.9    +2.1    +0.5    +0.3
    2            Hex S2 reduced vol.  43 k     -5.3    +6.0    +0.4    -0.9    -0.0
    2            Hex S2   2 mm        55 k     -0.34   +1.00   -0.48   -0.02   +0.38   <- default
    2            Hex 2    2 mm       108 k     -0.13   +0.97   -1.03   +0.39   +0.43

One quadratic hexahedron per 1 mm element is 16-27 % off (the load's edge falls on the element's boundary and
the point value at its centre is poorly resolved); two per element with the uniform 0.5 mm layers down to 2 mm
(then growing by 1.5 to 2 mm) is within 1 %. Selective reduced integration (fe_layer's default) needs at least 2 x
2 hexahedra per loaded quarter element and is worse here. The default :class:`BlockMesh` is the marked row
(Hex S2, full integration, ``per_element=2``, ``depth_fine=2e-3``, growth 1.5 to 2 mm).

Difference correction (``correction="difference"``, G_an(offset) + G_FE,block - G_FE,flat(offset) on the same mesh)
does not rescue the one-per-element mesh: on the 20 mm block it gets the centre right (3.271e-5 against 3.268e-5
m/N with 3 per element) but leaves the edge and corner 4.0 % and 5.4 % off (5.717e-5 / 9.236e-5 against 5.496e-5
/ 8.762e-5): the discretisation error at the edge is not the flat one. Not used by default.

Edge softening (must-show 2), static g_ii [m/N], full-depth grooves (free-standing blocks), 2 per element:

    block        DOFs    centre      edge-centre  corner      edge/centre  corner/centre
    20 x 20 mm   45 k    3.260e-5    5.465e-5     8.737e-5    1.676        2.680
    40 x 40 mm  177 k    3.235e-5    5.423e-5     8.728e-5    1.676        2.698
    20 x 20 mm,   51 k    3.238e-5    5.336e-5     8.405e-5    1.648        2.596
      grooves 6 mm deep (4 mm undertread), periodic cell
    (the flat layer's analytic g(0,0) = 3.243e-5 m/N: the 20 mm block's centre is 0.5 % (0.8 % on the finest
    mesh) softer than the flat layer, the 40 mm block's within the mesh error of it)

Undertread's cell boundary (20 mm block, 5 mm grooves 6 mm deep): a traction-free outer edge instead of the
periodic array's mirror conditions raises g_ii by +0.37 % (centre), +0.40 % (edge), +0.40 % (corner) and moves
the ratios by 0.03 %: with 2.5 mm of undertread beyond the block side and 4 mm undertread thickness the neighbour
blocks hardly matter statically. The periodic array (identical blocks, identically loaded) is the default.

Mesh convergence, 20 x 20 mm block, full-depth grooves (base mesh and two refinements of the top, the depth
layers refined with it):

    per_element  DOFs/class  centre     edge-centre  corner     edge/centre  corner/centre  time    peak RSS
    1              7.9 k     2.489e-5   4.936e-5     8.454e-5   1.983        3.396            4 s   0.28 GB
    2             45 k       3.260e-5   5.465e-5     8.737e-5   1.676        2.680           60 s   1.4 GB
    3            134 k       3.268e-5   5.496e-5     8.762e-5   1.682        2.681          395 s   4.7 GB

2 -> 3 per element: +0.25 / +0.58 / +0.28 % on g_ii, +0.35 / +0.04 % on the ratios (|G - G^T| 0.45 -> 0.33 %).
On a 4 x 4 mm block 2 -> 3 changes g_ii by +0.14 / +0.29 / +0.16 % and the ratios by +0.16 / +0.03 %. The
default mesh is about 0.5 % too stiff at the edge-centre element, 0.3 % elsewhere.

Independent model (:func:`tet_reference_influence`: skfem's own vector ``linear_elasticity`` form on quadratic
tetrahedra, whole block without symmetry, another mesh): 4 x 4 x 10 mm block, g_ii centre / edge / corner [1e-5 m/N]

    Hex S2, 2 per element    5.684   9.795   14.136
    Hex S2, 3 per element    5.692   9.823   14.159
    TetP2 0.5 mm             5.621   9.676   13.998   (-1.1 / -1.2 / -1.0 % against Hex S2 2)
    TetP2 1/3 mm             5.409   9.476   13.785   (not nested with 0.5 mm; TetP2 at nu 0.49 converges erratically)
    TetP2 0.25 mm            5.687   9.748   14.026   (+0.05 / -0.5 / -0.8 % against Hex S2 2)

so the two models agree within 1.2 % (0.8 % on the finest pair); the edge ratios 1.723 / 2.487 (Hex S2 3) against
1.714 / 2.466 (TetP2 0.25 mm). On an 8 x 8 x 10 mm block: Hex S2 2 / 3 per element 3.574 / 3.583 (centre), 6.206 /
6.238 (edge), 9.519 / 9.544 (corner) [1e-5 m/N], TetP2 0.5 mm 3.508 / 6.073 / 9.366 (-2.1 / -2.7 / -1.9 % against
Hex S2 3, the tetrahedra's usual stiffness at nu 0.49 on the coarser mesh); 2 -> 3 per element: +0.24 / +0.51 /
+0.27 %, the size of the remaining discretisation error of the default mesh at the edge.

Published closed form (:func:`gent_lindley_modulus`): the block pressed by a rigid plate bonded to its top
(:func:`bonded_plate_modulus`) against Gent & Lindley (1959), 1 / E_a = 1 / (E (1 + 2 S^2)) + 1 / B:

    block (h 10 mm)   S     FE bonded E_a/E (1 / 2 per el.)   Gent & Lindley   FE / GL   FE frictionless plate
    20 x 20 mm        0.5   1.668 / 1.643                     1.376            1.19      1.233
    40 x 40 mm        1.0   2.981 (1 per el.)                 2.542            1.17      1.645

The FE is 17-19 % stiffer than the closed form. Gent & Lindley's formula assumes parabolic bulging of a thin
block (S >> 1); Horton, Tupholme & Gover ("Axial loading of bonded rubber blocks", J. Appl. Mech., 2002,
doi:10.1115/1.1507769) show that it
underestimates E_a for small S, where the parabolic profile is invalid, so at S = 0.5-1 the closed form is not an
accurate oracle: the agreement is only of the order of magnitude and the trend with S. The independent FE model
above is the check that counts.

Dynamic (20 x 20 mm block, full depth, 2 per element, :class:`BlockModes` with 40 modes per class): modal form
against direct complex solves 0.04 % at 1 kHz, 0.65 % at 5 kHz (diagonal and whole columns). Natural
frequencies (Re E(f) lambda = (2 pi f)^2): rocking (odd in x or in y) 3.67 kHz, odd-odd (twist) 3.91 kHz,
6.18 kHz, first even-even (vertical) 6.74 kHz. |g_ii| at centre / edge / corner falls monotonically from 10 Hz
to 5 kHz (1.995 / 3.344 / 5.347 e-5 m/N at 10 Hz, 1.106 / 1.858 / 2.975 e-5 at 1 kHz, 0.872 / 1.506 / 2.471 e-5
at 5 kHz): with eta ~ 0.3 and E rising with frequency no peak of |g_ii| below 5 kHz; the rocking resonance shows
in the transfer to the far side (|g| from the centre to the block's edge at 5 kHz is 1.38 x its 10 Hz value,
against 0.44 x near the load). On an 8 x 8 mm block (1 per element) the rocking mode is at 2.76 kHz and |g| at
the edge and corner peaks at 2.39 kHz. Cost: modes 114 s (4 classes), sweep of 200 frequencies 0.1 s, one direct
complex frequency 80 s (4 factorisations).

Reciprocity: with greens' convention (centre value, uniform load) G is not exactly symmetric on a block;
max |G - G^T| / max G = 0.45 % (2 per element, 20 and 40 mm blocks). The element-mean matrix is symmetric to
round-off (tests).

Cost (static, all N sources, 4 symmetry classes, one core of a shared machine):

    block         per_element  DOFs/class  assembly  factor (4x)  solve (N RHS)  total    peak RSS  table N^2 x 8 B
    20 x 20 mm    1             7.9 k        0.4 s      2.0 s       1.4 s          4 s     0.28 GB    1.3 MB
    20 x 20 mm    2            45 k          1.7 s     43 s        14 s           60 s     1.4 GB     1.3 MB
    20 x 20 mm    2            51 k          1.9 s     55 s        15 s           73 s     1.5 GB     1.3 MB
      (grooves 6 mm deep, undertread)
    20 x 20 mm    3           134 k          9.0 s    323 s        59 s          395 s     4.7 GB     1.3 MB
    40 x 40 mm    1            30 k          1.6 s     16 s        29 s           48 s     1.2 GB    20.5 MB
    40 x 40 mm    2           177 k         15 s      568 s       421 s         1010 s     7.5 GB    20.5 MB

(the 40 mm run kept its 1600 right-hand sides as dense arrays; they are now solved in blocks of 64.) A complex
table per frequency doubles the table's memory (41 MB for 40 x 40); the modal form stores per class P phi and
F phi (N/4 x n_modes) and the static table instead.
"""


@dataclass(frozen=True)
class TreadPattern:
    """Geometry of a periodic block pattern: rectangular blocks separated by straight grooves.

    Parameters
    ----------
    block_length : float
        Block size along x (rolling direction) [m]; a whole multiple of ``element_size``.
    block_width : float
        Block size along y [m]; a whole multiple of ``element_size``.
    groove_width : float
        Width of the grooves between blocks (both directions) [m]; a whole multiple of ``element_size``
        (0: no grooves, a flat layer of period ``block_length`` x ``block_width``).
    groove_depth : float
        Groove depth from the surface [m], 0 <= groove_depth <= the tread thickness (checked against the material
        where the model is built); equal to the thickness: full-depth grooves (free-standing blocks).
    element_size : float
        Surface element size c [m] (1 mm in the study).
    """

    block_length: float
    block_width: float
    groove_width: float
    groove_depth: float
    element_size: float = 1e-3

    def __post_init__(self):
        c = float(self.element_size)
        if not (math.isfinite(c) and c > 0):
            raise ValueError(f"TreadPattern.element_size must be a length > 0 [m], got {self.element_size!r}")
        checks.whole_multiple("TreadPattern.block_length", self.block_length, c, allow_zero=False)
        checks.whole_multiple("TreadPattern.block_width", self.block_width, c, allow_zero=False)
        checks.whole_multiple("TreadPattern.groove_width", self.groove_width, c, allow_zero=True)
        d = float(self.groove_depth)
        if not (math.isfinite(d) and d >= 0):
            raise ValueError(f"TreadPattern.groove_depth must be a depth >= 0 [m], got {self.groove_depth!r}")

    @property
    def shape(self) -> tuple[int, int]:
        """(n_x, n_y): surface elements on the block [-]."""
        c = self.element_size
        return int(round(self.block_length / c)), int(round(self.block_width / c))

    def check_thickness(self, thickness: float) -> None:
        """Raise ValueError unless groove_depth <= thickness [m]."""
        if self.groove_depth > thickness * (1 + 1e-12):
            raise ValueError(f"TreadPattern.groove_depth = {self.groove_depth!r} m exceeds the tread thickness "
                             f"{thickness!r} m (expected 0 <= groove_depth <= thickness)")

    def has_undertread(self, thickness: float) -> bool:
        """True when the cell has material under the grooves (grooves shallower than the tread) [-]."""
        return self.groove_width > 0 and self.groove_depth < thickness * (1 - 1e-12)


@dataclass(frozen=True)
class BlockMesh:
    """Mesh layout of the block cell.

    Parameters
    ----------
    per_element : int
        Hexahedra per surface element along x and y on the block top (uniform there) [-].
    growth : float
        Vertical spacing ratio below the surface (>= 1) [-].
    coarse : float
        Largest vertical (and graded lateral) spacing [m].
    element : str
        ``"hexs2"`` (20-node serendipity), ``"hex2"`` (27-node) or ``"hex1"`` (locks at nu = 0.49).
    volumetric : str
        ``"full"`` or ``"reduced"`` Gauss order for the lambda div u div v term (see :mod:`tyreroad.fe_layer`).
    uniform_extent : float or None
        None: the whole block top is uniform (every element may be loaded). A length [m]: uniform only up to this
        distance from the block centre, graded by ``lateral_growth`` beyond (only elements inside it may be loaded;
        for large-block checks).
    lateral_growth : float
        Lateral spacing ratio beyond ``uniform_extent`` [-].
    undertread_edge : str
        ``"periodic"`` (mirror conditions at the cell boundary: the periodic array of identical, identically loaded
        blocks) or ``"free"`` (traction-free outer edge of the undertread).
    groove_spacing : float or None
        Lateral spacing in the half-groove [m]; default the top spacing c / per_element.
    depth_fine : float
        Depth below the surface meshed uniformly with the top spacing before the vertical grading starts [m].
    """

    per_element: int = 2
    growth: float = 1.5
    coarse: float = 2e-3
    element: str = "hexs2"
    volumetric: str = "full"
    uniform_extent: float | None = None
    lateral_growth: float = 1.5
    undertread_edge: str = "periodic"
    groove_spacing: float | None = None
    depth_fine: float = 2e-3

    def __post_init__(self):
        if int(self.per_element) != self.per_element or self.per_element < 1:
            raise ValueError(f"BlockMesh.per_element must be an integer >= 1, got {self.per_element!r}")
        if self.element not in ("hexs2", "hex2", "hex1"):
            raise ValueError(f"BlockMesh.element must be 'hexs2', 'hex2' or 'hex1', got {self.element!r}")
        if self.volumetric not in ("full", "reduced"):
            raise ValueError(f"BlockMesh.volumetric must be 'full' or 'reduced', got {self.volumetric!r}")
        if self.undertread_edge not in ("periodic", "free"):
            raise ValueError(f"BlockMesh.undertread_edge must be 'periodic' or 'free', got {self.undertread_edge!r}")
        if not (self.growth >= 1 and self.lateral_growth >= 1 and self.coarse > 0):
            raise ValueError("BlockMesh: need growth >= 1, lateral_growth >= 1 and coarse > 0 [m]")


def element_centres(pattern: TreadPattern) -> np.ndarray:
    """Centres of the block's surface elements from the block's corner, row-major over x then y.

    Returns
    -------
    numpy.ndarray
        Shape (n_x n_y, 2) [m]; row i n_y + j is ((i + 1/2) c, (j + 1/2) c).
    """
    nx, ny = pattern.shape
    c = pattern.element_size
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    return np.column_stack([(i.ravel() + 0.5) * c, (j.ravel() + 0.5) * c])


def _graded(a: float, b: float, first: float, growth: float, coarse: float) -> np.ndarray:
    """Nodes on [a, b] starting with spacing ``first`` at a and growing (``axis_nodes`` with no fine part)."""
    if b - a <= 0:
        return np.array([a])
    return a + axis_nodes(b - a, first, 0.0, growth, max(coarse, first))


def _lateral_axis(n: int, c: float, mesh: BlockMesh, groove_half: float) -> tuple[np.ndarray, float, float]:
    """Quarter-model nodes along one axis from the block centre (0) to the cell boundary, the block edge and the
    end of the uniformly meshed part (elements beyond it cannot be loaded) [m]."""
    half = n * c / 2
    h = c / mesh.per_element
    # element edges in the quarter: half - k c >= 0, and 0 (a mirror plane; splits the middle element if n is odd)
    edges = sorted({0.0} | {half - k * c for k in range(n // 2 + 1)})
    if mesh.uniform_extent is None:
        u_end = half
    else:
        u_end = min(half, max(e for e in edges if e <= mesh.uniform_extent + 1e-12 * c))
    nodes = [0.0]
    for a, b in zip(edges[:-1], edges[1:]):
        if b > u_end + 1e-12 * c:
            break
        k = max(1, int(round((b - a) / h)))
        nodes.extend(a + (b - a) * np.arange(1, k + 1) / k)
    x = np.asarray(nodes)
    if u_end < half - 1e-12 * c:
        x = np.concatenate([x, _graded(u_end, half, h * mesh.lateral_growth, mesh.lateral_growth,
                                       mesh.coarse)[1:]])
    if groove_half > 0:
        gs = mesh.groove_spacing or h
        k = max(1, int(math.ceil(groove_half / gs - 1e-9)))
        x = np.concatenate([x, half + groove_half * np.arange(1, k + 1) / k])
    return x, half, u_end


def _depth_axis(h: float, top: float, mesh: BlockMesh, groove_depth, z_planes=()) -> np.ndarray:
    """Node depths: uniform ``top`` to ``depth_fine``, then graded; the groove bottom and ``z_planes`` are planes."""
    n_f = int(round(min(mesh.depth_fine, h) / top))
    stops = sorted({n_f * top, h} | {float(z) for z in z_planes if 0 < z < h}
                   | ({float(groove_depth)} if groove_depth is not None and 0 < groove_depth < h else set()))
    z = list(np.arange(n_f + 1) * top)
    step = top
    for b in stops:
        a = z[-1]
        if b <= a + 1e-12 * h:
            continue
        seg = _graded(a, b, min(step * mesh.growth if a > 0 else top, b - a), mesh.growth, mesh.coarse)
        z.extend(seg[1:])
        step = z[-1] - z[-2]
    return np.asarray(z)


class BlockCell:
    """FE model of one tread block cell (quarter model by symmetry, or the full cell), assembled once.

    Parameters
    ----------
    pattern : TreadPattern
        Block and groove geometry.
    thickness : float
        Tread thickness h [m] (block height with full-depth grooves).
    poisson : float
        Poisson's ratio [-].
    density : float
        Density [kg/m^3].
    mesh : BlockMesh
        Mesh layout.
    symmetry : bool
        True: quarter model, four symmetry classes. False: the full cell (check of the recombination).
    z_planes : tuple of float
        Extra depths [m] that must be node planes (the flat reference of the difference correction gets the
        block's groove-bottom plane, so that both share the mesh).
    """

    def __init__(self, pattern: TreadPattern, thickness: float, poisson: float, density: float,
                 mesh: BlockMesh = BlockMesh(), symmetry: bool = True, z_planes=()):
        from skfem import Basis, MeshHex

        t0 = time.perf_counter()
        pattern.check_thickness(thickness)
        self.pattern, self.layout, self.symmetry = pattern, mesh, bool(symmetry)
        self.thickness = h = float(thickness)
        self.poisson, self.density = float(poisson), float(density)
        self.c = c = pattern.element_size
        nx, ny = pattern.shape
        under = pattern.has_undertread(h)
        gd = min(float(pattern.groove_depth), h)
        g_half = pattern.groove_width / 2 if under else 0.0
        xq, hx, ux = _lateral_axis(nx, c, mesh, g_half)
        yq, hy, uy = _lateral_axis(ny, c, mesh, g_half)
        self.uniform_end = (ux, uy)
        self.half = (hx, hy)
        self.cell_half = (float(xq[-1]), float(yq[-1]))
        z = _depth_axis(h, c / mesh.per_element, mesh, gd if under else None, z_planes)
        if self.symmetry:
            xs, ys = xq, yq
        else:
            xs = np.concatenate([-xq[::-1], xq[1:]])
            ys = np.concatenate([-yq[::-1], yq[1:]])
        self.planes = (xs, ys, z)
        m = MeshHex.init_tensor(xs, ys, z)
        if under:
            mid = m.p[:, m.t].mean(axis=1)
            groove = ((np.abs(mid[0]) > hx) | (np.abs(mid[1]) > hy)) & (mid[2] < gd)
            m = m.remove_elements(np.flatnonzero(groove)).remove_unused_nodes()
        self.mesh = m
        sb = Basis(m, _scalar_element(mesh.element), intorder=_INTORDER[mesh.element])
        vb = Basis(m, sb.elem, intorder=_INTORDER[mesh.element] - 2) if mesh.volumetric == "reduced" else None
        self.basis = sb
        self.K_ref, self.M = elasticity_matrices(sb, self.poisson, self.density, vb)
        self.assembly_time = time.perf_counter() - t0
        ns = sb.N
        tol = 1e-9 * c
        x = sb.doflocs

        # quarter (or full) surface elements: index (k, l) in the quarter, centre from the block centre
        if self.symmetry:
            kx = np.arange(nx - nx // 2)  # quarter elements along x: centres (k + 1/2) c (even n) or k c (odd)
            ky = np.arange(ny - ny // 2)
            cx = (kx + (0.5 if nx % 2 == 0 else 0.0)) * c
            cy = (ky + (0.5 if ny % 2 == 0 else 0.0)) * c
        else:
            cx = (np.arange(nx) + 0.5) * c - hx
            cy = (np.arange(ny) + 0.5) * c - hy
        self.centres = (cx, cy)
        CX, CY = np.meshgrid(cx, cy, indexing="ij")
        ux, uy = (self.uniform_end[0], self.uniform_end[1])
        self._loadable = ((np.abs(CX) + c / 2 <= ux + tol) & (np.abs(CY) + c / 2 <= uy + tol)).ravel()
        self.loads = self._element_loads(CX.ravel(), CY.ravel())  # (3 ns, n_el) sparse, pressure 1/c^2 [N]
        self._straddle = (np.isclose(CX.ravel(), 0.0, atol=tol), np.isclose(CY.ravel(), 0.0, atol=tol))
        pts = np.vstack([CX.ravel(), CY.ravel(), np.zeros(CX.size)])
        self.probes = sps.hstack([sps.csr_matrix((pts.shape[1], 2 * ns)), sb.probes(pts).tocsr()]).tocsr()

        def on(pred):
            return sb.get_dofs(pred).all()

        base = on(lambda p: np.abs(p[2] - h) < tol)
        self._fixed_base = np.concatenate([base, base + ns, base + 2 * ns])
        self._planes_x = [on(lambda p: np.abs(p[0]) < tol)]  # mirror planes and, periodic, the cell boundary
        self._planes_y = [on(lambda p: np.abs(p[1]) < tol)]
        if (under and mesh.undertread_edge == "periodic") or pattern.groove_width == 0:
            self._planes_x.append(on(lambda p: np.abs(np.abs(p[0]) - self.cell_half[0]) < tol))
            self._planes_y.append(on(lambda p: np.abs(np.abs(p[1]) - self.cell_half[1]) < tol))
        self._slaves = None
        if not self.symmetry:
            self._planes_x, self._planes_y = [], []
            if (under and mesh.undertread_edge == "periodic") or pattern.groove_width == 0:
                self._slaves = self._periodic_pairs()
        self._node_order = nested_dissection(x, self.planes)
        self.factor_time = 0.0
        self.solve_time = 0.0

    @property
    def classes(self) -> list[tuple[int, int]]:
        """Symmetry classes (a, b): +1 even, -1 odd in x and y; the full model has one, (0, 0)."""
        return [(1, 1), (1, -1), (-1, 1), (-1, -1)] if self.symmetry else [(0, 0)]

    def _element_loads(self, cx, cy) -> sps.csc_matrix:
        """Load vectors of a unit force spread over each surface element (its part inside the model) [N]."""
        from skfem import FacetBasis, LinearForm

        m, sb, c = self.mesh, self.basis, self.c
        tol = 1e-9 * c
        fmid = m.p[:, m.facets].mean(axis=1)
        top = np.flatnonzero(np.abs(fmid[2]) < tol)
        ns = sb.N
        cols = []
        c2 = c * c

        @LinearForm
        def pressure(v, w):
            return v / c2  # unit force over the c x c element, pushing into the tread (+z)

        # one facet assembly; each top facet's entries go to the column of the element containing it
        fb = FacetBasis(m, sb.elem, facets=top, intorder=_INTORDER[self.layout.element])
        # skfem's per-facet COO data (what ``asm`` sums): one pass instead of a FacetBasis per element; the sums
        # are checked against 1 N below, so a change of this private API cannot go unnoticed
        (rows,), data, _, _ = pressure._assemble(fb)
        fx, fy = fmid[0, top], fmid[1, top]
        col = np.full(top.size, -1)
        for k, (x0, y0) in enumerate(zip(cx, cy)):
            col[(np.abs(fx - x0) < c / 2) & (np.abs(fy - y0) < c / 2)] = k
        # a facet of a graded (non-loadable) region must not be cut by an element's edge
        cols = np.tile(col, fb.Nbfun)
        ok = cols >= 0
        Fz = sps.csr_matrix((data[ok], (rows[ok], cols[ok])), shape=(ns, len(cx)))
        total = np.asarray(Fz.sum(axis=0)).ravel()
        expect = np.where(self._loadable, 1.0, np.nan)
        fx_half = (np.isclose(cx, 0.0, atol=tol) & self.symmetry) * 1.0
        fy_half = (np.isclose(cy, 0.0, atol=tol) & self.symmetry) * 1.0
        expect = expect * (1 - 0.5 * fx_half) * (1 - 0.5 * fy_half)
        bad = self._loadable & ~np.isclose(total, expect, rtol=1e-9)
        if np.any(bad):
            raise RuntimeError(f"element loads sum to {total[bad][:3]} N, expected {expect[bad][:3]} N")
        return sps.vstack([sps.csr_matrix((2 * ns, Fz.shape[1])), Fz]).tocsc()

    def _free(self, cls) -> np.ndarray:
        ns = self.basis.N
        a, b = cls
        fixed = [self._fixed_base]
        for planes, sign, normal, tang in ((self._planes_x, a, 0, (1, 2)), (self._planes_y, b, 1, (0, 2))):
            for dofs in planes:
                comps = (normal,) if sign >= 0 else tang
                fixed.extend(dofs + ns * q for q in comps)
        if self._slaves is not None:
            fixed.append(self._slaves[0])
        fixed = np.unique(np.concatenate(fixed))
        vec = (self._node_order[:, None] + ns * np.arange(3)[None, :]).ravel()
        return vec[~np.isin(vec, fixed)]

    def _reduction(self, cls) -> sps.csr_matrix:
        """T (all DOFs x kept DOFs): u = T u_kept. Selection of the free DOFs; in the full periodic cell the DOFs
        on the +x / +y cell boundary are tied to their images on -x / -y (translation periodicity)."""
        free = self._free(cls)
        n = 3 * self.basis.N
        col = np.full(n, -1)
        col[free] = np.arange(free.size)
        rows, cols = free, np.arange(free.size)
        if self._slaves is not None:
            slave, master = self._slaves
            ok = col[master] >= 0
            rows = np.concatenate([rows, slave[ok]])
            cols = np.concatenate([cols, col[master[ok]]])
        return sps.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n, free.size))

    def _periodic_pairs(self):
        """(slave DOFs, master DOFs): nodes on x = +X (y = +Y) and their images at -X (-Y), all three components."""
        ns = self.basis.N
        x = self.basis.doflocs
        X, Y = self.cell_half
        tol = 1e-9 * self.c
        img = x.copy()
        sx = np.abs(x[0] - X) < tol
        sy = np.abs(x[1] - Y) < tol
        img[0, sx] = -X
        img[1, sy] = -Y
        slave = np.flatnonzero(sx | sy)
        key = {tuple(np.round(x[:, k] / tol).astype(np.int64)): k for k in range(ns)}
        master = np.array([key[tuple(np.round(img[:, k] / tol).astype(np.int64))] for k in slave], dtype=int)
        return (np.concatenate([slave + ns * q for q in range(3)]),
                np.concatenate([master + ns * q for q in range(3)]))

    def class_response(self, cls, modulus: complex = 1.0, omega: float = 0.0, sources=None, field="centre"):
        """Quarter responses of one symmetry class: field elements x source elements of the model.

        Returns
        -------
        numpy.ndarray
            U[p, s] [m/N]: u_z at the centre (``field="centre"``) or the mean over the field element's part in the
            model times its multiplicity (``"mean"``), for the class part of the unit load on source s.
        """
        T = self._reduction(cls)
        Tt = T.T.tocsr()
        a = (Tt @ self.K_ref @ T) * modulus
        if omega:
            a = a - (omega * omega) * (Tt @ self.M @ T)
        t0 = time.perf_counter()
        lu = spla.splu(a.tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        t1 = time.perf_counter()
        n_el = self.loads.shape[1]
        src = np.arange(n_el) if sources is None else np.asarray(sources)
        mult = self._multiplicity(cls)
        loads = Tt @ self.loads
        if field == "centre":
            P = (self.probes @ T).tocsr()
        elif field == "mean":
            P = (loads @ sps.diags(mult)).T.tocsr()
        else:
            raise ValueError(f"field must be 'centre' or 'mean', got {field!r}")
        log.info("block %s, symmetry class %s: %d DOFs factorised in %.1f s (%s, f = %.4g Hz); %d right-hand sides",
                 "x".join(str(n) for n in self.pattern.shape), cls, a.shape[0], t1 - t0,
                 "complex" if np.iscomplexobj(a) else "real", omega / (2 * np.pi), len(src))
        out = np.zeros((P.shape[0], len(src)), dtype=a.dtype)
        for k in range(0, len(src), 64):  # right-hand sides in blocks: the dense n_dofs x N arrays cost GBs
            part = src[k:k + 64]
            rhs = (loads[:, part] @ sps.diags(mult[part])).toarray().astype(a.dtype)
            out[:, k:k + 64] = P @ lu.solve(rhs)
            if len(src) > 256 and (k // 64) % 4 == 3:
                log.info("  %d of %d right-hand sides solved (%.0f s)", min(k + 64, len(src)), len(src),
                         time.perf_counter() - t1)
        self.factor_time += t1 - t0
        self.solve_time += time.perf_counter() - t1
        return np.asarray(out)

    def _multiplicity(self, cls) -> np.ndarray:
        """(1 + a) (1 + b) for elements cut by the mirror planes (their part in the quarter carries 1/2 or 1/4)."""
        a, b = cls
        mx = np.where(self._straddle[0], 1 + a, 1) if self.symmetry else np.ones(self._straddle[0].size)
        my = np.where(self._straddle[1], 1 + b, 1) if self.symmetry else np.ones(self._straddle[1].size)
        return (mx * my).astype(float)

    def influence(self, modulus: complex = 1.0, omega: float = 0.0, sources=None, field="centre",
                  responder=None) -> np.ndarray:
        """Influence matrix over the block's elements, row-major (i n_y + j), shape (N, len(sources)) [m/N].

        Parameters
        ----------
        modulus : complex
            Young's modulus [Pa] (the quasi-static modulus for a static solve).
        omega : float
            Angular frequency [rad/s].
        sources : array_like of int, optional
            Block element indices (row-major) of the loaded elements; default all N.
        field : str
            ``"centre"`` (greens' convention) or ``"mean"`` (element-mean displacement; symmetric matrix).
        responder : callable, optional
            ``responder(cls, quarter_sources)`` -> class response (quarter field x sources) used instead of a direct
            solve (:class:`BlockModes`).
        """
        modal = responder is not None
        if responder is None:
            def responder(cls, q):
                return self.class_response(cls, modulus, omega, q, field)
        nx, ny = self.pattern.shape
        src = np.arange(nx * ny) if sources is None else np.atleast_1d(np.asarray(sources, dtype=int))
        si, sj = np.divmod(src, ny)
        c, hx, hy = self.c, *self.half
        lx = np.abs((si + 0.5) * c - hx) + c / 2 <= self.uniform_end[0] * (1 + 1e-9)
        ly = np.abs((sj + 0.5) * c - hy) + c / 2 <= self.uniform_end[1] * (1 + 1e-9)
        if not np.all(lx & ly):
            raise ValueError(f"source elements {src[~(lx & ly)][:5]} lie outside the uniformly meshed part "
                             f"(BlockMesh.uniform_extent) and cannot be loaded")
        if not self.symmetry:
            u = responder((0, 0), src)
            return u.reshape(nx * ny, len(src))
        # quarter index and sign of every block element along each axis
        def fold(i, n):
            k = np.maximum(i, n - 1 - i) - n // 2
            return k, np.where(2 * i + 1 < n, -1, 1)

        ksx, sgx = fold(si, nx)
        ksy, sgy = fold(sj, ny)
        nqy = ny - ny // 2
        qsrc = ksx * nqy + ksy
        uq, inv = np.unique(qsrc, return_inverse=True)
        out = np.zeros((nx * ny, len(src)), dtype=complex if np.iscomplexobj(modulus) or omega else float)
        if modal:
            out = out.astype(complex)
        pi, pj = np.divmod(np.arange(nx * ny), ny)
        for cls in self.classes:
            a, b = cls
            U = responder(cls, uq)[:, inv]  # (quarter field, sources)
            # mirror the field point with the source's signs, then fold it into the quarter
            pi2 = np.where(sgx[None, :] < 0, nx - 1 - pi[:, None], pi[:, None])
            pj2 = np.where(sgy[None, :] < 0, ny - 1 - pj[:, None], pj[:, None])
            kpx, tx = fold(pi2, nx)
            kpy, ty = fold(pj2, ny)
            sign = np.where(tx < 0, a, 1) * np.where(ty < 0, b, 1)
            out += 0.25 * sign * np.take_along_axis(U, kpx * nqy + kpy, axis=0)
        return out

    @property
    def n_dofs(self) -> int:
        """Free DOFs of the largest class matrix [-]."""
        return max(self._reduction(cls).shape[1] for cls in self.classes)


def _check_material(material, pattern):
    pattern.check_thickness(float(material.thickness))


def block_static_influence(pattern: TreadPattern, material, mesh: BlockMesh = BlockMesh(), *,
                           field: str = "centre", symmetry: bool = True, return_cell: bool = False,
                           correction: str = "none", reach: int = 6):
    """Static influence matrix of every block surface element on every block surface element.

    Parameters
    ----------
    pattern : TreadPattern
        Block and groove geometry (groove_depth <= material.thickness).
    material : tyreroad.material.Material
        Provides ``quasi_static_modulus`` [Pa], ``poisson``, ``density`` and ``thickness`` [m].
    mesh : BlockMesh
        Mesh layout (default: 2 x 2 20-node hexahedra per surface element, 0.5 mm layers to 2 mm depth; within
        1 % of the flat layer at a large block's centre, see :data:`MEASURED`).
    field : str
        ``"centre"``: displacement at the field element's centre (greens' convention); ``"mean"``: its mean
        over the field element (a symmetric matrix).
    symmetry : bool
        Quarter model with four symmetry classes (default) or the full cell.
    return_cell : bool
        Also return the :class:`BlockCell` (timings, DOFs).
    correction : str
        ``"none"`` or ``"difference"``: add G_analytic(offset) - G_FE,flat(offset) (:func:`flat_correction`), the
        discretisation error of the same mesh on the flat layer, for offsets up to ``reach`` elements.
    reach : int
        Largest |offset| per axis [elements] that the difference correction covers.

    Returns
    -------
    centres : numpy.ndarray
        Element centres from the block's corner, shape (N, 2) [m], N = n_x n_y, row-major over x then y
        (row i n_y + j is element (i, j) at ((i + 1/2) c, (j + 1/2) c)).
    G : numpy.ndarray
        Shape (N, N) [m/N]: G[p, s] = normal displacement (into the tread, positive in compression) at element p
        per unit normal force spread uniformly over element s.
    """
    _check_material(material, pattern)
    cell = BlockCell(pattern, material.thickness, material.poisson, material.density, mesh, symmetry)
    g = cell.influence(float(material.quasi_static_modulus), 0.0, field=field)
    if correction == "difference":
        if field != "centre":
            raise ValueError("correction='difference' needs field='centre' (the analytic kernel's convention)")
        g = g + flat_correction(pattern, material, mesh, reach)[1]
    elif correction != "none":
        raise ValueError(f"correction must be 'none' or 'difference', got {correction!r}")
    out = (element_centres(pattern), g)
    return out + (cell,) if return_cell else out


def block_frequency_response(pattern: TreadPattern, material, frequencies, sources, mesh: BlockMesh = BlockMesh(),
                             *, field: str = "centre", cell: BlockCell | None = None, n_modes: int | None = None):
    """Complex influence of chosen source elements on every block element, per frequency.

    Solves (E(omega) K_1 - omega^2 M) u = f (exp(+i omega t); Im E > 0, so Im g < 0 for a passive block), the
    quasi-static modulus at f = 0.

    Parameters
    ----------
    pattern : TreadPattern
        Block geometry.
    material : tyreroad.material.Material
        ``modulus(omega)`` [Pa], ``quasi_static_modulus`` [Pa], ``poisson``, ``density`` [kg/m^3],
        ``thickness`` [m].
    frequencies : array_like
        Frequencies f >= 0 [Hz].
    sources : array_like of int
        Loaded elements (row-major indices i n_y + j).
    mesh : BlockMesh
        Mesh layout.
    field : str
        ``"centre"`` or ``"mean"`` (see :func:`block_static_influence`).
    cell : BlockCell, optional
        A cell built for this pattern and material (reused: assembly once).
    n_modes : int, optional
        Use the modal form (:class:`BlockModes`, this many modes per symmetry class plus the static residual)
        instead of a direct solve per frequency (40 modes: 0.65 % at 5 kHz on a 20 mm block).

    Returns
    -------
    numpy.ndarray
        Complex, shape (len(frequencies), N, len(sources)) [m/N].
    """
    _check_material(material, pattern)
    f = np.atleast_1d(np.asarray(frequencies, dtype=float))
    if np.any(f < 0):
        raise ValueError("frequencies must be >= 0 [Hz]")
    if cell is None:
        cell = BlockCell(pattern, material.thickness, material.poisson, material.density, mesh)
    src = np.atleast_1d(np.asarray(sources, dtype=int))
    out = np.empty((f.size, int(np.prod(pattern.shape)), src.size), dtype=complex)
    modes = BlockModes(cell, n_modes, field) if n_modes else None
    for n, fn in enumerate(f):
        w = 2 * np.pi * fn
        e = material.modulus_at(fn)
        out[n] = modes.influence(e, w, src) if modes else cell.influence(e, w, src, field)
    return out


def bonded_plate_modulus(cell: BlockCell, bonded: bool = True) -> float:
    """Apparent compression modulus E_a / E [-] of the block pressed by a rigid top plate, from the FE cell.

    The block's top face (z = 0 over the block) moves by u_z = 1 m (and, ``bonded``, u_x = u_y = 0: the plate is
    bonded to the rubber, as in Gent & Lindley's bonded blocks; otherwise the plate is frictionless); E_a = F h /
    (A delta) for E = 1 Pa. Uses the even-even symmetry class only (the load is symmetric).
    """
    ns = cell.basis.N
    c, (hx, hy) = cell.c, cell.half
    tol = 1e-9 * c
    x = cell.basis.doflocs
    top = np.flatnonzero((np.abs(x[2]) < tol) & (np.abs(x[0]) <= hx + tol) & (np.abs(x[1]) <= hy + tol))
    presc = {2 * ns + k: 1.0 for k in top}
    if bonded:
        presc.update({k: 0.0 for k in top})
        presc.update({ns + k: 0.0 for k in top})
    p_idx = np.array(sorted(presc))
    kept = cell._free((1, 1))  # free DOFs of the even-even class, nested-dissection order
    f_idx = kept[~np.isin(kept, p_idx)]
    p_idx = p_idx[np.isin(p_idx, kept)]  # top DOFs on a mirror plane stay fixed by the mirror condition
    up = np.array([presc[k] for k in p_idx])
    K = cell.K_ref.tocsr()
    kff = K[f_idx][:, f_idx].tocsc()
    lu = spla.splu(kff, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    uf = lu.solve(-(K[f_idx][:, p_idx] @ up))
    reaction = K[p_idx][:, f_idx] @ uf + K[p_idx][:, p_idx] @ up
    zrows = p_idx >= 2 * ns
    force = 4.0 * float(reaction[zrows].sum())  # quarter model
    area = 4 * hx * hy
    return force * cell.thickness / area


def gent_lindley_modulus(length: float, width: float, height: float, poisson: float, beta: float = 2.0) -> float:
    """Gent & Lindley's apparent compression modulus of a bonded rubber block, E_a / E [-].

    1 / E_a = 1 / (E (1 + beta S^2)) + 1 / B, with the shape factor S = loaded area / force-free area
    = L W / (2 (L + W) H) and the bulk modulus B = E / (3 (1 - 2 nu)); beta = 2 for square, circular and
    moderately rectangular blocks of unfilled rubber (smaller for filled rubbers).

    Parameters
    ----------
    length, width : float
        Sides of the bonded faces [m].
    height : float
        Block height between the bonded plates [m].
    poisson : float
        Poisson's ratio [-] (sets the bulk-compression term).
    beta : float
        Numerical constant [-].

    References
    ----------
    A. N. Gent, P. B. Lindley, "The compression of bonded rubber blocks", Proc. Inst. Mech. Eng. 173 (1959) 111;
    the formula and beta as quoted (Eqs. 1-2) in Strojniški vestnik - J. Mech. Eng. 60 (2014) 506-511,
    doi:10.5545/sv-jme.2013.1510.
    """
    s = length * width / (2 * (length + width) * height)
    bulk = 1.0 / (3 * (1 - 2 * poisson))
    return 1.0 / (1.0 / (1 + beta * s * s) + 1.0 / bulk)


def tet_reference_influence(pattern: TreadPattern, modulus: float, poisson: float, thickness: float, sources,
                            lateral: float = 0.5e-3, growth: float = 1.4, coarse: float = 2.5e-3,
                            mean_self: bool = False) -> np.ndarray:
    """Independent FE model of a free-standing block (full-depth grooves): an oracle for :class:`BlockCell`.

    Shares nothing with :class:`BlockCell` but the boundary-value problem: scikit-fem's own vector
    ``linear_elasticity`` form on 10-node quadratic tetrahedra (``ElementTetP2``, skfem's default quadrature, full
    integration), a different mesh (the whole block, no symmetry; 6 tetrahedra per box of a tensor grid with
    ``lateral`` spacing from the block's corner and a depth grading of its own), skfem's vector facet load. The
    sparse solve uses :func:`tyreroad.fe_layer.nested_dissection` as a fill-reducing order only.

    Parameters
    ----------
    pattern : TreadPattern
        Block geometry; the block stands alone (full-depth grooves) on the rigid belt.
    modulus : float
        Young's modulus [Pa].
    poisson : float
        Poisson's ratio [-].
    thickness : float
        Block height h [m].
    sources : array_like of int
        Loaded elements (row-major i n_y + j).
    lateral : float
        Lateral spacing [m] (a divisor of the element size).
    growth, coarse : float
        Depth grading ratio [-] and largest depth spacing [m].
    mean_self : bool
        Also return each source's own element-mean displacement (the energy f.u per unit force) [m/N].

    Returns
    -------
    numpy.ndarray
        u_z at every element centre (row-major) per unit force on each source, shape (N, len(sources)) [m/N].
    """
    from skfem import Basis, ElementTetP2, ElementVector, FacetBasis, LinearForm, MeshTet, asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    nx, ny = pattern.shape
    c = pattern.element_size
    k = int(round(c / lateral))
    xs = np.linspace(0.0, nx * c, nx * k + 1)
    ys = np.linspace(0.0, ny * c, ny * k + 1)
    z = _graded(0.0, thickness, lateral, growth, coarse)
    m = MeshTet.init_tensor(xs, ys, z)
    vb = Basis(m, ElementVector(ElementTetP2()))
    sb = Basis(m, ElementTetP2())
    K = asm(linear_elasticity(*lame_parameters(float(modulus), float(poisson))), vb).tocsr()
    tol = 1e-9 * c
    fixed = vb.get_dofs(lambda p: np.abs(p[2] - thickness) < tol).all()
    comp = vb.split_indices()
    # fill-reducing order: node-wise nested dissection on the tensor planes
    order = nested_dissection(sb.doflocs, (xs, ys, z))
    vec = np.column_stack([comp[q][order] for q in range(3)]).ravel()
    free = vec[~np.isin(vec, fixed)]
    src = np.atleast_1d(np.asarray(sources, dtype=int))
    fmid = m.p[:, m.facets].mean(axis=1)
    rhs = np.zeros((vb.N, src.size))

    @LinearForm
    def pressure(v, w):
        return v.value[2] / (c * c)

    for n, s in enumerate(src):
        i, j = divmod(int(s), ny)
        sel = np.flatnonzero((np.abs(fmid[2]) < tol) & (np.abs(fmid[0] - (i + 0.5) * c) < c / 2)
                            & (np.abs(fmid[1] - (j + 0.5) * c) < c / 2))
        rhs[:, n] = asm(pressure, FacetBasis(m, vb.elem, facets=sel))
    lu = spla.splu(K[free][:, free].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0,
                   options={"SymmetricMode": True})
    u = np.zeros((vb.N, src.size))
    u[free] = lu.solve(rhs[free])
    pts = np.vstack([element_centres(pattern).T, np.zeros(nx * ny)])
    P = sb.probes(pts).tocsr()
    if mean_self:
        return P @ u[comp[2]], np.einsum("ij,ij->j", rhs, u)
    return P @ u[comp[2]]


def flat_correction(pattern: TreadPattern, material, mesh: BlockMesh, reach: int = 6):
    """Discretisation error of the block's mesh on the flat layer: Delta(offset) = g_analytic - g_FE,flat.

    The flat layer is modelled with the same :class:`BlockMesh` (same hexahedra per element on the top, same depth
    planes, the block's groove bottom included) as a periodic flat cell, uniform over ``reach`` + 1 elements around
    the loaded element and graded beyond to a half period of ``reach`` + 30 elements (static images < 0.02 %).
    Adding Delta(p - s) to the block's FE influence cancels the error that the mesh makes on the flat layer
    (G_block ~ G_analytic(offset) + [G_FE,block - G_FE,flat(offset)]); near the block's edges it removes the part of
    the error that the edge does not change.

    Returns
    -------
    delta : numpy.ndarray
        Delta at offsets (di, dj) c, |di|, |dj| <= reach, shape (2 reach + 1, 2 reach + 1) [m/N].
    G_delta : numpy.ndarray
        Delta(p - s) over the block's elements (zero beyond ``reach``), shape (N, N) [m/N].
    """
    from tyreroad.greens import static_element_kernel

    c = pattern.element_size
    h = float(material.thickness)
    half = reach + 30
    flat = TreadPattern(2 * half * c, 2 * half * c, 0.0, 0.0, c)
    fmesh = BlockMesh(per_element=mesh.per_element, growth=mesh.growth, coarse=mesh.coarse, element=mesh.element,
                      volumetric=mesh.volumetric, uniform_extent=(reach + 1) * c, lateral_growth=1.5,
                      depth_fine=mesh.depth_fine)
    zp = (float(pattern.groove_depth),) if pattern.has_undertread(h) else ()
    cell = BlockCell(flat, h, material.poisson, material.density, fmesh, z_planes=zp)
    n = 2 * half
    g = cell.influence(float(material.quasi_static_modulus), 0.0, [half * n + half])[:, 0].reshape(n, n)
    d = np.arange(-reach, reach + 1)
    fe = g[half + d[:, None], half + d[None, :]]
    di, dj = np.meshgrid(d, d, indexing="ij")
    off = np.column_stack([di.ravel(), dj.ravel()]) * c
    an = static_element_kernel(off, c, float(material.quasi_static_modulus), material.poisson, h).reshape(fe.shape)
    delta = an - fe
    nx, ny = pattern.shape
    i, j = np.divmod(np.arange(nx * ny), ny)
    oi = i[:, None] - i[None, :]
    oj = j[:, None] - j[None, :]
    inside = (np.abs(oi) <= reach) & (np.abs(oj) <= reach)
    G = np.zeros((nx * ny, nx * ny))
    G[inside] = delta[(oi + reach)[inside], (oj + reach)[inside]]
    return delta, G


class BlockModes:
    """Modal form of the block's response: one generalised eigen-decomposition per symmetry class and geometry.

    K_1 phi = lambda M phi (K_1 for E = 1 Pa; phi M-orthonormal) serves every material with the same Poisson's
    ratio: with a frequency-independent nu, K(omega) = E(omega) K_1, so

        G(omega) = sum_k P phi_k phi_k^T F / (E(omega) lambda_k - omega^2)
                   + [P K_1^-1 F - sum_k P phi_k phi_k^T F / lambda_k] / E(omega),

    the second term being the static residual of the modes left out (exact at omega = 0, and wherever the omitted
    modes respond quasi-statically). A density scale s only rescales lambda -> lambda / s.

    Parameters
    ----------
    cell : BlockCell
        The assembled cell (its density sets lambda [1/(Pa s^2)]).
    n_modes : int
        Modes kept per symmetry class (the lowest, by shift-invert about 0).
    field : str
        ``"centre"`` or ``"mean"``.
    """

    def __init__(self, cell: BlockCell, n_modes: int, field: str = "centre"):
        self.cell, self.field = cell, field
        self.data = {}
        t0 = time.perf_counter()
        for cls in cell.classes:
            T = cell._reduction(cls)
            Tt = T.T.tocsr()
            K = (Tt @ cell.K_ref @ T).tocsc()
            M = (Tt @ cell.M @ T).tocsc()
            lu = spla.splu(K, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
            op = spla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
            k = min(int(n_modes), K.shape[0] - 2)
            t1 = time.perf_counter()
            # a seeded start vector: ARPACK's own is random, so two BlockModes of one cell differed at rounding
            # (1e-12 of an entry: tests/test_fe_pattern.py compares two of them at 1e-12) and a re-run with it
            v0 = np.random.default_rng(0).standard_normal(K.shape[0])
            lam, phi = spla.eigsh(K, k=k, M=M, sigma=0.0, which="LM", OPinv=op, v0=v0)
            log.info("block modes, symmetry class %s: %d DOFs, %d modes in %.1f s", cls, K.shape[0], k,
                     time.perf_counter() - t1)
            mult = cell._multiplicity(cls)
            F = (Tt @ cell.loads) @ sps.diags(mult)
            P = (cell.probes @ T) if field == "centre" else F.T
            Pphi = np.asarray(P @ phi)
            Fphi = np.asarray(F.T @ phi)
            static = np.asarray(P @ lu.solve(F.toarray()))
            self.data[cls] = (lam, Pphi, Fphi, static)
        self.time = time.perf_counter() - t0

    def frequencies(self, material) -> dict:
        """Undamped natural frequencies sqrt(Re E(f) lambda) / 2 pi solved by fixed point [Hz], per class."""
        return {cls: np.sort(material.undamped_frequencies(lam)) for cls, (lam, *_rest) in self.data.items()}

    def influence(self, modulus: complex, omega: float, sources=None) -> np.ndarray:
        """As :meth:`BlockCell.influence`, from the modes [m/N]."""
        e = complex(modulus)

        def responder(cls, q):
            lam, Pphi, Fphi, static = self.data[cls]
            modal = (Pphi / (e * lam - omega * omega)) @ Fphi[q].T
            resid = (static[:, q] - (Pphi / lam) @ Fphi[q].T) / e
            return modal + resid

        return self.cell.influence(e, omega, sources, self.field, responder=responder)
