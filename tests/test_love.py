"""tyreroad.reference.love: Love's uniformly loaded rectangle on a half-space."""

import numpy as np
import pytest
from scipy import integrate

from tyreroad.reference import love

E = 7.0e6
NU = 0.3
Q = 2.0e5
C = 1.0e-3
UNIT = (1 - NU**2) * Q * C / E  # (1 - nu^2) q c / E


def test_square_centre_corner_mean_anchors():
    w_centre = love.rectangle_displacement(0.0, 0.0, C, C, Q, E, NU)
    w_corner = love.rectangle_displacement(C / 2, C / 2, C, C, Q, E, NU)
    w_mean = love.rectangle_mean_displacement(C, C, Q, E, NU)
    assert w_centre / UNIT == pytest.approx(1.12220, abs=1e-5)
    assert w_corner / UNIT == pytest.approx(0.56110, abs=1e-5)
    assert w_mean / UNIT == pytest.approx(0.94640, abs=1e-5)
    assert love.CENTRE_FACTOR == pytest.approx(1.12220, abs=1e-5)
    assert love.CORNER_FACTOR == pytest.approx(0.56110, abs=1e-5)
    assert love.MEAN_FACTOR == pytest.approx(0.94640, abs=1e-5)


def test_mean_equals_average_of_pointwise_solution():
    # midpoint rule over a fine grid of the loaded rectangle (the 1/r singularity is integrable, so
    # the pointwise field is smooth enough for a 1e-4 check)
    a, b = 1.0e-3, 2.5e-3
    n = 400
    x = (np.arange(n) + 0.5) / n * a - a / 2
    y = (np.arange(n) + 0.5) / n * b - b / 2
    w = love.rectangle_displacement(x[:, None], y[None, :], a, b, Q, E, NU)
    assert w.mean() == pytest.approx(love.rectangle_mean_displacement(a, b, Q, E, NU), rel=1e-4)


def test_rectangle_against_direct_quadrature_inside_and_outside():
    a, b = 1.0e-3, 2.0e-3
    for x0, y0 in [(0.2e-3, -0.3e-3), (1.7e-3, 0.4e-3), (-3.0e-3, 5.0e-3)]:
        direct, _ = integrate.dblquad(
            lambda eta, xi: 1.0 / np.hypot(x0 - xi, y0 - eta), -a / 2, a / 2, -b / 2, b / 2,
            epsabs=0, epsrel=1e-10,
        )
        assert love.rectangle_potential(x0, y0, a, b) == pytest.approx(direct, rel=1e-7)


def test_symmetry_and_far_field():
    w1 = love.rectangle_displacement(3e-3, 1e-3, C, C, Q, E, NU)
    for x, y in [(-3e-3, 1e-3), (3e-3, -1e-3), (1e-3, 3e-3)]:
        assert love.rectangle_displacement(x, y, C, C, Q, E, NU) == pytest.approx(w1, rel=1e-13)
    force = Q * C * C
    for r in [50 * C, 200 * C]:
        w = love.rectangle_displacement(r, 0.0, C, C, Q, E, NU)
        far = love.point_load_displacement(r, force, E, NU)
        # the square's quadrupole correction is O((c/r)^2)
        assert w / far == pytest.approx(1.0, abs=0.2 * (C / r) ** 2)
        assert far == pytest.approx((1 - NU**2) * force / (np.pi * E * r), rel=1e-14)


def test_complex_modulus_is_linear_in_compliance():
    e_complex = E * (1 + 0.3j)
    w = love.rectangle_displacement(2e-3, 0.5e-3, C, C, Q, e_complex, NU)
    w_real = love.rectangle_displacement(2e-3, 0.5e-3, C, C, Q, E, NU)
    assert w == pytest.approx(w_real / (1 + 0.3j), rel=1e-14)


def test_bad_input_raises():
    with pytest.raises(ValueError, match="sides"):
        love.rectangle_potential(0.0, 0.0, -1.0, 1.0)
    with pytest.raises(ValueError, match="r must be"):
        love.point_load_displacement(0.0, 1.0, E, NU)
