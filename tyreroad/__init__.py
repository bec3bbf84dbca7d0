"""tyreroad: time-domain contact between a visco-elastic tyre tread and a rough road.

Reproduces and extends the study of :data:`SEED_REFERENCE` (Winroth, Andersson & Kropp, J. Sound
Vib. 2014), cited in one place: every module refers to this constant.

Modules, one per concept: ``surface`` (road patches), ``texture`` (ISO 13473 texture statistics),
``scans`` (measured scans), ``config`` (planning-time config checks), ``springs`` (element
contact springs), ``material`` (visco-elastic tread), ``layer`` (layer compliance), ``greens``
(element Green's functions), ``kernel`` (the layer kernel the solver uses, read once from a greens
file), ``influence`` (the influence operator G and the contact-set stiffness), ``contact``
(time-marching contact solver), with ``solver`` (its settings), ``loading`` (prescribed motions),
``history`` (displacement from past forces), ``memory`` (the creep beyond the kept lags),
``newton`` (the step solve), ``convolution`` (FFT sums), ``stiffness`` (K*(f; d0)), ``rolling``
(rolling contact), ``study`` (aggregation), ``report`` (claims table and report sections),
``plots`` (figures), ``io`` (netCDF with provenance), ``provenance`` (stage source hashes),
``pipeline`` (one function per workflow stage), ``reference`` (analytic oracles).
"""

from importlib.metadata import PackageNotFoundError, version

#: The study tyreroad reproduces. The DOI is left out on purpose: three different DOIs had been
#: cited in this code base and none could be checked against the publisher here; volume, issue
#: and pages agree in every source that gives them.
SEED_REFERENCE = (
    "Winroth, J., Andersson, P. B. U., & Kropp, W. (2014). Importance of tread inertia and damping on "
    "the tyre/road contact stiffness. Journal of Sound and Vibration 333(21), 5378-5385."
)

try:
    __version__ = version("tyreroad")
except PackageNotFoundError:  # pragma: no cover
    __version__ = "unknown"


def open_study(path):
    """Open ``results/study.nc`` with selection by material, mode and acceleration.

    See :func:`tyreroad.study.open_study`.
    """
    # deferred on purpose: ``import tyreroad`` stays light (no xarray, numba) for planning and
    # for the Snakemake adapters
    from .study import open_study as _open_study

    return _open_study(path)


__all__ = ["__version__", "SEED_REFERENCE", "open_study"]
