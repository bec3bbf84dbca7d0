"""Loadings: the prescribed motion of the tread, as the free compression of every spring at step n.

With the layer displacement w_e excluded, spring e would be compressed by z1_e - z2_e[n], the gap
closure that the loading prescribes (SPEC 1, 6). A *loading* is any object with

    ``n_steps``                     number of steps;
    ``shape``                       the patch (nx, ny) [elements], M = nx ny springs;
    ``time``                        t_n [s], shape (n_steps,), or None for a sequence of static states;
    ``free_compression(n)``         z1_e - z2_e[n] [m], shape (M,);
    ``rest_compression()``          z1_e - z2_e before step 0, at rest (the Newton warm start of step 0);
    ``describe(n)``                 a short text locating step n for messages ("d = 1.2e-04 m");
    ``prescribed()``                what to store with the result, {name: (values, units, long_name)},
                                    each values array with the step as its first axis;
    ``done(n, force)``              True to end the run after step n (a cycle ends once every element
                                    has separated); ``unfinished(n)`` the message if the path ran out
                                    before that (None when ending early is not required).

The march loop (:func:`tyreroad.contact.march`) reads nothing else, so a new kind of motion (a
load-unload cycle, a rolling tyre with a z2 field per element) is a new loading, not an edit of
the loop. Heights enter relative to the highest road peak (``gap0 = z1 - max z1``), so that
z1 - z2 = gap0 + d carries no cancellation of absolute heights.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Protocol

import numpy as np

from . import checks

__all__ = [
    "Loading",
    "IndentationPath",
    "SeparatingPath",
    "LoadingPreset",
    "LOADING_KINDS",
    "constant_acceleration_path",
    "constant_acceleration_steps",
    "cycle_path",
    "harmonic_path",
    "read_loading_table",
    "uniform_indentation_grid",
    "uniform_grid_steps",
]


class Loading(Protocol):
    """Prescribed motion; see the module docstring."""

    n_steps: int
    shape: tuple[int, int]
    time: np.ndarray | None

    def free_compression(self, n: int) -> np.ndarray:  # pragma: no cover - protocol
        ...

    def rest_compression(self) -> np.ndarray:  # pragma: no cover - protocol
        ...

    def describe(self, n: int) -> str:  # pragma: no cover - protocol
        ...

    def prescribed(self) -> dict[str, tuple[np.ndarray, str, str]]:  # pragma: no cover - protocol
        ...

    def done(self, n: int, force: np.ndarray) -> bool:  # pragma: no cover - protocol
        ...

    def unfinished(self, n: int) -> str | None:  # pragma: no cover - protocol
        ...


class IndentationPath:
    """A flat tread surface z2(t) = max z1 - d(t): every spring sees the same indentation d[n].

    Parameters
    ----------
    z1 : array_like
        Road matching heights z1[ex, ey] [m].
    indentation : array_like
        d[n] [m], one per step (any sign and order: loading, holding, unloading).
    time : array_like, optional
        t_n [s]; None for a sequence of static states (quasi-static runs).
    """

    def __init__(self, z1, indentation, time=None):
        z1 = checks.finite_array("z1", z1, ndim=2)
        if z1.size == 0:
            raise ValueError("z1: expected a finite 2-D array of element heights [m], got an empty array")
        d = checks.finite_array("indentation", indentation, ndim=1)
        if d.size == 0:
            raise ValueError("indentation: expected at least one step [m]")
        self.shape = z1.shape
        self.gap0 = z1.ravel() - z1.max()
        self.indentation = d
        self.n_steps = d.size
        if time is not None:
            time = checks.finite_array("time", time, ndim=1)
            if time.size != d.size:
                raise ValueError(f"time: expected {d.size} values (one per step), got {time.size}")
        self.time = time

    def free_compression(self, n: int) -> np.ndarray:
        """gap0 + d[n] [m], shape (M,)."""
        return self.gap0 + self.indentation[n]

    def rest_compression(self) -> np.ndarray:
        """gap0 [m]: the surface touching the highest peak (d = 0) before the first step."""
        return self.gap0.copy()

    def describe(self, n: int) -> str:
        """``d = ... m`` of step n."""
        return f"d = {self.indentation[n]:.6e} m"

    def prescribed(self) -> dict[str, tuple[np.ndarray, str, str]]:
        """The indentation path, as stored in the contact file."""
        return {"indentation": (self.indentation.copy(), "m", "indentation d")}

    def done(self, n: int, force: np.ndarray) -> bool:
        """A plain path runs to its last step."""
        return False

    def unfinished(self, n: int) -> str | None:
        """Nothing is required of the last step."""
        return None


def constant_acceleration_path(sample_rate: float, acceleration: float, d_max: float) -> tuple[np.ndarray, np.ndarray]:
    """The seed's loading: t_n = n / fs and d_n = a t_n^2 / 2 until d reaches d_max.

    Parameters
    ----------
    sample_rate : float
        fs [Hz].
    acceleration : float
        a [m/s^2].
    d_max : float
        Final indentation [m].

    Returns
    -------
    time : numpy.ndarray
        [s], from 0 to the first step with d >= d_max.
    indentation : numpy.ndarray
        [m].
    """
    fs = checks.real("sample_rate", sample_rate, positive=True)
    a = checks.real("acceleration", acceleration, positive=True)
    time = np.arange(constant_acceleration_steps(fs, a, d_max)) / fs
    return time, 0.5 * a * time**2


def constant_acceleration_steps(sample_rate: float, acceleration: float, d_max: float) -> int:
    """Steps of :func:`constant_acceleration_path`: n = 0 ... ceil(fs sqrt(2 d_max / a)) [1].

    The one place of this count (planning checks, cluster requests and the run itself use it): the
    ceiling is taken after a relative 1e-12 shrink, so that a d_max hit exactly at a sample (to
    round-off) ends the run there instead of one step later.
    """
    fs = checks.real("sample_rate", sample_rate, positive=True)
    a = checks.real("acceleration", acceleration, positive=True)
    d_max = checks.real("d_max", d_max, positive=True)
    return math.ceil(fs * math.sqrt(2.0 * d_max / a) * (1.0 - 1e-12)) + 1


def uniform_indentation_grid(d_max: float, step: float) -> np.ndarray:
    """Indentations 0, dd, 2 dd, ... up to the first point >= d_max [m] (quasi-static runs)."""
    return np.arange(uniform_grid_steps(d_max, step)) * step


def uniform_grid_steps(d_max: float, step: float) -> int:
    """Points of :func:`uniform_indentation_grid`: 0 ... ceil(d_max / step) (same rounding as
    :func:`constant_acceleration_steps`) [1]."""
    d_max = checks.real("d_max", d_max, positive=True)
    step = checks.real("step", step, positive=True)
    return math.ceil(d_max / step * (1.0 - 1e-12)) + 1


# --------------------------------------------------------------------------------------------
# Loading presets (config section ``loadings``, SPEC 10)
# --------------------------------------------------------------------------------------------
LOADING_KINDS = ("constant_acceleration", "cycle", "harmonic", "table")

_PRESET_KEYS = {
    "constant_acceleration": {"acceleration": "m/s^2", "d_max": "m"},
    "cycle": {"load_speed": "m/s", "d_max": "m", "hold_time": "s", "unload_speed": "m/s"},
    "harmonic": {"preload": "m", "preload_speed": "m/s", "relax_time": "s", "amplitude": "m",
                 "frequency": "Hz", "periods": "1"},
    "table": {"file": "path"},
}
_OPTIONAL = {"harmonic": {"preload_speed": 0.1}}


class SeparatingPath(IndentationPath):
    """An indentation path that ends once every element has separated after ``release_step``.

    The path continues below d = 0 so that the layer, still recovering, can leave the road; the
    run stops at the first step from ``release_step`` on with no element in contact. A path that
    ends with elements still in contact is an error naming the last d.
    """

    def __init__(self, z1, indentation, time, release_step: int):
        super().__init__(z1, indentation, time)
        self.release_step = checks.integer("release_step", release_step, minimum=0)

    def done(self, n: int, force: np.ndarray) -> bool:
        return n >= self.release_step and not np.any(force > 0)

    def unfinished(self, n: int) -> str:
        return (f"unloading reached {self.describe(n)} with elements still in contact (the layer has not "
                "recovered; lengthen the unloading)")


class LoadingPreset:
    """A named loading path from the config (``loadings.<name>``), for dynamic and quasi-static runs.

    Kinds (keys, SI units):

    ``constant_acceleration`` (acceleration, d_max)
        The seed's d = a t^2 / 2 up to d_max; quasi-static: the uniform grid of ``quasistatic_step``.
    ``cycle`` (load_speed, d_max, hold_time, unload_speed)
        Load at constant speed to d_max, hold, unload at constant speed until every element has
        separated (the path continues to d = -d_max at most). Quasi-static: the uniform grid up to
        d_max and the same grid back down to 0 and one step below (no hold: a static state has no
        time), so that the loading and unloading branches meet at the same d.
    ``harmonic`` (preload, preload_speed [default 0.1 m/s], relax_time, amplitude, frequency, periods)
        Ramp to the preload d0, hold it for ``relax_time`` (let the tread relax), then
        d0 + amplitude sin(2 pi f t) for ``periods`` periods. Quasi-static: the same samples.
    ``table`` (file)
        d(t) from a CSV file of two columns t [s], d [m] (a header line and ``#`` comments are
        allowed); t starts at 0 and increases. Dynamic runs interpolate it linearly at t_n = n / fs;
        quasi-static runs solve the listed states.

    Parameters
    ----------
    name : str
        Preset name (the ``{loading}`` wildcard).
    spec : mapping
        The preset's config section.
    base_dir : str or Path
        Directory that a relative table ``file`` is read from.
    """

    def __init__(self, name: str, spec, base_dir="."):
        self.name = str(name)
        where = f"loadings.{self.name}"
        spec = dict(spec or {})
        kind = spec.pop("kind", None)
        if kind not in LOADING_KINDS:
            raise ValueError(f"{where}.kind: expected one of {', '.join(LOADING_KINDS)}, got {kind!r}")
        self.kind = kind
        keys = _PRESET_KEYS[kind]
        unknown = sorted(set(spec) - set(keys))
        if unknown:
            raise ValueError(f"{where}.{unknown[0]}: unknown key for kind {kind} (expected {', '.join(keys)})")
        values = dict(_OPTIONAL.get(kind, {}))
        values.update(spec)
        missing = sorted(set(keys) - set(values))
        if missing:
            raise ValueError(f"{where}.{missing[0]}: missing (kind {kind} needs {', '.join(keys)})")
        params = {}
        for key, unit in keys.items():
            if unit == "path":
                params[key] = Path(base_dir) / str(values[key])
            elif key == "periods":
                params[key] = checks.integer(f"{where}.{key}", values[key])
            else:
                params[key] = checks.real(f"{where}.{key}", values[key], positive=key != "relax_time",
                                          nonnegative=True)
        self.params = params
        self.config = {"kind": kind, **{k: (str(values[k]) if keys[k] == "path" else values[k]) for k in keys}}
        if kind == "table":
            self._table = read_loading_table(params["file"])

    @property
    def separates(self) -> bool:
        """True for paths that end once every element has left the road (cycles)."""
        return self.kind == "cycle"

    def path(self, mode: str, sample_rate: float, quasistatic_step: float):
        """(time or None, d [m], release step or None) of this preset for a ``mode`` run."""
        p = self.params
        fs = checks.real("sample_rate", sample_rate, positive=True)
        if self.kind == "constant_acceleration":
            if mode == "quasistatic":
                return None, uniform_indentation_grid(p["d_max"], quasistatic_step), None
            t, d = constant_acceleration_path(fs, p["acceleration"], p["d_max"])
            return t, d, None
        if self.kind == "cycle":
            if mode == "quasistatic":
                up = uniform_indentation_grid(p["d_max"], quasistatic_step)
                d = np.concatenate([up, up[-2::-1], [-quasistatic_step]])
                return None, d, up.size
            return cycle_path(fs, p["load_speed"], p["d_max"], p["hold_time"], p["unload_speed"])
        if self.kind == "harmonic":
            t, d = harmonic_path(fs, p["preload"], p["preload_speed"], p["relax_time"], p["amplitude"],
                                 p["frequency"], p["periods"])
            return t, d, None
        t_tab, d_tab = self._table
        if mode == "quasistatic":
            return t_tab.copy(), d_tab.copy(), None
        t = np.arange(int(np.floor(t_tab[-1] * fs * (1 + 1e-12))) + 1) / fs
        return t, np.interp(t, t_tab, d_tab), None

    def loading(self, z1, mode: str, sample_rate: float, quasistatic_step: float) -> IndentationPath:
        """The :class:`IndentationPath` (or :class:`SeparatingPath`) of this preset on a road patch."""
        time, d, release = self.path(mode, sample_rate, quasistatic_step)
        if release is None:
            return IndentationPath(z1, d, time)
        return SeparatingPath(z1, d, time, release)


def cycle_path(sample_rate: float, load_speed: float, d_max: float, hold_time: float, unload_speed: float):
    """Load at ``load_speed`` to ``d_max``, hold ``hold_time``, unload at ``unload_speed`` to -d_max.

    Returns
    -------
    time : numpy.ndarray
        t_n = n / fs [s].
    indentation : numpy.ndarray
        d(t_n) [m], piecewise linear in t.
    release_step : int
        First step of the unloading.
    """
    fs = checks.real("sample_rate", sample_rate, positive=True)
    t_load = d_max / load_speed
    t_release = t_load + hold_time
    t_end = t_release + 2.0 * d_max / unload_speed
    time = np.arange(int(np.ceil(t_end * fs)) + 1) / fs
    d = np.where(time < t_load, load_speed * time, d_max)
    d = np.where(time > t_release, d_max - unload_speed * (time - t_release), d)
    return time, d, int(np.searchsorted(time, t_release, side="right"))


def harmonic_path(sample_rate: float, preload: float, preload_speed: float, relax_time: float,
                  amplitude: float, frequency: float, periods: int):
    """Ramp to ``preload`` at ``preload_speed``, hold ``relax_time``, then preload + amplitude sin(2 pi f t).

    Returns
    -------
    time, indentation : numpy.ndarray
        t_n = n / fs [s] and d(t_n) [m].
    """
    fs = checks.real("sample_rate", sample_rate, positive=True)
    if amplitude >= preload:
        raise ValueError(f"harmonic: amplitude {amplitude:g} m must be smaller than the preload {preload:g} m "
                         "(the tread must stay pressed onto the road)")
    t_ramp = preload / preload_speed
    t_start = t_ramp + relax_time
    t_end = t_start + periods / frequency
    time = np.arange(int(np.ceil(t_end * fs * (1 - 1e-12))) + 1) / fs
    d = np.where(time < t_ramp, preload_speed * time, preload)
    oscillating = time >= t_start
    d = np.where(oscillating, preload + amplitude * np.sin(2 * np.pi * frequency * (time - t_start)), d)
    return time, d


def read_loading_table(path):
    """(t [s], d [m]) of a loading table: two CSV columns, optional header line, ``#`` comments.

    Raises
    ------
    ValueError
        Naming the file: unreadable, not two numeric columns, non-finite values, t not starting
        at 0 or not increasing.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as err:
        raise ValueError(f"loading table {path}: cannot be read ({err.strerror})") from None
    rows = []
    for number, line in enumerate(text.splitlines(), start=1):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        fields = [f.strip() for f in line.replace(";", ",").split(",")]
        try:
            values = [float(f) for f in fields]
        except ValueError:
            if not rows:
                continue  # a header line
            raise ValueError(f"loading table {path}, line {number}: expected two numbers t [s], d [m], got {line!r}") from None
        if len(values) != 2:
            raise ValueError(f"loading table {path}, line {number}: expected two columns t [s], d [m], got {len(values)}")
        rows.append(values)
    if len(rows) < 2:
        raise ValueError(f"loading table {path}: expected at least two rows of t [s], d [m]")
    table = np.asarray(rows)
    t, d = table[:, 0], table[:, 1]
    if not np.all(np.isfinite(table)):
        raise ValueError(f"loading table {path}: contains NaN or infinite values")
    if t[0] != 0.0 or np.any(np.diff(t) <= 0):
        raise ValueError(f"loading table {path}: t must start at 0 s and increase strictly")
    return t, d
