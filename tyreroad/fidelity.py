r"""How faithful a march kernel is to the element FRF it was built from (issue 23), as the greens stage checks it.

The march kernel's own transfer function K(f) (kept lags + memory, :meth:`LayerKernel.own_frequency_response`)
is compared with the exact element FRF G(f) (:func:`tyreroad.greens.element_frf`) at every unique offset of
the patch over a band (default 10 Hz - 5 kHz, 160 log-spaced points):

* ``magnitude``: max over f and offsets of |K - G| / |G_0(f)|, the error relative to the excitation
  element's response at that frequency. A per-offset relative error |K/G| - 1 would be dominated by the
  far offsets, where |G| passes near zero (today's kernel: 5.7 % at offset (7, 3), where |G| is 1e-3 of
  |G_0|, against 0.42 % relative to |G_0|): what the contact feels is the error in the displacement it
  causes, which this measures on the scale of the largest response.
* ``phase``: max over f of |arg(K / G)| at the offsets where |G(f)| >= ``phase_floor`` |G_0(f)| (10 %: the
  excitation element and its near neighbours; a phase is not defined where G passes through zero).
* the per-offset relative errors too, reported (``offset_magnitude`` / ``offset_phase``), not judged.

A kernel is faithful when magnitude <= ``MAGNITUDE_LIMIT`` (1 %) and phase <= ``PHASE_LIMIT`` (0.01 rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .greens import element_frf, unique_offsets
from .kernel import LayerKernel

__all__ = ["MAGNITUDE_LIMIT", "PHASE_LIMIT", "FIDELITY_BAND", "KernelFidelity", "kernel_fidelity"]

MAGNITUDE_LIMIT = 0.01
PHASE_LIMIT = 0.01
FIDELITY_BAND = (10.0, 5000.0)
PHASE_FLOOR = 0.1


@dataclass(frozen=True)
class KernelFidelity:
    """A kernel's fidelity to its FRF (see the module docstring).

    Attributes
    ----------
    magnitude : float
        max |K - G| / |G_0| over the band and the patch's offsets [1].
    phase : float
        max |arg(K / G)| where |G| >= phase_floor |G_0| [rad].
    excitation : tuple of float
        (|K/G| - 1, |arg K/G|) worst over the band at the excitation element.
    offset_magnitude, offset_phase : float
        Worst per-offset relative errors over every offset (reported, not judged).
    worst_offset : tuple of int
        (dx, dy) [elements] of ``magnitude``.
    band : tuple of float
        [Hz].
    """

    magnitude: float
    phase: float
    excitation: tuple
    offset_magnitude: float
    offset_phase: float
    worst_offset: tuple
    band: tuple

    @property
    def faithful(self) -> bool:
        return self.magnitude <= MAGNITUDE_LIMIT and self.phase <= PHASE_LIMIT

    def describe(self) -> str:
        return (f"{self.magnitude:.3%} of |G_0| (worst offset {self.worst_offset}), phase {self.phase:.4f} rad, "
                f"excitation element {self.excitation[0]:.3%} / {self.excitation[1]:.4f} rad over "
                f"{self.band[0]:g}-{self.band[1]:g} Hz (per-offset relative, reported only: "
                f"{self.offset_magnitude:.3%} / {self.offset_phase:.4f} rad)")

    def variables(self) -> dict:
        band = f"{self.band[0]:g}-{self.band[1]:g} Hz"
        return {
            "fidelity_magnitude": ((), self.magnitude, {
                "units": "1", "long_name": f"max over {band} and the patch's offsets of |K - G| / |G_0|: the march "
                "kernel's transfer function K against the element FRF G, relative to the excitation element's",
                "limit": MAGNITUDE_LIMIT}),
            "fidelity_phase": ((), self.phase, {
                "units": "rad", "long_name": f"max over {band} of |arg(K / G)| where |G| >= {PHASE_FLOOR:g} |G_0|",
                "limit": PHASE_LIMIT}),
            "fidelity_excitation_magnitude": ((), self.excitation[0], {
                "units": "1", "long_name": f"max over {band} of ||K/G| - 1| at the excitation element"}),
            "fidelity_excitation_phase": ((), self.excitation[1], {
                "units": "rad", "long_name": f"max over {band} of |arg(K/G)| at the excitation element"}),
        }


def kernel_fidelity(kernel: LayerKernel, material, shape, band=FIDELITY_BAND, n_frequencies: int = 160,
                    phase_floor: float = PHASE_FLOOR, response=None) -> KernelFidelity:
    """:class:`KernelFidelity` of a dynamic kernel against its material's element FRF over an (nx, ny) patch.

    ``response``: the exact FRF when it is not the layer's alone (an object with ``frequency_response(f,
    shape)`` giving complex offset tables [m/N], e.g. :class:`tyreroad.belt_stage.BeltElementFRF` of tread +
    flexible belt); None: :func:`tyreroad.greens.element_frf` of ``material``."""
    if kernel.element_size is None:
        raise ValueError(f"{kernel.name}: the kernel's element size is needed for its FRF")
    f = np.geomspace(band[0], band[1], int(n_frequencies))
    omega = 2 * np.pi * f
    c = float(kernel.element_size)
    tables = kernel.own_frequency_response(f, shape)
    nx, ny = shape
    if response is None:
        uniq = unique_offsets(shape)  # the layer is isotropic: offsets up to sign and x <-> y
        a, b = uniq[:, 0], uniq[:, 1]
        exact = element_frf(uniq * c, c, omega, material.modulus(omega), material.poisson, material.density,
                            material.thickness)
        own = tables[:, a + nx - 1, b + ny - 1] if nx >= ny else tables[:, b + nx - 1, a + ny - 1]
    else:
        # an orthotropic response (a belt: circumference x, width y): every offset of the first quadrant
        uniq = np.stack(np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij"), axis=-1).reshape(-1, 2)
        a, b = uniq[:, 0], uniq[:, 1]
        exact = np.asarray(response.frequency_response(f, tuple(shape)))[:, a + nx - 1, b + ny - 1]
        own = tables[:, a + nx - 1, b + ny - 1]
    g0 = np.abs(exact[:, :1])
    err = np.abs(own - exact) / g0
    ratio = own / exact
    phase = np.abs(np.angle(ratio))
    judged = np.abs(exact) >= phase_floor * g0
    i_worst = int(np.unravel_index(np.argmax(err), err.shape)[1])
    return KernelFidelity(
        float(err.max()), float(phase[judged].max()),
        (float(np.abs(np.abs(ratio[:, 0]) - 1).max()), float(phase[:, 0].max())),
        float(np.abs(np.abs(ratio) - 1).max()), float(phase.max()),
        (int(uniq[i_worst, 0]), int(uniq[i_worst, 1])), (float(band[0]), float(band[1])),
    )
