"""Loading and checking the study configuration.

The JSON schema (``workflow/schemas/config.schema.yaml``) checks each key's type, range and unit.
:func:`check_references` adds the checks a schema cannot express: names in the ``study`` section
that must exist as presets, and consistent ranges. Snakemake runs both before any job.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Mapping

import yaml

__all__ = ["ConfigError", "load_config", "merge", "check_references"]


class ConfigError(ValueError):
    """The configuration is invalid; the message names the key and what was expected."""


def merge(base: Mapping[str, Any], overlay: Mapping[str, Any]) -> dict[str, Any]:
    """Recursively merge ``overlay`` into a copy of ``base`` (mappings merge, everything else replaces).

    This is how Snakemake applies ``--configfile`` overlays on top of ``configfile:``.
    """
    out = copy.deepcopy(dict(base))
    for key, value in overlay.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def load_config(*paths: str | Path) -> dict[str, Any]:
    """Read one or more YAML config files, later ones overlaid on earlier ones."""
    config: dict[str, Any] = {}
    for path in paths:
        path = Path(path)
        if not path.exists():
            raise ConfigError(f"{path}: config file not found")
        with path.open() as fh:
            data = yaml.safe_load(fh) or {}
        if not isinstance(data, Mapping):
            raise ConfigError(f"{path}: expected a mapping of config sections at the top level")
        config = merge(config, data)
    return config


def check_references(config: Mapping[str, Any]) -> None:
    """Check the cross-references of a schema-valid config.

    Raises
    ------
    ConfigError
        Naming the key, e.g. ``study.materials[2]: 'tread-x' is not a preset in materials``.
    """
    surfaces = config.get("surfaces", {})
    materials = config.get("materials", {})
    study = config.get("study", {})
    if study.get("surface") not in surfaces:
        raise ConfigError(
            f"study.surface: {study.get('surface')!r} is not a preset in surfaces (have: {sorted(surfaces)})"
        )
    if study.get("reference_material") not in materials:
        raise ConfigError(
            f"study.reference_material: {study.get('reference_material')!r} is not a preset in materials "
            f"(have: {sorted(materials)})"
        )
    if study.get("reference_material") not in study.get("materials", []):
        raise ConfigError("study.materials: must include study.reference_material")
    for i, name in enumerate(study.get("materials", [])):
        if name not in materials:
            raise ConfigError(f"study.materials[{i}]: {name!r} is not a preset in materials (have: {sorted(materials)})")
    for name, preset in materials.items():
        if "_" in name:
            raise ConfigError(f"materials.{name}: preset names may not contain '_' (it separates wildcards)")
        base = preset.get("base")
        if base is not None and base not in materials:
            raise ConfigError(f"materials.{name}.base: {base!r} is not a preset in materials")
        if base is None and "model" not in preset:
            raise ConfigError(f"materials.{name}: needs either 'model' or 'base'")
    loadings = config.get("loadings", {})
    for preset, names in study.get("loadings", {}).items():
        if preset not in loadings:
            raise ConfigError(f"study.loadings.{preset}: not a preset in loadings (have: {sorted(loadings)})")
        for i, name in enumerate(names):
            if name not in materials:
                raise ConfigError(
                    f"study.loadings.{preset}[{i}]: {name!r} is not a preset in materials (have: {sorted(materials)})"
                )
    from .loading import LoadingPreset

    for name, spec in loadings.items():
        if "_" in name:
            raise ConfigError(f"loadings.{name}: preset names may not contain '_' (it separates wildcards)")
        try:
            LoadingPreset(name, spec)  # every key, and a table file's contents, checked before any job
        except ValueError as err:
            raise ConfigError(str(err)) from None
    lo, hi = study.get("saturation_range", [1.8e-4, 2.5e-4])
    d_max = config.get("solver", {}).get("d_max", 2.5e-4)
    if not lo < hi <= d_max * (1 + 1e-12):
        raise ConfigError(
            f"study.saturation_range: expected lo < hi <= solver.d_max = {d_max:g} m, got [{lo:g}, {hi:g}]"
        )
