r"""Point and transfer mobilities of the tread surface on the flexible belt, and what published tyre data say.

What is computed
----------------
For a unit harmonic force spread uniformly over one c x c element of the tread surface (c = 1 mm by default),
time convention exp(+i w t), the velocity of the element centres at the offsets d = (x, y) (x circumferential,
y lateral; d = (0, 0) is the driving point) is

    Y(d, w) = i w [g(d, w) + Delta g(d, w)]   [m/(N s)],

* g: the element FRF of the tread layer on a rigid belt (:func:`tyreroad.greens.element_frf`);
* Delta g: the belt's part, the pre-tensioned orthotropic plate strip on its bed, periodic around the circumference
  and simply supported at the belt edges, coupled exactly to the tread (H = H_rigid + tau^2 / (Z + K_b),
  :func:`tyreroad.belt.belt_element_frf_correction_ring`).

For comparison the same function returns the rigid-belt mobility i w g and the belt-alone point mobility
(:func:`tyreroad.belt.belt_point_mobility`, a point force on the bare belt's centre line), and the dataset holds the
infinite-plate value 1 / (8 sqrt(B m'')) with B = sqrt(D_x D_y) (the Huber plate, D_xy = sqrt(D_x D_y)).
:func:`run_belt_mobility` is the Snakemake entry point (1 mm element, 60 log-spaced frequencies 20 Hz - 5 kHz,
offsets 0, 10, 30, 100 mm along x and 30 mm across). Cost, measured on one core (OPENBLAS_NUM_THREADS=1, shared
2-core machine at load ~2): 7-10 s in all, of which the belt's ring-and-strip mode sum ~5.7 s, the element FRF
~0.5 s, the bare belt ~0.2 s, the netCDF file and the figure ~1 s.

What the default tyre gives (the tread preset ``tread`` of config/config.yaml on ``DEFAULT_BELT``)
-------------------------------------------------------------------------------------------------
* Driving point of the 1 mm element: the local compliance of the 10 mm tread dominates (|Y| rises about as f, phase
  70-80 deg). The belt adds to it in series at low frequency (|Y| 3.0e-3 against 2.3e-3 m/(N s) on a rigid belt
  at 20 Hz, 1.6e-2 against 1.0e-2 at 108 Hz) and hardly matters at the top (tread + belt over rigid belt at 5 kHz:
  |Y| ratio 0.987, phase -1.6 deg).
* Tread + belt: first resonance at about 136-140 Hz (point and 100 mm transfer), the belt's first strip mode
  (n = 0, m = 1) lowered by the tread riding on it as a mass.
* Belt alone: stiffness-like (phase +88 deg) up to its first strip mode at about 184 Hz (set by the lateral tension
  across the simply supported width), modal with peaks up to twice the infinite-plate value to about 1 kHz, then
  within a factor 1.3 of the infinite plate 1 / (8 sqrt(B m'')) = 2.5e-2 m/(N s) above about 1.9 kHz (on 2-10 kHz:
  0.85-1.23 of it, geometric mean 0.99).
* Transfer mobilities (10, 30, 100 mm along x, 30 mm across) follow the belt's modes up to a few hundred Hz; above
  1 kHz they fall far below the driving point's: by 16, 20, 55 and 28 times at 1 kHz, 53, 190, 610 and 190 times
  at 5 kHz (in the order above).

Comparison with published measurements
--------------------------------------
No published measured tyre mobility LEVEL could be read (session s15: the stored public-text index held only
abstracts and first pages of the tyre papers; see :data:`PUBLISHED_MOBILITY` and docs/belt.md). What was read gives
frequencies only, and the figure draws them as bands:

* Pinnington & Briscoe (abstract): below 100 Hz tension and sidewall control the stiffness; for a car tyre the
  modal behaviour ceases above about 400 Hz, where the input looks like an infinite belt.
* Muggleton, Mace & Brennan (2003, abstract; tyre on a rim, line force, model in reasonable agreement with
  experiment): stiffness-like below 100 Hz, resonant 100-500 Hz, towards an infinite orthotropic plate above 500 Hz.
* Boulahbal, Muthukrishnan & Shanshal (2003, SAE 2003-01-1531, abstract): the measured drive-point conductance
  (Re Y) of a typical passenger-car tyre falls steadily above 1 kHz, "a-typical since SEA theory predicts such
  conductance should remain relatively flat"; they trace it to the transducer's mass (20 g: measured and corrected
  conductance 12 dB apart) and, less, to the local contact stiffness of the tread. The model's conductance stays
  flat there, as their SEA expectation has it.
* Andersson & Larsson (2005, Acta Acustica united with Acustica 91, 121-131, abstract; not in the table, it gives no
  frequencies): a two-layer (tread + belt) model agrees well with measured radial point mobilities of a tyre,
  "capturing the local behaviour at the excitation point", and with the radial transfer mobilities, once the
  measurement equipment is included in the model.

Against these the default belt (whose parameters are estimates, not fitted values) agrees qualitatively
(stiffness-like at the bottom, resonant in the middle, plate-like with a flat conductance at the top) but its first
resonance (about 140 Hz with the tread, 184 Hz bare) lies above the 100 Hz where the sources put the end of the
stiffness-controlled range, and it stays modal to about 1-2 kHz instead of 400-500 Hz: too little damping (the
tension is lossless and carries much of the stiffness). The 1 mm element's own driving point is not what those
measurements see: above a few hundred Hz it is the local tread compliance, which a transducer spread over a larger
area does not load the same way. A quantitative check of levels needs a published measured mobility, which was not
available.

References
----------
Pinnington, R. J. & Briscoe, A. R., A wave model for a pneumatic tyre belt, J. Sound Vib. (abstract read).
Muggleton, J. M., Mace, B. R. & Brennan, M. J. (2003), Vibrational response prediction of a pneumatic tyre using an
orthotropic two-plate wave model, J. Sound Vib. 264(4), 929-950 (abstract read).
Andersson, P. & Larsson, K. (2005), Validation of a high frequency three-dimensional tyre model, Acta Acustica
united with Acustica 91(1), 121-131 (abstract read).
Boulahbal, D., Muthukrishnan, M. & Shanshal, Y. (2003), Tire mobility measurements: compensation for transducer and
mounting effects, SAE Technical Paper 2003-01-1531. doi:10.4271/2003-01-1531 (abstract read).
Cremer, L., Heckl, M. & Petersson, B. A. T. (2005), Structure-Borne Sound, 3rd ed., Springer (infinite plate).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

from .belt import DEFAULT_BELT, BeltProperties, belt_element_frf_correction_ring, belt_point_mobility
from .greens import element_frf

logger = logging.getLogger(__name__)

__all__ = [
    "PublishedStatement",
    "PUBLISHED_MOBILITY",
    "DEFAULT_OFFSETS",
    "DEFAULT_LABELS",
    "default_frequencies",
    "infinite_plate_mobility",
    "tread_surface_mobility",
    "mobility_dataset",
    "mobility_figure",
    "run_belt_mobility",
]

#: Offsets (x, y) [m] of the default points: the driving point, 10, 30 and 100 mm along the circumference, 30 mm across.
DEFAULT_OFFSETS = ((0.0, 0.0), (0.010, 0.0), (0.030, 0.0), (0.100, 0.0), (0.0, 0.030))
DEFAULT_LABELS = ("point", "x 10 mm", "x 30 mm", "x 100 mm", "y 30 mm")

_BELT_UNITS = {
    "bending_x": "N m", "bending_y": "N m", "bending_xy": "N m", "tension_x": "N/m", "tension_y": "N/m",
    "mass": "kg/m^2", "bed": "N/m^3", "loss_factor": "1", "circumference": "m", "width": "m",
    "loss_model": "-", "loss_frequency": "Hz",
}


@dataclass(frozen=True)
class PublishedStatement:
    """One published statement about a measured (or measurement-checked) tyre mobility.

    Parameters
    ----------
    key : str
        Short label for the figure.
    source : str
        Authors, year, title, where published, DOI if given, and what of it was read.
    tyre, condition : str
        The tyre and the test condition as the source states them ("not stated" otherwise).
    statement : str
        What the source says, in its words as far as read.
    f_lo, f_hi : float or None
        Frequency band [Hz] the statement covers (None: open end).
    level_lo, level_hi : float or None
        |Y| band [m/(N s)] if the source gives numbers; None when it gives none (the figure then draws the frequency
        band only).
    """

    key: str
    source: str
    tyre: str
    condition: str
    statement: str
    f_lo: float | None = None
    f_hi: float | None = None
    level_lo: float | None = None
    level_hi: float | None = None


_PB = ("Pinnington, R. J. & Briscoe, A. R., 'A wave model for a pneumatic tyre belt', J. Sound Vib. "
       "(abstract read at slh.alljournals.cn; year, volume and pages not read)")
_MMB = ("Muggleton, J. M., Mace, B. R. & Brennan, M. J. (2003), 'Vibrational response prediction of a pneumatic tyre "
        "using an orthotropic two-plate wave model', J. Sound Vib. 264(4), 929-950 (abstract read)")
_BMS = ("Boulahbal, D., Muthukrishnan, M. & Shanshal, Y. (2003), 'Tire mobility measurements: compensation for "
        "transducer and mounting effects', SAE Technical Paper 2003-01-1531, doi:10.4271/2003-01-1531 (abstract read)")

#: What published sources say about measured tyre mobilities, as far as they could be read (session s15): only
#: abstracts, which give frequency ranges and no mobility levels, so no entry has ``level_lo``/``level_hi``.
#: Searched and not found with numbers: Kropp (1989), Larsson & Kropp (2002), Andersson, Larsson & Kropp (2001),
#: Andersson & Larsson (2005), Pinnington (2006), Bolton/Kim, Le Bot et al. (2017, 2018), Hoever (2014 thesis),
#: Hoever & Kropp (2015).
PUBLISHED_MOBILITY: tuple[PublishedStatement, ...] = (
    PublishedStatement(
        "P&B <100 Hz", _PB, "car tyre (not named in the abstract)", "not stated in the abstract",
        "Tension and the sidewall control the deformation and stiffness below 100 Hz; waves propagate around the "
        "belt above this frequency.", None, 100.0),
    PublishedStatement(
        "P&B >400 Hz", _PB, "car tyre (not named in the abstract)", "not stated in the abstract",
        "The model should be valid above about 400 Hz, when for a car tyre the modal behaviour is observed to "
        "cease; in this high-frequency region the tyre at the input appears to be of infinite extent.", 400.0, None),
    PublishedStatement(
        "MMB <100 Hz", _MMB, "pneumatic tyre (not named in the abstract)",
        "inflated tyre fitted to a wheel rim, line force excitation (model; experiments in reasonable agreement)",
        "At low frequencies (<100 Hz) the response is stiffness-like, controlled by the sidewall properties and "
        "tension effects resulting from the tyre pressure.", None, 100.0),
    PublishedStatement(
        "MMB 100-500 Hz", _MMB, "pneumatic tyre (not named in the abstract)",
        "inflated tyre fitted to a wheel rim, line force excitation (model; experiments in reasonable agreement)",
        "In the mid-frequency range (100-500 Hz) a resonant response is observed, associated with modes both "
        "across and around the tyre.", 100.0, 500.0),
    PublishedStatement(
        "MMB >500 Hz", _MMB, "pneumatic tyre (not named in the abstract)",
        "inflated tyre fitted to a wheel rim, line force excitation (model; experiments in reasonable agreement)",
        "At high frequencies (>500 Hz) the response tends towards that of an infinite orthotropic plate.",
        500.0, None),
    PublishedStatement(
        "BMS >1 kHz", _BMS, "a typical passenger car tire", "drive-point conductance, measured with a transducer",
        "The measured drive-point conductance drops steadily above 1000 Hz, a-typical since SEA predicts a flat "
        "conductance; traced to the added mass of the transducer (20 g: measured and corrected conductance 12 dB "
        "apart) and, less, to the local contact stiffness of the tread rubber.", 1000.0, None),
)


def default_frequencies(n: int = 60, f_min: float = 20.0, f_max: float = 5000.0) -> np.ndarray:
    """``n`` log-spaced frequencies [Hz] from ``f_min`` to ``f_max`` (defaults: 60 from 20 Hz to 5 kHz)."""
    if not (0.0 < f_min < f_max) or n < 2:
        raise ValueError(f"default_frequencies: need 0 < f_min < f_max and n >= 2, got {f_min}, {f_max}, {n}")
    return np.geomspace(f_min, f_max, int(n))


def infinite_plate_mobility(belt: BeltProperties, omega=None):
    """Point mobility |1 / (8 sqrt(B phi(w) m''))| [m/(N s)] of the infinite untensioned plate, B = sqrt(D_x D_y).

    Exact for a Huber orthotropic plate (D_xy = sqrt(D_x D_y)) without tension or bed; the belt approaches it at
    high frequency, where bending and inertia dominate (Cremer, Heckl & Petersson 2005). phi is the belt's loss
    factor on bending (:meth:`tyreroad.belt.BeltProperties.stiffness_factor`: with the causal loss the bending
    stiffness grows with frequency); without ``omega`` [rad/s], phi = 1 (the storage stiffness at the belt's
    ``loss_frequency``) and a float is returned.
    """
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
    b = math.sqrt(belt.bending_x * belt.bending_y)
    if omega is None:
        return 1.0 / (8.0 * math.sqrt(b * belt.mass))
    return np.abs(1.0 / (8.0 * np.sqrt(b * belt.stiffness_factor(omega) * belt.mass)))


def _check_offsets(offsets) -> np.ndarray:
    off = np.asarray(offsets, dtype=float)
    if off.ndim != 2 or off.shape[1] != 2 or off.shape[0] < 1 or not np.all(np.isfinite(off)):
        raise ValueError(f"offsets: expected a finite (n, 2) array of (x, y) [m], got shape {off.shape}")
    return off


def _check_frequencies(frequencies) -> np.ndarray:
    f = np.atleast_1d(np.asarray(frequencies, dtype=float))
    if f.ndim != 1 or f.size < 1 or not np.all(np.isfinite(f)) or np.any(f <= 0.0):
        raise ValueError("frequencies: expected a 1-D array of finite frequencies > 0 Hz")
    return f


def tread_surface_mobility(material, belt: BeltProperties, element_size: float, frequencies, offsets
                           ) -> dict[str, np.ndarray]:
    """Mobilities Y = i w (g + Delta g) [m/(N s)] of the tread surface on the belt, and their two references.

    Parameters
    ----------
    material : tyreroad.material.Material
        The tread (``modulus(omega)`` [Pa], ``poisson`` [-], ``density`` [kg/m^3], ``thickness`` [m]).
    belt : tyreroad.belt.BeltProperties
        The belt (ring of circumference L, simply supported width W; its ``scaled(1e12)`` is a rigid belt).
    element_size : float
        Side c [m] of the square surface element the unit force is spread over (> 0).
    frequencies : array_like
        Frequencies f [Hz] (> 0), shape (m,).
    offsets : array_like
        Offsets (x, y) [m] of the field element centres from the driven element's, shape (n, 2); x
        circumferential, y lateral (|y| < W / 2); (0, 0) is the driving point.

    Returns
    -------
    dict of numpy.ndarray (complex)
        ``tread_belt`` (m, n): Y = i w (g + Delta g), tread on the flexible belt [m/(N s)];
        ``tread_rigid`` (m, n): i w g, tread on a rigid belt [m/(N s)];
        ``belt_alone`` (m,): point mobility of the bare belt on its centre line [m/(N s)]
        (:func:`tyreroad.belt.belt_point_mobility`). Time convention exp(+i w t): stiffness-like is +90 deg,
        passive means Re Y >= 0 at the driving point.
    """
    if not isinstance(belt, BeltProperties):
        raise ValueError(f"belt: expected a BeltProperties, got {type(belt).__name__}")
    f = _check_frequencies(frequencies)
    off = _check_offsets(offsets)
    c = float(element_size)
    if not (math.isfinite(c) and c > 0.0):
        raise ValueError(f"element_size: expected a finite length > 0 m, got {element_size!r}")
    w = 2.0 * math.pi * f
    e = material.modulus(w)
    g = element_frf(off, c, w, e, material.poisson, material.density, material.thickness)
    dg = belt_element_frf_correction_ring(off, c, w, e, material.poisson, material.density, material.thickness, belt)
    iw = 1j * w[:, None]
    return {
        "tread_belt": iw * (g + dg),
        "tread_rigid": iw * g,
        "belt_alone": np.asarray(belt_point_mobility(w, belt), dtype=complex).reshape(f.shape),
    }


def _attrs(units, long_name, **extra):
    return {"units": units, "long_name": long_name, **extra}


def mobility_dataset(material, belt: BeltProperties = DEFAULT_BELT, element_size: float = 1e-3, frequencies=None,
                     offsets: Sequence[Sequence[float]] = DEFAULT_OFFSETS, labels: Sequence[str] | None = None,
                     material_name: str | None = None) -> xr.Dataset:
    """The mobilities of :func:`tread_surface_mobility` as an xarray Dataset (dims ``frequency``, ``point``).

    Parameters
    ----------
    material : tyreroad.material.Material
        The tread.
    belt : tyreroad.belt.BeltProperties
        The belt (default :data:`tyreroad.belt.DEFAULT_BELT`).
    element_size : float
        Element side c [m] (default 1 mm).
    frequencies : array_like, optional
        Frequencies [Hz] (default :func:`default_frequencies`: 60 from 20 Hz to 5 kHz).
    offsets : array_like
        (n, 2) offsets (x, y) [m] (default :data:`DEFAULT_OFFSETS`).
    labels : sequence of str, optional
        One label per offset (default :data:`DEFAULT_LABELS` for the default offsets, else "x ... mm, y ... mm").
    material_name : str, optional
        Stored as the ``material`` attribute (default ``material.name``).

    Returns
    -------
    xarray.Dataset
        ``mobility_real``/``mobility_imag`` (frequency, point): tread on belt; ``rigid_mobility_real``/``_imag``:
        tread on a rigid belt; ``belt_mobility_real``/``_imag`` (frequency): bare belt; ``infinite_plate_mobility``
        (scalar); all [m/(N s)], real and imaginary parts stored apart (netCDF has no complex type). Coordinates
        ``frequency`` [Hz], ``point`` [1], ``offset_x``/``offset_y`` [m], ``point_label``. Attributes: ``material``,
        ``element_size`` [m], ``belt_<field>`` (units in ``belt_units``), ``time_convention``.
    """
    f = default_frequencies() if frequencies is None else _check_frequencies(frequencies)
    off = _check_offsets(offsets)
    if labels is None:
        if off.shape == np.shape(DEFAULT_OFFSETS) and np.allclose(off, DEFAULT_OFFSETS):
            labels = DEFAULT_LABELS
        else:
            labels = tuple(f"x {1e3 * x:g} mm, y {1e3 * y:g} mm" for x, y in off)
    labels = [str(s) for s in labels]
    if len(labels) != len(off):
        raise ValueError(f"labels: expected {len(off)} labels, got {len(labels)}")
    t0 = time.perf_counter()
    y = tread_surface_mobility(material, belt, element_size, f, off)
    elapsed = time.perf_counter() - t0
    unit = "m/(N s)"
    ds = xr.Dataset(
        {
            "mobility_real": (("frequency", "point"), y["tread_belt"].real,
                              _attrs(unit, "real part of the tread-surface mobility, tread on the flexible belt")),
            "mobility_imag": (("frequency", "point"), y["tread_belt"].imag,
                              _attrs(unit, "imaginary part of the tread-surface mobility, tread on the flexible belt")),
            "rigid_mobility_real": (("frequency", "point"), y["tread_rigid"].real,
                                    _attrs(unit, "real part of the tread-surface mobility, tread on a rigid belt")),
            "rigid_mobility_imag": (("frequency", "point"), y["tread_rigid"].imag,
                                    _attrs(unit, "imaginary part of the tread-surface mobility, tread on a rigid "
                                                 "belt")),
            "belt_mobility_real": ("frequency", y["belt_alone"].real,
                                   _attrs(unit, "real part of the point mobility of the bare belt (centre line)")),
            "belt_mobility_imag": ("frequency", y["belt_alone"].imag,
                                   _attrs(unit, "imaginary part of the point mobility of the bare belt (centre line)")),
            "infinite_plate_mobility": ("frequency", infinite_plate_mobility(belt, 2.0 * np.pi * f),
                                        _attrs(unit, "|point mobility| 1/(8 sqrt(B phi m'')) of the infinite plate, "
                                                     "B = sqrt(D_x D_y), phi the belt's loss factor on bending")),
        },
        coords={
            "frequency": ("frequency", f, _attrs("Hz", "frequency")),
            "point": ("point", np.arange(len(off)), _attrs("1", "index of the field element")),
            "offset_x": ("point", off[:, 0], _attrs("m", "circumferential offset of the field element from the "
                                                         "driven element")),
            "offset_y": ("point", off[:, 1], _attrs("m", "lateral offset of the field element from the driven "
                                                         "element")),
            "point_label": ("point", np.array(labels, dtype=object), {"long_name": "field element label"}),
        },
        attrs={
            "title": "tread-surface point and transfer mobilities on the flexible belt",
            "material": str(material_name if material_name is not None else getattr(material, "name", "")),
            "element_size": float(element_size),
            "element_size_units": "m",
            "time_convention": "exp(+i omega t); mobility = i omega displacement / force",
            "belt_units": "; ".join(f"{k}: {u}" for k, u in _BELT_UNITS.items()),
            **{f"belt_{k}": (v if isinstance(v, str) else float(v)) for k, v in asdict(belt).items()},
        },
    )
    logger.info("belt mobility %s: %d frequencies x %d points in %.1f s", ds.attrs["material"], f.size, len(off),
                elapsed)
    return ds


def _complex(ds: xr.Dataset, prefix: str) -> np.ndarray:
    return np.asarray(ds[f"{prefix}_real"].values) + 1j * np.asarray(ds[f"{prefix}_imag"].values)


def mobility_figure(ds: xr.Dataset, out_png, reference: Sequence[PublishedStatement] | None = None) -> Path:
    """Figure of |Y| (log-log) and phase of the mobilities in ``ds``, with the published statements.

    Top: |Y| [m/(N s)] of the tread on the belt at every point (the driving point bold), of the tread on a rigid
    belt and of the bare belt at the driving point, and the infinite-plate level; statements with levels are
    drawn there as boxes. Middle: phase [deg] of the same driving-point curves (+90 deg stiffness-like, 0
    resistive, -90 deg mass-like). Bottom: the frequency bands of the statements (every one of
    :data:`PUBLISHED_MOBILITY` is a band without levels).

    Parameters
    ----------
    ds : xarray.Dataset
        From :func:`mobility_dataset` (or read back from its netCDF file).
    out_png : path-like
        The PNG file (written atomically).
    reference : sequence of PublishedStatement, optional
        Statements to draw; default :data:`PUBLISHED_MOBILITY`; ``()`` draws none.

    Returns
    -------
    pathlib.Path
        ``out_png``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .io import atomic_path

    missing = [v for v in ("mobility_real", "mobility_imag", "rigid_mobility_real", "rigid_mobility_imag",
                           "belt_mobility_real", "belt_mobility_imag") if v not in ds]
    if missing:
        raise ValueError(f"mobility_figure: dataset lacks {missing}")
    reference = PUBLISHED_MOBILITY if reference is None else tuple(reference)
    f = np.asarray(ds["frequency"].values)
    y = _complex(ds, "mobility")
    yr = _complex(ds, "rigid_mobility")
    yb = _complex(ds, "belt_mobility")
    labels = [str(s) for s in ds["point_label"].values] if "point_label" in ds.coords else \
        [f"point {i}" for i in range(y.shape[1])]
    drive = np.nonzero((np.asarray(ds["offset_x"].values) == 0.0) & (np.asarray(ds["offset_y"].values) == 0.0))[0]
    i0 = int(drive[0]) if drive.size else 0

    fig, (ax, axp, axr) = plt.subplots(3, 1, figsize=(7.5, 9.0), sharex=True,
                                       gridspec_kw={"height_ratios": [3.0, 1.6, 1.2]})
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for j in range(y.shape[1]):
        main = j == i0
        ax.loglog(f, np.abs(y[:, j]), color="k" if main else colors[j % len(colors)], lw=2.0 if main else 1.0,
                  label=f"tread + belt, {labels[j]}")
    ax.loglog(f, np.abs(yr[:, i0]), "k--", lw=1.2, label=f"tread on rigid belt, {labels[i0]}")
    ax.loglog(f, np.abs(yb), color="0.45", ls=":", lw=1.6, label="belt alone, point")
    if "infinite_plate_mobility" in ds:
        ax.loglog(f, ds["infinite_plate_mobility"].values, color="0.6", lw=0.8, ls="-.",
                  label="infinite plate 1/(8 sqrt(B m''))")
    for s in reference:
        if s.level_lo is None and s.level_hi is None:
            continue
        lo = s.level_lo if s.level_lo is not None else s.level_hi
        hi = s.level_hi if s.level_hi is not None else s.level_lo
        f_lo = s.f_lo if s.f_lo is not None else f[0]
        f_hi = s.f_hi if s.f_hi is not None else f[-1]
        ax.fill_between([f_lo, f_hi], [lo, lo], [hi, hi], color="tab:red", alpha=0.2, lw=0)
        ax.plot([np.sqrt(f_lo * f_hi)], [np.sqrt(lo * hi)], "rs", ms=5, label=f"published: {s.key}")
    ax.set_ylabel("|Y| [m/(N s)]")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="best")
    el = ds.attrs.get("element_size")
    ax.set_title(f"Tread-surface mobility, {ds.attrs.get('material', '')}"
                 + (f", element {1e3 * float(el):g} mm" if el is not None else ""), fontsize=10)

    for curve, style, lab in ((y[:, i0], dict(color="k", lw=2.0), "tread + belt"),
                              (yr[:, i0], dict(color="k", ls="--", lw=1.2), "rigid belt"),
                              (yb, dict(color="0.45", ls=":", lw=1.6), "belt alone")):
        axp.semilogx(f, np.degrees(np.angle(curve)), label=lab, **style)
    axp.set_ylim(-100, 100)
    axp.set_yticks([-90, -45, 0, 45, 90])
    axp.set_ylabel("phase [deg]")
    axp.grid(True, which="both", alpha=0.3)
    axp.legend(fontsize=7, loc="lower left")

    bands = [s for s in reference if s.level_lo is None and s.level_hi is None]
    for k, s in enumerate(bands):
        f_lo = s.f_lo if s.f_lo is not None else f[0]
        f_hi = s.f_hi if s.f_hi is not None else f[-1]
        axr.semilogx([f_lo, f_hi], [k, k], color=colors[k % len(colors)], lw=6, solid_capstyle="butt")
        axr.text(np.sqrt(f_lo * f_hi), k + 0.3, s.key, ha="center", va="bottom", fontsize=7)
    axr.set_ylim(-0.7, max(len(bands), 1) + 0.2)
    axr.set_yticks([])
    axr.set_ylabel("published\n(no levels)", fontsize=8)
    axr.set_xlabel("frequency [Hz]")
    axr.grid(True, which="both", axis="x", alpha=0.3)
    axr.set_xlim(f[0], f[-1])
    fig.tight_layout()
    path = Path(out_png)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=130, format="png")
    plt.close(fig)
    logger.info("wrote %s", path)
    return path


def _belt_from_config(belt_cfg: Mapping[str, Any] | None) -> BeltProperties:
    """``DEFAULT_BELT`` with the fields given in ``belt_cfg`` replaced (None: ``DEFAULT_BELT``; the config's
    ``belt.properties``, checked by :func:`tyreroad.belt_stage.belt_from_config`)."""
    from .belt_stage import belt_from_config

    if isinstance(belt_cfg, BeltProperties):
        return belt_cfg
    return belt_from_config(belt_cfg)


def run_belt_mobility(material_name: str, material_cfg: Mapping[str, Any], belt_cfg_or_None, out_nc, out_png,
                      frequencies=None, element_size: float = 1e-3) -> xr.Dataset:
    """Snakemake entry point: the mobility dataset of one tread preset on the belt, written with its figure.

    Parameters
    ----------
    material_name : str
        The preset's name (``materials.<name>``).
    material_cfg : mapping
        The resolved preset (:func:`tyreroad.pipeline.resolved_material_config`).
    belt_cfg_or_None : mapping or None
        Belt fields (names of :class:`tyreroad.belt.BeltProperties`, SI units) replacing those of
        :data:`tyreroad.belt.DEFAULT_BELT`; None for the default belt.
    out_nc, out_png : path-like
        The netCDF file (:func:`tyreroad.io.write_dataset`, with the config as provenance) and the figure.
    frequencies : array_like, optional
        Frequencies [Hz]; default 60 log-spaced from 20 Hz to 5 kHz.
    element_size : float
        Element side [m], default 1 mm.

    Returns
    -------
    xarray.Dataset
        The dataset written (cost with the defaults: 7-10 s on one core).
    """
    from .io import write_dataset
    from .pipeline import _material

    material = _material(material_name, material_cfg)
    belt = _belt_from_config(belt_cfg_or_None)
    ds = mobility_dataset(material, belt, element_size, frequencies, material_name=material_name)
    belt_section = None if belt_cfg_or_None is None else (
        asdict(belt_cfg_or_None) if isinstance(belt_cfg_or_None, BeltProperties) else
        {k: (v if isinstance(v, str) else float(v)) for k, v in dict(belt_cfg_or_None).items()})
    section = {"materials": {material_name: dict(material_cfg)}, "belt": belt_section,
               "element_size": float(element_size)}
    write_dataset(ds, out_nc, section, stage="belt_mobility")
    mobility_figure(ds, out_png)
    return ds
