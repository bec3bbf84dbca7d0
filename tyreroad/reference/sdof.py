"""One-degree-of-freedom oracle for the contact solver (SPEC section 8, "Solver").

A layer idealised as a mass-spring-damper (mass m, stiffness k_l, damping ratio zeta_d) has the
displacement impulse response

    g(t) = exp(-zeta_d w0 t) sin(w_d t) / (m w_d),  w0 = sqrt(k_l / m), w_d = w0 sqrt(1 - zeta_d^2),

for t >= 0. Pressed by a rigid indenter through a linear contact spring k_c with prescribed
indentation d(t) = a t^2 / 2 it obeys

    m w'' + c w' + k_l w = F,  F = k_c max(d - w, 0),  c = 2 zeta_d sqrt(k_l m),  w(0) = w'(0) = 0,

which :func:`contact_force_ode` integrates accurately. :func:`first_order_hold_kernel` gives the
discrete kernel g[l] for which w(t_n) = sum_l g[l] F[n - l] holds exactly when F is piecewise
linear between samples (first-order hold); the contact solver's discretisation error is then
O((w dt)^2).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["impulse_response", "first_order_hold_kernel", "contact_force_ode"]


def _check(mass: float, stiffness: float, damping_ratio: float) -> tuple[complex, float]:
    if not (mass > 0 and stiffness > 0 and 0 <= damping_ratio < 1):
        raise ValueError(
            f"sdof: need mass > 0 [kg], stiffness > 0 [N/m], 0 <= damping_ratio < 1; "
            f"got {mass!r}, {stiffness!r}, {damping_ratio!r}"
        )
    w0 = math.sqrt(stiffness / mass)
    wd = w0 * math.sqrt(1.0 - damping_ratio**2)
    return complex(-damping_ratio * w0, wd), wd


def impulse_response(t, mass: float, stiffness: float, damping_ratio: float) -> np.ndarray:
    """Displacement impulse response g(t) [m/(N s)] of the under-damped oscillator (0 for t < 0).

    Parameters
    ----------
    t : array_like
        Time [s].
    mass : float
        m [kg].
    stiffness : float
        k_l [N/m].
    damping_ratio : float
        zeta_d [1], < 1.
    """
    s, wd = _check(mass, stiffness, damping_ratio)
    t = np.asarray(t, dtype=float)
    return np.where(t >= 0, np.exp(s.real * t) * np.sin(wd * t) / (mass * wd), 0.0)


def first_order_hold_kernel(
    n_lags: int, sample_rate: float, mass: float, stiffness: float, damping_ratio: float
) -> np.ndarray:
    """Discrete kernel g[l] [m/N], exact for forces that are piecewise linear between samples.

    With F(t) = sum_j F_j phi_j(t) (hat functions phi_j of width 2 dt around t_j),
    w(t_n) = integral g(t_n - tau) F(tau) dtau = sum_l g[l] F[n - l] with

        g[0] = integral_0^dt g(u) (1 - u/dt) du,
        g[l] = integral_{(l-1)dt}^{(l+1)dt} g(u) (1 - |u - l dt| / dt) du   (l >= 1),

    evaluated in closed form through g(u) = Im(exp(s u)) / (m w_d), s = -zeta_d w0 + i w_d.
    sum_l g[l] = integral g = 1 / k_l.

    Parameters
    ----------
    n_lags : int
        Number of lags L.
    sample_rate : float
        fs [Hz], dt = 1 / fs.
    mass, stiffness, damping_ratio : float
        Oscillator parameters [kg], [N/m], [1].

    Returns
    -------
    numpy.ndarray
        g[0 ... L-1] [m/N].
    """
    s, wd = _check(mass, stiffness, damping_ratio)
    dt = 1.0 / float(sample_rate)
    e = np.exp(s * dt)
    j0 = (e - 1.0) / s  # integral_0^dt exp(s v) dv
    j1 = (e * (dt / s - 1.0 / s**2) + 1.0 / s**2)  # integral_0^dt v exp(s v) dv
    lag = np.arange(int(n_lags))
    falling = np.exp(s * lag * dt) * (j0 - j1 / dt)
    rising = np.where(lag >= 1, np.exp(s * (lag - 1) * dt) * j1 / dt, 0.0)
    return np.imag(falling + rising) / (mass * wd)


def contact_force_ode(
    times,
    mass: float,
    stiffness: float,
    damping_ratio: float,
    contact_stiffness: float,
    acceleration: float,
    rtol: float = 1e-10,
) -> np.ndarray:
    """Contact force F(t) [N] of the oscillator pressed by d(t) = a t^2 / 2 through spring k_c.

    Parameters
    ----------
    times : array_like
        Output times [s], increasing, >= 0.
    mass, stiffness, damping_ratio : float
        Oscillator (layer) parameters [kg], [N/m], [1].
    contact_stiffness : float
        k_c [N/m].
    acceleration : float
        a [m/s^2].
    rtol : float
        Relative tolerance of the DOP853 integration.

    Returns
    -------
    numpy.ndarray
        F at ``times`` [N].
    """
    _check(mass, stiffness, damping_ratio)
    times = np.asarray(times, dtype=float)
    damping = 2.0 * damping_ratio * math.sqrt(stiffness * mass)
    kc, a = float(contact_stiffness), float(acceleration)

    def rhs(t, y):
        force = kc * max(0.5 * a * t * t - y[0], 0.0)
        return [y[1], (force - damping * y[1] - stiffness * y[0]) / mass]

    scale = 0.5 * a * times[-1] ** 2
    sol = solve_ivp(
        rhs, (0.0, times[-1]), [0.0, 0.0], method="DOP853", t_eval=times,
        rtol=rtol, atol=[rtol * scale, rtol * scale * math.sqrt(stiffness / mass)],
    )
    if not sol.success:
        raise RuntimeError(f"contact_force_ode: integration failed: {sol.message}")
    return kc * np.maximum(0.5 * a * times**2 - sol.y[0], 0.0)
