"""Figures of the study (matplotlib, Agg backend, PNG).

``surface`` (fig 4), ``springs``, ``greens`` (figs 2-3) and ``study`` (figs 5-8).
"""

import logging
from pathlib import Path

import matplotlib

matplotlib.use("Agg")


def save_png(fig, path, logger: logging.Logger) -> Path:
    """Write ``fig`` to ``path`` as a 150 dpi PNG through a temporary file (:func:`tyreroad.io.atomic_path`: no
    partial figure is left on failure), close it and log the path on ``logger`` (the figure module's)."""
    import matplotlib.pyplot as plt

    from ..io import atomic_path

    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=150, format="png")
    plt.close(fig)
    logger.info("wrote %s", path)
    return path
