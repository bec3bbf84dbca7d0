"""Rolling contact: a slick tyre rolling over the road strip (SPEC section 12).

A cylinder of radius R (a slick tyre without crown, its belt rigid, the axle at a fixed height)
rolls without slip at speed v along x over a road strip of nx x ny elements. In the road frame
the tread material in contact does not move sideways; its undeformed surface follows the belt,

    z2_e(t) = z_top - d0 + (x_e - x_c(t))^2 / (2 R),      x_c(t) = x_0 + v t,

(the parabolic approximation of the circle), so the free compression of spring e at step n is
z1_e - z2_e[n] = gap0_e + d0 - (x_e - x_c[n])^2 / (2 R), gap0 = z1 - z_top, z_top = max z1. This
is a :class:`RollingPass`, a loading of :mod:`tyreroad.loading`'s protocol: the march loop, the
Newton driver and the histories (kept lags and the long-memory tail) are those of
:mod:`tyreroad.contact`, unchanged.

Assumptions (stated as SPEC 12 asks):

* The layer keeps the Green's functions of a flat, laterally infinite layer. This is valid when
  the tread thickness h is small against the contact length 2a and both are small against R
  (default: h = 10 mm, 2a ~ 20 mm, R = 300 mm; the first inequality is only marginal, so the
  layer's curvature and the finite belt are neglected, not resolved).
* The tread layer is fixed in the road frame while in contact (no slip, no sideways motion).
* d0 (the axle height) is constant over the pass: it is set from a wheel load through a
  quasi-static solve with the contact centred on the strip (:func:`static_indentation`), or given.

Quantities of a pass (:func:`rolling_dataset`):

* total force F(t), contact count, pressure centre x_p = sum F_e x_e / F;
* the belt power P = sum_e F_e (-dz2_e/dt) = (v / R) sum_e F_e (x_e - x_c) (the force's moment
  about x_c, times v / R), and the work W = int P dt over the pass from first to last contact
  (trapezoid rule at the steps). Every road element passes under the whole contact once in a
  pass, so the rolled distance of the rolling-loss force W / dx is the strip length dx = nx c
  (not the distance from first to last contact, which adds the entry and exit);
* the steady part: x_c with the contact half-length a = sqrt(2 R d0) plus a margin of
  ``steady_margin`` elements fully on the strip; mean force, mean belt power / v (the steady
  rolling-loss force, a cross-check of W / dx);
* element forces at chosen instants (x_c at given fractions of the strip length);
* the 1/3-octave spectrum of the force fluctuation over the steady part (:func:`band_levels`).

Quasi-static passes solve static states at x_c on a grid of ``quasistatic_step`` that does not
depend on the speed (the speed only labels their time axis t = (x_c - x_0) / v), so that two speeds
give the same F(x_c): a quasi-static pass has no rate effect.

Modules, one per concept (every public name is re-exported here, so ``from tyreroad.rolling import
X`` works for each of them):

* :mod:`~tyreroad.rolling.settings`: :class:`RollingSettings` (config section ``rolling``);
* :mod:`~tyreroad.rolling.geometry`: the pass (:func:`contact_half_length`, :func:`pass_limits`,
  :func:`pass_positions`) and the belt as a loading, :class:`RollingPass`;
* :mod:`~tyreroad.rolling.recorder`: :class:`RollingRecorder` and its :class:`RollingResult`;
* :mod:`~tyreroad.rolling.run`: the run (:func:`static_indentation`, :func:`solve_rolling`,
  :func:`solve_rolling_run`);
* :mod:`~tyreroad.rolling.analysis`: work, steady part and spectra (:func:`belt_power`,
  :func:`pass_work`, :func:`steady_mask`, :func:`third_octave_centres`, :func:`band_levels`);
* :mod:`~tyreroad.rolling.dataset`: the file of a pass (:func:`rolling_dataset`) and the rolling
  study (:func:`aggregate_rolling`).

The markdown of the rolling study is a report section: :func:`tyreroad.report.rolling_section`.

References
----------
Winroth, Andersson & Kropp (2014), J. Sound Vib. 333(21), 5378-5385 (the contact model).
ANSI S1.11 / IEC 61260: base-10 one-third-octave band centres f_c = 1000 * 10^(k/10) Hz.
"""

from .analysis import band_levels, belt_power, pass_work, steady_mask, third_octave_centres
from .dataset import aggregate_rolling, rolling_dataset
from .geometry import RollingPass, contact_half_length, pass_limits, pass_positions
from .recorder import RollingRecorder, RollingResult
# _march is private; it stays importable from here because tests/test_rolling.py imported it from tyreroad.rolling
from .run import _march, solve_rolling, solve_rolling_run, static_indentation  # noqa: F401
from .settings import RollingSettings

__all__ = [
    "RollingSettings",
    "RollingPass",
    "RollingRecorder",
    "RollingResult",
    "contact_half_length",
    "pass_limits",
    "pass_positions",
    "static_indentation",
    "solve_rolling",
    "solve_rolling_run",
    "belt_power",
    "pass_work",
    "steady_mask",
    "rolling_dataset",
    "third_octave_centres",
    "band_levels",
    "aggregate_rolling",
]
