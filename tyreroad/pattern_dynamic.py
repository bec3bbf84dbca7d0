r"""Dynamic runs on a patterned tread: the block's modal form as a Radau IIA-3 stage kernel (issue 27).

A tread block's response is not translation invariant, so the layer's offset tables (:mod:`tyreroad.kernel`)
cannot carry it, and a table of N x N matrices per lag (N = the block's elements) would need N² L numbers
(330 MB for a 20 mm block at L = 256, 5.2 GB for a 40 mm block). The block's FE model gives the response in
modal form instead (:class:`tyreroad.fe_pattern.BlockModes`: K(omega) = E(omega) K_1 for a frequency-independent
Poisson's ratio, K_1 phi = lambda M phi):

    G(s) = sum_k psi_k psi_k^T h_k(s) + R / E(s),      h_k(s) = 1 / (E(s) lambda_k + s^2),

with psi_k the mode's work-equivalent element loads (the element-mean displacement per unit element force:
the **mean** field, which makes G symmetric; the static tables of the quasi-static runs use the element-centre
displacement, see below), and R the static compliance of the modes left out at E = 1 Pa (exact at s = 0,
positive semi-definite). :class:`BlockModalForm` holds psi (N x K), lambda (K) and R (N x N): memory N K + N²
whatever the number of lags.

Time kernel: the Radau IIA-3 convolution quadrature of every scalar h_k and of 1 / E (:func:`modal_weights`;
:mod:`tyreroad.radau`, the layer's stage kernel :mod:`tyreroad.stage`), so that the stage block weights are

    W_l = sum_k psi_k psi_k^T (x) w_k[l] + R (x) c[l]      (w_k[l], c[l]: 3 x 3),

and beyond the kept lags the creep's exact Radau-CQ images with a spatial factor per output stage that makes a
held force relax to G(0) exactly (the layer's sum rule, :meth:`tyreroad.stage.StageTail.with_sum_rule`, here
with block matrices).

Stable for every spring, by construction: each h_k and 1 / E is the receptance of a passive system (s h_k(s)
and s / E(s) positive real), so for s in the right half-plane and e^{i phi} = s / |s|, Herm(e^{i phi} G(s)) =
sum_k psi_k psi_k^T Re(s h_k(s)) / |s| + R Re(s / E(s)) / |s| is positive semi-definite (definite with loss);
the Radau generating function's eigenvalues lie in Re s > 0 on and inside the unit circle, so I + S^(1/2)
G(Delta / h) S^(1/2) is nonsingular for springs S >= 0 equal at the three stages (the argument of
:mod:`tyreroad.stage`). That needs G symmetric, hence the mean field; :func:`form_margin` measures the margin
of the exact modal form, and :meth:`PatternStageKernel.truncation` what the kept lags and the tail cut off.

The march: a :class:`PatternStageKernel` is a :class:`tyreroad.kernel.LayerKernel` whose collaborators are
the stage substrate block by block (:class:`PatternStageSubstrate`, a dense 3 N_b x 3 N_b W_0 per block, the
loaded set solved directly) and the history in modal coordinates (:class:`PatternStageHistory`: per block the
modal forces q_k = psi_k^T F over the kept lags, K x 9 L per step, and the residual's R (x) c[l] on the block's
element forces) plus the tail (:class:`PatternTailHistory`); its :meth:`march_view` is the stage kernel's, so
the march itself is unchanged.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
import xarray as xr

from . import checks
from .history import HistorySum, _StepCounter
from .kernel import LayerKernel
from .pattern import PatchLayout, PatternKernel
from .radau import STAGES, radau_weights, stage_transfer
from .stage import StageDenseSubstrate, StageKernel, StageTail, StageTailRecursion

logger = logging.getLogger(__name__)

__all__ = ["BlockModalForm", "modal_weights", "PatternStageKernel", "PatternStageSubstrate",
           "PatternStageHistory", "PatternTailHistory", "form_margin", "DYNAMIC_FIELD"]

#: The displacement the dynamic block kernel gives per element: the element mean (symmetric G, see the module
#: docstring).
DYNAMIC_FIELD = "mean"


# --------------------------------------------------------------------------------------------
# the block's modal form
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class BlockModalForm:
    """G(s) = sum_k psi_k psi_k^T / (E(s) lambda_k + s^2) + R / E(s) over a block's N surface elements.

    Attributes
    ----------
    psi : numpy.ndarray
        (N, K) [1/sqrt(kg)]: the modes' element loads (M-orthonormal modes; psi_k^T F is the modal force).
    lam : numpy.ndarray
        (K,) [1/(Pa s^2)]: lambda_k, so that omega_k^2 = E lambda_k.
    residual : numpy.ndarray
        R (N, N) [Pa m/N]: the static compliance of the modes left out, at E = 1 Pa.
    static : numpy.ndarray
        (N, N) [Pa m/N]: the block's static compliance at E = 1 Pa (sum_k psi psi^T / lambda + R).
    density : float
        rho [kg/m^3] the lambdas are for (:meth:`with_density` rescales them).
    block_elements : (int, int)
        The block's elements along x and y (row-major index i n_y + j).
    classes : numpy.ndarray
        (K, 2) int: each mode's parity about the block's x and y mid-planes (+1 even, -1 odd).
    """

    psi: np.ndarray
    lam: np.ndarray
    residual: np.ndarray
    static: np.ndarray
    density: float
    block_elements: tuple
    classes: np.ndarray = field(default=None, repr=False)

    def __post_init__(self):
        psi, lam = np.asarray(self.psi, dtype=float), np.asarray(self.lam, dtype=float)
        n = math.prod(self.block_elements)
        if psi.ndim != 2 or psi.shape[0] != n or lam.shape != (psi.shape[1],):
            raise ValueError(f"BlockModalForm: expected psi (N, K) and lam (K,) for N = {n}, got {psi.shape} and "
                             f"{lam.shape}")
        if not np.all(lam > 0) or not np.all(np.isfinite(psi)):
            raise ValueError("BlockModalForm: lambda must be > 0 and psi finite")
        for name in ("residual", "static"):
            if np.shape(getattr(self, name)) != (n, n):
                raise ValueError(f"BlockModalForm: {name} must be ({n}, {n}), got {np.shape(getattr(self, name))}")
        checks.real("density", self.density, positive=True)

    @property
    def n_modes(self) -> int:
        return int(self.lam.size)

    @classmethod
    def from_modes(cls, modes) -> "BlockModalForm":
        """The full-block form of a :class:`tyreroad.fe_pattern.BlockModes` computed with ``field="mean"``.

        Each symmetry class's quarter-model mode is one mode of the whole block; its full N x N contribution is
        unfolded by the cell's own mirroring (:meth:`tyreroad.fe_pattern.BlockCell.influence`) and factorised
        (rank one, symmetric: checked).
        """
        if modes.field != DYNAMIC_FIELD:
            raise ValueError(f"BlockModalForm: expected modes of the {DYNAMIC_FIELD!r} field (symmetric G), got "
                             f"{modes.field!r}")
        cell = modes.cell
        n_x, n_y = cell.pattern.shape
        nqy = n_y - n_y // 2
        psi, lam, classes = [], [], []
        for cls_, (lam_c, p_phi, f_phi, _static) in modes.data.items():
            for k in range(lam_c.size):
                def responder(c, q, cls_=cls_, k=k, p_phi=p_phi, f_phi=f_phi):
                    if c != cls_:
                        return np.zeros((p_phi.shape[0], len(q)))
                    return np.outer(p_phi[:, k], f_phi[q, k])

                # one column of the mode's full N x N part psi psi^T, at the source where the quarter's load is
                # largest (quarter index (qx, qy) is block element (qx + n_x // 2, qy + n_y // 2)): psi itself
                qx, qy = divmod(int(np.argmax(np.abs(f_phi[:, k]))), nqy)
                source = (qx + n_x // 2) * n_y + qy + n_y // 2
                column = cell.influence(1.0, 0.0, [source], DYNAMIC_FIELD, responder=responder).real[:, 0]
                if not column[source] > 0:
                    raise ValueError(f"mode {k} of class {cls_}: no positive self term at element {source}")
                psi.append(column / math.sqrt(column[source]))
                lam.append(float(lam_c[k]))
                classes.append(cls_)
        psi = np.array(psi).T
        lam = np.array(lam)
        order = np.argsort(lam)
        psi, lam, classes = psi[:, order], lam[order], np.array(classes, dtype=int)[order]
        # the static solves BlockModes already made per class (P K_1^-1 F), unfolded: no second factorisation
        static = cell.influence(1.0, 0.0, None, DYNAMIC_FIELD,
                                responder=lambda c, q: modes.data[c][3][:, q]).real
        static = 0.5 * (static + static.T)
        residual = static - (psi / lam) @ psi.T
        return cls(psi, lam, 0.5 * (residual + residual.T), static, float(cell.density),
                   tuple(cell.pattern.shape), classes)

    def with_density(self, density: float) -> "BlockModalForm":
        """The same block of another density: lambda scales as 1 / rho (K_1 fixed, M proportional to rho)."""
        rho = checks.real("density", density, positive=True)
        return dataclasses.replace(self, lam=self.lam * self.density / rho, psi=self.psi * math.sqrt(self.density / rho),
                                   density=rho)

    def scalar_laplace(self, material):
        """s (n,) -> (n, K + 1): h_k(s) = 1 / (E(s) lambda_k + s^2) and, last, 1 / E(s)."""
        lam = self.lam

        def fn(s):
            s = np.asarray(s, dtype=complex)
            e = np.asarray(material.laplace_modulus(s), dtype=complex).reshape(s.shape)
            return np.concatenate([1.0 / (e[:, None] * lam[None, :] + (s * s)[:, None]), 1.0 / e[:, None]], axis=1)

        return fn

    def response(self, material, frequencies) -> np.ndarray:
        """G(i omega) [m/N], (n_f, N, N) complex (f = 0: the quasi-static modulus)."""
        f = np.atleast_1d(np.asarray(frequencies, dtype=float))
        out = np.empty((f.size,) + self.static.shape, dtype=complex)
        for i, fi in enumerate(f):
            w = 2 * math.pi * fi
            e = material.modulus_at(fi)
            out[i] = (self.psi / (e * self.lam - w * w)) @ self.psi.T + self.residual / e
        return out

    def natural_frequencies(self, material) -> np.ndarray:
        """sqrt(Re E(f) lambda) / 2 pi solved by fixed point [Hz] (undamped), ascending."""
        return np.sort(material.undamped_frequencies(self.lam))

    def to_dataset(self) -> xr.Dataset:
        """The form as the variables of a dynamic pattern greens file (docs/data_contracts.md)."""
        return xr.Dataset(
            {
                "mode_load": (("element", "mode"), self.psi,
                              {"units": "1/sqrt(kg)", "long_name": "mode's work-equivalent element loads psi_k"}),
                "mode_lambda": (("mode",), self.lam, {"units": "1/(Pa s2)", "long_name": "lambda_k: omega_k^2 = E lambda_k"}),
                "mode_class": (("mode", "axis"), self.classes,
                               {"units": "1", "long_name": "parity about the block's x and y mid-planes"}),
                "modal_residual": (("element", "source"), self.residual,
                                   {"units": "Pa m/N", "long_name": "static compliance of the modes left out, E = 1 Pa"}),
                "modal_static": (("element", "source"), self.static,
                                 {"units": "Pa m/N", "long_name": "block static compliance (element mean), E = 1 Pa"}),
            },
            attrs={"modal_density": self.density, "block_elements_x": self.block_elements[0],
                   "block_elements_y": self.block_elements[1], "modal_field": DYNAMIC_FIELD},
        )

    @classmethod
    def from_dataset(cls, ds: xr.Dataset) -> "BlockModalForm":
        """Read :meth:`to_dataset`'s variables."""
        if "mode_load" not in ds:
            raise ValueError(f"pattern greens {ds.attrs.get('pattern', '?')}/{ds.attrs.get('material', '?')}: no modal "
                             "form (mode_load); expected a file written with pattern.modes including dynamic")
        return cls(ds["mode_load"].transpose("element", "mode").values, ds["mode_lambda"].values,
                   ds["modal_residual"].transpose("element", "source").values,
                   ds["modal_static"].transpose("element", "source").values, float(ds.attrs["modal_density"]),
                   (int(ds.attrs["block_elements_x"]), int(ds.attrs["block_elements_y"])),
                   ds["mode_class"].transpose("mode", "axis").values)


def form_margin(form: BlockModalForm, material, sample_rate: float, n_theta: int = 256) -> dict:
    """The stability margin of the exact modal form on the Radau generating function's eigenvalues.

    min over theta in (0, pi] and the three eigenvalues s = d_i(e^{-i theta}) / h of
    lambda_min Herm(e^{i phi} G(s)) / lambda_max G(0) at the phase e^{i phi} = s / |s| (module docstring);
    > 0: I + S^(1/2) G S^(1/2) nonsingular for every spring S >= 0 equal at the stages. Also the smallest
    eigenvalue of the residual R relative to the static table's largest (>= 0 up to rounding).
    """
    from .radau import circle_laplace_points

    s = circle_laplace_points(n_theta, sample_rate)[1].ravel()
    values = form.scalar_laplace(material)(s)  # (n 3, K + 1)
    phase = s / np.abs(s)
    scale = float(np.linalg.eigvalsh(form.static)[-1]) / float(material.quasi_static_modulus)
    worst = math.inf
    for i in range(s.size):
        w = (phase[i] * values[i]).real
        herm = (form.psi * w[:-1]) @ form.psi.T + form.residual * w[-1]
        worst = min(worst, float(np.linalg.eigvalsh(herm)[0]) / scale)
    res = np.linalg.eigvalsh(form.residual)
    return {"margin": worst, "residual_min": float(res[0] / np.linalg.eigvalsh(form.static)[-1]),
            "min_real_part_s": float(s.real.min())}


# --------------------------------------------------------------------------------------------
# the Radau weights of the modal form
# --------------------------------------------------------------------------------------------
def modal_weights(form: BlockModalForm, material, sample_rate: float, n_lags: int) -> np.ndarray:
    """Radau IIA-3 CQ block weights of every h_k and of 1 / E: (L, 3, 3, K + 1), the last for the residual."""
    return radau_weights(form.scalar_laplace(material), int(n_lags), 1.0 / float(sample_rate))


def _stage_w0(form: BlockModalForm, weights0: np.ndarray) -> np.ndarray:
    """W_0 of the block, (3 N, 3 N) stage-major: sum_k psi_k psi_k^T w_k[0][i, j] + R c[0][i, j]."""
    n = form.psi.shape[0]
    out = np.empty((STAGES * n, STAGES * n))
    for i in range(STAGES):
        for j in range(STAGES):
            out[i * n:(i + 1) * n, j * n:(j + 1) * n] = (form.psi * weights0[i, j, :-1]) @ form.psi.T + \
                form.residual * weights0[i, j, -1]
    return out


# --------------------------------------------------------------------------------------------
# the march's collaborators
# --------------------------------------------------------------------------------------------
def _stage_index(index: np.ndarray, size: int) -> np.ndarray:
    """Stage-major positions of ``index`` in a vector of 3 ``size``."""
    return (np.arange(STAGES)[:, None] * size + np.asarray(index)[None, :]).ravel()


class PatternStageSubstrate:
    """W_0 of the patch, block by block: each block's loaded stage set solved directly
    (:class:`tyreroad.stage.StageDenseSubstrate`: one LU kept across corrections, loaded and unloaded springs
    as Woodbury columns on it, changed stiffnesses refined on it); grooved elements (never loaded) keep
    delta = -r."""

    def __init__(self, layout: PatchLayout, w0_block: np.ndarray):
        m = math.prod(layout.shape)
        n = math.prod(layout.geometry.block_elements)
        self._parts = []
        for idx, loc in layout.blocks:
            whole = loc.size == n and np.array_equal(loc, np.arange(n))
            # whole blocks share the one W_0 (read only; each keeps its own factors), cut blocks take their part
            rows = _stage_index(loc, n)
            self._parts.append((_stage_index(idx, m),
                                StageDenseSubstrate(w0_block if whole else w0_block[np.ix_(rows, rows)])))
        self.self_compliance = float(np.mean(np.diag(w0_block)))

    @property
    def factorisations(self) -> int:
        return sum(p.factorisations for _, p in self._parts)

    def instant(self, force: np.ndarray) -> np.ndarray:
        out = np.zeros(np.shape(force))
        for glob, part in self._parts:
            out[glob] = part.g0 @ force[glob]
        return out

    def begin_step(self) -> None:
        """Nothing to reset."""

    def correction(self, stiffness: np.ndarray, residual: np.ndarray, polish: bool) -> tuple[np.ndarray, int]:
        delta = -np.asarray(residual, dtype=float).copy()
        for glob, part in self._parts:
            if np.any(stiffness[glob]):
                delta[glob] = part.correction(stiffness[glob], residual[glob], polish)[0]
        return delta, 0

    def tangent(self, stiffness):
        raise NotImplementedError("the pattern stage substrate belongs to a dynamic kernel: no quasi-static tangent")


class PatternStageHistory:
    """sum_{l=1}^{min(n, L-1)} W_l F_{n-l} block by block, in modal coordinates (module docstring).

    Per block a doubled ring of the last L - 1 steps' modal forces q = F psi (3, K) and element forces (3, N_b),
    so that the lags of a step are one contiguous window (most recent first).
    """

    def __init__(self, layout: PatchLayout, form: BlockModalForm, weights: np.ndarray):
        self.m = math.prod(layout.shape)
        self.depth = weights.shape[0] - 1
        d = max(self.depth, 1)
        # per mode w_k[l][i, j] for l = 1 ... L - 1 as (K, 3, (L - 1) 3), and the residual's c[l] as (3, (L - 1) 3):
        # each step is then one batched matrix-vector product over a contiguous window of the rings
        self._wm = np.ascontiguousarray(weights[1:, :, :, :-1].transpose(3, 1, 0, 2).reshape(form.n_modes, STAGES, -1))
        self._wc = np.ascontiguousarray(weights[1:, :, :, -1].transpose(1, 0, 2).reshape(STAGES, -1))
        self._blocks = []
        for idx, loc in layout.blocks:
            psi = np.ascontiguousarray(form.psi[loc])
            res = np.ascontiguousarray(form.residual[np.ix_(loc, loc)])
            self._blocks.append((idx, psi, res, np.zeros((form.n_modes, 2 * d * STAGES)),
                                 np.zeros((2 * d, STAGES, idx.size))))
        self._pos = 0
        self._steps = _StepCounter()

    @property
    def nbytes(self) -> int:
        return sum(b[3].nbytes + b[4].nbytes for b in self._blocks) + self._wm.nbytes

    def record(self, n: int, force: np.ndarray) -> None:
        """Store the stage forces F_n [N], (3 M,) stage-major."""
        self._steps.check_record(n, "PatternStageHistory")
        if self.depth == 0:
            return
        f = np.asarray(force, dtype=float).reshape(STAGES, self.m)
        d = self.depth
        self._pos = (self._pos - 1) % d
        for idx, psi, _, ring_q, ring_f in self._blocks:
            fb = f[:, idx]
            q = fb @ psi
            for p in (self._pos, self._pos + d):
                ring_q[:, p * STAGES:(p + 1) * STAGES] = q.T
                ring_f[p] = fb

    def displacement(self, n: int) -> np.ndarray:
        """h_n [m], (3 M,) stage-major."""
        self._steps.check_displacement(n, "PatternStageHistory")
        out = np.zeros((STAGES, self.m))
        terms = min(n, self.depth)
        if terms == 0:
            return out.reshape(-1)
        lo, hi = self._pos, self._pos + terms
        wm = self._wm[:, :, : terms * STAGES]
        wc = self._wc[:, : terms * STAGES]
        for idx, psi, res, ring_q, ring_f in self._blocks:
            # modal: hist[k, i] = sum_{l, j} w_k[l][i, j] q_k[n - l, j]
            hist = np.matmul(wm, ring_q[:, lo * STAGES:hi * STAGES, None])[:, :, 0]  # (K, 3)
            resid = wc @ ring_f[lo:hi].reshape(terms * STAGES, -1)  # (3, N_b)
            out[:, idx] = (psi @ hist).T + resid @ res.T
        return out.reshape(-1)


class PatternTailHistory(StageTailRecursion):
    """Lags l >= L of the pattern's stage kernel (:class:`tyreroad.stage.StageTailRecursion`): stage i of h_n =
    T_i z_i block by block, T_i the tail's spatial factor of output stage i (an N x N block matrix)."""

    def __init__(self, layout: PatchLayout, tail: StageTail):
        super().__init__(tail, math.prod(layout.shape))
        shape_table = np.asarray(tail.shape_table)  # (N, N, 3)
        self._blocks = [(idx, [np.ascontiguousarray(shape_table[np.ix_(loc, loc)][:, :, i]) for i in range(STAGES)])
                        for idx, loc in layout.blocks]

    def _spatial(self, z: np.ndarray) -> np.ndarray:
        out = np.zeros((STAGES, self.m))
        for idx, mats in self._blocks:
            for i in range(STAGES):
                out[i, idx] = mats[i] @ z[i, idx]
        return out.reshape(-1)


# --------------------------------------------------------------------------------------------
# the kernel
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PatternStageKernel(LayerKernel):
    """The patterned tread's dynamic kernel (module docstring): a :class:`tyreroad.kernel.LayerKernel` whose march
    solves the three Radau stages per step on the block's modal form.

    Build it with :meth:`from_form`. ``lags`` holds the block centre's step-end self response per lag (an honest
    single-stage summary, as for :class:`tyreroad.stage.StageKernel`; the march does not use it).
    """

    layout: PatchLayout = field(default=None, repr=False)
    form: BlockModalForm = field(default=None, repr=False)
    weights: np.ndarray = field(default=None, repr=False)
    tail: StageTail | None = field(default=None, repr=False)
    quasi_static_modulus: float = float("nan")

    @classmethod
    def from_form(cls, layout: PatchLayout, form: BlockModalForm, material, sample_rate: float, n_lags: int = 256,
                  spectrum=None, name: str | None = None) -> "PatternStageKernel":
        """The kernel of ``material`` (E(s), density) on the patch ``layout`` from the block's modal form.

        Parameters
        ----------
        layout : tyreroad.pattern.PatchLayout
        form : BlockModalForm
            Rescaled to the material's density here.
        material : tyreroad.material.Material
        sample_rate : float
            fs [Hz].
        n_lags : int
            L, the kept block weights.
        spectrum : tyreroad.memory.RetardationSpectrum, optional
            The creep fit of 1 / E (default :func:`tyreroad.memory.fit_retardation_spectrum` up to fs / 2).
        """
        from .memory import fit_retardation_spectrum

        fs = checks.real("sample_rate", sample_rate, positive=True)
        n_lags = checks.integer("n_lags", n_lags, minimum=2)
        if tuple(form.block_elements) != tuple(layout.geometry.block_elements):
            raise ValueError(f"modal form of a {form.block_elements} block, layout of pattern "
                             f"{layout.geometry.name!r} with {layout.geometry.block_elements}")
        form = form.with_density(float(material.density))
        weights = modal_weights(form, material, fs, n_lags)
        e0 = float(material.quasi_static_modulus)
        if spectrum is None:
            spectrum = fit_retardation_spectrum(material, fs / 2)
        static = form.static / e0  # [m/N]
        tail = StageTail.from_spectrum(np.zeros((1, 1)), spectrum, fs, n_lags)
        if tail.r.size:
            # the spatial factor per output stage that makes a held force relax to G(0) exactly (the sum rule), from
            # the kept weights summed over lags and input stages in modal form
            sums = weights.sum(axis=(0, 2))  # (3, K + 1)
            kept = np.stack([(form.psi * sums[i, :-1]) @ form.psi.T + form.residual * sums[i, -1]
                             for i in range(STAGES)], axis=-1)  # (N, N, 3)
            tail = tail.with_kept_sums(kept, static)
            if np.shape(tail.shape_table)[:2] != static.shape:
                raise ValueError(f"{material.name}: the creep tail's held sums are not positive; no sum rule for the "
                                 "block's tail")
        else:
            tail = None
        centre = (form.block_elements[0] // 2) * form.block_elements[1] + form.block_elements[1] // 2
        self_lags = np.einsum("k,lk->l", form.psi[centre] ** 2, weights[:, 2, :, :-1].sum(axis=1)) + \
            form.residual[centre, centre] * weights[:, 2, :, -1].sum(axis=1)
        return cls(self_lags[None, None, :], False, fs, None, layout.geometry.element_size, None, None,
                   name or f"{material.name}/{layout.geometry.name} Radau IIA-3 modal", math.inf,
                   "radau-modal", layout=layout, form=form, weights=weights, tail=tail,
                   quasi_static_modulus=e0)

    @property
    def static_table(self) -> np.ndarray:
        """G(0) of the block [m/N] (element-mean field) at the material's quasi-static modulus."""
        return self.form.static / self.quasi_static_modulus

    needs_memory = StageKernel.needs_memory
    table = PatternKernel.table

    def collaborators(self, shape, settings, workers: int = 1, n_steps: int | None = None):
        """(:class:`PatternStageSubstrate`, :class:`PatternStageHistory` [+ :class:`PatternTailHistory`])."""
        if tuple(shape) != tuple(self.layout.shape):
            raise ValueError(f"{self.name}: the run's patch {tuple(shape)} differs from the patch placed on the "
                             f"pattern {tuple(self.layout.shape)}")
        if self.needs_memory(n_steps) and (self.tail is None or not settings.long_memory):
            raise ValueError(f"the run needs {n_steps} steps of memory but the kernel keeps {self.n_lags} lags and "
                             + ("solver.long_memory is off" if self.tail is not None else "has no creep tail"))
        substrate = PatternStageSubstrate(self.layout, _stage_w0(self.form, self.weights[0]))
        history = PatternStageHistory(self.layout, self.form, self.weights)
        if self.needs_memory(n_steps):
            logger.info("long memory: %s", self.tail.describe())
            history = HistorySum([history, PatternTailHistory(self.layout, self.tail)])
        return substrate, history

    march_view = StageKernel.march_view

    # ------------------------------------------------------------------ frequency domain and checks
    def block_transfer(self, frequencies) -> np.ndarray:
        """The march's own transfer from a harmonic force to the step's end value, block matrix (n_f, N, N)
        complex [m/N] (kept lags + tail; :func:`tyreroad.radau.stage_transfer`); the exact answer is
        :meth:`BlockModalForm.response`."""
        f = np.atleast_1d(np.asarray(frequencies, dtype=float))
        theta = 2 * np.pi * f / self.sample_rate
        z = np.exp(-1j * theta[:, None] * np.arange(self.weights.shape[0])[None, :])
        sym = np.einsum("fl,lijk->fijk", z, self.weights)  # (n_f, 3, 3, K + 1)
        scalar = stage_transfer(sym, f, self.sample_rate)  # (n_f, K + 1)
        out = np.einsum("nk,fk,mk->fnm", self.form.psi, scalar[:, :-1], self.form.psi) + \
            scalar[:, -1][:, None, None] * self.form.residual[None]
        if self.tail is not None:
            tail_scalar = stage_transfer(self.tail.block_symbol(theta), f, self.sample_rate)  # (n_f,): times T_3
            out = out + tail_scalar[:, None, None] * self.tail.shape_table[None, :, :, STAGES - 1]
        return out

    def relaxed(self) -> PatternKernel:
        """The static kernel of the same block (element-mean field) at the quasi-static modulus: what a
        quasi-static run beside the dynamic ones uses."""
        return PatternKernel.from_block(self.layout, self.static_table,
                                        name=f"{self.name} (relaxed)")

    def frequency_influences(self, frequencies, shape, workers: int = 1) -> list:
        raise NotImplementedError(f"{self.name}: K*(f) on a pattern is tyreroad.pattern_spectrum's")

    def backing_force(self, force) -> np.ndarray:
        raise NotImplementedError(f"{self.name}: the force at the belt under a block is not modelled (the block's "
                                  "base reaction needs its modal participation)")


# --------------------------------------------------------------------------------------------
# runs and the study of the dynamic pattern runs
# --------------------------------------------------------------------------------------------
def kernel_from_modes(modes: xr.Dataset, material, shape, origin=(0.0, 0.0), sample_rate: float = 51200.0,
                      n_lags: int = 256) -> PatternStageKernel:
    """The dynamic kernel of ``material`` on a patch of ``shape`` placed at ``origin`` [m] from a modes file
    (:func:`tyreroad.pattern_stage.pattern_modes_dataset`).

    Raises
    ------
    ValueError
        If the material's thickness or Poisson's ratio differ from the file's (the modal form is for those).
    """
    from .pattern import PatternGeometry, place_pattern

    a = modes.attrs
    for key in ("thickness", "poisson"):
        if not math.isclose(float(getattr(material, key)), float(a[key]), rel_tol=1e-12):
            raise ValueError(f"modes file of pattern {a.get('pattern')!r}: {key} {float(a[key]):g} differs from material "
                             f"{material.name!r}'s {float(getattr(material, key)):g}; expected the same thickness and "
                             "Poisson's ratio (the modal form is computed for them)")
    layout = place_pattern(PatternGeometry.from_attrs(a), shape, origin)
    return PatternStageKernel.from_form(layout, BlockModalForm.from_dataset(modes), material, sample_rate, n_lags)


def solve_modal_run(surface: xr.Dataset, springs: xr.Dataset, modes: xr.Dataset, material, mode: str,
                    acceleration: float, settings, sample_rate: float, n_lags: int = 256, origin=(0.0, 0.0),
                    threads: int = 1):
    """One run on the block's modal form: ``dynamic`` (d = a t^2 / 2 up to ``settings.d_max`` at ``sample_rate``,
    the study's loading) or ``quasistatic`` (the uniform grid on the same form's relaxed table, element-mean field).

    Returns
    -------
    result : tyreroad.contact.ContactResult
    grooved : numpy.ndarray
        bool (nx, ny).
    info : dict
        ``elapsed`` (the march) [s], ``alternation`` (fs/2 alternation over the run's last 20 %, relative to the
        force there; NaN for quasi-static), ``max_spring_stiffness`` [N/m], ``natural_frequency`` (lowest) [Hz].
    """
    from .contact import run_loading_path
    from .loading import IndentationPath, constant_acceleration_path, uniform_indentation_grid
    from .pattern import groove_springs
    from .springs import SpringTable
    from .stability import fs2_alternation

    z1 = surface["z1"].transpose("ex", "ey").values
    c = surface.attrs.get("element_size")
    if c is not None and not math.isclose(float(c), float(modes.attrs["element_size"]), rel_tol=1e-9):
        raise ValueError(f"element_size differs: surface {float(c)} m, modes file {float(modes.attrs['element_size'])} m")
    kernel = kernel_from_modes(modes, material, z1.shape, origin, sample_rate, n_lags)
    table = SpringTable.from_dataset(springs)
    table = SpringTable.checked(table.stiffness, table.force, table.zeta_step, z1.size)
    grooved = kernel.layout.grooved
    table = groove_springs(table, grooved)
    start = time.perf_counter()
    if mode == "quasistatic":
        d = uniform_indentation_grid(settings.d_max, settings.quasistatic_step)
        result = run_loading_path(IndentationPath(z1, d), table, kernel.relaxed(), settings, threads)
        alternation = math.nan
    elif mode == "dynamic":
        t, d = constant_acceleration_path(float(sample_rate), float(acceleration), settings.d_max)
        result = run_loading_path(IndentationPath(z1, d, t), table, kernel, settings, threads)
        alternation = fs2_alternation(result.force)
    else:
        raise ValueError(f"mode: expected 'dynamic' or 'quasistatic', got {mode!r}")
    elapsed = time.perf_counter() - start
    k_max = float(np.max(table.stiffness))
    logger.info("%s %s a = %g m/s^2: %d steps in %.3g s, F(d_max) = %.5g N, fs/2 alternation %.2e", kernel.name, mode,
                acceleration, d.size, elapsed, result.force[-1], alternation)
    return result, grooved, {"elapsed": elapsed, "alternation": alternation, "max_spring_stiffness": k_max,
                             "natural_frequency": float(kernel.form.natural_frequencies(material)[0]),
                             "loss_scale": float(material.loss_scale), "density": float(material.density)}


def modal_contact_dataset(result, grooved, info: dict, mode: str, acceleration: float, surface_name: str,
                          material_name: str, pattern_name: str) -> xr.Dataset:
    """The contact file of a run on the modal form: the study's contact dataset (the backing force is not modelled
    on a block: NaN, said in ``backing_force_note``), the ``grooved`` mask and the run's checks."""
    from .pattern import pattern_contact_dataset

    if mode == "dynamic":
        result = dataclasses.replace(result, backing_force=np.full(np.shape(result.force), np.nan))
    path = "pattern: block-diagonal dense" + (" stages (Radau, modal)" if mode == "dynamic" else "")
    ds = pattern_contact_dataset(result, grooved, float(info["elapsed"]), surface_name, material_name, pattern_name,
                                 path, "modal", mode, acceleration)
    ds.attrs.update({"fs2_alternation": float(info["alternation"]),
                     "max_spring_stiffness": float(info["max_spring_stiffness"]),
                     "lowest_natural_frequency": float(info["natural_frequency"]),
                     "loss_scale": float(info.get("loss_scale", 1.0)), "density": float(info.get("density", math.nan)),
                     "kernel": "Radau IIA-3 stage kernel of the block's modal form (element-mean field); quasi-static: "
                               "its relaxed table",
                     "critical_stiffness": math.inf,
                     "backing_force_note": "not modelled on a block (NaN): the base reaction needs the modes' "
                                           "participation"})
    return ds


def dynamic_study(contacts: Sequence[xr.Dataset], modes: Sequence[xr.Dataset], study_settings) -> xr.Dataset:
    """K(d) and K_sat of the runs on the modal forms (the study's definitions, :mod:`tyreroad.study`), per
    material, pattern, mode and acceleration, with each run's fs/2 alternation and wall time and each pattern's
    modal check.

    Returns
    -------
    xarray.Dataset
        Dim ``case`` (``material/pattern/mode_accel``) and ``indentation``.
    """
    from .pattern import grid_variables, run_on_grid

    rows = []
    for i, ds in enumerate(contacts):
        src = str(ds.encoding.get("source", f"modal contact #{i}"))
        # K(d) is of the surface force; the backing force (NaN on a block: not modelled) is not read here, but
        # native_samples also differentiates it, so the surface force stands in for that unused column
        grid, k_sat = run_on_grid(ds.assign(backing_force=ds["force"]), src, study_settings)
        rows.append({"material": str(ds.attrs["material"]), "pattern": str(ds.attrs["pattern"]),
                     "mode": str(ds.attrs["mode"]), "accel": float(ds.attrs["acceleration"]), "grid": grid,
                     "k_sat": k_sat,
                     "alternation": float(ds.attrs.get("fs2_alternation", math.nan)),
                     "loss_scale": float(ds.attrs.get("loss_scale", 1.0)), "density": float(ds.attrs.get("density", math.nan)),
                     "time": float(ds.attrs["run_time_s"]), "steps": int(ds.sizes["step"])})
    by_pattern = {str(m.attrs["pattern"]): m for m in modes}

    def var(dims, values, units, long_name):
        return xr.Variable(dims, values, {"units": units, "long_name": long_name})

    labels = [f"{r['material']}/{r['pattern']}/{r['mode']}_{r['accel']:g}" for r in rows]
    data = {
        **grid_variables(rows),
        "fs2_alternation": var(("case",), np.array([r["alternation"] for r in rows]), "1",
                               "fs/2 alternation over the run's last 20 % relative to the force (NaN: quasi-static)"),
        "contact_time": var(("case",), np.array([r["time"] for r in rows]), "s", "wall time of the march"),
        "steps": var(("case",), np.array([r["steps"] for r in rows], dtype=np.int64), "1", "steps of the run"),
    }
    coords = {
        "case": ("case", labels, {"units": "1", "long_name": "material/pattern/mode_acceleration"}),
        "material": ("case", [r["material"] for r in rows], {"units": "1", "long_name": "tread material preset"}),
        "pattern": ("case", [r["pattern"] for r in rows], {"units": "1", "long_name": "pattern preset"}),
        "mode": ("case", [r["mode"] for r in rows], {"units": "1", "long_name": "run mode"}),
        "acceleration": ("case", [r["accel"] for r in rows], {"units": "m/s^2", "long_name": "indentation acceleration"}),
        "loss_scale": ("case", [r["loss_scale"] for r in rows], {"units": "1", "long_name": "material's loss scale"}),
        "density": ("case", [r["density"] for r in rows], {"units": "kg/m^3", "long_name": "material's density"}),
        "indentation": ("indentation", study_settings.grid, {"units": "m", "long_name": "indentation d"}),
    }
    out = xr.Dataset(data, coords=coords)
    names = sorted(by_pattern)
    out = out.assign_coords(modal_pattern=("modal_pattern", names, {"units": "1",
                                                                   "long_name": "pattern of a modal form"}))
    for key, units, long_name in (("modal_error", "1", "modal form against a direct FE solve at check_frequency"),
                                  ("check_frequency", "Hz", "frequency of the modal check"),
                                  ("modes_time_s", "s", "eigen-decomposition time"),
                                  ("compute_time_s", "s", "modes stage time (with the check)"),
                                  ("modal_bytes", "B", "memory of the modal form (psi, R, static)")):
        out[key] = var(("modal_pattern",), np.array([float(by_pattern[p].attrs[key]) for p in names]), units, long_name)
    out["lowest_natural_frequency"] = var(("modal_pattern",), np.array(
        [float(by_pattern[p]["natural_frequency"].values[0]) for p in names]), "Hz",
        "lowest undamped natural frequency of the block (the modes file's material)")
    out.attrs.update({"saturation_range_m": np.asarray(study_settings.saturation_range, dtype=float),
                      "kernel": "Radau IIA-3 stage kernel of the FE block's modal form (element-mean field), stable "
                                "for every spring; quasistatic_0: the same form's relaxed table"})
    return out
