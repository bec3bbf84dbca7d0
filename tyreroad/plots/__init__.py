"""Figures of the study (matplotlib, Agg backend, PNG).

``surface`` (fig 4), ``springs``, ``greens`` (figs 2-3) and ``study`` (figs 5-8).
"""

import matplotlib

matplotlib.use("Agg")
