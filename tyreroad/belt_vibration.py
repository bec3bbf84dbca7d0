r"""Belt vibration of a rolling tyre: the belt's normal velocity near the contact from the element contact forces.

The belt and tread of :mod:`tyreroad.belt`: a pre-tensioned orthotropic plate belt on an elastic bed (ring of
circumference L in x, simply supported width W in y) behind the viscoelastic tread layer (thickness h), coupled
through the layer's two-port. Time convention exp(+i w t); SI units.

The belt under the tread
------------------------
For a surface pressure p(k, w) on the tread, the two-port [F0, F1] = K [u0, u1] (F0 = p, F1 = sigma_zz(h) the
force per area on the layer's base face in +z, K symmetric) with the belt pushing back, F1 = -Z u1, gives from
its second row K_10 u0 + (K_11 + Z) u1 = 0 and its first u0 = H_rigid (p - K_01 u1):

    u1 = -K_10 H_rigid p / (Z + K_11 - K_10 K_01 H_rigid) = +tau / (Z + K_b) p,

tau = -K_10 H_rigid, K_b = K_11 - K_10 K_01 H_rigid (:mod:`tyreroad.belt`), and u0 = (H_rigid + tau^2 / (Z + K_b)) p.
So the belt (= the tread base) moves by tau / (Z + K_b) per unit surface pressure, with the SAME sign as the
surface (tau -> 1 for long static waves: a pressure pushing the tread into the tyre pushes the belt inwards too).
Checked against a direct solve of the 2 x 2 system, K assembled from the two-port's two load cases (rigid base:
H_rigid, tau; driven base: K_b and the reciprocal u0), to 1e-10 (tests/test_belt_vibration.py).

Transfer: the ring-and-strip mode sum
-------------------------------------
:func:`belt_displacement_transfer` is the belt's normal displacement at a POINT offset (dx, dy) from a unit force
spread over one c x c tread-surface element on the belt centre line, the sum of
:func:`tyreroad.belt.belt_element_frf_correction_ring` with tau in place of tau^2:

    T(dx, dy, w) = (2 / (L W)) sum_{n in Z} sum_{m odd} sinc(kx_n c / 2) sinc(ky_m c / 2) tau / (Z + K_b)
                   cos(kx_n dx) cos(ky_m dy),   kx_n = 2 pi n / L, ky_m = m pi / W,

truncated at |kx|, ky <= k_max = extent x max(25 / h, 1.5 k_s + 20 / h) (the ring correction's rule; 4.8e4 modes
for the default tyre). tau decays like exp(-k h) (not exp(-2 k h) as tau^2), so the belt displacement needs more
modes than the surface correction; measured against k_max = 50 / h at 0-6 kHz and offsets 0-0.5 m: 25 / h leaves
< 2e-13 relative (15 / h: 2e-8, 10 / h: 1e-5). The response to sources off the centre line is taken as a function
of the offset alone (odd lateral modes, cos(ky dy)), as the ring correction does: exact for sources on the centre
line, an approximation for the strip's 20 mm of the 160 mm belt (the even modes' sin(ky y_e) sin(ky y) terms).

Cost. tau, K_b depend on |k| only; the exact two-port at every mode costs ~0.2 s per frequency (the reference,
``port_step=None``). With ``port_step`` they are interpolated (4-point Lagrange, mirrored at k = 0) from a uniform
|k| grid, and the modes below ``exact_below`` (where Z + K_b can nearly cancel) are evaluated exactly: with
step 0.02 / h and exact below 3 / h the transfer changes by < 5e-10 relative (0-6 kHz; step 0.05 / h: 2e-8), at
~2000 two-port evaluations per frequency instead of 4.8e4.

The frame and the moving observation points
--------------------------------------------
In the contact the tread material does not slip on the road, so the tread's and the belt's material frame is the
road frame (the belt's rotation is neglected, as the tread's is, :mod:`tyreroad.rolling`): the element forces
F_e(t) act at fixed material points x_e, and the belt's displacement field w(x, y, t) is a fixed-frame response,

    w(x, y, t) = sum_e int T(x - x_e, y - y_e, t - t') F_e(t') dt'.

The velocity of the belt material, v = dw/dt at fixed x, is observed at points that move with the contact,
x_obs(t) = x_c(t) + offset (e.g. 5 mm ahead of and behind the contact edges x_c +- a): v_obs(t) = v(x_obs(t), t).
This is the material velocity at the material point under the observation point, not the rate of change of
w(x_obs(t), t) (which would add v_c dw/dx).

:func:`belt_velocity_at_points`, in the frequency domain:

1. the force history, zero-padded by ``pad_time`` (default 0.25 s), is FFT'd in time; bins up to
   ``max_frequency`` (default 6 kHz) are kept, with a raised-cosine taper over its top 5 % (5.7-6 kHz: the
   5 kHz band ends at 5.62 kHz), so the result is band-limited and does not depend on where the bins fall;
2. the field along x at each observation y is a convolution of T with the forces: done in the modal domain
   (exact on the ring), sum_e cos(kx (x - x_e)) F_e = Re-part pairs of sum_e exp(-+ i kx x_e) F_e (matrix
   products), the lateral sum sum_m f_nm cos(ky (y - y_e)) per mode n, and the synthesis on a grid of x
   spacing c (``grid_spacing``) covering the observation tracks;
3. multiplied by i w and inverse-FFT'd per grid node, each time sample is interpolated (cubic Lagrange, 4 nodes) at
   x_obs(t_n).

Padding and wrap-around. The FFT makes the convolution circular: the response that the pad does not absorb wraps
to the start. The belt rings long: its tension-dominated modes carry the loss factor only on bending and bed
(eta_eff ~ 0.02 near 100-200 Hz: decay times of 0.05-0.1 s) and the fractional tread relaxes algebraically. Measured on
a 150 x 20 strip, 2000 steps at 51.2 kHz (contact 16 mm moving at 5 m/s, random element forces), against a 1 s pad:
the velocity differs by 3.6e-3 (0.1 s pad), 1.0e-4 (0.25 s) and 4e-6 (0.5 s) of its maximum, and the 1/3-octave
levels over the steady part by at most 0.54 dB, 0.006 dB and < 1e-5 dB (worst band 200 Hz). An exponential
window (damped FFT) would shorten the pad but needs T at complex frequency: the belt's constant loss factor
(1 + i eta) has no causal continuation (measured: 0.4 % errors), so it is not used.

Interpolation in x. With grid spacing c = 1 mm the cubic interpolation error is 2e-6 of the largest velocity on
the strip case below (0-6 kHz, against spacing c / 2; band levels > 98 dB below) and 4e-7 in the tests (12
elements with random forces, 0-2 kHz, against points that are grid nodes; c / 2: 1e-8).

Cost (150 x 20 elements, 2000 steps at 51.2 kHz, two observation points at one y, one core): 22-26 s with
the 0.25 s pad (1758 frequencies x 4.8e4 modes; 0.4 GB peak for the whole process including the 48 MB force
history); 12 s with 0.1 s, 49 s with 0.5 s. The cost is linear in the
number of frequencies (record + pad) x max_frequency and in the distinct observation y's.

Causality of the belt model. :class:`tyreroad.belt.BeltProperties`' loss factor is frequency independent, so Z is
not the transform of a causal operator (Z(-w) = conj Z(w) jumps at w = 0, Z(0) is complex): the time response
has a precursor and a creep that decay only algebraically, and a transfer at w = 0 is complex (the FFT's DC bin
keeps its real part). The rolling signals (forces zero at the start and end of a pass) and band levels are not
affected beyond the padding numbers above, but a 1e-6 "steady state after a switch-on" is reached only with a
damped belt or a loss-free belt on a lossy tread (tests).

Spectra: :func:`belt_vibration_spectra` (dB re 5e-8 m/s) and :func:`force_spectrum` (dB re 1 N, the rolling
study's force levels), both :func:`tyreroad.rolling.analysis.band_levels` over the steady part.

The element forces of every step come from :class:`tyreroad.rolling.recorder.RollingRecorder` with
``record_forces=True`` (``RollingResult.element_force``).

References
----------
Kropp, W. (1989), Structure-borne sound on a smooth tyre, Applied Acoustics 26, 181-192.
doi:10.1016/0003-682X(89)90084-7
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft
import scipy.sparse

from . import checks
from .belt import (BeltProperties, _element_inputs, _sinc, _two_port_numpy, belt_stiffness_terms, ring_modes,
                   ring_truncation)
from .rolling.analysis import band_levels, third_octave_centres

__all__ = [
    "VELOCITY_REFERENCE",
    "FORCE_REFERENCE",
    "belt_displacement_transfer",
    "belt_velocity_at_points",
    "belt_vibration_spectra",
    "force_spectrum",
]

#: Reference of the belt velocity levels [m/s]: 5e-8 m/s, about the particle velocity of a plane sound wave at
#: 0 dB SPL (20 uPa / (rho c) = 4.8e-8 m/s), the reference of tyre vibration levels (e.g. Kropp 1989).
VELOCITY_REFERENCE = 5e-8
#: Reference of the contact force levels [N] (the rolling study's force band levels, tyreroad.rolling.dataset).
FORCE_REFERENCE = 1.0


class _Modes:
    """The ring-and-strip modes |kx_n| <= k_max (n >= 0), ky_m <= k_max (odd m) and their frequency-free parts.

    ``base`` = (n = 0 ? 1 : 2) (2 / (L W)) sinc(kx c / 2) sinc(ky c / 2): the mode weight of a unit force spread over
    one c x c element on the belt centre line, paired +-n (cos) and projected on sin(ky y) (odd m only);
    ``elastic`` and ``tension``: Z(s) = phi(s) elastic + tension + m s^2 (phi the belt's loss factor on bending and
    bed, :meth:`tyreroad.belt.BeltProperties.laplace_stiffness_factor`).
    """

    def __init__(self, belt: BeltProperties, element_size: float, k_max: float):
        self.belt = belt
        self.k_max = k_max
        self.kx, self.ky, weight = ring_modes(belt, k_max)
        kxg, kyg = np.meshgrid(self.kx, self.ky, indexing="ij")
        self.k = np.hypot(kxg, kyg)
        self.base = weight * _sinc(0.5 * element_size * kxg) * _sinc(0.5 * element_size * kyg)
        self.elastic, self.tension = belt_stiffness_terms(kxg, kyg, belt)

    @property
    def size(self) -> int:
        return self.k.size

    def weights(self, s, tau, k_base):
        """Modal weights f_nm = base tau / (Z + K_b) [m/N] at Laplace frequencies s (n_f,) [rad/s] (s = i w on the
        frequency axis: Z = phi(s) elastic + tension + m s^2); tau and k_base (n_f, N_n, N_m)."""
        s = np.asarray(s)
        phi = self.belt.laplace_stiffness_factor(s)
        z = (phi[:, None, None] * self.elastic[None] + self.tension[None]
             + (self.belt.mass * s**2)[:, None, None])
        return self.base[None] * tau / (z + k_base)


def _two_port_s(k, s, modulus_s, poisson, density, thickness):
    """(tau, K_b [Pa/m]) of the tread layer at wavenumbers k [rad/m] and Laplace frequencies s [rad/s] (Re s >= 0).

    tyreroad.belt's two-port solver with e_s = -rho (s h)^2 / mu(s): at s = i w this is
    :func:`tyreroad.belt.layer_two_port` (rho (w h)^2 / mu); for Re s > 0 it is its analytic continuation (the
    principal roots keep Re a, Re b > 0 there, :func:`tyreroad.layer.laplace_compliance`), with E(s) the
    material's ``laplace_modulus``. k, s and modulus_s broadcast together.
    """
    mu = np.asarray(modulus_s, dtype=complex) / (2.0 * (1.0 + poisson))
    r = (1.0 - 2.0 * poisson) / (2.0 * (1.0 - poisson))
    e_s = -density * (np.asarray(s, dtype=complex) * thickness) ** 2 / mu
    _, tau, kb, _ = _two_port_numpy(np.asarray(k, dtype=float) * thickness, e_s, r)
    return tau, kb * mu / thickness


class _ExactPort:
    """tau, K_b of the two-port solver at every mode's |k| (the reference; ~0.2 s per frequency for the 4.8e4
    modes of the default tyre)."""

    def __init__(self, modes: _Modes, poisson, density, thickness):
        self.k = modes.k
        self.args = (poisson, density, thickness)

    def __call__(self, s, modulus):
        out = [_two_port_s(self.k, si, ei, *self.args) for si, ei in zip(s, modulus)]
        return np.array([o[0] for o in out]), np.array([o[1] for o in out])


class _GridPort:
    """tau, K_b at the modes' |k|: exactly below ``exact_below`` [rad/m], above it by 4-point Lagrange interpolation
    from a uniform |k| grid of step ``step`` [rad/m].

    tau and K_b are even, smooth functions of k (the tread's loss broadens its guided waves). The low modes, where
    Z + K_b can nearly cancel (the belt's free waves) and an interpolation error of K_b is amplified, are few and
    are evaluated exactly. The interpolation indices and weights depend on the modes only.
    """

    def __init__(self, modes: _Modes, poisson, density, thickness, step, exact_below):
        self.args = (poisson, density, thickness)
        k = modes.k.ravel()
        self.low = np.flatnonzero(k < exact_below)
        self.high = np.flatnonzero(k >= exact_below)
        self.k_low = k[self.low]
        q = k[self.high] / step
        i = np.floor(q).astype(np.int64)
        t = q - i
        top = int(i.max(initial=0)) + 3
        grid = np.abs(np.arange(-1, top, dtype=float)) * step  # grid index j <-> k = (j - 1) step, mirrored
        index = i[:, None] + np.arange(4)[None, :]  # nodes at k-units i - 1 ... i + 2
        coef = np.stack([-t * (t - 1.0) * (t - 2.0) / 6.0, (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
                              -(t + 1.0) * t * (t - 2.0) / 2.0, (t + 1.0) * t * (t - 1.0) / 6.0], axis=1)
        used = np.unique(index)  # evaluate the grid only where it is used
        self.grid = grid[used]
        self.matrix = scipy.sparse.csr_matrix(
            (coef.ravel(), np.searchsorted(used, index).ravel(), np.arange(0, 4 * q.size + 1, 4)),
            shape=(q.size, used.size))  # (high modes, grid nodes): the Lagrange weights
        self.shape = modes.k.shape
        self.size = k.size

    def __call__(self, s, modulus):
        s = np.asarray(s, dtype=complex)
        e = np.asarray(modulus, dtype=complex)
        k = np.concatenate([self.grid, self.k_low])
        out = []
        for g in _two_port_s(k[None, :], s[:, None], e[:, None], *self.args):
            g = np.atleast_2d(g)
            v = np.empty((len(s), self.size), dtype=complex)
            v[:, self.high] = (self.matrix @ g[:, :self.grid.size].T).T
            v[:, self.low] = g[:, self.grid.size:]
            out.append(v.reshape((len(s),) + self.shape))
        return tuple(out)


def _port(modes, poisson, density, thickness, port_step, exact_below=None):
    if port_step is None:
        return _ExactPort(modes, poisson, density, thickness)
    step = checks.real("port_step", port_step, positive=True)
    exact_below = 0.0 if exact_below is None else exact_below
    return _GridPort(modes, poisson, density, thickness, step, exact_below)


def belt_displacement_transfer(offsets, element_size, omega, modulus, poisson, density, thickness,
                               belt: BeltProperties, extent: float = 1.0, port_step: float | None = None,
                               exact_below: float | None = None):
    r"""Normal displacement of the belt [m/N] at offsets from a unit force on one tread-surface element.

    T(dx, dy, w) = (2 / (L W)) sum_n sum_{m odd} sinc(kx_n c / 2) sinc(ky_m c / 2) tau / (Z + K_b)
                   cos(kx_n dx) cos(ky_m dy)

    (module docstring): a unit normal force [N] spread uniformly over one c x c element of the tread SURFACE on the
    belt centre line, the belt's normal displacement [m] at the point (dx, dy) from the element centre (no element
    averaging at the field point), in the tread's z direction (into the tyre; the surface displacement's sign).
    Time convention exp(+i w t). tau / (Z + K_b) is the belt (tread-base) displacement per surface pressure,
    derived in the module docstring.

    Parameters
    ----------
    offsets : array_like
        Offsets (dx, dy) [m] of the field points from the loaded element's centre, (n, 2); dx circumferential
        (any distance: the ring is periodic in L), |dy| < W / 2.
    element_size : float
        Element size c [m].
    omega : array_like
        Angular frequencies [rad/s], >= 0.
    modulus : array_like
        Complex Young's modulus of the tread E(omega) [Pa], broadcastable with ``omega``.
    poisson, density, thickness : float
        Tread Poisson's ratio [-], density [kg/m^3], thickness h [m].
    belt : BeltProperties
        The belt (its circumference L and width W are used).
    extent : float
        k_max factor (>= 1) of the truncation k_max = extent x max(25 / h, 1.5 k_s + 20 / h).
    port_step : float, optional
        |k| step [rad/m] of the interpolated two-port (None: exact at every mode, ~0.2 s per frequency for the
        default tyre; 0.02 / h: < 5e-10 relative, ~40x faster).
    exact_below : float, optional
        With ``port_step``: modes with |k| below it [rad/m] are evaluated exactly (default 0: none; 3 / h used by
        :func:`belt_velocity_at_points`).

    Returns
    -------
    numpy.ndarray
        Complex T, shape (len(omega), n) [m/N].
    """
    offsets, c, omega, e_all, nu, rho, h, extent = _element_inputs(offsets, element_size, omega, modulus, poisson,
                                                                   density, thickness, belt, extent)
    if np.any(np.abs(offsets[:, 1]) >= 0.5 * belt.width):
        raise ValueError("offsets: lateral offsets must stay inside the belt (|y| < W / 2)")
    modes = _Modes(belt, c, ring_truncation(omega, e_all, nu, rho, h, extent))
    port = _port(modes, nu, rho, h, port_step, exact_below)
    ax, ay = np.abs(offsets[:, 0]), np.abs(offsets[:, 1])
    uy, inverse = np.unique(ay, return_inverse=True)
    cy = np.cos(np.outer(modes.ky, uy))  # (N_m, n_uy)
    cx = np.cos(np.outer(modes.kx, ax))  # (N_n, n_offsets)
    out = np.empty((omega.size, len(offsets)), dtype=complex)
    chunk = max(1, int(2**22 // max(modes.size, 1)))
    for s in range(0, omega.size, chunk):
        sl = slice(s, s + chunk)
        tau, kb = port(1j * omega[sl], e_all[sl])
        f = modes.weights(1j * omega[sl], tau, kb)  # (n_f, N_n, N_m)
        b = f @ cy  # (n_f, N_n, n_uy)
        for u in range(uy.size):
            cols = np.flatnonzero(inverse == u)
            out[sl, cols] = b[:, :, u] @ cx[:, cols]
    return out


def _lagrange4(x, x0, dx, n):
    """Indices (m, 4) and weights (m, 4) of 4-point (cubic) Lagrange interpolation at ``x`` on the uniform grid
    x0 + j dx, j = 0 ... n - 1 (nodes j - 1 ... j + 2 around the interval j <= q < j + 1, q = (x - x0) / dx)."""
    q = (np.asarray(x, dtype=float) - x0) / dx
    j = np.clip(np.floor(q).astype(np.int64), 1, n - 3)
    t = q - j
    index = j[..., None] + np.arange(-1, 3)
    coef = np.stack([-t * (t - 1.0) * (t - 2.0) / 6.0, (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
                     -(t + 1.0) * t * (t - 2.0) / 2.0, (t + 1.0) * t * (t - 1.0) / 6.0], axis=-1)
    return index, coef


def belt_velocity_at_points(force_history, element_x, element_y, sample_rate, observation_x, observation_y,
                            material, belt: BeltProperties, element_size, *, max_frequency: float | None = 6000.0,
                            pad_time: float = 0.25, extent: float = 1.0, port_step: float | None = None,
                            exact_below: float | None = None, grid_spacing: float | None = None,
                            displacement: bool = False, info: dict | None = None):
    r"""Normal velocity [m/s] of the belt at observation points moving with the contact, from the element forces.

    v_p(t_n) = dw/dt (x_obs_p(t_n), y_obs_p, t_n): the velocity of the belt material (time derivative at a fixed
    material point, the road frame = the tread's and belt's material frame) sampled where the observation point
    is at that step. w(x, y, t) = sum_e (T(. , y - y_e) * F_e)(x - x_e, t), T of :func:`belt_displacement_transfer`
    (positive into the tyre, the sense of the contact force on the tread). Frequency-domain method, padding,
    accuracy and cost: module docstring.

    Parameters
    ----------
    force_history : array_like
        F_e[n] [N], (n_steps, nx, ny): every element's contact force at every step (compressive > 0, pushing the
        tread into the tyre), e.g. ``RollingResult.element_force``.
    element_x, element_y : array_like
        Element centre positions [m], (nx,) and (ny,), in the road (material) frame; y relative to any origin
        (only y differences enter), the strip taken as centred on the belt.
    sample_rate : float
        Step rate f_s [Hz] (the steps are uniform in time).
    observation_x : array_like
        x_obs_p[n] [m], (n_points, n_steps) (or (n_steps,) for one point): each point's position at each step,
        e.g. x_c(t_n) + a + 5 mm (ahead of the contact) and x_c(t_n) - a - 5 mm (behind).
    observation_y : array_like
        y_obs_p [m], (n_points,), fixed; within W / 2 of every element row.
    material : tyreroad.material.Material
        The tread (``modulus(omega)``, ``poisson``, ``density``, ``thickness``).
    belt : BeltProperties
        The belt.
    element_size : float
        Element size c [m].
    max_frequency : float or None
        Highest frequency kept [Hz] (default 6000, raised-cosine taper over its top 5 %); None: up to f_s / 2.
    pad_time : float
        Zero padding after the record [s] (default 0.25: wrap-around 1e-4 of the largest velocity, 0.006 dB in the
        band levels; 0.5: 4e-6; module docstring).
    extent : float
        Mode-sum truncation factor (>= 1; :func:`belt_displacement_transfer`).
    port_step, exact_below : float, optional
        Two-port interpolation (default 0.02 / h and 3 / h [rad/m]: < 5e-10 relative on the transfer).
    grid_spacing : float, optional
        x spacing of the field grid [m] (default c; cubic interpolation error 2e-6 of the largest velocity at c
        on a rolling strip, 0-6 kHz; 16 times less at c / 2).
    displacement : bool
        Return the displacement w [m] instead of the velocity (the same path without the factor i w).
    info : dict, optional
        Filled with ``n_fft``, ``n_frequencies``, ``n_modes``, ``k_max`` [rad/m] and ``pad_samples``.

    Returns
    -------
    numpy.ndarray
        Belt velocity [m/s] (or displacement [m]), shape (n_points, n_steps).
    """
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
    force = np.asarray(force_history, dtype=float)
    if force.ndim != 3 or not np.all(np.isfinite(force)):
        raise ValueError(f"force_history: expected finite values of shape (n_steps, nx, ny), got {force.shape}")
    n_steps, nx, ny = force.shape
    ex = checks.finite_array("element_x", element_x, ndim=1)
    ey = checks.finite_array("element_y", element_y, ndim=1)
    if ex.size != nx or ey.size != ny:
        raise ValueError(f"element_x, element_y: expected {nx} and {ny} positions, got {ex.size} and {ey.size}")
    fs = checks.real("sample_rate", sample_rate, positive=True)
    obs_y = np.atleast_1d(checks.finite_array("observation_y", observation_y))
    obs_x = np.asarray(observation_x, dtype=float)
    if obs_x.ndim == 1:
        obs_x = obs_x[None, :]
    if obs_x.shape != (obs_y.size, n_steps) or not np.all(np.isfinite(obs_x)):
        raise ValueError(f"observation_x: expected finite values of shape ({obs_y.size}, {n_steps}) (one track per "
                         f"observation point), got {obs_x.shape}")
    if np.any(np.abs(obs_y[:, None] - ey[None, :]) >= 0.5 * belt.width):
        raise ValueError("observation_y: every observation point must lie within W / 2 of every element row")
    c = checks.real("element_size", element_size, positive=True)
    pad_time = checks.real("pad_time", pad_time, nonnegative=True)
    hx = c if grid_spacing is None else checks.real("grid_spacing", grid_spacing, positive=True)
    nu, rho, h = material.poisson, material.density, material.thickness
    port_step = 0.02 / h if port_step is None else port_step
    exact_below = 3.0 / h if exact_below is None else exact_below

    # time -> frequency: zero-padded real FFT, frequencies up to max_frequency kept (raised-cosine taper over
    # its top 5 %, so that the result does not depend on where the bins fall)
    n_fft = scipy.fft.next_fast_len(n_steps + int(math.ceil(pad_time * fs)), real=True)
    freq = np.fft.rfftfreq(n_fft, 1.0 / fs)
    taper = np.ones(freq.size)
    if max_frequency is not None:
        f_max = checks.real("max_frequency", max_frequency, positive=True)
        ramp = np.clip((freq - 0.95 * f_max) / (0.05 * f_max), 0.0, 1.0)
        taper = 0.5 * (1.0 + np.cos(math.pi * ramp))
    keep = int(np.count_nonzero(taper > 0.0))
    omega = 2.0 * math.pi * freq[:keep]
    spectrum = np.empty((keep, nx, ny), dtype=complex)
    per = max(1, int(2**22 // n_fft))  # elements per FFT batch (bounds the full-length temporaries)
    flat = force.reshape(n_steps, nx * ny)
    spec_flat = spectrum.reshape(keep, nx * ny)
    for s in range(0, nx * ny, per):
        spec_flat[:, s:s + per] = scipy.fft.rfft(flat[:, s:s + per], n=n_fft, axis=0)[:keep]
    del flat, spec_flat
    e_all = np.asarray(material.modulus(omega), dtype=complex)
    lap = 1j * omega  # s = i w: the modes' weights are written in s
    modes = _Modes(belt, c, ring_truncation(omega, e_all, nu, rho, h, extent))
    port = _port(modes, nu, rho, h, port_step, exact_below)
    phase_e = np.exp(-1j * np.outer(modes.kx, ex))  # (N_n, nx): exp(-i kx x_e)

    # one field grid per distinct observation y, covering its tracks (2 nodes beyond for the cubic)
    uy, which = np.unique(obs_y, return_inverse=True)
    grids = []
    for u in range(uy.size):
        track = obs_x[which == u]
        x0 = track.min() - 2.0 * hx
        n_grid = int(math.ceil((track.max() + 2.0 * hx - x0) / hx)) + 1
        xg = x0 + hx * np.arange(n_grid)
        grids.append((x0, n_grid, np.exp(1j * np.outer(xg, modes.kx)), np.cos(np.outer(modes.ky, uy[u] - ey))))
    fields = [np.zeros((keep, g[1]), dtype=complex) for g in grids]

    chunk = max(1, int(2**19 // max(modes.size, 1)))  # frequencies per batch: ~10 for the default tyre
    for s in range(0, keep, chunk):
        sl = slice(s, min(s + chunk, keep))
        tau, kb = port(lap[sl], e_all[sl])
        f = modes.weights(lap[sl], tau, kb)  # (n_f, N_n, N_m) [m/N]
        plus = phase_e @ spectrum[sl]  # (n_f, N_n, ny): sum_e exp(-i kx x_e) F_e
        minus = np.conj(phase_e) @ spectrum[sl]
        for u, (x0, n_grid, phase_g, cy) in enumerate(grids):
            g = f @ cy  # (n_f, N_n, ny): sum_m f_nm cos(ky (y - y_e))
            a_plus = np.einsum("fne,fne->fn", g, plus)
            a_minus = np.einsum("fne,fne->fn", g, minus)
            # cos(kx (x - x_e)) = (exp(i kx (x - x_e)) + exp(-i kx (x - x_e))) / 2
            fields[u][sl] = 0.5 * (a_plus @ phase_g.T + a_minus @ np.conj(phase_g).T)
    del spectrum

    out = np.empty((obs_y.size, n_steps))
    factor = taper[:keep] * (1.0 if displacement else lap)  # d/dt <-> i w
    for u, (x0, n_grid, _, _) in enumerate(grids):
        full = np.zeros((n_fft // 2 + 1, n_grid), dtype=complex)
        full[:keep] = fields[u] * factor[:, None]
        series = scipy.fft.irfft(full, n=n_fft, axis=0)[:n_steps]  # (n_steps, n_grid)
        for p in np.flatnonzero(which == u):
            index, coef = _lagrange4(obs_x[p], x0, hx, n_grid)
            out[p] = np.sum(series[np.arange(n_steps)[:, None], index] * coef, axis=1)
    if info is not None:
        info.update({"n_fft": n_fft, "n_frequencies": keep, "n_modes": modes.size, "k_max": modes.k_max,
                     "pad_samples": n_fft - n_steps})
    return out


def _levels(signal, sample_rate, mask, band_limits, reference):
    """Band levels of each row of ``signal`` over ``mask``: (centres [Hz], levels (n_rows, n_bands) [dB])."""
    x = np.asarray(signal, dtype=float)
    one = x.ndim == 1
    x = np.atleast_2d(x)
    fs = checks.real("sample_rate", sample_rate, positive=True)
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != x.shape[-1:]:
        raise ValueError(f"mask: expected {x.shape[-1]} flags (one per step), got shape {mask.shape}")
    lo, hi = (float(b) for b in band_limits)
    if not 0.0 < lo <= hi:
        raise ValueError(f"band_limits: expected 0 < low <= high [Hz], got {band_limits!r}")
    centres = third_octave_centres(lo, hi)
    levels = np.array([band_levels(row[mask], 1.0 / fs, centres, reference=reference) for row in x])
    return centres, (levels[0] if one else levels)


def belt_vibration_spectra(velocity, sample_rate, mask, band_limits=(100.0, 5000.0)):
    """1/3-octave band levels of the belt velocity over the steady part [dB re 5e-8 m/s].

    The velocity fluctuation (mean removed) of the steps in ``mask``, Hann-windowed, its periodogram summed over
    each band (:func:`tyreroad.rolling.analysis.band_levels`): L = 10 log10(v_band^2 / v_ref^2) with
    v_ref = :data:`VELOCITY_REFERENCE` = 5e-8 m/s (the velocity of a 0 dB plane sound wave; not ISO 1683's
    1e-9 m/s). Bands the record does not
    resolve (centre below 2 / T, or above the Nyquist frequency) are NaN.

    Parameters
    ----------
    velocity : array_like
        Belt velocity [m/s], (n_steps,) or (n_points, n_steps) (:func:`belt_velocity_at_points`).
    sample_rate : float
        Step rate [Hz].
    mask : array_like of bool
        (n_steps,): the steps of the steady part (:func:`tyreroad.rolling.analysis.steady_mask`).
    band_limits : tuple of float
        Lowest and highest band centre [Hz] (base-10 centres, :func:`tyreroad.rolling.analysis.third_octave_centres`).

    Returns
    -------
    centres : numpy.ndarray
        Band centres [Hz].
    levels : numpy.ndarray
        Band levels [dB re 5e-8 m/s], (n_bands,) or (n_points, n_bands).
    """
    return _levels(velocity, sample_rate, mask, band_limits, VELOCITY_REFERENCE)


def force_spectrum(force, sample_rate, mask, band_limits=(100.0, 5000.0)):
    """1/3-octave band levels of a contact force over the steady part [dB re 1 N].

    As :func:`belt_vibration_spectra`, with the reference :data:`FORCE_REFERENCE` = 1 N: the convention of the
    rolling study's force band levels (:func:`tyreroad.rolling.dataset.aggregate_rolling`, ``band_level``), which
    it reproduces for the total force.

    Parameters
    ----------
    force : array_like
        Force [N], (n_steps,) (e.g. the total contact force) or (n_rows, n_steps).
    sample_rate : float
        Step rate [Hz].
    mask : array_like of bool
        (n_steps,): the steps of the steady part.
    band_limits : tuple of float
        Lowest and highest band centre [Hz].

    Returns
    -------
    centres : numpy.ndarray
        Band centres [Hz].
    levels : numpy.ndarray
        Band levels [dB re 1 N], (n_bands,) or (n_rows, n_bands).
    """
    return _levels(force, sample_rate, mask, band_limits, FORCE_REFERENCE)
