"""Hertz contact of a rigid paraboloid (sphere) on an elastic half-space: an analytic oracle.

A rigid paraboloid z = -r^2 / (2 R) pressed a depth delta into an elastic half-space of plane
strain modulus E* = E / (1 - nu^2) (or two elastic bodies with 1/E* = sum (1 - nu_i^2)/E_i)
makes a circular contact of radius a = sqrt(R delta) and carries

    F = 4/3 E* sqrt(R) delta^(3/2),   dF/d delta = 2 E* a.

The element springs of :mod:`tyreroad.springs` reproduce it when the overlap area is taken as the
true contact area pi R delta; with the geometric overlap area 2 pi R delta (the truncated
paraboloid, no sink-in) the same flat-punch construction gives sqrt(2) times the Hertz force
(:func:`geometric_overlap_force`, SPEC 4).

References
----------
Hertz, H. (1882). Ueber die Beruehrung fester elastischer Koerper. J. reine angew. Math. 92,
156-171. doi:10.1515/crll.1882.92.156
Johnson, K. L. (1985). Contact Mechanics, section 4.2. Cambridge University Press.
doi:10.1017/CBO9781139171731
"""

from __future__ import annotations

import numpy as np

__all__ = ["hertz_contact_radius", "hertz_force", "hertz_stiffness", "geometric_overlap_force"]


def _check(indentation, radius, effective_modulus=None):
    delta = np.asarray(indentation, dtype=float)
    if not np.isfinite(radius) or radius <= 0:
        raise ValueError(f"radius must be a finite number > 0 m, got {radius!r}")
    if effective_modulus is not None and (not np.isfinite(effective_modulus) or effective_modulus <= 0):
        raise ValueError(f"effective_modulus must be a finite number > 0 Pa, got {effective_modulus!r}")
    return np.maximum(delta, 0.0)


def hertz_contact_radius(indentation, radius: float) -> np.ndarray:
    """Hertz contact radius a = sqrt(R delta) [m].

    Parameters
    ----------
    indentation : array_like
        Indentation delta [m]; delta <= 0 gives 0.
    radius : float
        Radius of curvature R of the paraboloid tip [m].
    """
    return np.sqrt(radius * _check(indentation, radius))


def hertz_force(indentation, radius: float, effective_modulus: float) -> np.ndarray:
    """Hertz force F = 4/3 E* sqrt(R) delta^(3/2) [N].

    Parameters
    ----------
    indentation : array_like
        Indentation delta [m]; delta <= 0 gives 0.
    radius : float
        Radius of curvature R [m].
    effective_modulus : float
        Plane-strain modulus E* = E / (1 - nu^2) [Pa].
    """
    delta = _check(indentation, radius, effective_modulus)
    return 4.0 / 3.0 * effective_modulus * np.sqrt(radius) * delta**1.5


def hertz_stiffness(indentation, radius: float, effective_modulus: float) -> np.ndarray:
    """Hertz contact stiffness dF/d delta = 2 E* a = 2 E* sqrt(R delta) [N/m]."""
    delta = _check(indentation, radius, effective_modulus)
    return 2.0 * effective_modulus * np.sqrt(radius * delta)


def geometric_overlap_force(indentation, radius: float, effective_modulus: float) -> np.ndarray:
    """Force of the equivalent flat punch with the geometric overlap area 2 pi R delta [N].

    k = 2 E* sqrt(A / pi) = 2 E* sqrt(2 R delta), integrated: sqrt(2) times :func:`hertz_force`.
    """
    return np.sqrt(2.0) * hertz_force(indentation, radius, effective_modulus)
