"""tyreroad: time-domain contact between a visco-elastic tyre tread and a rough road.

Reproduces and extends Winroth, Andersson & Kropp, "Importance of tread inertia and damping on the
tyre/road contact stiffness", J. Sound Vib. 333 (2014), doi:10.1016/j.jsv.2014.06.014.

Modules, one per concept: ``surface`` (road patches), ``texture`` (ISO 13473 texture statistics),
``scans`` (measured scans), ``config`` (planning-time config checks), ``springs`` (element
contact springs), ``material`` (visco-elastic tread), ``layer`` (layer compliance), ``greens``
(element Green's functions), ``contact`` (time-stepping contact solver), ``study`` (aggregation),
``report`` (claims table), ``plots`` (figures), ``io`` (netCDF with provenance), ``pipeline``
(one function per workflow stage), ``reference`` (analytic oracles).
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("tyreroad")
except PackageNotFoundError:  # pragma: no cover
    __version__ = "unknown"


def open_study(path):
    """Open ``results/study.nc`` with selection by material, mode and acceleration.

    See :func:`tyreroad.study.open_study`.
    """
    from .study import open_study as _open_study

    return _open_study(path)


__all__ = ["__version__", "open_study"]
