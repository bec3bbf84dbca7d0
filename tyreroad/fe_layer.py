"""Frequency-domain finite-element model of the flat tread layer (issue 27, first step).

The first step towards FE Green's functions of a grooved tread cell: the same FE cell without grooves, checked
against today's analytic element kernel (:func:`tyreroad.greens.static_element_kernel`,
:func:`tyreroad.greens.element_frf`) on the same 1 mm surface elements.

Formulation
-----------
The layer 0 <= z <= h (z into the tread, surface z = 0, rigid belt at z = h) is an isotropic visco-elastic
solid with a complex Young's modulus E(omega) (exp(+i omega t), Im E >= 0) and a frequency-independent
Poisson's ratio, so that the stiffness scales with the modulus: K(omega) = E(omega) K_1 with K_1 the stiffness
for E = 1 Pa. K_1 and the consistent mass M are assembled once; each frequency solves

    (E(omega) K_1 - omega^2 M) u = f,

the static case (omega = 0) with the material's quasi-static modulus. The load f is a uniform normal pressure
1 / c^2 [Pa per N] on the loaded element [-c/2, c/2]^2, pushing into the layer (+z); the output is u_z at the
centres of the surface elements (i c, j c) (point values from skfem's ``probes``), i.e. exactly greens'
convention (displacement at the field element's centre, not its average; force spread uniformly over the
loaded element), so g_FE = u_z [m/N] per unit force.

Element: displacement-based Galerkin with 27-node triquadratic (``hex2``, skfem ElementHex2) or 20-node
serendipity (``hexs2``) hexahedra, 3 x 3 x 3 Gauss points (exact for the stiffness and mass integrands on the
axis-aligned boxes used; skfem's default order for Hex2 is 7 points per direction and cost 580 s instead of 31 s
for 1296 elements). At nu = 0.49 (lambda / mu = 49) trilinear hexahedra lock: ``hex1`` on a 0.25 mm mesh is
14 % too stiff at the excitation element (6-14 % at the neighbours), against 1.4 % at nu = 0.3 on the same mesh.
The quadratic elements do not lock outright but converge more slowly at nu = 0.49 than at 0.3 (Hex S2 at
0.25 mm: 0.1 % at nu = 0.3, 0.6 % at 0.49). Selective reduced integration of the lambda div u div v term
(``volumetric="reduced"``: 2 x 2 x 2 points for it, the shear term fully integrated, so no zero-energy modes)
removes most of that once the loaded quarter element has at least 2 x 2 elements (Hex S2, 0.25 mm: -0.21 /
+0.23 / -0.06 % instead of -0.59 / +0.74 / -0.33 % at (0,0) / (1,0) / (1,1)), but is 6-7 % off when it is a
single element (0.5 mm). Default: Hex S2 with reduced volumetric integration, 0.25 mm at the load.

Assembly with scikit-fem (``asm`` of scalar forms): the vector operator is combined from the nine scalar
derivative matrices S_pq = int d_p phi_j d_q phi_i (:func:`elasticity_matrices`); this equals skfem's vector
``linear_elasticity`` form to round-off (tests) and is about 15x faster (2 s instead of 31 s for 1296 Hex2
elements), because skfem's vector form evaluates the tensor algebra for every one of the (3 x 27)^2 basis pairs.

Boundary conditions and cell
----------------------------
The quarter cell [0, L/2] x [0, L/2] x [0, h] with the load's centre at the corner: u = 0 at z = h; on all four
lateral faces the symmetry (roller) condition, zero normal displacement and zero tangential traction
(u_x = 0 at x = 0 and x = L/2, u_y = 0 at y = 0 and y = L/2); top traction-free except the loaded quarter
element (1/4 N on the quarter, which gives the full cell's displacement). The mirror planes at x = 0 and
x = L/2 make this exactly the laterally infinite layer under a periodic array of the load with period L in x and
y: the periodic cell, with the load's quarter symmetry used (1/4 of the unknowns). :func:`periodic_images` sums
the analytic kernel over these images, which separates the discretisation error (FE against the image sum) from
the cell-size error (image sum against the single load). Image effects of the analytic kernel, relative to g at
the offset, for the tread preset (h = 10 mm, nu = 0.49; |.| in %):

    period   static (0,0) (1,0) (2,0) (3,0)     5 kHz (0,0) (1,0) (1,1) (2,0) (3,0)
    40 mm           0.10  0.39  1.00  2.0             0.44  1.56  2.32  3.54  6.1
    60 mm           0.016 0.06  0.16  0.32            0.19  0.68  1.00  1.53  2.7
    80 mm           0.003 0.01  0.03  0.06            0.10  0.36  0.53  0.81  1.4

The static kernel of a bonded layer decays exponentially (its compliance is analytic at k = 0), so the static
images are negligible beyond a few h; at 1 kHz the images are as small as static ones, but above the first
thickness resonance (about 4 kHz) the layer carries guided waves, damped only by the material loss (eta 0.29 at
5 kHz): the images fall slowly with the period. No absorbing layer was built; the default period is 80 mm
(``half_width`` 40 mm), which the graded mesh makes cheap (the outer 20 mm add about 4 coarse elements per
lateral direction), and the 5 kHz neighbours carry the image error of the table above.

Mesh: tensor-product, graded (:func:`axis_nodes`): spacing ``fine`` (a divisor of c/2, so that the loaded
element's edges are mesh planes) up to ``fine_extent`` from the load's centre (laterally) and below the surface,
then growing by ``growth`` up to ``coarse``. At 5 kHz the shear wavelength is about 34 mm, resolved by 4 mm
quadratic elements.

Solver: SuperLU (scipy ``splu``) of the complex symmetric matrix in a geometric nested-dissection order of the
nodes (:func:`nested_dissection`, each node's three DOFs together), with diagonal pivots (``diag_pivot_thresh``
0, ``SymmetricMode``): SuperLU's own COLAMD gave 150 M factor entries and 56 s (MMD on A^T + A: 360 M, 570 s) for
a 34 k-DOF static Hex2 matrix that nested dissection factors with 38 M entries in 5 s. One factorisation per
frequency.

Measured accuracy and cost (benchmarks/fe_layer_convergence.py; tread preset, period 80 mm; one core of a shared
machine). The reference itself was checked while building this: its H0(k) against a numerical boundary-value
solve of the plane-strain layer equations (1e-13), and its image sum against a 2-D FFT of H0 P (0.03 %).

Hex2, full integration, three meshes refined towards the load (fine spacing 0.5 / 0.25 / 0.125 mm over 4 fine
elements, growth 1.5, 4 mm far field):

    mesh (fine)     free DOFs  assembly  LU entries  peak RSS  factor+solve static / complex
    A (0.5 mm)         63 630     5.0 s      96 M      4.5 GB    18 s / 48-62 s
    B (0.25 mm)        87 098     5.3 s     153 M      6.8 GB    32 s / 92-101 s
    C (0.125 mm)      126 854     5.5 s     256 M     11.2 GB   112 s / 124-204 s

    |g_FE / g - 1| [%] against the infinite layer (in brackets: against the image sum, i.e. discretisation only,
    where they differ by more than 0.05)
    f        mesh   (0,0)         (1,0)         (1,1)         (2,0)
    static   A      0.16          0.85          1.23          0.20
             B      0.49          0.46          0.40          0.39
             C      0.06          0.25          0.33          0.17
    100 Hz, 1 kHz:  the static numbers within 0.01
    5 kHz    A      0.12 (0.18)   1.05 (0.73)   0.70 (1.05)   0.92 (0.12)
             B      0.40 (0.48)   0.71 (0.38)   0.33 (0.36)   1.05 (0.27)
             C      0.07 (0.06)   0.54 (0.21)   0.35 (0.30)   0.91 (0.11)

Signs (static): A -0.16 / +0.87 / -1.22 / +0.23, B -0.49 / +0.47 / -0.38 / +0.42 (the base mesh's small
excitation-element error is a cancellation; the neighbours converge). At 5 kHz the remaining neighbour error
is the 80 mm period's images (0.4-0.8 %), not the mesh.

Hex S2 with selective reduced integration (``volumetric="reduced"``), same three meshes; the default
:class:`CellMesh` is mesh B:

    mesh (fine)     free DOFs  assembly  LU entries  peak RSS  factor+solve static / complex
    A (0.5 mm)         32 112     2.6 s      49 M      2.4 GB     8 s / 14 s
    B (0.25 mm)        43 934     4.0 s      76 M      3.8 GB    17 s / 27-29 s
    C (0.125 mm)       63 934     3.7 s     129 M      6.0 GB    30 s / 55-63 s

    g_FE / g - 1 [%] against the infinite layer (static signed, FRF |.|; in brackets: against the image sum)
    f        mesh   (0,0)         (1,0)         (1,1)         (2,0)
    static   A     -5.72          +7.08         -2.17         -0.02
             B     -0.22          +0.25         -0.10         +0.15
             C      0.00          +0.52         -0.09         -0.04
    100 Hz, 1 kHz:  the static magnitudes within 0.01
    5 kHz    A      5.43 (5.51)   6.55 (6.24)   1.40 (1.79)   0.81 (0.01)
             B      0.14 (0.21)   0.56 (0.23)   0.47 (0.07)   0.92 (0.14)
             C      0.10 (0.00)   0.79 (0.47)   0.48 (0.06)   0.80 (0.01)

(1,0) in mesh C: with the fine patch shrunk to 0.5 mm, x = 1 mm lies in 0.3-0.4 mm graded elements, coarser than
mesh B's 0.25 mm there; the refinement sequence refines the load's neighbourhood, not the first neighbour's.
With the fine patch kept at 1.5 mm on all meshes (``--fine-extent 0.0015``), Hex S2 reduced:

    mesh (fine)    DOFs  LU entries  RSS     static solve  static (0,0) (1,0) (1,1) (2,0)  5 kHz vs image sum
    A' (0.5 mm)   25 328     35 M    1.9 GB     6 s        -5.73 +7.06 -2.15 -1.19       5.5 6.2 1.8 0.9
    B' (0.25 mm)  63 934    129 M    6.0 GB    30 s        -0.21 +0.20 -0.08 +0.09       0.20 0.18 0.05 0.09
    C' (0.125 mm): killed by the OOM killer at 24 GB RSS (SuperLU, one core): beyond this machine.

The test mesh (tests/test_fe_layer.py: ``hexs2``, period 60 mm, 0.5 mm growing by 1.6 to 5 mm, 18.9 k DOFs,
assembly 2.6 s, static solve 7 s, complex 8-11 s): static -0.38 % (0,0), +0.81 % (1,0), -0.79 % (1,1), -0.24 %
(2,0); 5 kHz 0.41 / 1.06 / 1.14 / 1.56 % (0.38 / 0.74 / 0.62 / 0.14 % against the image sum).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

__all__ = ["CellMesh", "axis_nodes", "LayerCell"]


def axis_nodes(length: float, fine: float, fine_extent: float, growth: float, coarse: float) -> np.ndarray:
    """Graded 1-D node coordinates on [0, length].

    Parameters
    ----------
    length : float
        Length of the axis [m].
    fine : float
        Uniform spacing on [0, fine_extent] [m].
    fine_extent : float
        End of the uniformly fine part [m]; rounded to a multiple of ``fine``.
    growth : float
        Ratio of successive spacings beyond ``fine_extent`` (>= 1).
    coarse : float
        Largest spacing [m].

    Returns
    -------
    numpy.ndarray
        Increasing coordinates, first 0, last ``length`` [m].
    """
    if not (0 < fine <= coarse and fine_extent >= 0 and growth >= 1 and length > 0):
        raise ValueError("axis_nodes: need 0 < fine <= coarse, fine_extent >= 0, growth >= 1, length > 0")
    n_fine = int(round(min(fine_extent, length) / fine))
    x = list(np.arange(n_fine + 1) * fine)
    step = fine
    while x[-1] < length * (1 - 1e-9):
        step = min(step * growth, coarse)
        rest = length - x[-1]
        if rest <= step * 1.5:
            # finish with one or two equal intervals no longer than about step
            n = max(1, int(math.ceil(rest / step - 1e-9)))
            x.extend(x[-1] + rest * np.arange(1, n + 1) / n)
            break
        x.append(x[-1] + step)
    x = np.asarray(x)
    x[-1] = length
    return x


@dataclass(frozen=True)
class CellMesh:
    """Graded tensor-product hexahedral mesh of the quarter cell [0, L/2] x [0, L/2] x [0, h].

    Parameters
    ----------
    half_width : float
        Half the cell period, L / 2 [m] (the quarter cell's lateral size).
    fine : float
        Lateral and vertical node spacing near the loaded element [m]; must divide c / 2.
    fine_extent : float
        Lateral extent of the fine part (from the load's centre) and depth of the fine part below the surface [m].
    growth : float
        Spacing ratio beyond the fine part (>= 1).
    coarse : float
        Largest spacing [m].
    element : str
        ``"hex2"`` (27-node triquadratic), ``"hexs2"`` (20-node serendipity) or ``"hex1"`` (trilinear).
    volumetric : str
        ``"full"`` or ``"reduced"``: Gauss order of the lambda div u div v term (selective reduced integration,
        one point per direction fewer).
    """

    half_width: float = 40e-3
    fine: float = 0.25e-3
    fine_extent: float = 1e-3
    growth: float = 1.5
    coarse: float = 4e-3
    element: str = "hexs2"
    volumetric: str = "reduced"


_ELEMENTS = ("hex2", "hexs2", "hex1")
# Gauss order per element: exact for the stiffness and mass integrands on the axis-aligned boxes of the mesh
_INTORDER = {"hex2": 5, "hexs2": 5, "hex1": 3}


def _scalar_element(name: str):
    from skfem import ElementHex1, ElementHex2, ElementHexS2

    table = {"hex1": ElementHex1, "hex2": ElementHex2, "hexs2": ElementHexS2}
    if name not in table:
        raise ValueError(f"element must be one of {list(_ELEMENTS)}, got {name!r}")
    return table[name]()


def derivative_matrices(basis) -> list[list[sps.csr_matrix]]:
    """S[p][q][i, j] = int d_p phi_j d_q phi_i dV for the scalar basis (trial j, test i) [m].

    Nine skfem scalar assemblies; :func:`elasticity_matrices` combines them into the vector operator.
    """
    from skfem import BilinearForm, asm

    out = [[None] * 3 for _ in range(3)]
    for p in range(3):
        for q in range(3):
            if q < p:
                continue

            @BilinearForm
            def form(u, v, w, p=p, q=q):
                return u.grad[p] * v.grad[q]

            out[p][q] = asm(form, basis).tocsr()
    for p in range(3):
        for q in range(p):
            out[p][q] = out[q][p].T.tocsr()  # S[p][q][i, j] = S[q][p][j, i]
    return out


def elasticity_matrices(basis, poisson: float, density: float, volumetric_basis=None):
    """Stiffness for E = 1 Pa and mass of the isotropic solid on a scalar basis, component-major DOFs.

    With v = psi e_a (test) and u = phi e_b (trial), the bilinear form int 2 mu eps(u):eps(v) + lambda div u div v
    gives the block K_ab = mu delta_ab (S_xx + S_yy + S_zz) + mu S[trial d_a, test d_b] + lambda S[trial d_b,
    test d_a], all from skfem scalar assemblies (an order of magnitude faster than skfem's vector
    ``linear_elasticity`` form, which loops over (3 n)^2 basis pairs with tensor algebra; both agree to round-off,
    tests/test_fe_layer.py).

    Parameters
    ----------
    basis : skfem.Basis
        Scalar H1 basis.
    poisson : float
        Poisson's ratio [-].
    density : float
        Density [kg/m^3].
    volumetric_basis : skfem.Basis, optional
        The same scalar element with a lower Gauss order for the lambda div u div v term (selective reduced
        integration); default ``basis`` (full integration).

    Returns
    -------
    K_ref : scipy.sparse.csr_matrix
        Stiffness for Young's modulus 1 Pa [N/m / Pa], DOFs ordered (u_x of all nodes, u_y ..., u_z ...).
    M : scipy.sparse.csr_matrix
        Consistent mass [kg], same ordering.
    """
    from skfem import BilinearForm, asm
    from skfem.models.elasticity import lame_parameters

    lam, mu = lame_parameters(1.0, float(poisson))
    S = derivative_matrices(basis)
    V = S if volumetric_basis is None else derivative_matrices(volumetric_basis)
    lap = S[0][0] + S[1][1] + S[2][2]
    blocks = [[None] * 3 for _ in range(3)]
    for a in range(3):
        for b in range(3):
            blk = mu * S[a][b] + lam * V[b][a]
            if a == b:
                blk = blk + mu * lap
            blocks[a][b] = blk

    @BilinearForm
    def mass(u, v, w):
        return u * v

    m = asm(mass, basis) * float(density)
    K = sps.bmat(blocks, format="csr")
    M = sps.block_diag([m, m, m], format="csr")
    return K, M


def nested_dissection(points: np.ndarray, planes: tuple, leaf: int = 64) -> np.ndarray:
    """Geometric nested-dissection ordering of the nodes of a tensor-product hexahedral mesh.

    The box of vertex planes is split recursively at the vertex plane nearest the middle of its longest
    (in elements) axis; nodes on that plane separate the two halves (no element couples across it) and are
    numbered after both. SuperLU's own orderings do poorly on these 3-D matrices (COLAMD: 150 M factor
    entries and 56 s for 34 k DOFs; MMD on A^T + A: 360 M, 570 s).

    Parameters
    ----------
    points : numpy.ndarray
        Node coordinates, shape (3, n) [m].
    planes : tuple of numpy.ndarray
        Vertex coordinates of the tensor grid per axis [m].
    leaf : int
        Subsets with at most this many nodes are not split further.

    Returns
    -------
    numpy.ndarray
        Permutation of range(n) (elimination order).
    """
    tol = 1e-9 * max(float(np.ptp(p)) for p in planes)
    order = []

    def split(idx, lo, hi):
        spans = [hi[a] - lo[a] for a in range(3)]
        axis = int(np.argmax(spans))
        if idx.size <= leaf or spans[axis] < 2:
            order.append(idx)
            return
        k = (lo[axis] + hi[axis]) // 2
        xk = planes[axis][k]
        coord = points[axis, idx]
        sep = np.abs(coord - xk) < tol
        left = idx[(coord < xk) & ~sep]
        right = idx[(coord > xk) & ~sep]
        hi_l = list(hi)
        hi_l[axis] = k
        lo_r = list(lo)
        lo_r[axis] = k
        split(left, lo, hi_l)
        split(right, lo_r, hi)
        order.append(idx[sep])

    split(np.arange(points.shape[1]), [0, 0, 0], [len(p) - 1 for p in planes])
    perm = np.concatenate(order)
    assert perm.size == points.shape[1] and np.unique(perm).size == perm.size
    return perm


class LayerCell:
    """FE model of the flat layer's quarter cell: K_ref, M, load vector and surface probes, assembled once.

    Parameters
    ----------
    thickness : float
        Layer thickness h [m].
    poisson : float
        Poisson's ratio [-] (frequency independent).
    density : float
        Density [kg/m^3].
    element_size : float
        Surface element size c [m]; the loaded element is [-c/2, c/2]^2 at the origin.
    mesh : CellMesh
        Mesh layout.
    n_field : int, optional
        Surface element centres (i c, j c), 0 <= i, j <= n_field, at which the displacement is returned;
        default all within the quarter cell.
    """

    def __init__(self, thickness: float, poisson: float, density: float, element_size: float = 1e-3,
                 mesh: CellMesh = CellMesh(), n_field: int | None = None):
        from skfem import Basis, FacetBasis, LinearForm, MeshHex, asm

        t0 = time.perf_counter()
        self.thickness = h = float(thickness)
        self.poisson = float(poisson)
        self.density = float(density)
        self.element_size = c = float(element_size)
        self.layout = mesh
        if abs(round(c / 2 / mesh.fine) * mesh.fine - c / 2) > 1e-9 * c:
            raise ValueError("mesh.fine must divide element_size / 2 (the loaded element's edge is a mesh plane)")
        half = mesh.half_width
        xy = axis_nodes(half, mesh.fine, mesh.fine_extent, mesh.growth, mesh.coarse)
        z = axis_nodes(h, mesh.fine, mesh.fine_extent, mesh.growth, mesh.coarse)
        self.mesh = m = MeshHex.init_tensor(xy, xy, z)
        self.basis = sb = Basis(m, _scalar_element(mesh.element), intorder=_INTORDER[mesh.element])
        ns = sb.N
        if mesh.volumetric not in ("full", "reduced"):
            raise ValueError(f"mesh.volumetric must be 'full' or 'reduced', got {mesh.volumetric!r}")
        vb = None
        if mesh.volumetric == "reduced":
            vb = Basis(m, sb.elem, intorder=_INTORDER[mesh.element] - 2)
        self.K_ref, self.M = elasticity_matrices(sb, self.poisson, self.density, vb)
        tol = 1e-9 * c
        loaded = m.facets_satisfying(lambda x: (np.abs(x[2]) < tol) & (x[0] < c / 2 + tol) & (x[1] < c / 2 + tol))
        fb = FacetBasis(m, sb.elem, facets=loaded, intorder=_INTORDER[mesh.element])

        @LinearForm
        def pressure(v, w):
            # unit force over the c x c element, pushing into the layer (+z); the quarter carries 1/4 N
            return v / (c * c)

        self.f = np.zeros(3 * ns)
        self.f[2 * ns:] = asm(pressure, fb)  # [N]
        if not math.isclose(self.f.sum(), 0.25, rel_tol=1e-10):
            raise RuntimeError(f"load on the quarter element sums to {self.f.sum()} N, expected 0.25 N")

        def on(pred):
            return sb.get_dofs(pred).all()

        base = on(lambda x: np.abs(x[2] - h) < tol)
        fixed = np.unique(np.concatenate([
            base, base + ns, base + 2 * ns,
            on(lambda x: np.abs(x[0]) < tol), on(lambda x: np.abs(x[0] - half) < tol),  # u_x = 0
            ns + on(lambda x: np.abs(x[1]) < tol), ns + on(lambda x: np.abs(x[1] - half) < tol),  # u_y = 0
        ]))
        node_order = nested_dissection(sb.doflocs, (xy, xy, z))
        vec_order = (node_order[:, None] + ns * np.arange(3)[None, :]).ravel()  # the node's 3 DOFs together
        self.free = vec_order[~np.isin(vec_order, fixed)]
        n_max = int(math.floor(half / c + 1e-9))
        n = n_max if n_field is None else min(int(n_field), n_max)
        i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
        self.offsets = np.column_stack([i.ravel(), j.ravel()]) * c  # [m]
        pts = np.vstack([self.offsets.T, np.zeros(len(self.offsets))])
        P = sps.hstack([sps.csr_matrix((pts.shape[1], 2 * ns)), sb.probes(pts).tocsr()]).tocsr()
        self._P = P[:, self.free].tocsr()
        self._K = self.K_ref[self.free][:, self.free].tocsc()
        self._M = self.M[self.free][:, self.free].tocsc()
        self._f = self.f[self.free]
        self.assembly_time = time.perf_counter() - t0
        self.factor_nnz = 0

    @property
    def n_dofs(self) -> int:
        """Number of free degrees of freedom."""
        return int(self.free.size)

    def solve(self, modulus: complex, omega: float = 0.0) -> np.ndarray:
        """Surface displacement at the element centres for one frequency.

        Parameters
        ----------
        modulus : complex
            Young's modulus E(omega) [Pa] (exp(+i omega t), Im E >= 0); the quasi-static modulus for omega = 0.
        omega : float
            Angular frequency [rad/s].

        Returns
        -------
        numpy.ndarray
            g at :attr:`offsets`, shape (n,) [m/N]; real for a real modulus at omega = 0.
        """
        a = self._K * modulus
        if omega:
            a = a - (omega * omega) * self._M
        lu = spla.splu(a.tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
        self.factor_nnz = lu.L.nnz + lu.U.nnz
        u = lu.solve(self._f.astype(a.dtype))
        return self._P @ u

    def response(self, material, frequencies) -> np.ndarray:
        """Element FRF of the cell, static included, for a :class:`tyreroad.material.Material`.

        Parameters
        ----------
        material : tyreroad.material.Material
            Provides ``modulus(omega)`` [Pa] and ``quasi_static_modulus`` [Pa] (used at f = 0); its Poisson's
            ratio, density and thickness must be the cell's.
        frequencies : array_like
            Frequencies f >= 0 [Hz].

        Returns
        -------
        numpy.ndarray
            Complex g, shape (len(frequencies), len(offsets)) [m/N]: the normal displacement at the centre of
            the surface element at :attr:`offsets` per unit normal force on the loaded element.
        """
        for key, mine in (("poisson", self.poisson), ("density", self.density), ("thickness", self.thickness)):
            if not math.isclose(float(getattr(material, key)), mine, rel_tol=1e-12):
                raise ValueError(f"material {key} {getattr(material, key)} differs from the cell's {mine}")
        f = np.atleast_1d(np.asarray(frequencies, dtype=float))
        if np.any(f < 0):
            raise ValueError("frequencies must be >= 0")
        out = np.empty((f.size, len(self.offsets)), dtype=complex)
        for n, fn in enumerate(f):
            w = 2 * np.pi * fn
            e = material.quasi_static_modulus if fn == 0 else complex(np.ravel(material.modulus(w))[0])
            out[n] = self.solve(e, w)
        return out


def periodic_images(kernel, offsets, period: float, n_images: int = 8) -> np.ndarray:
    """Sum of an analytic kernel over the load's periodic images: what the quarter cell represents.

    Parameters
    ----------
    kernel : callable
        ``kernel(offsets)`` -> array (..., n) [m/N], e.g. a partial of :func:`tyreroad.greens.element_frf`.
    offsets : array_like
        Field offsets, shape (n, 2) [m].
    period : float
        Cell period L = 2 half_width [m].
    n_images : int
        Images (i L, j L) with |i|, |j| <= n_images are summed.

    Returns
    -------
    numpy.ndarray
        sum_ij kernel(offsets - (i L, j L)), same shape as ``kernel(offsets)``.
    """
    offsets = np.asarray(offsets, dtype=float).reshape(-1, 2)
    r = np.arange(-n_images, n_images + 1) * float(period)
    shifts = np.stack(np.meshgrid(r, r, indexing="ij"), -1).reshape(-1, 2)
    pts = (offsets[None, :, :] - shifts[:, None, :]).reshape(-1, 2)
    vals = np.asarray(kernel(pts))
    return vals.reshape(vals.shape[:-1] + (len(shifts), len(offsets))).sum(axis=-2)
