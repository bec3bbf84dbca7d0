"""Plain dense-matrix forms of the contact solver's sums: the obviously-correct references for tests.

The solver never forms these M x M matrices (:mod:`tyreroad.history`, :mod:`tyreroad.newton`);
the tests compare its fast sums against them.
"""

from __future__ import annotations

import numpy as np

from ..convolution import check_offset_kernel
from ..influence import offset_matrix

__all__ = ["lag_matrix", "dense_history_sum"]


def lag_matrix(kernel, lag: int) -> np.ndarray:
    """Dense M x M influence matrix of one lag: G[e, m] = g[e - m, lag] [m/N] (C-order elements)."""
    g = np.asarray(kernel, dtype=float)
    return offset_matrix(g[:, :, lag])


def dense_history_sum(kernel, force_history, n: int) -> np.ndarray:
    """History term h[n] = sum_{l=1}^{L-1} G_l F[n-l] with dense M x M matrices.

    Parameters
    ----------
    kernel : array_like
        g[dx, dy, lag] [m/N], shape (2 nx - 1, 2 ny - 1, L).
    force_history : array_like
        F[s, ex, ey] [N] for steps s = 0 ... >= n - 1 (forces before step 0 are zero).
    n : int
        Current step.

    Returns
    -------
    numpy.ndarray
        h[n] [m], shape (nx, ny).
    """
    f = np.asarray(force_history, dtype=float)
    if f.ndim != 3:
        raise ValueError(f"force_history: expected F[step, ex, ey], got shape {f.shape}")
    nx, ny = f.shape[1:]
    g = check_offset_kernel(kernel, nx, ny)
    h = np.zeros(nx * ny)
    for lag in range(1, min(g.shape[2] - 1, n) + 1):
        h += lag_matrix(g, lag) @ f[n - lag].ravel()
    return h.reshape(nx, ny)
