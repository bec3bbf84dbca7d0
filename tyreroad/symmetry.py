r"""The reflection symmetry of a patch's influence matrices: four exact diagonal blocks instead of one matrix.

The layer is isotropic, so every offset table of a kernel (kept lags, tail, transfer function at any
theta, and the excitation element's correction, which sits at offset (0, 0)) is even in each offset:
g(dx, dy) = g(-dx, dy) = g(dx, -dy) (exactly, bit for bit, in the greens tables). The patch matrix
G[e, m] = g(e - m) then commutes with the reflections x -> nx - 1 - x and y -> ny - 1 - y of the patch,
and in the basis of functions even or odd under each reflection it is block diagonal:

    Q^T G Q = diag(G_ee, G_eo, G_oe, G_oo),   Q = Q_x (x) Q_y orthogonal,

with G_st of size m_s(nx) m_t(ny), m_even(n) = ceil(n / 2), m_odd(n) = floor(n / 2) (20 x 20: four 100 x 100
blocks). Per axis (n elements, i' = n - 1 - i), the even basis vectors are (e_i + e_i') / |.| for
i < ceil(n / 2) and the odd ones (e_i - e_i') / sqrt 2 for i < floor(n / 2); a 1-D Toeplitz t(i - k) becomes

    even: 2 (t(i - k) + t(i - k')) / (|v_i| |v_k|),      odd: t(i - k) - t(i - k'),

and the 2-D blocks are the tensor products of these folds. Q is real and orthogonal, so Herm(e^{i phi} G)
has exactly the spectrum of the four blocks' Herm(e^{i phi} G_st) together (lambda_min = min over blocks),
and positive definiteness of G + s I is that of every block: the patch margin's Cholesky certificates and
eigen-solves (:mod:`tyreroad.margin`, :func:`tyreroad.construction.patch_support`) run on the blocks at
1/16 of the cost, with the same spectrum of the whole patch matrix (Cauchy interlacing on contact sets
still applies to it).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse

__all__ = ["ReflectionBlocks", "is_reflection_even"]


def is_reflection_even(table: np.ndarray) -> bool:
    """True when a (..., 2 nx - 1, 2 ny - 1) offset table is exactly even in dx and in dy."""
    t = np.asarray(table)
    return bool(np.array_equal(t, t[..., ::-1, :]) and np.array_equal(t, t[..., :, ::-1]))


def _axis_fold(n: int, odd: bool):
    """(index into the offset axis of t(i - k), of t(i - k'), sign of the second, weight) for one axis."""
    m = n // 2 if odd else (n + 1) // 2
    i = np.arange(m)
    direct = i[:, None] - i[None, :] + n - 1  # offset i - k, shifted to a table index
    mirror = i[:, None] + i[None, :]  # offset i - (n - 1 - k) + n - 1
    if odd:
        return direct, mirror, -1.0, np.ones((m, m))
    norm = np.where(2 * i == n - 1, 2.0, np.sqrt(2.0))
    return direct, mirror, 1.0, 2.0 / np.outer(norm, norm)


class ReflectionBlocks:
    """The four reflection blocks of an (nx, ny) patch's influence matrices (see the module docstring).

    Parameters
    ----------
    shape : (int, int)
        Patch (nx, ny); blocks of zero size (a 1-element axis has no odd part) are left out.

    Attributes
    ----------
    sizes : list of int
        The blocks' sizes (their sum is nx ny).
    """

    def __init__(self, shape):
        nx, ny = (int(v) for v in shape)
        if nx < 1 or ny < 1:
            raise ValueError(f"patch shape must be positive, got {shape}")
        self.shape = (nx, ny)
        self._parts = []
        for odd_x in (False, True):
            fx = _axis_fold(nx, odd_x)
            for odd_y in (False, True):
                fy = _axis_fold(ny, odd_y)
                mx, my = fx[0].shape[0], fy[0].shape[0]
                if mx == 0 or my == 0:
                    continue
                # element (i, j) of the block numbered i my + j, as offset_matrix numbers the patch; the block
                # as a sparse map from the flattened (2 nx - 1) x (2 ny - 1) table (four terms per entry)
                m = mx * my
                weight = (fx[3][:, None, :, None] * fy[3][None, :, None, :]).reshape(-1)
                rows, cols, vals = [], [], []
                for ix, sx in ((fx[0], 1.0), (fx[1], fx[2])):
                    for iy, sy in ((fy[0], 1.0), (fy[1], fy[2])):
                        flat = ix[:, None, :, None] * (2 * ny - 1) + iy[None, :, None, :]
                        rows.append(np.arange(m * m))
                        cols.append(flat.reshape(-1))
                        vals.append(sx * sy * weight)
                fold = scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                                               shape=(m * m, (2 * nx - 1) * (2 * ny - 1)))
                self._parts.append((fold, m))
        self.sizes = [p[1] for p in self._parts]

    def blocks(self, table: np.ndarray) -> list[np.ndarray]:
        """The blocks Q^T G Q of the patch matrix of one (2 nx - 1, 2 ny - 1) offset table (real or complex),
        or, for a stack (..., 2 nx - 1, 2 ny - 1), stacks (..., m_b, m_b).

        The table must be even in dx and dy (:func:`is_reflection_even`); it is not checked here."""
        t = np.asarray(table)
        nx, ny = self.shape
        if t.shape[-2:] != (2 * nx - 1, 2 * ny - 1):
            raise ValueError(f"offset table {t.shape[-2:]} does not match the patch {self.shape}")
        lead = t.shape[:-2]
        flat = t.reshape((-1, t.shape[-2] * t.shape[-1]))
        if not lead:  # one table: one sparse product per block
            return [(fold @ flat[0]).reshape(m, m) for fold, m in self._parts]
        return [np.stack([fold @ row for row in flat]).reshape(lead + (m, m)) for fold, m in self._parts]
