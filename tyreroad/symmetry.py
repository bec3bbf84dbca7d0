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

import math

import numpy as np
import scipy.sparse

__all__ = ["ReflectionBlocks", "is_reflection_even", "is_swap_symmetric", "patch_blocks", "fits", "strip_symbol_blocks",
           "strip_lambda_min"]


def is_reflection_even(table: np.ndarray) -> bool:
    """True when a (..., 2 nx - 1, 2 ny - 1) offset table is exactly even in dx and in dy."""
    t = np.asarray(table)
    return bool(np.array_equal(t, t[..., ::-1, :]) and np.array_equal(t, t[..., :, ::-1]))


def is_swap_symmetric(table: np.ndarray) -> bool:
    """True when a (..., 2 n - 1, 2 n - 1) offset table is exactly symmetric under dx <-> dy."""
    t = np.asarray(table)
    return t.shape[-1] == t.shape[-2] and bool(np.array_equal(t, np.swapaxes(t, -1, -2)))


def _swap_basis(m: int, sign: float):
    """Orthonormal basis (m^2 x k, sparse) of the m x m block's vectors with v[j, i] = sign v[i, j]."""
    rows, cols, vals = [], [], []
    k = 0
    for i in range(m):
        for j in range(i, m):
            if i == j:
                if sign > 0:
                    rows.append(i * m + i), cols.append(k), vals.append(1.0)
                    k += 1
                continue
            rows += [i * m + j, j * m + i]
            cols += [k, k]
            vals += [1 / np.sqrt(2.0), sign / np.sqrt(2.0)]
            k += 1
    return scipy.sparse.csr_matrix((vals, (rows, cols)), shape=(m * m, k))


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
    swap : bool
        A square patch whose tables are also symmetric under x <-> y (:func:`is_swap_symmetric`): the
        swap splits the even-even and odd-odd blocks into their swap-symmetric and -antisymmetric parts
        (m (m + 1) / 2 and m (m - 1) / 2) and maps the even-odd block onto the odd-even one (the same
        spectrum: only one is kept). 20 x 20: blocks 55, 45, 100, 55, 45 (2.6x less work than four of 100).

    Attributes
    ----------
    sizes : list of int
        The blocks' sizes (their sum is nx ny, less the odd-even block's with ``swap``).
    """

    def __init__(self, shape, swap: bool = False):
        nx, ny = (int(v) for v in shape)
        if nx < 1 or ny < 1:
            raise ValueError(f"patch shape must be positive, got {shape}")
        if swap and nx != ny:
            raise ValueError(f"the x <-> y swap needs a square patch, got {shape}")
        self.shape = (nx, ny)
        self.swap = bool(swap)
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
                if not swap:
                    self._parts.append((fold, m))
                elif odd_x == odd_y:  # swap-symmetric and -antisymmetric parts
                    for sign in (1.0, -1.0):
                        p = _swap_basis(mx, sign)
                        if p.shape[1]:
                            self._parts.append(((scipy.sparse.kron(p.T, p.T) @ fold).tocsr(), p.shape[1]))
                elif not odd_x:  # even-odd; odd-even has the same spectrum
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
        return [np.ascontiguousarray((fold @ flat.T).T).reshape(lead + (m, m)) for fold, m in self._parts]


def patch_blocks(tables: np.ndarray, shape) -> "ReflectionBlocks | None":
    """The finest :class:`ReflectionBlocks` a stack of (..., 2 nx - 1, 2 ny - 1) offset tables allows (swap too
    when the patch is square and the tables symmetric under dx <-> dy), or None if they are not even."""
    if not is_reflection_even(tables):
        return None
    return ReflectionBlocks(shape, swap=shape[0] == shape[1] and is_swap_symmetric(tables))


def fits(blocks: "ReflectionBlocks", tables: np.ndarray) -> bool:
    """Whether ``tables`` have the symmetry ``blocks`` were made for."""
    return is_reflection_even(tables) and (not blocks.swap or is_swap_symmetric(tables))


def strip_symbol_blocks(tables: np.ndarray, shape) -> list[tuple[np.ndarray, np.ndarray]]:
    r"""The strip bound's matrices: a patch's offset tables wrapped circularly along its long axis only.

    The patch matrix of an even offset table is block Toeplitz along the long axis (nx blocks of the short
    axis' ny x ny matrices A_m, m = dx, A_{-m} = A_m). It is the leading principal submatrix of the block
    circulant of the same blocks wrapped on 2 nx - 1, whose spectrum is that of the symbol's blocks
    A^_j = sum_m A_m exp(-2 pi i j m / (2 nx - 1)), j = 0 ... nx - 1 (j and 2 nx - 1 - j are equal), and,
    elementwise, Herm(e^{i phi} .) commutes with both steps. So (Cauchy interlacing)

        lambda_min Herm(e^{i phi} G_d) of the patch >= min_j lambda_min Herm(e^{i phi} A^_j),

    exact across the short axis (no truncated-offset symbol there, unlike the two-axis circulant bound) and
    conservative along the long one only, where the kept offsets reach the far end of the strip. Each A^_j is
    ny x ny Toeplitz and even, so it is split further into its even and odd blocks under the short axis'
    reflection (:mod:`tyreroad.symmetry`).

    Parameters
    ----------
    tables : numpy.ndarray
        (n, 2 nx - 1, 2 ny - 1) complex offset tables, even in dx and dy [m/N] (larger tables are cropped).
    shape : (int, int)
        Patch (nx, ny); the longer axis is wrapped.

    Returns
    -------
    list of (b, c)
        Re and Im of the even and the odd blocks (an axis of one element has no odd part), each
        (n, nx, m, m) for the long axis' nx wave numbers and the block size m [m/N].
    """
    nx, ny = (int(v) for v in shape)
    tables = np.asarray(tables)
    cx, cy = (tables.shape[1] - 1) // 2, (tables.shape[2] - 1) // 2
    crop = tables[:, cx - (nx - 1): cx + nx, cy - (ny - 1): cy + ny]
    if ny > nx:
        crop, nx, ny = np.swapaxes(crop, 1, 2), ny, nx
    n_wrap = 2 * nx - 1
    wrapped = np.zeros((crop.shape[0], n_wrap, 2 * ny - 1), dtype=complex)
    wrapped[:, np.arange(-(nx - 1), nx) % n_wrap] = crop
    symbol = np.fft.fft(wrapped, axis=1)[:, :nx]  # (n, nx, 2 ny - 1): the short-axis table of each wave number
    out = []
    for odd in (False, True):
        direct, mirror, sign, weight = _axis_fold(ny, odd)
        if direct.shape[0] == 0:
            continue
        block = weight * (symbol[:, :, direct] + sign * symbol[:, :, mirror])
        out.append((np.ascontiguousarray(block.real), np.ascontiguousarray(block.imag)))
    return out


def strip_lambda_min(parts, phi: float):
    """lambda_min Herm(e^{i phi} .) of the strip bound's matrices (:func:`strip_symbol_blocks`), the smallest over
    the wave numbers and the even and odd blocks: one value per table, (n,), or a scalar for blocks of one table
    ((nx, m, m)) [m/N]."""
    cp, sp = math.cos(phi), math.sin(phi)
    return np.min([np.linalg.eigvalsh(cp * b - sp * c)[..., 0].min(axis=-1) for b, c in parts], axis=0)
