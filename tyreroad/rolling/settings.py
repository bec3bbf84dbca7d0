"""Settings of a rolling pass: the config section ``rolling`` (SPEC 12)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

from .. import checks

__all__ = ["RollingSettings"]


@dataclass(frozen=True)
class RollingSettings:
    """What a rolling pass needs of the config section ``rolling`` (SI units).

    Parameters
    ----------
    radius : float
        Tyre radius R [m] (default 0.3).
    load : float or None
        Wheel load on the strip [N] (default 500 for the 20 mm wide strip): d0 is set pass by pass
        so that the mean force over the steady part is the load (from the quasi-static indentation
        on). Exactly one of ``load`` and ``d0`` is given.
    load_tolerance : float
        Relative tolerance of the steady mean force on ``load`` (default 0.005).
    d0 : float or None
        Indentation of the belt below the highest road peak at x_c [m].
    x_start, x_end : float or None
        Pass: first and last contact centre x_c [m] from the strip's start; None: the contact
        half-length a = sqrt(2 R d0) plus ``entry_margin`` elements outside the strip.
    quasistatic_step : float
        x_c step of quasi-static passes [m] (default 1e-4).
    steady_margin : int
        Elements beyond the contact half-length that the contact must be inside the strip for
        the steady part (default 2).
    steady_entry : float
        Distance [m] the contact's rear (x_c - a) must have travelled onto the strip before the
        steady part begins (default 0.03, 3 h of the default tread): the layer spreads the
        memory of earlier forces over a few thicknesses, and before that the strip behind the
        contact is shorter than the memory's reach (the force still drifts by ~0.5 %).
    entry_margin : int
        Elements beyond a before the strip starts and after it ends of the automatic pass (default 3).
    snapshots : tuple of float
        x_c of the stored element force maps, as fractions of the strip length (default 0.25, 0.5, 0.75).
    band_limits : tuple of float
        Lowest and highest 1/3-octave band centres of the force spectrum [Hz] (default 100, 5000).
    contact_window : int
        Elements along x the contact may span (default 40; the default load's contact spans 26-30 on the rough strip): the rolling
        kernel's spring-safe correction and stability margin are computed on this window of the strip (every
        contact inside it is covered), and a pass whose contact spans more is refused (``solver.stability``).
    """

    radius: float = 0.3
    load: float | None = 500.0
    load_tolerance: float = 0.005
    d0: float | None = None
    x_start: float | None = None
    x_end: float | None = None
    quasistatic_step: float = 1.0e-4
    steady_margin: int = 2
    steady_entry: float = 0.03
    entry_margin: int = 3
    snapshots: tuple[float, ...] = (0.25, 0.5, 0.75)
    band_limits: tuple[float, float] = (100.0, 5000.0)
    contact_window: int = 40

    def __post_init__(self) -> None:
        checks.real("rolling.radius", self.radius, positive=True)
        if (self.load is None) == (self.d0 is None):
            raise ValueError("rolling: give exactly one of rolling.load [N] and rolling.d0 [m] (the other null)")
        if self.load is not None:
            checks.real("rolling.load", self.load, positive=True)
        if not 0.0 < checks.real("rolling.load_tolerance", self.load_tolerance) < 0.5:
            raise ValueError(f"rolling.load_tolerance: expected a relative tolerance in (0, 0.5), got {self.load_tolerance!r}")
        if self.d0 is not None:
            checks.real("rolling.d0", self.d0, positive=True)
        checks.real("rolling.quasistatic_step", self.quasistatic_step, positive=True)
        checks.integer("rolling.steady_margin", self.steady_margin, minimum=0)
        checks.real("rolling.steady_entry", self.steady_entry, nonnegative=True)
        checks.integer("rolling.entry_margin", self.entry_margin, minimum=0)
        checks.integer("rolling.contact_window", self.contact_window, minimum=2)
        if (self.x_start is None) != (self.x_end is None):
            raise ValueError("rolling.pass: give both x_start and x_end [m], or neither (automatic pass)")
        if self.x_start is not None and not self.x_start < self.x_end:
            raise ValueError(f"rolling.pass: expected x_start < x_end [m], got [{self.x_start}, {self.x_end}]")
        if not self.snapshots or any(not 0.0 <= s <= 1.0 for s in self.snapshots):
            raise ValueError(f"rolling.snapshots: expected fractions of the strip length in [0, 1], got {self.snapshots}")
        lo, hi = self.band_limits
        if not 0 < lo <= hi:
            raise ValueError(f"rolling.band_limits: expected 0 < low <= high [Hz], got {list(self.band_limits)}")

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "RollingSettings":
        """Build from the ``rolling`` config section (its study keys surface/materials/speeds are ignored).

        A key that is absent takes the dataclass field's default (the only place the defaults are
        written); ``pass: [x_start, x_end]`` gives both ends or neither.
        """
        s = dict(section or {})
        kwargs: dict[str, Any] = {}
        for name, convert in _CONVERTERS.items():
            if name in s:
                kwargs[name] = convert(s[name])
        x_start, x_end = s.get("pass") or (None, None)
        kwargs["x_start"] = _optional_float(x_start)
        kwargs["x_end"] = _optional_float(x_end)
        return cls(**kwargs)


def _optional_float(value: Any) -> float | None:
    return None if value is None else float(value)


def _float_tuple(values: Any) -> tuple[float, ...]:
    return tuple(float(v) for v in values)


#: How each config key of the section becomes a field (keys absent from the section keep the field default).
_CONVERTERS = {
    "radius": float,
    "load": _optional_float,
    "load_tolerance": float,
    "d0": _optional_float,
    "quasistatic_step": float,
    "steady_margin": int,
    "steady_entry": float,
    "entry_margin": int,
    "snapshots": _float_tuple,
    "band_limits": _float_tuple,
    "contact_window": int,
}
