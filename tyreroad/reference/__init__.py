"""Analytic reference solutions (oracles) the tests assert against.

``love`` (uniformly loaded rectangle on a half-space), ``hertz`` (paraboloid contact),
``layer1d`` (one-dimensional layer limits, Rayleigh speed), ``sdof`` (one-degree-of-freedom contact ODE),
``dense`` (the solver's convolution sums as plain dense matrices).
"""
