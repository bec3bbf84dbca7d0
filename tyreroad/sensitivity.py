"""What decides claims 5-7: a sweep of the stand-in material and the road surface.

The seed's claims 5 (saturation), 6 (a higher loss factor stiffens the saturated contact) and 7
(density ripples) depend on things the seed does not give: the tread's frequency dependence and the
road surface. This module re-runs the seed's experiment at one acceleration (default 500 m/s^2) for
a set of *points*, each a variant of the study's reference material and surface, and measures for
each point what the claims test (:mod:`tyreroad.report`):

* claim 6: the K_sat change of the loss-factor variants (x0.5 / x1.5, causal: the phase scaled and |E|
  kept at ``loss_anchor``, issue 24; the seed's constant-|E| variants are not causal and are refused here,
  as in every time-domain stage) -- sign and size;
* claim 7: the K_sat change of the density variant (x2) and the ripple ratio
  ripple(rho x2) / ripple(reference);
* claim 5: the contact fraction at 0.15 mm and the line-fit change of K over the saturation range;
* the equivalent quasi-static modulus factor s and its misfit
  (:func:`tyreroad.study.equivalent_modulus_scale`).

The measurements and verdicts of claims 5-7 are those of the report: the point's runs form a small
study (materials ``reference``, ``eta-low``, ``eta-high``, ``rho-high``; the quasi-static run of the
reference) on which the claim functions of :data:`tyreroad.report.CLAIMS` are evaluated
(:func:`measure_claims`). K(d), the contact fraction and K_sat of every run are the study's
(:func:`tyreroad.study.native_samples`, :func:`tyreroad.study.case_on_grid`).

A point is given in config section ``sensitivity.points`` as overrides of the study's reference
material preset (``material:``; a different ``model`` replaces the model keys and keeps
poisson_ratio, density, thickness and quasi_static_modulus) and of the study's surface preset
(``surface:``). Calibration (``calibrate: true``, the default): the moduli of the point's material
(every modulus key of its model; the springs follow through the quasi-static modulus) are multiplied
by a factor found so that the reference case's K_sat is within ``calibration_tolerance`` of
``target_stiffness`` (2.75 MN/m, claim 8): the first estimate assumes K_sat proportional to the
modulus (exact for the quasi-static force, approximate for a dynamic run), the next ones are
secant steps on log K_sat against log factor. The achieved K_sat is recorded. Loss and density
variants of a point use its calibrated moduli.

Every contact run goes through the public stage functions (:func:`tyreroad.surface.prepare_surface`,
:func:`tyreroad.springs.element_springs`, :func:`tyreroad.pipeline.build_greens`,
:func:`tyreroad.contact.solve_run`), exactly as the study's rules call them.
"""

from __future__ import annotations

import copy
import logging
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import xarray as xr

from . import io
from .contact import contact_dataset, solve_run
from .greens import GreensSettings
from .log import Progress
from .material import material_from_config
from .pipeline import build_greens, resolved_material_config
from .report.claims import CLAIMS, THRESHOLDS, ClaimContext
from .solver import SolverSettings
from .springs import SpringModel, element_springs, resolve_spring_modulus
from .study import (
    DEFAULT_INDENTATION_STEP,
    DEFAULT_SATURATION_RANGE,
    EQUIVALENT_RANGE,
    StudySettings,
    case_label,
    case_on_grid,
    equivalent_modulus_scale,
    native_samples,
    saturated_stiffness,
)
from .surface import prepare_surface

logger = logging.getLogger(__name__)

__all__ = [
    "SensitivitySettings",
    "VARIANTS",
    "point_material_preset",
    "point_surface_spec",
    "scale_moduli",
    "measure_claims",
    "run_point",
    "PointProgress",
    "combine_points",
    "conclusions",
    "sensitivity_markdown",
    "check_points",
    "planned_points",
    "point_files",
    "point_settings",
    "run_point_stage",
    "run_sensitivity_stage",
]

#: Cases run per point: the calibrated reference, its loss and density variants, and its quasi-static run.
VARIANTS = ("reference", "eta-low", "eta-high", "rho-high", "quasistatic")

#: Cases whose small-d ripple is measured: the quasi-static run has no inertia at all, so its ripple is
#: the part that comes from elements entering contact (the surface), not from the layer's inertia.
RIPPLE_CASES = ("reference", "rho-high", "quasistatic")

#: Modulus keys of each material model (multiplied by the calibration factor).
_MODULUS_KEYS = {
    "fractional_kelvin_voigt": ("E0", "E1"),
    "generalized_maxwell": ("E_inf", "moduli"),
    "table": ("storage_modulus",),
}
_COMMON_MATERIAL_KEYS = ("poisson_ratio", "density", "thickness", "quasi_static_modulus")
_POINT_KEYS = {"description", "material", "surface", "calibrate"}
_KEYS = {"acceleration", "target_stiffness", "calibration_tolerance", "max_calibration_runs", "loss_scales",
         "density_scale", "points", "loss_anchor"}
#: Frequencies at which the material is summarised in the table [Hz].
SUMMARY_FREQUENCIES = (1000.0, 10000.0)
#: Frequencies of the material curves stored per point (figure) [Hz].
CURVE_FREQUENCIES = np.geomspace(10.0, 25600.0, 61)


@dataclass(frozen=True)
class SensitivitySettings:
    """Config section ``sensitivity``.

    Attributes
    ----------
    points : dict
        Point name -> ``{"description": str, "material": {...}, "surface": {...}, "calibrate": bool}``.
    acceleration : float
        Indentation acceleration of the dynamic runs [m/s^2].
    target_stiffness : float
        K_sat the reference case of every calibrated point is tuned to [N/m].
    calibration_tolerance : float
        Accepted relative deviation of the achieved K_sat from the target [1].
    max_calibration_runs : int
        Dynamic runs allowed for the calibration of one point.
    loss_scales : tuple of float
        The low and high loss-factor scale (the seed: 0.5 and 1.5) [1].
    density_scale : float
        Density scale of the density variant (the seed: 2) [1].
    loss_anchor : float
        f_a [Hz] of the loss variants (causal, :mod:`tyreroad.material`); a point material's own
        ``loss_anchor`` wins (default 1 kHz, the study's).
    """

    points: dict = field(default_factory=dict)
    acceleration: float = 500.0
    target_stiffness: float = 2.75e6
    calibration_tolerance: float = 0.01
    max_calibration_runs: int = 4
    loss_scales: tuple[float, float] = (0.5, 1.5)
    density_scale: float = 2.0
    loss_anchor: float = 1000.0

    @classmethod
    def from_config(cls, section: Mapping[str, Any] | None) -> "SensitivitySettings":
        """Build from the ``sensitivity`` config section; missing keys take the defaults above.

        Raises
        ------
        ValueError
            Naming ``sensitivity.<key>`` for a missing section, an unknown key or a bad value.
        """
        if section is None:
            raise ValueError("config section 'sensitivity' is missing (needed by the sensitivity target)")
        if not isinstance(section, Mapping):
            raise ValueError(f"config section 'sensitivity' must be a mapping, got {type(section).__name__}")
        unknown = set(section) - _KEYS
        if unknown:
            raise ValueError(f"unknown key(s) {', '.join(sorted('sensitivity.' + k for k in unknown))}")
        points = section.get("points") or {}
        if not isinstance(points, Mapping) or not points:
            raise ValueError("sensitivity.points must be a non-empty mapping of point name -> settings")
        checked = {}
        for name, point in points.items():
            key = f"sensitivity.points.{name}"
            if not isinstance(name, str) or not name or not all(ch.isalnum() or ch in ".-" for ch in name):
                raise ValueError(f"{key}: point name must be letters, digits, '.' or '-' (it names a file)")
            point = {} if point is None else point
            if not isinstance(point, Mapping):
                raise ValueError(f"{key}: expected a mapping, got {type(point).__name__}")
            bad = set(point) - _POINT_KEYS
            if bad:
                raise ValueError(f"{key}: unknown key(s) {sorted(bad)}; expected {sorted(_POINT_KEYS)}")
            for sub in ("material", "surface"):
                if not isinstance(point.get(sub, {}) or {}, Mapping):
                    raise ValueError(f"{key}.{sub}: expected a mapping of preset overrides")
            if not isinstance(point.get("calibrate", True), bool):
                raise ValueError(f"{key}.calibrate: expected true or false, got {point['calibrate']!r}")
            checked[name] = {
                "description": str(point.get("description", name)),
                "material": dict(point.get("material") or {}),
                "surface": dict(point.get("surface") or {}),
                "calibrate": bool(point.get("calibrate", True)),
            }
        try:
            loss = tuple(float(x) for x in section.get("loss_scales", (0.5, 1.5)))
            values = {
                "acceleration": float(section.get("acceleration", 500.0)),
                "target_stiffness": float(section.get("target_stiffness", 2.75e6)),
                "calibration_tolerance": float(section.get("calibration_tolerance", 0.01)),
                "max_calibration_runs": int(section.get("max_calibration_runs", 4)),
                "density_scale": float(section.get("density_scale", 2.0)),
                "loss_anchor": float(section.get("loss_anchor", 1000.0)),
            }
        except (TypeError, ValueError) as exc:
            raise ValueError(f"sensitivity: numeric key with a non-numeric value: {exc}") from exc
        if len(loss) != 2 or not (0 < loss[0] < 1 < loss[1]):
            raise ValueError(f"sensitivity.loss_scales must be [low, high] with 0 < low < 1 < high, got {list(loss)!r}")
        for k in ("acceleration", "target_stiffness", "calibration_tolerance", "max_calibration_runs"):
            if not values[k] > 0:
                raise ValueError(f"sensitivity.{k} must be positive, got {values[k]!r}")
        if not (math.isfinite(values["loss_anchor"]) and values["loss_anchor"] >= 0):
            raise ValueError(f"sensitivity.loss_anchor must be a frequency >= 0 [Hz], got {values['loss_anchor']!r}")
        if not (values["density_scale"] > 0 and values["density_scale"] != 1):
            raise ValueError(f"sensitivity.density_scale must be positive and not 1, got {values['density_scale']!r}")
        return cls(points=checked, loss_scales=loss, **values)


def point_material_preset(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """The material preset of a point: the study's reference preset with the point's overrides.

    When the overrides name another ``model``, the base's model keys are dropped (only
    poisson_ratio, density, thickness and quasi_static_modulus are kept); otherwise the overrides
    replace single keys. ``base:``-chains must be resolved beforehand
    (:func:`tyreroad.pipeline.resolved_material_config`).
    """
    base = copy.deepcopy(dict(base))
    if "model" in overrides and overrides["model"] != base.get("model"):
        base = {k: base[k] for k in _COMMON_MATERIAL_KEYS if k in base}
    base.update(copy.deepcopy(dict(overrides)))
    return base


def point_surface_spec(base: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """The surface preset of a point: the study's surface preset with the point's overrides."""
    spec = copy.deepcopy(dict(base))
    spec.update(copy.deepcopy(dict(overrides)))
    return spec


def scale_moduli(preset: Mapping[str, Any], factor: float) -> dict[str, Any]:
    """A copy of a material preset with every modulus multiplied by ``factor`` [1].

    The modulus keys of the model (fractional: E0, E1; Maxwell: E_inf, moduli; table:
    storage_modulus) and a numeric quasi_static_modulus are scaled; the loss factor, density,
    Poisson's ratio and thickness are not.
    """
    model = preset.get("model")
    if model not in _MODULUS_KEYS:
        raise ValueError(f"material model {model!r}: expected one of {sorted(_MODULUS_KEYS)}")
    out = copy.deepcopy(dict(preset))
    for key in _MODULUS_KEYS[model]:
        if key in out:
            v = out[key]
            out[key] = [float(x) * factor for x in v] if isinstance(v, (list, tuple)) else float(v) * factor
    qs = out.get("quasi_static_modulus")
    if qs is not None and qs != "zero_frequency":
        out["quasi_static_modulus"] = float(qs) * factor
    return out


def loss_variant_preset(preset: Mapping[str, Any], scale: float, settings: SensitivitySettings) -> dict[str, Any]:
    """The loss variant of a point's (calibrated) preset: loss scale x ``scale``, causal (phase scaled,
    |E| kept at the preset's own ``loss_anchor`` or else ``settings.loss_anchor``)."""
    anchor = preset.get("loss_anchor")
    return dict(preset, loss_scale=scale * float(preset.get("loss_scale", 1.0)),
                loss_anchor=settings.loss_anchor if anchor is None else anchor)


def check_points(settings: SensitivitySettings, reference_material: Mapping[str, Any]) -> None:
    """Planning-time check: every point's material preset builds (calibration scaling included), and it
    and its loss variants are causal (every run of the sweep is in the time domain, issue 24).

    Raises
    ------
    ValueError
        Naming ``sensitivity.points.<name>.material`` and the material error.
    """
    from .material import causality_error

    for name, point in settings.points.items():
        preset = point_material_preset(reference_material, point["material"])
        try:
            material = material_from_config(name, {name: scale_moduli(preset, 1.0)})
            for scale in settings.loss_scales:
                material_from_config(name, {name: loss_variant_preset(scale_moduli(preset, 1.0), scale, settings)})
        except (KeyError, ValueError) as exc:
            raise ValueError(f"sensitivity.points.{name}.material: {exc}") from exc
        error = causality_error(material, f"sensitivity.points.{name}.material", "the sweep's contact runs")
        if error is not None:
            raise ValueError(error.replace(f"materials.{name}.loss_anchor",
                                           f"sensitivity.points.{name}.material.loss_anchor"))


def planned_points(config: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The sweep points of a whole config, checked at planning time ({} without a ``sensitivity`` section).

    Used by ``workflow/rules/sensitivity.smk``: validates the section (:class:`SensitivitySettings`)
    and every point's material (:func:`check_points`) against the study's reference material.
    """
    section = config.get("sensitivity")
    if section is None:
        return {}
    settings = SensitivitySettings.from_config(section)
    check_points(settings, resolved_material_config(config["study"]["reference_material"], config["materials"]))
    return settings.points


def point_files(points: Mapping[str, Any], results_dir: str = "results") -> list[str]:
    """Result files of the sweep points under ``results_dir``; a missing section is an error naming the key."""
    if not points:
        raise ValueError("config has no 'sensitivity' section: the sensitivity target needs sensitivity.points")
    return [f"{results_dir}/sensitivity/{name}.nc" for name in points]


def point_settings(sensitivity_cfg: Mapping[str, Any], name: str, point: Mapping[str, Any]) -> SensitivitySettings:
    """Settings of one point: the section's global keys with ``points`` reduced to this point."""
    return SensitivitySettings.from_config({**{k: v for k, v in sensitivity_cfg.items() if k != "points"},
                                            "points": {name: dict(point)}})


# --------------------------------------------------------------------------------------------------
# one point
# --------------------------------------------------------------------------------------------------
#: Runs of a point after its calibration: the loss variants, the density variant and the quasi-static run.
_VARIANT_RUNS = len(VARIANTS) - 1


class PointProgress:
    """Progress of one sweep point's contact runs: after each run a log line with the time left.

    A point runs its calibration (1 run without ``calibrate``, else until K_sat is within the
    tolerance, at most ``max_calibration_runs``) and then :data:`_VARIANT_RUNS` variant runs. Until the
    calibration has converged the total is an estimate (written ``~``): two calibration runs (the first
    run and one proportional step), one more for each further step; the time left is the rate estimate
    of :class:`tyreroad.log.Progress` (runs are taken as equally long; the first also builds the
    springs and Green's functions, so early estimates are high).

    Parameters
    ----------
    point : str
        Point name (in every line).
    calibrate : bool
        Whether the point calibrates its moduli.
    clock : callable, optional
        Monotonic clock [s] (tests pass a fake one).
    """

    def __init__(self, point: str, calibrate: bool, clock=None) -> None:
        self.point = point
        self.calibrating = bool(calibrate)
        self.done = 0
        self.progress = Progress((2 if calibrate else 1) + _VARIANT_RUNS, interval=0.0, clock=clock)

    @property
    def total(self) -> int:
        """Runs of the point, as far as known (an estimate while calibrating)."""
        return self.progress.total

    def calibration_step(self, runs: int) -> None:
        """Calibration run number ``runs`` (1-based) is about to start: the total counts at least it."""
        self.progress.total = max(self.progress.total, runs + _VARIANT_RUNS)

    def calibrated(self, runs: int) -> None:
        """The calibration ended after ``runs`` runs: the total is now exact."""
        self.calibrating = False
        self.progress.total = runs + _VARIANT_RUNS

    def run_done(self, label: str) -> str:
        """Log (INFO) and return the line for a finished run, e.g.
        ``point soft: run 3 of ~6 done (calibration 3, dynamic a=500), elapsed 1 min 10 s, about 2 min 20 s left``."""
        self.done += 1
        self.progress.total = max(self.progress.total, self.done)
        approx = "~" if self.calibrating else ""
        line = (f"point {self.point}: run {self.done} of {approx}{self.progress.total} done ({label}), "
                f"{self.progress.status(self.done)}")
        logger.info(line)
        return line


class _Runner:
    """Runs the stage functions for one surface; caches springs and Green's functions per material.

    ``study`` is the point as a study (:func:`_point_study`): its grid and saturation range.
    """

    def __init__(self, surface_name, surface, springs_cfg, greens_cfg, solver_cfg, study: StudySettings, threads):
        self.surface_name = surface_name
        self.surface = surface
        self.spring_model = SpringModel.from_config(springs_cfg)
        self.greens_settings = GreensSettings.from_config(greens_cfg)
        self.solver = SolverSettings.from_config(solver_cfg)
        self.study = study
        self.threads = threads
        self.n_elements = (int(surface.sizes["ex"]), int(surface.sizes["ey"]))
        self.element_size = float(surface.attrs["element_size"])
        self._cache: dict[str, tuple] = {}
        self.runs = 0
        self.progress: PointProgress | None = None

    def stages(self, name: str, preset: Mapping[str, Any]):
        key = io.config_yaml(dict(preset))
        if key not in self._cache:
            material = material_from_config(name, {name: dict(preset)})
            springs = element_springs(
                self.surface, self.spring_model,
                modulus=resolve_spring_modulus(self.spring_model, material.quasi_static_modulus),
                poisson=material.poisson, thickness=material.thickness,
            )
            # the study's own kernel (greens.construction, its correction and checks), not a bare fold
            greens = build_greens(material, self.n_elements, self.element_size, self.greens_settings)
            self._cache[key] = (material, springs, greens)
        return self._cache[key]

    def run(self, name: str, preset: Mapping[str, Any], mode: str, accel: float, label: str = "") -> dict[str, Any]:
        """One contact run; K(d), contact fraction on the grid and K_sat, as the study computes them.

        ``label`` names the run in the progress line (default: ``name``)."""
        material, springs, greens = self.stages(name, preset)
        res = solve_run(self.surface, springs, greens, material, mode, accel, self.solver, self.threads)
        self.runs += 1
        ds = contact_dataset(res, mode, accel, self.surface_name, name)
        curves = case_on_grid(native_samples(ds, f"{name} {mode} a={accel:g}", self.study), self.study)
        k = curves["stiffness"]
        ksat = saturated_stiffness(self.study.grid, k, self.study.saturation_range)
        logger.info("%s %s a=%g: K_sat = %.4g N/m", name, mode, accel, ksat)
        if self.progress is not None:
            self.progress.run_done(f"{label or name}, {mode} a={accel:g}")
        return {"stiffness": k, "contact_fraction": curves["contact_fraction"], "ksat": ksat, "material": material}


def _calibrate(runner: _Runner, name: str, preset: Mapping[str, Any], settings: SensitivitySettings,
               calibrate: bool) -> tuple[float, dict[str, Any], list[tuple[float, float]]]:
    """Modulus factor that puts the reference case's K_sat at the target; returns (factor, run, history)."""
    a, target = settings.acceleration, settings.target_stiffness
    factor = 1.0
    history: list[tuple[float, float]] = []
    progress = getattr(runner, "progress", None)
    out = runner.run(name, scale_moduli(preset, factor), "dynamic", a, label="calibration 1")
    history.append((factor, out["ksat"]))
    while calibrate and abs(out["ksat"] / target - 1) > settings.calibration_tolerance:
        if len(history) >= settings.max_calibration_runs:
            logger.warning("point %s: calibration stopped after %d runs at K_sat = %.4g N/m (target %.4g)",
                           name, len(history), out["ksat"], target)
            break
        if progress is not None:
            progress.calibration_step(len(history) + 1)
        if len(history) == 1:
            factor = factor * target / out["ksat"]  # K proportional to the modulus (exact quasi-statically)
        else:
            (s1, k1), (s2, k2) = history[-2], history[-1]
            slope = (math.log(k2) - math.log(k1)) / (math.log(s2) - math.log(s1))
            if not (math.isfinite(slope) and slope > 0.1):
                slope = 1.0
            factor = s2 * math.exp((math.log(target) - math.log(k2)) / slope)
        out = runner.run(name, scale_moduli(preset, factor), "dynamic", a, label=f"calibration {len(history) + 1}")
        history.append((factor, out["ksat"]))
    if progress is not None:
        progress.calibrated(len(history))
    return factor, out, history


#: The point's cases as a study (material label, mode), one per entry of :data:`VARIANTS`: the quasi-static
#: run is the reference material's.
_POINT_CASES = {"reference": ("reference", "dynamic"), "eta-low": ("eta-low", "dynamic"),
                "eta-high": ("eta-high", "dynamic"), "rho-high": ("rho-high", "dynamic"),
                "quasistatic": ("reference", "quasistatic")}


def _point_study(name: str, study_cfg: Mapping[str, Any], d_max: float, settings: SensitivitySettings) -> StudySettings:
    """The point as a study: its variants as materials, one acceleration, the study's grid and saturation range."""
    return StudySettings(
        surface=f"sensitivity-{name}",
        reference_material="reference",
        materials=tuple(dict.fromkeys(material for material, _ in _POINT_CASES.values())),
        accelerations=(float(settings.acceleration),),
        indentation_step=float(study_cfg.get("indentation_step", DEFAULT_INDENTATION_STEP)),
        saturation_range=tuple(float(x) for x in study_cfg.get("saturation_range", DEFAULT_SATURATION_RANGE)),
        d_max=d_max,
    )


def measure_claims(runs: Mapping[str, Mapping[str, Any]], study: StudySettings,
                   settings: SensitivitySettings) -> dict[str, Any]:
    """Claims 5, 6 and 7 of one point, measured and decided by the report's claim registry.

    The runs form a study dataset (cases :data:`_POINT_CASES`, the loss variants at
    ``settings.loss_scales`` and the density variant at ``settings.density_scale`` as the variant
    groups) on which :data:`tyreroad.report.CLAIMS` 5, 6 and 7 are evaluated with the report's
    thresholds, so that a point's verdict is the one the report would give for the same curves.

    Parameters
    ----------
    runs : mapping
        Variant (:data:`VARIANTS`) -> ``{"stiffness": K [N/m], "contact_fraction": [1], "ksat": K_sat [N/m]}``
        on ``study.grid``.
    study : StudySettings
        The point as a study (:func:`_point_study`).
    settings : SensitivitySettings
        The sweep settings (acceleration, loss and density scales).

    Returns
    -------
    dict
        ``loss_delta`` {scale: Delta K_sat [1]}, ``claim6_verdict``, ``density_delta`` [1],
        ``ripple`` {case of :data:`RIPPLE_CASES`: ripple / K_sat [1]}, ``ripple_ratio`` [1],
        ``claim7_verdict``, ``fraction_at_c5`` [1], ``saturation_change`` [1], ``claim5_verdict``.
    """
    cases = [(*_POINT_CASES[v], 0.0 if _POINT_CASES[v][1] == "quasistatic" else float(settings.acceleration))
             for v in VARIANTS]
    cols = {"units": "1", "long_name": "case"}
    ds = xr.Dataset(
        {
            "stiffness": (("case", "indentation"), np.stack([runs[v]["stiffness"] for v in VARIANTS])),
            "contact_fraction": (("case", "indentation"), np.stack([runs[v]["contact_fraction"] for v in VARIANTS])),
            "saturated_stiffness": ("case", np.array([runs[v]["ksat"] for v in VARIANTS])),
        },
        coords={
            "case": ("case", [case_label(*c) for c in cases], cols),
            "material": ("case", [c[0] for c in cases], cols),
            "mode": ("case", [c[1] for c in cases], cols),
            "accel": ("case", np.array([c[2] for c in cases]), cols),
            "indentation": ("indentation", study.grid, {"units": "m", "long_name": "indentation d"}),
        },
    )
    lo, hi = settings.loss_scales
    variants = {"loss": [[lo, "eta-low"], [1.0, "reference"], [hi, "eta-high"]],
                "density": [[1.0, "reference"], [settings.density_scale, "rho-high"]]}
    ctx = ClaimContext(ds, study, variants)
    c5, c6, c7 = (CLAIMS[n](ctx) for n in (5, 6, 7))
    rip = c7.values["ripple"]
    return {
        "loss_delta": dict(c6.values["delta"]),
        "claim6_verdict": c6.verdict,
        "density_delta": c7.values["delta"][settings.density_scale],
        "ripple": {"reference": rip[1.0], "rho-high": rip[settings.density_scale],
                   "quasistatic": c7.values["ripple_quasistatic"]},
        "ripple_ratio": c7.values["ripple_ratio"],
        "claim7_verdict": c7.verdict,
        "fraction_at_c5": c5.values["fraction"],
        "saturation_change": c5.values["change"],
        "claim5_verdict": c5.verdict,
    }


def run_point(
    name: str,
    point: Mapping[str, Any],
    reference_material: Mapping[str, Any],
    surface_spec: Mapping[str, Any],
    springs_cfg: Mapping[str, Any],
    greens_cfg: Mapping[str, Any],
    solver_cfg: Mapping[str, Any],
    study_cfg: Mapping[str, Any],
    settings: SensitivitySettings,
    threads: int = 1,
    clock=None,
) -> xr.Dataset:
    """Run and measure one point of the sweep.

    Parameters
    ----------
    name : str
        Point name.
    point : mapping
        ``{"description", "material", "surface", "calibrate"}`` (see :class:`SensitivitySettings`).
    reference_material : mapping
        The study's reference material preset, ``base:`` resolved.
    surface_spec : mapping
        The study's surface preset.
    springs_cfg, greens_cfg, solver_cfg : mapping
        Config sections ``springs``, ``greens`` and ``solver`` (the study's).
    study_cfg : mapping
        Config section ``study`` (indentation_step, saturation_range).
    settings : SensitivitySettings
        The sweep settings.
    threads : int
        numba threads of the contact solver.
    clock : callable, optional
        Monotonic clock [s] of the progress lines (:class:`PointProgress`; default ``time.monotonic``).

    Returns
    -------
    xarray.Dataset
        Dimension ``point`` (length 1), ``variant`` (:data:`VARIANTS`) and ``indentation``; see
        :func:`combine_points` for the variables.
    """
    start = time.perf_counter()
    d_max = float(solver_cfg["d_max"])
    study = _point_study(name, study_cfg, d_max, settings)
    grid, sat = study.grid, study.saturation_range
    preset = point_material_preset(reference_material, point.get("material", {}))
    spec = point_surface_spec(surface_spec, point.get("surface", {}))
    surface = prepare_surface(f"sensitivity-{name}", spec)
    runner = _Runner(f"sensitivity-{name}", surface, springs_cfg, greens_cfg, solver_cfg, study, threads)
    calibrate = bool(point.get("calibrate", True))
    runner.progress = PointProgress(name, calibrate, clock=clock)  # a line with the time left after each run

    factor, ref, history = _calibrate(runner, name, preset, settings, calibrate)
    cal = scale_moduli(preset, factor)
    lo_s, hi_s = settings.loss_scales
    runs = {"reference": ref}
    for label, scale in (("eta-low", lo_s), ("eta-high", hi_s)):
        runs[label] = runner.run(name, loss_variant_preset(cal, scale, settings), "dynamic", settings.acceleration,
                                 label=label)
    runs["rho-high"] = runner.run(name, dict(cal, density=float(cal["density"]) * settings.density_scale), "dynamic",
                                  settings.acceleration, label="rho-high")
    runs["quasistatic"] = runner.run(name, cal, "quasistatic", 0.0, label="reference")

    ksat = {v: runs[v]["ksat"] for v in VARIANTS}
    k_ref = ksat["reference"]
    m = measure_claims(runs, study, settings)
    loss_delta, rip, ratio, change = m["loss_delta"], m["ripple"], m["ripple_ratio"], m["saturation_change"]
    eq_range = (EQUIVALENT_RANGE[0], min(EQUIVALENT_RANGE[1], d_max))
    s_eq, misfit = equivalent_modulus_scale(grid, runs["reference"]["stiffness"], runs["quasistatic"]["stiffness"],
                                            eq_range)
    mat = ref["material"]
    w = 2 * np.pi * np.asarray(SUMMARY_FREQUENCIES)
    w_curve = 2 * np.pi * CURVE_FREQUENCIES
    hi_mat = runs["eta-high"]["material"]
    storage_change_high = hi_mat.storage_modulus(w) / mat.storage_modulus(w) - 1.0
    logger.info(
        "point %s: factor %.4f (%d calibration runs), K_sat %.4g N/m; dK eta: %s; ripple ratio %.3f; "
        "K change %.3f; %d runs in all", name, factor, len(history), k_ref, loss_delta, ratio, change, runner.runs,
    )

    def one(values, dims=()):
        return (("point", *dims), np.asarray(values)[None, ...])

    data = {
        "stiffness": one(np.stack([runs[v]["stiffness"] for v in VARIANTS]), ("variant", "indentation")),
        "contact_fraction": one(np.stack([runs[v]["contact_fraction"] for v in VARIANTS]), ("variant", "indentation")),
        "saturated_stiffness": one([ksat[v] for v in VARIANTS], ("variant",)),
        "modulus_factor": one(factor),
        "calibration_runs": one(len(history)),
        "loss_delta": one([loss_delta[lo_s], loss_delta[hi_s]], ("loss_scale",)),
        "claim6_verdict": one(m["claim6_verdict"]),
        "density_delta": one(m["density_delta"]),
        "ripple": one([rip[v] for v in RIPPLE_CASES], ("ripple_case",)),
        "ripple_ratio": one(ratio),
        "claim7_verdict": one(m["claim7_verdict"]),
        "fraction_at_c5": one(m["fraction_at_c5"]),
        "saturation_change": one(change),
        "claim5_verdict": one(m["claim5_verdict"]),
        "equivalent_modulus_scale": one(s_eq),
        "equivalent_misfit": one(misfit),
        "storage_modulus": one(mat.storage_modulus(w), ("summary_frequency",)),
        "loss_factor": one(mat.loss_factor(w), ("summary_frequency",)),
        "storage_change_high_loss": one(storage_change_high, ("summary_frequency",)),
        "storage_curve": one(mat.storage_modulus(w_curve), ("frequency",)),
        "loss_factor_curve": one(mat.loss_factor(w_curve), ("frequency",)),
        "contact_runs": one(runner.runs),
        "wall_time": one(time.perf_counter() - start),
        "description": one(str(point.get("description", name))),
        "material_preset": one(io.config_yaml(cal)),
        "surface_preset": one(io.config_yaml(spec)),
    }
    coords = {
        "point": [name],
        "variant": list(VARIANTS),
        "indentation": grid,
        "loss_scale": [lo_s, hi_s],
        "ripple_case": list(RIPPLE_CASES),
        "summary_frequency": list(SUMMARY_FREQUENCIES),
        "frequency": CURVE_FREQUENCIES,
    }
    ds = xr.Dataset(data, coords=coords)
    _annotate(ds, settings, sat, eq_range)
    return ds


_ATTRS = {
    "point": ("1", "sweep point"),
    "variant": ("1", "case of the point: calibrated reference, loss-factor low/high, density high, quasi-static"),
    "indentation": ("m", "indentation d"),
    "loss_scale": ("1", "loss-factor scale of the loss variants (causal: phase scaled, |E| kept at loss_anchor_Hz)"),
    "ripple_case": ("1", "case of the ripple measure"),
    "summary_frequency": ("Hz", "frequency of the material summary"),
    "frequency": ("Hz", "frequency of the material curves"),
    "storage_curve": ("Pa", "storage modulus E'(f) of the point's calibrated material"),
    "loss_factor_curve": ("1", "loss factor eta(f) of the point's calibrated material"),
    "contact_runs": ("1", "contact runs of the point (calibration, variants, quasi-static)"),
    "wall_time": ("s", "wall-clock time of the point (surface, springs, Green's functions, runs)"),
    "stiffness": ("N/m", "contact stiffness K = dF/dd on the grid (loading branch)"),
    "contact_fraction": ("1", "fraction of elements in contact"),
    "saturated_stiffness": ("N/m", "K_sat: median of K over the saturation range"),
    "modulus_factor": ("1", "calibration factor applied to every modulus of the point's material"),
    "calibration_runs": ("1", "dynamic runs used by the calibration"),
    "loss_delta": ("1", "K_sat(loss variant) / K_sat(reference) - 1 (claim 6)"),
    "claim6_verdict": ("1", "claim 6 verdict: holds / size holds, direction opposite / fails"),
    "density_delta": ("1", "K_sat(density variant) / K_sat(reference) - 1 (claim 7)"),
    "ripple": ("1", "RMS of K minus its smoothing for small d over K_sat(reference) (claim 7)"),
    "ripple_ratio": ("1", "ripple(density variant) / ripple(reference) (claim 7)"),
    "claim7_verdict": ("1", "claim 7 verdict: holds / fails"),
    "fraction_at_c5": ("1", f"contact fraction of the reference case at {THRESHOLDS['c5_d'] * 1e3:g} mm (claim 5)"),
    "saturation_change": ("1", "line-fit change of K over the saturation range over K_sat (claim 5)"),
    "claim5_verdict": ("1", "claim 5 verdict: holds / fails"),
    "equivalent_modulus_scale": ("1", "least-squares factor s of K_dyn(d) ~ s K_QS(d) over the equivalent range"),
    "equivalent_misfit": ("1", "RMS(K_dyn - s K_QS) / RMS(K_dyn) over the equivalent range"),
    "storage_modulus": ("Pa", "storage modulus E' of the point's calibrated material"),
    "loss_factor": ("1", "loss factor of the point's calibrated material"),
    "storage_change_high_loss": ("1", "E'(high loss variant) / E'(reference) - 1"),
    "description": ("1", "what the point changes"),
    "material_preset": ("1", "the point's calibrated material preset (YAML)"),
    "surface_preset": ("1", "the point's surface preset (YAML)"),
}


def _annotate(ds: xr.Dataset, settings: SensitivitySettings, sat, eq_range) -> None:
    for name, (units, long_name) in _ATTRS.items():
        if name in ds.variables:
            ds[name].attrs.update({"units": units, "long_name": long_name})
    ds.attrs.update({
        "acceleration_m_s2": settings.acceleration,
        "target_stiffness_N_m": settings.target_stiffness,
        "calibration_tolerance": settings.calibration_tolerance,
        "density_scale": settings.density_scale,
        "loss_anchor_Hz": settings.loss_anchor,
        "saturation_range_m": np.asarray(sat, dtype=float),
        "equivalent_range_m": np.asarray(eq_range, dtype=float),
    })


def combine_points(points: Sequence[xr.Dataset]) -> xr.Dataset:
    """The sweep dataset ``results/sensitivity.nc``: the points along ``point``.

    Variables (per point): ``stiffness``/``contact_fraction`` (variant, indentation),
    ``saturated_stiffness`` (variant), ``modulus_factor``, ``calibration_runs``, ``loss_delta``
    (loss_scale), ``claim6_verdict``, ``density_delta``, ``ripple`` (ripple_case), ``ripple_ratio``,
    ``claim7_verdict``, ``fraction_at_c5``, ``saturation_change``, ``claim5_verdict``,
    ``equivalent_modulus_scale``, ``equivalent_misfit``, ``storage_modulus``/``loss_factor``/
    ``storage_change_high_loss`` (summary_frequency), ``description``, ``material_preset``,
    ``surface_preset``.
    """
    if not points:
        raise ValueError("no sweep points to combine")
    names = [str(p["point"].values[0]) for p in points]
    if len(set(names)) != len(names):
        raise ValueError(f"duplicate sweep points: {names}")
    out = xr.concat(list(points), dim="point", data_vars="minimal", coords="minimal", compat="override",
                    combine_attrs="override")
    return out


# --------------------------------------------------------------------------------------------------
# conclusions and markdown
# --------------------------------------------------------------------------------------------------
def conclusions(ds: xr.Dataset) -> dict[str, list[str]]:
    """Which points reproduce the seed's claims 5, 6 (direction) and 7 (ripples).

    Returns
    -------
    dict
        ``{"claim5": [...], "claim6_direction": [...], "claim6": [...], "claim7_ripples": [...],
        "claim7": [...]}``: the point names for which the claim (or the named part) holds.
    """
    names = [str(p) for p in ds["point"].values]
    v6 = ds["claim6_verdict"].values.astype(str)
    delta = ds["loss_delta"].values
    scales = ds["loss_scale"].values
    direction = [bool(np.all(np.sign(delta[i]) == np.sign(scales - 1.0))) for i in range(len(names))]
    ripples = ds["ripple_ratio"].values >= THRESHOLDS["c7_ripple_ratio_min"]
    return {
        "claim5": [n for n, v in zip(names, ds["claim5_verdict"].values.astype(str)) if v == "holds"],
        "claim6_direction": [n for n, ok in zip(names, direction) if ok],
        "claim6": [n for n, v in zip(names, v6) if v == "holds"],
        "claim7_ripples": [n for n, ok in zip(names, ripples) if ok],
        "claim7": [n for n, v in zip(names, ds["claim7_verdict"].values.astype(str)) if v == "holds"],
    }


def _cell(text) -> str:
    """Text for a markdown table cell (pipes escaped)."""
    return str(text).replace("|", "\\|")


def _list(names: Sequence[str]) -> str:
    return ", ".join(f"`{n}`" for n in names)


def sensitivity_markdown(ds: xr.Dataset, timing: str | None = None) -> str:
    """The sweep section ``results/sensitivity.md``: "What decides claims 5–7", table and conclusion."""
    t = THRESHOLDS
    names = [str(p) for p in ds["point"].values]
    f = ds["summary_frequency"].values
    lo, hi = ds["loss_scale"].values
    a = float(ds.attrs.get("acceleration_m_s2", 500.0))
    lines = [
        "# What decides claims 5–7: sensitivity sweep",
        "",
        f"Each point changes the study's reference material or surface, recalibrates the moduli so that the "
        f"dynamic K_sat at a = {a:g} m/s² is {float(ds.attrs.get('target_stiffness_N_m', 2.75e6)) * 1e-6:g} MN/m "
        f"(± {100 * float(ds.attrs.get('calibration_tolerance', 0.01)):g} %, unless `calibrate: false`), and "
        f"measures claim 6 (K_sat change of η×{lo:g} and η×{hi:g}, causal: phase scaled, |E| kept at "
        f"{float(ds.attrs.get('loss_anchor_Hz', 1000.0)):g} Hz), claim 7 (K_sat change and "
        f"ripple ratio of ρ×{float(ds.attrs.get('density_scale', 2.0)):g}) and claim 5 (contact fraction at "
        f"{t['c5_d'] * 1e3:g} mm, change of K over the saturation range), with the report's tests and thresholds.",
        "",
        "| point | what | E′ / η at " + " / ".join(f"{x / 1e3:g}" for x in f) + " kHz | factor | K_sat [MN/m] | "
        f"ΔK_sat η×{lo:g} | ΔK_sat η×{hi:g} | claim 6 | ΔK_sat ρ×{float(ds.attrs.get('density_scale', 2.0)):g} | "
        f"ripple ×1e-3 ref / ρ / QS | ripple ratio | claim 7 | fraction at {t['c5_d'] * 1e3:g} mm | K change | claim 5 | "
        "s(a) / misfit |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for i, n in enumerate(names):
        p = ds.isel(point=i)
        mat = "; ".join(f"{float(e) / 1e6:.0f} MPa / {float(eta):.2f}"
                        for e, eta in zip(p["storage_modulus"].values, p["loss_factor"].values))
        d6 = p["loss_delta"].values
        lines.append(
            f"| `{n}` | {_cell(p['description'].values)} | {mat} | {float(p['modulus_factor']):.3f} | "
            f"{float(p['saturated_stiffness'].sel(variant='reference')) * 1e-6:.3f} | "
            f"{100 * d6[0]:+.2f} % | {100 * d6[1]:+.2f} % | {str(p['claim6_verdict'].values)} | "
            f"{100 * float(p['density_delta']):+.2f} % | "
            + " / ".join(f"{1e3 * float(r):.2f}" for r in p["ripple"].values)
            + f" | {float(p['ripple_ratio']):.2f} | {str(p['claim7_verdict'].values)} | "
            f"{float(p['fraction_at_c5']):.3f} | {100 * float(p['saturation_change']):.1f} % | "
            f"{str(p['claim5_verdict'].values)} | {float(p['equivalent_modulus_scale']):.3f} / "
            f"{100 * float(p['equivalent_misfit']):.2f} % |"
        )
    c = conclusions(ds)
    d_hi = ds["loss_delta"].values[:, 1]
    ratios = ds["ripple_ratio"].values
    change = ds["saturation_change"].values
    lines += ["", "## Conclusion", ""]
    if c["claim6_direction"]:
        lines.append(f"- **Claim 6, direction.** The seed's direction (η×{hi:g} stiffer, η×{lo:g} softer) comes out "
                     f"for {_list(c['claim6_direction'])}; with the seed's size as well (claim holds) for "
                     f"{_list(c['claim6']) or 'none'}. Every other point gives the opposite direction or a mixed one.")
    else:
        e_hi = ds["storage_change_high_loss"].values
        text = (f"- **Claim 6, direction.** None of the {len(names)} points reproduces the seed's direction: "
                f"ΔK_sat(η×{hi:g}) lies between {100 * d_hi.min():+.2f} % and {100 * d_hi.max():+.2f} %. "
                f"The causal loss scaling (|E| kept at {float(ds.attrs.get('loss_anchor_Hz', 1000.0)):g} Hz) η×{hi:g} changes E′ by "
                f"{100 * e_hi.min():+.1f} % to {100 * e_hi.max():+.1f} % at "
                + " and ".join(f"{x / 1e3:g}" for x in f) + " kHz")
        if np.all(np.sign(d_hi) == np.sign(e_hi[:, 0])):
            text += ", and K_sat follows the sign of the E′ change at every point."
        else:
            text += "."
        lines.append(text)
    if c["claim7_ripples"]:
        lines.append(f"- **Claim 7, ripples.** A ripple ratio ≥ {t['c7_ripple_ratio_min']:g} comes out for "
                     f"{_list(c['claim7_ripples'])}; the whole claim (also |ΔK_sat| ≤ {100 * t['c7_delta_max']:g} %) "
                     f"holds for {_list(c['claim7']) or 'none'}.")
    else:
        lines.append(f"- **Claim 7, ripples.** None of the points gives density ripples: the ripple ratio "
                     f"ρ×{float(ds.attrs.get('density_scale', 2.0)):g}/reference lies between {ratios.min():.2f} and {ratios.max():.2f} "
                     f"(the test asks ≥ {t['c7_ripple_ratio_min']:g}).")
    if "quasistatic" in [str(c) for c in ds["ripple_case"].values]:
        qs_share = (ds["ripple"].sel(ripple_case="quasistatic") / ds["ripple"].sel(ripple_case="reference")).values
        lines.append(f"  The quasi-static run, which has no inertia, ripples {qs_share.min():.2f}–{qs_share.max():.2f} "
                     "times as much as the dynamic reference: the small-d ripple measured here comes mostly from "
                     "elements entering contact one by one (the surface), not from the layer's inertia.")
    if c["claim5"]:
        lines.append(f"- **Claim 5, saturation.** Holds for {_list(c['claim5'])}; the change of K over the "
                     f"saturation range runs from {100 * change.min():.1f} % to {100 * change.max():.1f} % "
                     f"(limit {100 * t['c5_change_max']:g} %).")
    else:
        lines.append(f"- **Claim 5, saturation.** Holds for no point: the change of K over the saturation range "
                     f"runs from {100 * change.min():.1f} % to {100 * change.max():.1f} % "
                     f"(limit {100 * t['c5_change_max']:g} %).")
    frac = ds["fraction_at_c5"].values
    inside = np.all((frac >= t["c5_fraction_lo"]) & (frac <= t["c5_fraction_hi"]))
    lines.append(f"  The contact fraction at {t['c5_d'] * 1e3:g} mm runs from {frac.min():.3f} to {frac.max():.3f}"
                 + (", inside the claim's range at every point: what fails is the saturation." if inside else "."))
    wall = ds["wall_time"].values
    lines += [
        "",
        f"Cost: {int(ds['contact_runs'].values.sum())} contact runs (with {int(ds['calibration_runs'].values.sum())} "
        f"calibration runs) and their Green's functions in {wall.sum() / 60:.1f} min of computation "
        f"({wall.min():.0f}–{wall.max():.0f} s per point, one core each).",
    ]
    if timing:
        lines += ["", timing]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------------
# stages (the Snakemake adapters of workflow/rules/sensitivity.smk call these)
# --------------------------------------------------------------------------------------------------
def run_point_stage(name: str, point: Mapping[str, Any], reference_material: Mapping[str, Any],
                    surface_spec: Mapping[str, Any], springs_cfg: Mapping[str, Any], greens_cfg: Mapping[str, Any],
                    solver_cfg: Mapping[str, Any], study_cfg: Mapping[str, Any], sensitivity_cfg: Mapping[str, Any],
                    out_nc, threads: int = 1) -> None:
    """Stage ``sensitivity_point``: run one point (:func:`run_point`) and write its netCDF."""
    settings = point_settings(sensitivity_cfg, name, point)
    point = settings.points[name]
    ds = run_point(name, point, reference_material, surface_spec, springs_cfg, greens_cfg, solver_cfg, study_cfg,
                   settings, threads)
    provenance = {
        "sensitivity": dict(sensitivity_cfg), "point": {name: dict(point)}, "reference_material": dict(reference_material),
        "surface": dict(surface_spec), "springs": dict(springs_cfg), "greens": dict(greens_cfg),
        "solver": dict(solver_cfg), "study": dict(study_cfg),
    }
    io.write_dataset(ds, out_nc, provenance, stage="sensitivity_point", point=name)


def run_sensitivity_stage(point_ncs: Sequence, sensitivity_cfg: Mapping[str, Any], out_nc, out_png, out_md) -> None:
    """Stage ``sensitivity``: combine the points, write ``sensitivity.nc``, its figure and ``sensitivity.md``."""
    # deferred on purpose: matplotlib is needed by this stage only, not by the sensitivity_point jobs
    # (the module is imported there too), whose start-up stays short without it
    from .plots.sensitivity import plot_sensitivity

    ds = combine_points([io.read_dataset(p) for p in point_ncs])
    io.write_dataset(ds, out_nc, {"sensitivity": dict(sensitivity_cfg)}, stage="sensitivity")
    with io.atomic_path(out_png) as tmp:
        plot_sensitivity(ds, tmp)
    text = sensitivity_markdown(ds)
    with io.atomic_path(out_md) as tmp:
        Path(tmp).write_text(text, encoding="utf-8")
    logger.info("wrote %s, %s and %s", out_nc, out_png, out_md)
