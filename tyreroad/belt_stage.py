r"""The flexible belt in the pipeline (issue 26): config, the exact element FRF of tread + belt, and the belt's
part of a greens file.

A greens file "with the belt" holds the rigid-belt kernel of :func:`tyreroad.greens.greens_dataset` plus the
belt's part of the element Green's function, Delta g (:mod:`tyreroad.belt`, ring-and-strip mode sum), as a
rational discrete model (:mod:`tyreroad.belt_kernel`): its first L lags are added to the kept lags ``g``, the
rest runs as recursive filters beside the creep tail (:class:`tyreroad.kernel.MemorySum`), and its static value
is added to ``g_static``. The spring-safe correction, the stability margin and the fidelity check of the greens
stage then see the whole kernel (tread + belt).

The indentation's reference (config ``belt.reference``)
--------------------------------------------------------
The study prescribes the indentation d(t): the approach of the road to "the tyre". With a rigid belt that is
the belt. A flexible belt deflects under the contact force, mostly as a whole over a 20 mm patch (its static
deflection spreads over sqrt(T_x / s) ~ 0.16 m): for the default belt Delta g at 19 mm diagonal offset is still
70 % of its value at the loaded element. Three references:

* ``footprint`` (default): the patch is what the paper takes it for, a sample of a tyre footprint (~150 x 200 mm)
  in which every 20 mm cell carries a similar load. The belt then sees the patch's force pattern repeated over
  the footprint: its response splits into the footprint's mean pressure -- the tyre's global deflection, which a
  tyre model computes itself and which is not contact compliance -- and the pressure's variation at the patch
  scale, which stays: Delta g is the mode sum over the cell's wavenumbers k = 2 pi (p / L_x, q / L_y) without
  k = 0 (:func:`tyreroad.belt_fit.belt_correction_table` with ``cell``). The plate is taken as wide and long
  there (L_x = 20 mm is far below the ring and strip). This is the local contact stiffness on a flexible belt.
* ``patch_mean``: the patch alone on the belt, d measured from the belt's mean position under it. The
  belt-borne displacement a uniform unit load over the patch gives on average,
  c(omega) = sum_d Delta g(d, omega) (nx - |dx|)(ny - |dy|) / (nx ny)^2, is subtracted from every offset:
  u_e - c sum_e' F_e' is the tread surface measured from that mean. What remains is the belt's deformation
  across the patch and its dynamics (waves, modes, the belt's inertia behind the tread): the local contact
  stiffness that a tyre model, which resolves the belt's own large-scale motion, needs. The kernel stays
  translation invariant and symmetric; c is exactly representable in the rational model (the same poles). But an
  isolated loaded patch bends the belt into a bowl (its centre sinks more than its edges), and peripheral
  contacts then count as stiffer than the mean: an artefact of loading only the patch (measured on the default
  study: K_sat +11 to +53 %, where ``footprint`` gives a fraction of a percent, see the report).
* ``rim``: d is the approach of the road to the rim (the belt's elastic bed is anchored there): the tyre's
  structural compliance is in series with the contact, K(d) is then mostly the tyre's radial stiffness (a few
  1e5 N/m) and the study's d_max is not reached by the contact itself. Available, not run by default.

Both tend to the rigid-belt kernel as the belt stiffens (Delta g and c -> 0).
"""

from __future__ import annotations

import logging
import time
from dataclasses import fields
from typing import Any, Mapping

import numpy as np

from . import checks
from .belt import DEFAULT_BELT, BeltProperties
from .belt_fit import belt_correction_table
from .belt_kernel import belt_of_greens, belt_table_index

logger = logging.getLogger(__name__)

__all__ = ["BELT_REFERENCES", "belt_from_config", "belt_settings", "patch_mean_weights", "BeltElementFRF",
           "belt_of_greens", "response_of", "add_belt"]

#: Where the indentation is measured from (module docstring).
BELT_REFERENCES = ("footprint", "patch_mean", "rim")


def belt_from_config(properties: Mapping[str, Any] | None, key: str = "belt.properties") -> BeltProperties:
    """:class:`tyreroad.belt.BeltProperties` from the config: ``DEFAULT_BELT`` with the given fields replaced.

    Raises
    ------
    ValueError
        Naming ``<key>.<field>`` for an unknown field or a value out of range.
    """
    props = {} if properties is None else properties
    if not isinstance(props, Mapping):
        raise ValueError(f"{key}: expected a mapping of belt properties, got {type(props).__name__}")
    names = [f.name for f in fields(BeltProperties)]
    unknown = sorted(set(props) - set(names))
    if unknown:
        raise ValueError(f"{key}.{unknown[0]}: unknown belt property; expected some of {names}")
    values = {n: getattr(DEFAULT_BELT, n) for n in names}
    values.update(props)
    try:
        return BeltProperties(**values)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{key}: {err}") from None


def belt_settings(section: Mapping[str, Any] | None) -> tuple[BeltProperties, str] | None:
    """(belt, reference) of a greens job's ``belt`` params, or None for the rigid belt.

    ``section``: the config's ``belt`` section (``properties``, ``reference``); None: rigid belt.
    """
    if section is None:
        return None
    reference = section.get("reference", "footprint")
    if reference not in BELT_REFERENCES:
        raise ValueError(f"belt.reference = {reference!r}: expected one of {list(BELT_REFERENCES)}")
    return belt_from_config(section.get("properties")), str(reference)


def patch_mean_weights(shape) -> np.ndarray:
    """w[dx, dy] = (nx - |dx|)(ny - |dy|) / (nx ny)^2 on the full offset table (sums to 1): the patch mean of a
    translation-invariant response to a uniform unit load, sum_d table[d] w[d]."""
    nx, ny = (checks.integer(f"shape[{i}]", v) for i, v in enumerate(shape))
    wx = (nx - np.abs(np.arange(-(nx - 1), nx))) / nx
    wy = (ny - np.abs(np.arange(-(ny - 1), ny))) / ny
    return np.outer(wx, wy) / (nx * ny)


class BeltElementFRF:
    """The exact element FRF of tread + flexible belt, g(dx, dy, f) = element_frf + Delta g (- c) [m/N] (for
    ``footprint``, Delta g of the patch repeated over the footprint without its uniform mode, c = 0).

    Delta g: :func:`tyreroad.belt_fit.belt_correction_table` (the ring-and-strip mode sum of
    :func:`tyreroad.belt.belt_element_frf_correction_ring` in its fast form; the loaded patch on the belt's centre
    line); with ``reference = 'patch_mean'`` the patch mean c(f) over ``reference_shape`` is subtracted from
    every offset (module docstring). Used as a :class:`tyreroad.kernel.LayerKernel`'s ``response`` (K*(f)) and
    by the greens stage's fidelity check.

    Parameters
    ----------
    material : tyreroad.material.Material
    belt : tyreroad.belt.BeltProperties
    element_size : float
        c [m].
    reference : {"patch_mean", "rim"}
    reference_shape : (int, int)
        The patch the mean is taken over (the greens file's patch); needed for ``patch_mean``.
    """

    def __init__(self, material, belt: BeltProperties, element_size: float, reference: str = "footprint",
                 reference_shape=None):
        from .greens import ElementFRF

        if not isinstance(belt, BeltProperties):
            raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
        if reference not in BELT_REFERENCES:
            raise ValueError(f"reference: expected one of {list(BELT_REFERENCES)}, got {reference!r}")
        if reference != "rim" and reference_shape is None:
            raise ValueError(f"reference_shape: the patch of the {reference!r} reference is needed")
        self.material = material
        self.belt = belt
        self.element_size = checks.real("element_size", element_size, positive=True)
        self.reference = reference
        self.reference_shape = None if reference_shape is None else tuple(int(n) for n in reference_shape)
        self._layer = ElementFRF(material, self.element_size)

    def belt_part(self, frequencies, shape) -> np.ndarray:
        """Delta g - c as complex offset tables (n_f, 2 nx - 1, 2 ny - 1) [m/N] (c = 0 for ``rim``)."""
        f = np.asarray(frequencies, dtype=float)
        shape = tuple(int(n) for n in shape)
        mat, c = self.material, self.element_size
        ref = self.reference_shape if self.reference == "patch_mean" else None
        big = shape if ref is None else (max(shape[0], ref[0]), max(shape[1], ref[1]))
        cell = None
        if self.reference == "footprint":
            cell = (self.reference_shape[0] * c, self.reference_shape[1] * c)
        t0 = time.perf_counter()
        values = belt_correction_table(mat, self.belt, big, c, f, cell=cell)  # the mode sum, fast form
        tables = values[:, belt_table_index(big)[2]]
        logger.debug("belt part of the element FRF: %d frequencies, %d offsets, %.1f s", f.size, values.shape[1],
                     time.perf_counter() - t0)
        if ref is not None:
            cx, cy = big[0] - 1, big[1] - 1
            own = tables[:, cx - (ref[0] - 1): cx + ref[0], cy - (ref[1] - 1): cy + ref[1]]
            tables = tables - np.einsum("fxy,xy->f", own, patch_mean_weights(ref))[:, None, None]
        cx, cy = big[0] - 1, big[1] - 1
        return tables[:, cx - (shape[0] - 1): cx + shape[0], cy - (shape[1] - 1): cy + shape[1]]

    def frequency_response(self, frequencies, shape) -> np.ndarray:
        """Complex offset tables g(dx, dy, f) [m/N] of tread + belt, shape (n_f, 2 nx - 1, 2 ny - 1)."""
        return self._layer.frequency_response(frequencies, shape) + self.belt_part(frequencies, shape)

    def frequency_influences(self, frequencies, shape, workers: int = 1) -> list:
        """The influence operator G(f) of each frequency (:func:`tyreroad.influence.offset_influences`)."""
        from .influence import offset_influences

        return offset_influences(self.frequency_response(frequencies, shape), frequencies, shape, workers)


def response_of(greens, material):
    """The exact element FRF a greens file's kernel stands for: :class:`tyreroad.greens.ElementFRF` of the
    layer, or :class:`BeltElementFRF` of tread + belt when the file was built with the belt."""
    from .greens import ElementFRF

    c = float(greens.attrs["element_size"])
    recorded = belt_of_greens(greens)
    if recorded is None:
        return ElementFRF(material, c)
    belt, reference, shape = recorded
    return BeltElementFRF(material, belt, c, reference, shape)


def add_belt(ds, material, belt: BeltProperties, reference: str, shape):
    """The rigid-belt greens dataset ``ds`` with the flexible belt's part added (module docstring).

    Fits the belt's rational discrete model (:func:`tyreroad.belt_fit.fit_belt_kernel`) on ``shape`` at the
    file's sample rate (``footprint``: the patch as one cell of the footprint), subtracts the patch mean
    (``patch_mean``), adds its first L lags to ``g``
    and its static value (quasi-static modulus) to ``g_static``, and stores its poles and residues (the memory
    beyond L) with the belt's properties in the attributes.

    Returns
    -------
    (xarray.Dataset, BeltElementFRF)
        The dataset with the belt, and the exact FRF its kernel stands for (for the fidelity check).
    """
    from .belt_fit import fit_belt_kernel

    if reference not in BELT_REFERENCES:
        raise ValueError(f"belt.reference = {reference!r}: expected one of {list(BELT_REFERENCES)}")
    shape = tuple(int(n) for n in shape)
    fs = float(ds.attrs["sample_rate"])
    n_lags = int(ds.sizes["lag"])
    c = float(ds.attrs["element_size"])
    t0 = time.perf_counter()
    cell = (shape[0] * c, shape[1] * c) if reference == "footprint" else None
    model = fit_belt_kernel(material, belt, shape, c, fs, n_lags, cell=cell)
    if reference == "patch_mean":
        model = model.referenced(patch_mean_weights(shape))
    logger.info("greens %s: belt %s (reference %s), %.1f s", material.name, model.describe(), reference,
                time.perf_counter() - t0)
    out = ds.copy()
    g = ds["g"].transpose("dx", "dy", "lag").values + model.lags(n_lags)
    out["g"] = (("dx", "dy", "lag"), g, dict(ds["g"].attrs))
    g_static = ds["g_static"].transpose("dx", "dy").values + model.static
    out["g_static"] = (("dx", "dy"), g_static, dict(ds["g_static"].attrs))
    out = out.assign(model.variables())
    d = model.diagnostics
    out.attrs.update({"belt": 1, "belt_reference": reference, "belt_reference_patch": list(shape),
                      "belt_fit_error": float(d.get("max_error_band", np.nan)),
                      "belt_fit_error_all": float(d.get("max_error", np.nan)),
                      "belt_passivity_min": float(d.get("passivity_min", np.nan)),
                      **{f"belt_{f.name}": (v if isinstance(v, str) else float(v))
                         for f in fields(BeltProperties) for v in (getattr(belt, f.name),)}})
    return out, BeltElementFRF(material, belt, c, reference, shape)
