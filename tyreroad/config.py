"""Loading and checking the study configuration, before any job runs.

Snakemake runs these checks while it plans (``snakemake -n`` included), from
``workflow/rules/common.smk``:

1. :func:`check_config_files`: every YAML config file is read again with duplicate keys as errors
   (YAML itself keeps the last value silently).
2. :func:`validate_schema`: the JSON schema (``workflow/schemas/config.schema.yaml``) checks each
   key's type, range and unit; the error names the key path, the value and what is expected.
3. :func:`check_config`: the rules a schema cannot express: cross-references between sections,
   FFT sizes and lag counts, grids that must divide each other, file-name labels that must be
   unique, ``solver.d_max`` against the spring table and the tread thickness, every surface preset
   as the surface stage will parse it, every scan file (exists, not empty, header readable,
   crop window and patch inside the scan), the rolling section and the K*(f) frequency grid
   against the kernel's sample rate.
   :func:`sensitivity_points` (from ``workflow/rules/sensitivity.smk``): the sweep's section, each
   point's material and each point's surface preset against the schema.
4. :func:`check_job`: per job of the plan, the presets named by its wildcards (a requested target
   such as ``results/surface/foo.nc`` names a preset ``foo`` that must exist).

Every failure raises :class:`ConfigError` with one short paragraph: the key path (or file), the
value, and what is expected.

Which source each stage runs and its hash (the rules' ``code`` param) live in
:mod:`tyreroad.provenance`.
"""

from __future__ import annotations

import copy
import difflib
import math
import re
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import jsonschema
import yaml

from . import scans
from . import surface as S
from .greens import GreensSettings
from .loading import LoadingPreset, constant_acceleration_steps, uniform_grid_steps
from .claim6 import Claim6Settings
from .material import causality_error, expand_temperatures, material_from_config
from .rolling import RollingSettings
from .sensitivity import planned_points, point_surface_spec
from .solver import SolverSettings
from .springs import SpringModel
from .stiffness import SpectrumSettings
from .study import StudySettings, case_label

__all__ = [
    "ConfigError",
    "load_config",
    "read_yaml",
    "merge",
    "check_config_files",
    "config_file_order",
    "key_source",
    "naming_config_files",
    "validate_schema",
    "check_references",
    "check_config",
    "check_job",
    "sensitivity_points",
    "rolling_materials",
    "time_domain_materials",
    "expand_material_temperatures",
]


class ConfigError(ValueError):
    """The configuration is invalid; the message names the key and what was expected."""


# ---------------------------------------------------------------------------------------------
# Reading YAML
# ---------------------------------------------------------------------------------------------
class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that refuses a key given twice in one mapping."""

    source = "<config>"

    def construct_mapping(self, node, deep=False):
        seen: dict[Any, Any] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            if key in seen:
                raise ConfigError(
                    f"{self.source}, line {key_node.start_mark.line + 1}: duplicate key {key!r} (first given on "
                    f"line {seen[key] + 1}); YAML would silently keep only the last value, remove one of them"
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def read_yaml(path: str | Path) -> dict[str, Any]:
    """Read one YAML config file; a duplicate key is a :class:`ConfigError` naming key, file and line."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: config file not found")
    loader_cls = type("_Loader", (_UniqueKeyLoader,), {"source": str(path)})
    with path.open() as fh:
        try:
            data = yaml.load(fh, Loader=loader_cls) or {}  # noqa: S506 - a SafeLoader subclass
        except yaml.YAMLError as exc:
            raise ConfigError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, Mapping):
        raise ConfigError(f"{path}: expected a mapping of config sections at the top level")
    return dict(data)


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
    """Read one or more YAML config files, later ones overlaid on earlier ones (temperature variants expanded,
    :func:`expand_material_temperatures`)."""
    config: dict[str, Any] = {}
    for path in paths:
        config = merge(config, read_yaml(path))
    return expand_material_temperatures(config)


def expand_material_temperatures(config: Mapping[str, Any]) -> dict[str, Any]:
    """``config`` with each table preset's ``temperatures: [T, ...]`` expanded into the ``base:`` variants
    ``<name>-T<T:g>`` (:func:`tyreroad.material.expand_temperatures`); a config without them is returned as is.

    Raises
    ------
    ConfigError
        Naming ``materials.<name>.temperatures`` (not a list of temperatures [degC], or a variant name taken).
    """
    materials = config.get("materials")
    if not isinstance(materials, Mapping):
        return dict(config)
    try:
        return {**config, "materials": expand_temperatures(materials)}
    except ValueError as exc:
        raise _wrap(exc, "materials") from None


def check_config_files(paths: Iterable[str | Path]) -> None:
    """Read every config file Snakemake loaded, with duplicate keys as errors."""
    for path in paths:
        read_yaml(path)


def config_file_order(configfiles: Iterable[str | Path], overwrite_configfiles: Iterable[str | Path] = ()) -> list[str]:
    """Snakemake's config files in the order their keys apply (a later file wins).

    Snakemake lists the ``--configfile`` files (``workflow.overwrite_configfiles``) first in
    ``workflow.configfiles`` and appends the Snakefile's ``configfile:``; but it applies the
    Snakefile's file first and the command line's on top of it, in their order.

    Parameters
    ----------
    configfiles : iterable of path-like
        ``workflow.configfiles``.
    overwrite_configfiles : iterable of path-like
        ``workflow.overwrite_configfiles`` (the ``--configfile`` arguments).

    Returns
    -------
    list of str
        The files, lowest precedence first, each once (at its last place of application).
    """
    cli = [str(p) for p in (overwrite_configfiles or ())]
    cli_resolved = {Path(p).resolve() for p in cli}
    first = [str(p) for p in configfiles if Path(p).resolve() not in cli_resolved]
    out: list[str] = []
    for p in first + cli:
        same = [q for q in out if Path(q).resolve() == Path(p).resolve()]
        for q in same:
            out.remove(q)
        out.append(p)
    return out


#: Top-level keys of the config (the schema's sections): an error paragraph that starts with one names a key.
_SECTIONS = ("results_dir", "surfaces", "materials", "springs", "spring_comparison", "belt", "pattern", "greens",
             "solver", "loadings", "study", "stiffness_spectrum", "sensitivity", "rolling")

#: The key path an error paragraph starts with (``greens.n_fft``, ``study.accelerations[1]``, ...).
_LEADING_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_.\-]*(?:\[\d+\][A-Za-z0-9_.\-]*)*)(?= = |: |\b)")


def _set_path(node: Any, rest: str) -> tuple[bool, list[str]]:
    """Whether ``node`` (a config file's data) sets the key path ``rest``, and the longest part it sets.

    Preset names may contain dots (``tread-eta0.5``), so the path is matched against the keys the
    data holds rather than split on dots.
    """
    if rest == "":
        return True, []
    best: tuple[bool, list[str]] = (False, [])
    if isinstance(node, Mapping):
        for key, value in node.items():
            k = str(key)
            if rest == k or rest.startswith(k + ".") or rest.startswith(k + "["):
                sub = rest[len(k):]
                full, parts = _set_path(value, sub[1:] if sub.startswith(".") else sub)
                cand = (full, [k, *parts])
                if (cand[0], len(cand[1])) > (best[0], len(best[1])):
                    best = cand
    elif isinstance(node, list):
        m = re.match(r"^\[(\d+)\]\.?", rest)
        if m and int(m.group(1)) < len(node):
            full, parts = _set_path(node[int(m.group(1))], rest[m.end():])
            best = (full, [f"[{m.group(1)}]", *parts])
    return best


def key_source(key: str, paths: Sequence[str | Path]) -> tuple[str | None, str, bool]:
    """The config file that sets ``key`` last (later files win), or that sets the longest part of it.

    Parameters
    ----------
    key : str
        Key path as the error paragraphs write it (``surfaces.myroad.patch_selection``).
    paths : sequence of path-like
        The config files, lowest precedence first (:func:`config_file_order`).

    Returns
    -------
    file : str or None
        The file; None if no file sets the key or its preset (a section alone does not count).
    part : str
        The key path that file sets: ``key`` itself, or the preset (``surfaces.myroad``) when the key
        is not in any file (a schema or package default).
    full : bool
        Whether ``file`` sets ``key`` itself.
    """
    found: list[tuple[bool, list[str], str]] = []
    for path in paths:
        try:
            data = read_yaml(path)
        except ConfigError:
            continue
        full, parts = _set_path(data, key)
        if parts:
            found.append((full, parts, str(path)))
    setters = [f for f in found if f[0]]
    if setters:
        return setters[-1][2], key, True
    partial = [f for f in found if len(f[1]) >= 2]
    if not partial:
        return None, key, False
    depth = max(len(f[1]) for f in partial)
    full, parts, path = [f for f in partial if len(f[1]) == depth][-1]
    return path, _key_path_text(parts), False


def _key_path_text(parts: Sequence[str]) -> str:
    return "".join(p if p.startswith("[") or i == 0 else f".{p}" for i, p in enumerate(parts))


def with_config_file(message: str, paths: Sequence[str | Path]) -> str:
    """``message`` with the config file its leading key path comes from (see :func:`key_source`)."""
    m = _LEADING_KEY.match(message)
    if not m or re.split(r"[.\[]", m.group(1))[0] not in _SECTIONS:
        return message
    key = m.group(1).rstrip(".")
    path, part, full = key_source(key, paths)
    if path is None:
        return (f"{message} [{key}: in none of the config files ({', '.join(_shown(p) for p in paths)}): "
                f"a default or a derived preset]")
    path = _shown(path)
    if full:
        return f"{message} [{key}: set in {path}]"
    return f"{message} [{key}: not set in any config file (a default); {part} is set in {path}]"


def _shown(path: str | Path) -> str:
    """``path`` relative to the working directory when it lies inside it (Snakemake makes them absolute)."""
    path = Path(path)
    if path.is_absolute():
        try:
            return str(path.relative_to(Path.cwd()))
        except ValueError:
            return str(path)
    return str(path)


@contextmanager
def naming_config_files(paths: Sequence[str | Path]):
    """Re-raise a :class:`ConfigError` of the block with the config file its key path comes from.

    Used around the planning checks of ``workflow/rules/common.smk``, with the files of
    :func:`config_file_order`: an error paragraph about a key an overlay sets then names that
    overlay (``[greens.n_fft: set in my.yaml]``).
    """
    try:
        yield
    except ConfigError as exc:
        raise ConfigError(with_config_file(str(exc), paths)) from None


# ---------------------------------------------------------------------------------------------
# Schema
# ---------------------------------------------------------------------------------------------
def _key_path(parts: Iterable[Any]) -> str:
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "(top level)"


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


def _resolve_ref(schema: Mapping, node: Mapping) -> Mapping:
    while isinstance(node, Mapping) and "$ref" in node:
        ref = node["$ref"]
        target: Any = schema
        for part in ref.lstrip("#/").split("/"):
            target = target[part]
        node = {**target, **{k: v for k, v in node.items() if k != "$ref"}}
    return node


def _schema_at(schema: Mapping, path: Sequence[Any]) -> Mapping:
    """The sub-schema (with its description) that describes the key at ``path``."""
    node = _resolve_ref(schema, schema)
    for part in path:
        if isinstance(part, int):
            node = _resolve_ref(schema, node.get("items", {}))
        elif part in node.get("properties", {}):
            node = _resolve_ref(schema, node["properties"][part])
        elif isinstance(node.get("additionalProperties"), Mapping):
            node = _resolve_ref(schema, node["additionalProperties"])
        else:
            return {}
    return node


@lru_cache(maxsize=4)
def _load_schema(schema_path: str) -> dict[str, Any]:
    # libyaml's loader when PyYAML has it: the pure-Python one took ~0.5 s of every Snakemake start for this file
    with open(schema_path) as fh:
        return yaml.load(fh, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))  # noqa: S506 - a safe loader


def validate_schema(config: Mapping[str, Any], schema_path: str | Path) -> None:
    """Validate ``config`` against the JSON schema; raise :class:`ConfigError` for the first error.

    The message is one paragraph: the key path, the value, the violated rule and the key's
    description from the schema (which states the unit and the default). Defaults are not
    inserted here (Snakemake's ``validate`` does that afterwards).
    """
    schema = _load_schema(str(schema_path))
    validator_cls = jsonschema.validators.validator_for(schema)
    errors = list(validator_cls(schema).iter_errors(config))
    if not errors:
        return
    err = jsonschema.exceptions.best_match(errors)
    path = list(err.absolute_path)
    if err.validator == "additionalProperties":
        known = sorted(_schema_at(schema, path).get("properties", {}))
        extra = sorted(set(err.instance) - set(known))
        close = difflib.get_close_matches(str(extra[0]), known, n=1) if extra else []
        hint = f" did you mean {close[0]!r}?" if close else ""
        listed = f"expected one of: {', '.join(known)}" if len(known) <= 12 else f"{len(known)} keys are known"
        raise ConfigError(
            f"{_key_path(path + extra[:1])}: unknown key;{hint} {listed} "
            f"(each described in workflow/schemas/config.schema.yaml)"
        )
    if "propertyNames" in err.relative_schema_path:
        raise ConfigError(
            f"{_key_path(path)}: preset name {err.instance!r} is not path safe; expected letters, digits, "
            f"'.' and '-', starting with a letter or digit (it becomes a file name and a wildcard)"
        )
    if err.validator == "required":
        raise ConfigError(f"{_key_path(path)}: {err.message}")
    value = err.instance
    hint = ""
    if isinstance(value, str):
        try:
            float(value)
            hint = f" (YAML reads {value} as text: write the exponent with a sign and the mantissa with a point, e.g. 2.0e+7)"
        except ValueError:
            pass
    desc = _schema_at(schema, path).get("description", "")
    raise ConfigError(
        f"{_key_path(path)} = {_show(value)}: {err.message}{hint}."
        + (f" Expected: {desc}" if desc else "")
    )


# ---------------------------------------------------------------------------------------------
# Cross-field rules
# ---------------------------------------------------------------------------------------------
def _fail(key: str, value: Any, expected: str) -> ConfigError:
    return ConfigError(f"{key} = {_show(value)}: expected {expected}")


def _wrap(exc: Exception, key: str) -> ConfigError:
    """A package ValueError as a ConfigError; prefix the key path unless the message names one."""
    msg = str(exc).strip("'\"")
    if re.match(r"^(surfaces|materials|springs|greens|solver|study|results_dir|rolling|loadings|sensitivity|stiffness_spectrum|pattern)\b", msg) or msg.startswith("/"):
        return ConfigError(msg)
    return ConfigError(f"{key}: {msg}")


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
            f"study.surface = {study.get('surface')!r}: not a preset in surfaces (have: {', '.join(sorted(surfaces))})"
        )
    if study.get("reference_material") not in materials:
        raise ConfigError(
            f"study.reference_material = {study.get('reference_material')!r}: not a preset in materials "
            f"(have: {', '.join(sorted(materials))})"
        )
    if study.get("reference_material") not in study.get("materials", []):
        raise ConfigError(
            f"study.materials = {study.get('materials')!r}: must include study.reference_material "
            f"{study.get('reference_material')!r}"
        )
    for i, name in enumerate(study.get("materials", [])):
        if name not in materials:
            raise ConfigError(
                f"study.materials[{i}] = {name!r}: not a preset in materials (have: {', '.join(sorted(materials))})"
            )
    for name, preset in materials.items():
        if "_" in name:
            raise ConfigError(f"materials.{name}: preset names may not contain '_' (it separates wildcards)")
        base = preset.get("base")
        if base is not None and base not in materials:
            raise ConfigError(f"materials.{name}.base = {base!r}: not a preset in materials")
        if base is None and "model" not in preset:
            raise ConfigError(f"materials.{name}: needs either 'model' or 'base'")
    own = config.get("greens", {}).get("construction", "passive")
    if own in study.get("compare_constructions", []):
        raise ConfigError(
            f"study.compare_constructions = {study['compare_constructions']!r}: names the study's own kernel "
            f"construction greens.construction = {own!r}; list only the others to run beside it"
        )
    loadings = config.get("loadings", {})
    for preset, names in study.get("loadings", {}).items():
        if preset not in loadings:
            raise ConfigError(f"study.loadings.{preset}: not a preset in loadings (have: {sorted(loadings)})")
        for i, name in enumerate(names):
            if name not in materials:
                raise ConfigError(
                    f"study.loadings.{preset}[{i}]: {name!r} is not a preset in materials (have: {sorted(materials)})"
                )
    for name, spec in loadings.items():
        if "_" in name:
            raise ConfigError(f"loadings.{name}: preset names may not contain '_' (it separates wildcards)")
        try:
            LoadingPreset(name, spec)  # every key, and a table file's contents, checked before any job
        except ValueError as err:
            raise ConfigError(str(err)) from None
    lo, hi = study.get("saturation_range", [1.8e-4, 2.5e-4])
    d_max = _d_max(config)
    if not lo < hi <= d_max * (1 + 1e-12):
        raise ConfigError(
            f"study.saturation_range = [{lo:g}, {hi:g}]: expected lo < hi <= solver.d_max = {d_max:g} m"
        )


#: Scan files up to this size [bytes] are read in full at planning time (all the job's checks of
#: the heights run then); larger ones get the header check only, the rest runs in the job.
SCAN_READ_LIMIT = 64 * 2**20

#: Minimum number of steps of a run: the study differentiates F(d) with a 3-point rule.
MIN_RUN_STEPS = 3

#: Defaults of the sections whose keys the checks read, from the package's settings classes (the
#: one place of each default; the schema states the same values, tests/test_config.py checks it).
_SOLVER = SolverSettings()
_GREENS = GreensSettings()
_SPRINGS = SpringModel()


def _d_max(config: Mapping[str, Any]) -> float:
    """``solver.d_max`` [m], or its default."""
    return float(config.get("solver", {}).get("d_max", _SOLVER.d_max))


def _sample_rate(config: Mapping[str, Any]) -> float:
    """``greens.sample_rate`` [Hz], or its default."""
    return float(config.get("greens", {}).get("sample_rate", _GREENS.sample_rate))


def _check_case_collisions(section: str, names: Iterable[str]) -> None:
    seen: dict[str, str] = {}
    for name in names:
        low = name.lower()
        if low in seen:
            raise ConfigError(
                f"{section}.{name}: preset name collides with {section}.{seen[low]} on case-insensitive file "
                f"systems (macOS, Windows); expected names that differ in more than case"
            )
        seen[low] = name


def _check_results_dir(config: Mapping[str, Any]) -> None:
    value = config.get("results_dir", "results")
    parts = Path(value).parts
    if not value or value.strip() != value or ".." in parts or Path(value) == Path("."):
        raise _fail("results_dir", value, "a folder path without '..' (default: results)")
    if parts and parts[0] in {"workflow", "config", "tyreroad", "tests", "benchmarks", "docs", "profiles", ".snakemake"}:
        raise _fail("results_dir", value, "a folder outside the repository's source folders (e.g. results-mystudy)")


def _check_solver_and_study(config: Mapping[str, Any]) -> None:
    solver = config.get("solver", {})
    study = config["study"]
    greens = config.get("greens", {})
    springs = config.get("springs", {})
    d_max = _d_max(config)

    # Green's functions: FFT size and kept lags
    n_fft = greens.get("n_fft", _GREENS.n_fft)
    if isinstance(n_fft, int) and (n_fft < 4096 or n_fft & (n_fft - 1)):
        raise _fail("greens.n_fft", n_fft, "a power of two >= 4096 (e.g. 4096, 8192, 16384)")
    n_lags = greens.get("n_lags", _GREENS.n_lags)
    if isinstance(n_lags, int) and isinstance(n_fft, int) and n_lags > n_fft // 2:
        raise _fail("greens.n_lags", n_lags, f"at most greens.n_fft / 2 = {n_fft // 2}")

    # springs: the table grid
    zeta_max = float(springs.get("zeta_max", _SPRINGS.zeta_max))
    zeta_step = float(springs.get("zeta_step", _SPRINGS.zeta_step))
    ratio = zeta_max / zeta_step
    if abs(ratio - round(ratio)) > 1e-6 * ratio:
        raise _fail(
            "springs.zeta_step", zeta_step,
            f"a step that divides springs.zeta_max = {zeta_max:g} m into whole steps (e.g. "
            f"{zeta_max / math.ceil(ratio):.4g} m)",
        )
    # solver.d_max against the spring table and the layer
    if d_max > zeta_max * (1 + 1e-12):
        raise _fail(
            "solver.d_max", d_max,
            f"at most springs.zeta_max = {zeta_max:g} m: an element's compression reaches d_max and the "
            f"spring table ends at zeta_max",
        )
    for name in study.get("materials", []):
        try:
            h = material_from_config(name, config["materials"]).thickness
        except (ValueError, KeyError, TypeError) as exc:
            raise _wrap(exc, f"materials.{name}") from None
        if d_max >= 0.5 * h:
            raise _fail(
                "solver.d_max", d_max,
                f"less than half the tread thickness of study material {name!r} ({0.5 * h:g} m); the layer "
                f"model is linear (small strain)",
            )
    # quasi-static grid
    qs = float(solver.get("quasistatic_step", _SOLVER.quasistatic_step))
    if qs > d_max or uniform_grid_steps(d_max, qs) < MIN_RUN_STEPS:
        raise _fail(
            "solver.quasistatic_step", qs,
            f"at most solver.d_max / {MIN_RUN_STEPS - 1} = {d_max / (MIN_RUN_STEPS - 1):g} m (a run needs "
            f"{MIN_RUN_STEPS} indentation points)",
        )
    # dynamic runs: enough time steps, unique file labels
    fs = _sample_rate(config)
    labels: dict[str, int] = {}
    for i, a in enumerate(study.get("accelerations", [])):
        label = case_label("", "dynamic", a).split("/")[-1]
        if label in labels:
            j = labels[label]
            raise ConfigError(
                f"study.accelerations[{i}] = {a!r}: gives the same file label '{label}' (format '{{:g}}') as "
                f"study.accelerations[{j}] = {study['accelerations'][j]!r}; expected accelerations that differ "
                f"in their first 6 significant digits"
            )
        labels[label] = i
        steps = constant_acceleration_steps(fs, float(a), d_max) - 1  # time steps after t = 0
        if steps < MIN_RUN_STEPS:
            a_max = 2.0 * d_max * (fs / MIN_RUN_STEPS) ** 2
            raise _fail(
                f"study.accelerations[{i}]", a,
                f"at most {a_max:.4g} m/s^2: the run reaches solver.d_max in {steps} time step(s) at "
                f"greens.sample_rate = {fs:g} Hz, and needs at least {MIN_RUN_STEPS}",
            )
    # the study's indentation grid and saturation range
    try:
        StudySettings.from_config(study, d_max=d_max)
    except ValueError as exc:
        raise _wrap(exc, "study") from None


def _check_package_settings(config: Mapping[str, Any]) -> None:
    """Build every settings object the jobs build, so that their checks run now."""
    for section, build in (("greens", GreensSettings.from_config), ("springs", SpringModel.from_config),
                           ("solver", SolverSettings.from_config)):
        try:
            build(config.get(section, {}))
        except (ValueError, TypeError) as exc:
            raise _wrap(exc, section) from None
    for name in config.get("materials", {}):
        try:
            material_from_config(name, config["materials"])
        except (ValueError, KeyError, TypeError) as exc:
            raise _wrap(exc, f"materials.{name}") from None
    _check_qlv_springs(config)


def _check_qlv_springs(config: Mapping[str, Any]) -> None:
    """QLV springs (springs.rheology: qlv) need the springs' modulus to be every material's E(0)."""
    springs = config.get("springs", {}) or {}
    if springs.get("rheology", "elastic") != "qlv":
        return
    from .qlv import check_relaxed_modulus
    from .springs import resolve_spring_modulus

    model = SpringModel.from_config(springs)
    study = config.get("study", {}) or {}
    claim6 = study.get("claim6", {}) or {}
    used = set(study.get("materials", [])) | set((config.get("rolling", {}) or {}).get("materials", []) or [])
    used |= {m for names in (study.get("loadings", {}) or {}).values() for m in names}
    used |= {m for key in ("anchor_variants", "storage_checks", "springs_checks", "layer_checks")
             for m in claim6.get(key, []) or []}
    # the presets that get springs files (a preset nobody runs is not checked)
    for name in [m for m in config.get("materials", {}) if m in used]:
        material = material_from_config(name, config["materials"])
        try:
            check_relaxed_modulus(float(material.modulus([0.0]).real[0]),
                                  resolve_spring_modulus(model, material.quasi_static_modulus), name)
        except ValueError as exc:
            raise _wrap(exc, "springs") from None


def _check_belt(config: Mapping[str, Any]) -> None:
    """The flexible belt (issue 26): its properties make a valid belt, and its study runs on a kernel that has
    a belt memory (not the Radau stage kernel)."""
    section = config.get("belt")
    if not section:
        return
    from .belt_stage import belt_from_config

    try:
        belt_from_config(section.get("properties"), "belt.properties")
    except ValueError as exc:
        raise _wrap(exc, "belt.properties") from None
    own = (config.get("greens", {}) or {}).get("construction", _GREENS.construction)
    if section.get("study", False) and own == "radau":
        raise ConfigError("belt.study: true with greens.construction = 'radau': the Radau stage kernel has no belt "
                          "memory; use greens.construction: passive (or fold, seed) for the belt study")


def _check_pattern(config: Mapping[str, Any]) -> None:
    """The pattern section (issue 27; :func:`tyreroad.pattern.check_pattern_config`): geometry on the element
    grid, grooves no deeper than the tread, a patch holding a whole block, a static (quasi-static) study."""
    if not config.get("pattern"):
        return
    from .pattern import check_pattern_config

    try:
        check_pattern_config(config)
    except (ValueError, TypeError, KeyError) as exc:
        raise _wrap(exc, "pattern") from None


def _check_hard_contact(config: Mapping[str, Any]) -> None:
    """Hard contact (springs.model: hard) in the study's dynamic runs needs the stage kernel (greens.construction:
    radau): its penalty springs (1e10 N/m by default) are far past every single-stage kernel's stability limit
    (passive: 1.2e5 N/m), whose march would alternate at fs/2 and diverge. The study always runs dynamic
    (study.accelerations), and so do the comparison constructions (study.compare_constructions)."""
    from .greens import KERNEL_CONSTRUCTIONS

    model = (config.get("springs", {}) or {}).get("model", _SPRINGS.model)
    own = (config.get("greens", {}) or {}).get("construction", _GREENS.construction)
    if own == "radau":
        from .stage import DENSE_LIMIT

        surface = (config.get("study", {}) or {}).get("surface")
        patch = ((config.get("surfaces", {}) or {}).get(surface, {}) or {}).get("patch_elements")
        if patch is not None and int(patch[0]) * int(patch[1]) > DENSE_LIMIT:
            raise ConfigError(
                f"greens.construction = 'radau' with surfaces.{surface}.patch_elements = {list(patch)}: the Radau "
                f"stage kernel has a dense substrate only, patches up to {DENSE_LIMIT} elements")
    if model != "hard":
        return
    stable = "radau"
    others = [c for c in KERNEL_CONSTRUCTIONS if c != stable]
    if own != stable:
        raise ConfigError(
            f"greens.construction = {own!r} with springs.model = 'hard': the study's dynamic runs on hard contact "
            f"(penalty springs of springs.hard_stiffness) need the kernel stable for every spring, "
            f"greens.construction: {stable} (the {', '.join(others)} kernels are stable only for springs below their "
            "critical stiffness, 1.2e5 N/m for passive); set greens.construction: radau")
    compared = [c for c in (config.get("study", {}) or {}).get("compare_constructions", []) or [] if c != stable]
    if compared:
        raise ConfigError(
            f"study.compare_constructions = {compared!r} with springs.model = 'hard': their dynamic runs on hard "
            f"contact would alternate at fs/2 and diverge (only greens.construction: {stable} is stable for every "
            "spring); set study.compare_constructions: []")


def check_rolling_kernel(config: Mapping[str, Any]) -> None:
    """The rolling strips on the Radau stage kernel (dense substrate only) must fit its dense limit.

    Called when the rolling jobs are planned (rule ``rolling_greens``), not by :func:`check_config`: the default
    config's 150 x 20 strip must not refuse a ``radau`` config that only runs the study.

    Raises
    ------
    ConfigError
        Naming ``greens.construction``, the strip's ``patch_elements`` and the limit.
    """
    own = (config.get("greens", {}) or {}).get("construction", _GREENS.construction)
    if own != "radau":
        return
    from .stage import DENSE_LIMIT

    for name in (config.get("rolling", {}) or {}).get("surfaces", []) or []:
        patch = ((config.get("surfaces", {}) or {}).get(name, {}) or {}).get("patch_elements")
        if patch is not None and int(patch[0]) * int(patch[1]) > DENSE_LIMIT:
            raise ConfigError(
                f"greens.construction = 'radau' with the rolling strip surfaces.{name}.patch_elements = "
                f"{list(patch)} ({int(patch[0]) * int(patch[1])} elements): the Radau stage kernel has a dense "
                f"substrate only, strips up to {DENSE_LIMIT} elements (e.g. [150, 10], config/rolling-narrow.yaml), "
                "or the passive kernel (greens.construction: passive)")


def surface_plan(name: str, spec: Mapping[str, Any], base_dir: str | Path = ".") -> dict[str, Any]:
    """Parse a surface preset as the surface stage will, and check that its patch fits.

    For ``generator: file`` the scan file is checked cheaply (:func:`tyreroad.scans.check_scan_header`);
    a scan of at most :data:`SCAN_READ_LIMIT` bytes is read in full and, under the default
    ``patch_selection: contact_fraction``, its patch is selected as the job will
    (:func:`tyreroad.surface.select_patch`), so that a scan without a qualifying patch stops planning
    with the keys to set (``surfaces.<name>.patch_selection`` or ``surfaces.<name>.origin``).

    Returns
    -------
    dict
        ``element_size`` [m], ``patch_elements``, ``scan`` (header info or None).
    """
    try:
        c = S._common(name, spec)
        generator = spec.get("generator")
        n = int(c["samples_per_element"])
        step = float(c["element_size"]) / n
        px, py = (int(v) for v in c["patch_elements"])
        info = scan = None
        if generator in ("iso10844", "spectral"):
            cls = S.Iso10844Parameters if generator == "iso10844" else S.SpectralParameters
            params = S._preset_params(cls, name, spec, S.COMMON_KEYS)
            shape = S._grid_shape(params.field_size, step)
            if generator == "spectral" and params.short_cutoff is not None and params.short_cutoff >= min(params.field_size):
                raise _fail(
                    f"surfaces.{name}.short_cutoff", params.short_cutoff,
                    f"less than the field size {min(params.field_size):g} m (longer cut-offs remove all power)",
                )
            where = f"surfaces.{name}.field_size"
            have = f"{list(params.field_size)} m ({shape[0]} x {shape[1]} samples at {step:.4g} m)"
        elif generator == "flat":
            params = S._preset_params(S.FlatParameters, name, spec, S.COMMON_KEYS)
            size = params.field_size
            shape = (px * n, py * n) if size is None else S._grid_shape(size, step)
            where = f"surfaces.{name}.field_size"
            have = f"{size if size is None else list(size)} m ({shape[0]} x {shape[1]} samples at {step:.4g} m)"
        else:
            scan_spec = scans.scan_spec_from_config(name, spec, S.COMMON_KEYS)
            try:
                info = scans.check_scan_header(scan_spec, base_dir)
            except (FileNotFoundError, scans.ScanError, ImportError) as exc:
                raise ConfigError(f"surfaces.{name}.path = {spec.get('path')!r}: {exc}") from None
            shape = None
            if info["path"].stat().st_size <= SCAN_READ_LIMIT:
                # small enough to read in full now: the job's checks (missing samples, flat scan,
                # height range and unit) then run at planning time too
                try:
                    scan = scans.read_scan(scan_spec, base_dir)
                except (FileNotFoundError, scans.ScanError, ImportError) as exc:
                    raise ConfigError(f"surfaces.{name}.path = {spec.get('path')!r}: {exc}") from None
                shape = scans.element_grid_shape(scan.height.shape, scan.step, step)
            elif info["shape"] is not None and info["step"] is not None:
                raw_shape = info["shape"]
                if scan_spec.crop is not None:
                    raw_shape = scans.crop_window(raw_shape, info["step"], scan_spec.crop, info["path"])[1]
                shape = scans.element_grid_shape(raw_shape, info["step"], step)
            where = f"surfaces.{name}.path"
            have = f"the scan {info['path']} ({'' if shape is None else f'{shape[0]} x {shape[1]} samples at {step:.4g} m'})"
        if shape is not None:
            sel = c["selection"]
            need = (px * n, py * n)
            if sel.origin is not None:
                i0, j0 = int(round(sel.origin[0] / step)), int(round(sel.origin[1] / step))
                if i0 + need[0] > shape[0] or j0 + need[1] > shape[1]:
                    raise _fail(
                        f"surfaces.{name}.origin", list(sel.origin),
                        f"a patch origin such that the {px} x {py}-element patch ({need[0]} x {need[1]} samples) "
                        f"lies inside {have}",
                    )
            elif need[0] > shape[0] or need[1] > shape[1]:
                raise _fail(
                    f"surfaces.{name}.patch_elements", [px, py],
                    f"a patch of at most {shape[0] // n} x {shape[1] // n} elements: it needs {need[0]} x {need[1]} "
                    f"samples at {step:.4g} m, {where} gives {have}",
                )
            if scan is not None and sel.origin is None and sel.rule == "contact_fraction":
                # a scan read in full: the job's patch selection runs now, so that a scan without a
                # qualifying patch (e.g. one exported from a study patch) stops planning, not the job
                field = scans.to_element_grid(scan, step, (px, py), n)
                try:
                    S.select_patch(field, n, step, sel, preset=name)
                except ValueError as exc:
                    hint = S.levelled_scan_hint(name, scan_spec, base_dir, step, n, sel, str(exc))
                    raise ConfigError(f"{exc} (scan {info['path']}){'. ' + hint if hint else ''}") from None
        return {"element_size": float(c["element_size"]), "patch_elements": (px, py), "scan": info}
    except ConfigError:
        raise
    except (ValueError, TypeError) as exc:
        raise _wrap(exc, f"surfaces.{name}") from None


def check_config(config: Mapping[str, Any], base_dir: str | Path = ".") -> None:
    """Every check of a schema-valid config that needs no computed result.

    Parameters
    ----------
    config : mapping
        The merged config (after :func:`validate_schema`; schema defaults may be inserted or not,
        except that a ``rolling`` section needs its ``surfaces``, which validation inserts).
    base_dir : path-like
        Directory against which relative scan paths are resolved (Snakemake's working directory).

    Raises
    ------
    ConfigError
        One paragraph naming the key path, the value and what is expected.
    """
    _check_results_dir(config)
    check_references(config)
    _check_case_collisions("surfaces", config["surfaces"])
    _check_case_collisions("materials", config["materials"])
    _check_solver_and_study(config)
    _check_package_settings(config)
    _check_hard_contact(config)
    _check_belt(config)
    _check_pattern(config)
    for name, spec in config["surfaces"].items():
        surface_plan(name, spec, base_dir)
    _check_rolling(config)
    _check_stiffness_spectrum(config)
    _check_claim6(config)
    _check_causality(config)


def time_domain_materials(config: Mapping[str, Any]) -> list[tuple[str, str, str]]:
    """Every material a time-domain stage of this config runs, with the key that sends it there.

    Returns
    -------
    list of (key, material, use)
        ``study.materials[i]`` (contact runs, the K* transient state), ``study.loadings.<preset>[i]``
        (loading runs), ``rolling.materials[i]`` (rolling passes; rolling.materials defaults to
        study.materials), ``study.claim6.anchor_variants[i]`` and ``study.claim6.storage_checks[i]``
        (contact runs). The sensitivity sweep's materials are checked with its points
        (:func:`sensitivity_points`).
    """
    study = config.get("study", {})
    out = [(f"study.materials[{i}]", m, "a contact run") for i, m in enumerate(study.get("materials", []))]
    for preset, names in (study.get("loadings") or {}).items():
        out += [(f"study.loadings.{preset}[{i}]", m, "a loading run") for i, m in enumerate(names)]
    if config.get("rolling") is not None:
        names, _ = rolling_materials(config)
        key = "rolling.materials" if "materials" in config["rolling"] else "rolling.materials (default: study.materials)"
        out += [(f"{key}[{i}]", m, "a rolling pass") for i, m in enumerate(names)]
    claim6 = study.get("claim6") or {}
    for key in ("anchor_variants", "storage_checks", "springs_checks", "layer_checks"):
        out += [(f"study.claim6.{key}[{i}]", m, "a contact run") for i, m in enumerate(claim6.get(key) or [])]
    return out


def _check_causality(config: Mapping[str, Any]) -> None:
    """No material that is not causal (the seed's constant-|E| loss variant) reaches a time-domain stage."""
    materials = config["materials"]
    for key, name, use in time_domain_materials(config):
        if name not in materials:
            continue  # named by the reference checks
        error = causality_error(material_from_config(name, materials), key, use)
        if error is not None:
            raise ConfigError(error)


def _check_claim6(config: Mapping[str, Any]) -> None:
    """``study.claim6``: its keys, its materials exist, the seed variants are the reference's loss variants
    with the reference's relaxed modulus (their K* uses the reference's relaxed state), and f_c lies below fs/2."""
    study = config["study"]
    section = study.get("claim6")
    if section is None:
        return
    try:
        settings = Claim6Settings.from_config(section)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    materials = config["materials"]
    for key in ("seed_variants", "anchor_variants", "storage_checks", "springs_checks", "layer_checks"):
        for i, name in enumerate(getattr(settings, key)):
            if name not in materials:
                raise ConfigError(f"study.claim6.{key}[{i}] = {name!r}: not a preset in materials "
                                  f"(have: {', '.join(sorted(materials))})")
    ref = material_from_config(study["reference_material"], materials)
    for i, name in enumerate(settings.seed_variants):
        m = material_from_config(name, materials)
        if m.loss_scale == 1.0 or m.loss_anchor is not None or not math.isclose(
                m.quasi_static_modulus, ref.quasi_static_modulus, rel_tol=1e-9):
            raise ConfigError(
                f"study.claim6.seed_variants[{i}] = {name!r}: expected a seed loss variant of the reference "
                f"{ref.name!r} (loss_scale != 1, no loss_anchor) with its quasi-static modulus "
                f"({ref.quasi_static_modulus:.6g} Pa; got {m.quasi_static_modulus:.6g} Pa): its K* is taken about the "
                "reference's relaxed preload state")
    fs = _sample_rate(config)
    if not settings.frequency < 0.5 * fs:
        raise _fail("study.claim6.frequency", settings.frequency, f"a frequency below greens.sample_rate / 2 = {0.5 * fs:g} Hz")
    if not settings.preload < _d_max(config):
        raise _fail("study.claim6.preload", settings.preload, f"a preload below solver.d_max = {_d_max(config):g} m")


def _check_stiffness_spectrum(config: Mapping[str, Any]) -> None:
    """The ``stiffness_spectrum`` section and its frequency grid against ``greens.sample_rate`` (the
    grid must lie below fs / 2), as :class:`tyreroad.stiffness.SpectrumSettings` builds them in the job."""
    try:
        SpectrumSettings.from_config(config.get("stiffness_spectrum", {})).frequencies(_sample_rate(config))
    except (ValueError, TypeError) as exc:
        raise _wrap(exc, "stiffness_spectrum") from None


def sensitivity_points(config: Mapping[str, Any], schema_path: str | Path) -> dict[str, dict[str, Any]]:
    """The sensitivity sweep's points, checked at planning time ({} without a ``sensitivity`` section).

    Checks the section (:class:`tyreroad.sensitivity.SensitivitySettings`), every point's material
    (its calibration scaling included, :func:`tyreroad.sensitivity.planned_points`) and every
    point's surface: the study surface preset with the point's ``surface`` overrides, against the
    JSON schema.

    Parameters
    ----------
    config : mapping
        The validated config.
    schema_path : path-like
        ``workflow/schemas/config.schema.yaml``.

    Returns
    -------
    dict
        ``sensitivity.points``: point name -> point settings.

    Raises
    ------
    ConfigError
        Naming ``sensitivity.<key>`` or ``sensitivity.points.<name>.surface.<key>`` and the value.
    """
    try:
        points = planned_points(config)
    except (ValueError, TypeError, KeyError) as exc:
        raise _wrap(exc, "sensitivity") from None
    base = config["surfaces"][config["study"]["surface"]]
    for name, point in points.items():
        label = f"sensitivity-{name}"
        try:
            validate_schema({**config, "surfaces": {label: point_surface_spec(base, point["surface"])}}, schema_path)
        except ConfigError as exc:
            raise ConfigError(str(exc).replace(f"surfaces.{label}", f"sensitivity.points.{name}.surface", 1)) from None
    return points


def rolling_materials(config: Mapping[str, Any]) -> tuple[list[str], str]:
    """Materials of the rolling passes and the one of the contact map (figure 14).

    The two defaults of the ``rolling`` section that the schema cannot state: ``rolling.materials``
    defaults to ``study.materials``, ``rolling.reference_material`` to the first of them. (The
    section's other defaults are the schema's, inserted when Snakemake validates the config, and
    :class:`tyreroad.rolling.RollingSettings`' for the pass.)
    """
    rolling = config.get("rolling") or {}
    names = list(rolling.get("materials", config["study"]["materials"]))
    return names, rolling.get("reference_material", names[0])


def _check_rolling(config: Mapping[str, Any]) -> None:
    """The ``rolling`` section: its strips and materials exist, load xor d0, the pass, element sizes."""
    rolling = config.get("rolling")
    if rolling is None:
        return
    surfaces, materials = config["surfaces"], config["materials"]
    if "surfaces" not in rolling:
        raise ConfigError("rolling.surfaces: missing; expected the strips rolled over (validation against "
                          "workflow/schemas/config.schema.yaml inserts the default)")
    for i, name in enumerate(rolling["surfaces"]):
        if name not in surfaces:
            raise ConfigError(f"rolling.surfaces[{i}] = {name!r}: not a preset in surfaces (have: {', '.join(sorted(surfaces))})")
        c_here = float(surfaces[name].get("element_size", 1e-3))
        c_study = float(surfaces[config["study"]["surface"]].get("element_size", 1e-3))
        if not math.isclose(c_here, c_study, rel_tol=1e-9):
            raise ConfigError(f"rolling.surfaces[{i}] = {name!r}: element_size {c_here:g} m differs from that of the "
                              f"study surface ({c_study:g} m), for which the greens are computed; expected equal")
    names, ref = rolling_materials(config)
    for i, name in enumerate(names):
        if name not in materials:
            raise ConfigError(f"rolling.materials[{i}] = {name!r}: not a preset in materials (have: {', '.join(sorted(materials))})")
    if ref not in names:
        raise ConfigError(f"rolling.reference_material = {ref!r}: expected one of rolling.materials {list(names)}")
    try:
        RollingSettings.from_config(rolling)
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


# ---------------------------------------------------------------------------------------------
# Per job of the plan
# ---------------------------------------------------------------------------------------------
def check_job(config: Mapping[str, Any], target: str, wildcards: Mapping[str, str]) -> None:
    """Check the presets and labels named by the wildcards of one planned job.

    Parameters
    ----------
    config : mapping
        The validated config.
    target : str
        The job's output file (for the message).
    wildcards : mapping
        ``surface``, ``material``, ``mode``, ``accel`` as present.

    Raises
    ------
    ConfigError
        ``<target>: surface 'foo' is not a preset in surfaces (have: ...)`` and the like.
    """
    surfaces, materials = config["surfaces"], config["materials"]
    surface = wildcards.get("surface")
    if surface is not None and surface not in surfaces:
        raise ConfigError(
            f"{target}: surface {surface!r} is not a preset in surfaces; expected one of: {', '.join(sorted(surfaces))}"
        )
    material = wildcards.get("material")
    if material is not None and material not in materials:
        raise ConfigError(
            f"{target}: material {material!r} is not a preset in materials; expected one of: "
            f"{', '.join(sorted(materials))}"
        )
    mode, accel = wildcards.get("mode"), wildcards.get("accel")
    loading = wildcards.get("loading")
    if loading is not None and loading not in config.get("loadings", {}):
        raise ConfigError(
            f"{target}: loading {loading!r} is not a preset in loadings; expected one of: "
            f"{', '.join(sorted(config.get('loadings', {}))) or '(none defined)'}"
        )
    speed = wildcards.get("speed")
    if speed is not None:
        try:
            v = float(speed)
        except ValueError:
            raise ConfigError(f"{target}: speed {speed!r} is not a number [m/s]") from None
        if not math.isfinite(v) or v <= 0 or f"{v:g}" != speed:
            raise ConfigError(f"{target}: speed label {speed!r}; expected a positive speed [m/s] written as '{{:g}}' "
                              "(e.g. dynamic_v20.nc)")
    if mode is not None and loading is None and speed is None:
        try:
            a = float(accel)
        except (TypeError, ValueError):
            raise ConfigError(f"{target}: acceleration {accel!r} is not a number [m/s^2]") from None
        if mode == "quasistatic" and accel != "0":
            raise ConfigError(f"{target}: a quasi-static run has no acceleration; expected the file quasistatic_0.nc")
        if mode == "dynamic" and (not math.isfinite(a) or a <= 0 or f"{a:g}" != accel):
            raise ConfigError(
                f"{target}: acceleration label {accel!r}; expected a positive acceleration [m/s^2] written as "
                f"'{{:g}}' (e.g. dynamic_500.nc)"
            )
        if mode == "dynamic":
            fs, d_max = _sample_rate(config), _d_max(config)
            if constant_acceleration_steps(fs, a, d_max) - 1 < MIN_RUN_STEPS:  # time steps after t = 0
                raise ConfigError(
                    f"{target}: acceleration {a:g} m/s^2 reaches solver.d_max in fewer than {MIN_RUN_STEPS} time "
                    f"steps at greens.sample_rate = {fs:g} Hz; expected at most "
                    f"{2.0 * d_max * (fs / MIN_RUN_STEPS) ** 2:.4g} m/s^2"
                )
    if material is not None and (mode is not None or surface is None):
        # a run (mode) or a time-domain kernel (the greens file: material only): causal materials only
        error = causality_error(material_from_config(material, materials), target,
                                "a time-domain kernel" if mode is None else "a time-domain run")
        if error is not None:
            raise ConfigError(error)
    if material is not None and mode is not None:
        d_max = _d_max(config)
        h = material_from_config(material, materials).thickness
        if d_max >= 0.5 * h:
            raise ConfigError(
                f"{target}: solver.d_max = {d_max:g} m is not less than half the tread thickness of material "
                f"{material!r} ({0.5 * h:g} m)"
            )
    if surface is not None and mode is not None:
        study_surface = config["study"]["surface"]
        c_here = float(surfaces[surface].get("element_size", 1e-3))
        c_greens = float(surfaces[study_surface].get("element_size", 1e-3))
        if not math.isclose(c_here, c_greens, rel_tol=1e-9):
            raise ConfigError(
                f"{target}: surfaces.{surface}.element_size = {c_here:g} m differs from that of the study surface "
                f"{study_surface!r} ({c_greens:g} m), for which the Green's functions are computed; expected equal "
                f"element sizes"
            )
