"""Which tyreroad source each workflow stage runs, and a hash of it (the rules' ``code`` param).

Snakemake tracks only a rule's adapter script. Each rule therefore passes
``source_hash(<stage>)`` as a param, so that a change in the package re-plans exactly the stages
whose code changed (and what depends on their results), through Snakemake's ``params`` rerun
trigger. :data:`STAGE_MODULES` names the entry modules of each stage; :func:`stage_modules`
follows their imports in the source (no module is imported); :func:`source_hash` hashes the files.

An entry may name a subpackage (a folder with ``__init__.py``, e.g. ``rolling`` once it is split
into modules): the stage then runs every module of that folder, in sorted order, and what they
import. Modules reached by an import count one by one (``plots.rolling`` does not pull in the
other plot modules).
"""

from __future__ import annotations

import ast
import re
import hashlib
from functools import lru_cache
from pathlib import Path

__all__ = ["STAGE_MODULES", "stage_modules", "stage_files", "source_hash"]

#: Entry modules of each workflow stage (rule): the modules its ``tyreroad.pipeline.run_*``
#: function imports. :func:`stage_modules` adds everything these import, recursively.
#: A new stage, or a stage function that imports a new module, extends this map.
STAGE_MODULES: dict[str, tuple[str, ...]] = {
    "prepare_surface": ("log", "pipeline", "surface", "plots.surface"),
    "element_springs": ("log", "pipeline", "springs", "qlv", "material"),
    "springs_figure": ("log", "pipeline", "plots.springs"),
    "greens": ("log", "pipeline", "greens", "material", "construction", "fidelity", "margin", "belt_stage"),
    "greens_figures": ("log", "pipeline", "plots.greens"),
    "belt_mobility": ("log", "pipeline", "belt_mobility", "belt_stage"),
    "belt_rolling_spectra": ("log", "pipeline", "plots.belt", "belt_vibration"),
    "contact": ("log", "pipeline", "contact", "material"),
    "study": ("log", "pipeline", "study"),
    "study_figures": ("log", "pipeline", "plots.study", "study"),
    "report": ("log", "pipeline", "report", "study", "stiffness", "claim6"),
    "claim6": ("log", "pipeline", "claim6", "claim6_runs", "study", "stiffness", "greens", "material", "contact"),
    "loading": ("log", "pipeline", "contact", "material", "loading", "hysteresis"),
    "loading_study": ("log", "pipeline", "hysteresis"),
    "hysteresis_figure": ("log", "pipeline", "plots.hysteresis"),
    "stiffness_spectrum": ("log", "pipeline", "contact", "material", "stiffness", "greens", "loading", "springs"),
    "stiffness_figure": ("log", "pipeline", "plots.stiffness", "stiffness"),
    "stiffness_combined": ("log", "pipeline", "kstar"),
    "sensitivity": ("log", "sensitivity"),
    "rolling": ("log", "pipeline", "contact", "rolling", "belt_vibration", "belt_kernel", "material"),
    "rolling_study": ("log", "pipeline", "rolling"),
    "rolling_figures": ("log", "pipeline", "plots.rolling"),
    "rolling_report": ("log", "pipeline", "report"),
    "pattern_greens": ("log", "pipeline", "pattern", "pattern_stage", "material"),
    "pattern_contact": ("log", "pipeline", "pattern", "contact"),
    "pattern_study": ("log", "pipeline", "pattern", "study"),
    "pattern_stiffness_spectrum": ("log", "pipeline", "pattern_spectrum", "material"),
    "pattern_report": ("log", "pipeline", "report.pattern", "report.pattern_dynamic"),
    "pattern_modes": ("log", "pipeline", "pattern_stage", "pattern_dynamic", "fe_pattern", "material"),
    "pattern_dynamic": ("log", "pipeline", "pattern_dynamic", "pattern", "contact", "material"),
    "pattern_dynamic_study": ("log", "pipeline", "pattern_dynamic", "study"),
    "pattern_figures": ("log", "pipeline", "plots.pattern"),
}

_PACKAGE_DIR = Path(__file__).resolve().parent
#: Modules whose function-level imports are lazy dispatch, not code of every stage. ``stage``: its function-level
#: imports (element FRF, offsets, fidelity) build the Radau stage kernel at the greens stage (whose entries list
#: them); a contact run reads that kernel from the greens file and runs only the module-level code.
_LAZY_DISPATCH = {"__init__", "pipeline", "stage"}


def _module_file(module: str, package_dir: Path) -> Path | None:
    """The source file of a dotted module name relative to the package (``plots.rolling``), or None."""
    base = package_dir.joinpath(*module.split("."))
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def _package_members(module: str, package_dir: Path) -> list[str]:
    """Every module of a subpackage folder (recursively, sorted); [] if ``module`` is a plain module."""
    path = _module_file(module, package_dir)
    if path is None or path.name != "__init__.py":
        return []
    members = []
    for file in sorted(path.parent.rglob("*.py")):
        rel = file.relative_to(package_dir).with_suffix("")
        parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
        members.append(".".join(parts))
    return members


def _imports_of(module: str, package_dir: Path, top_level_only: bool) -> set[str]:
    """tyreroad modules imported by ``module`` (relative to the package), read from its source."""
    path = _module_file(module, package_dir)
    if path is None:
        raise KeyError(f"module {module!r}: no {module.replace('.', '/')}.py nor package folder under {package_dir}")
    return set(_imports_in_source(module, package_dir, path.stat().st_mtime_ns, top_level_only))


# An import statement at the start of a line: "from X import (a,\n b)" or "from X import a, b" or "import X".
_IMPORT_LINE = re.compile(r"^([ \t]*)((?:from[ \t]+[.\w]+[ \t]+import[ \t]+(?:\([^)]*\)|[^\n]*))|(?:import[ \t]+[^\n]*))",
                          re.MULTILINE)


def _import_statements(source: str, top_level_only: bool) -> list:
    """The import statements of a module's source as ast nodes (top-level ones only, if asked).

    Parsing only the import lines instead of the whole module (ast.parse + ast.walk of every module a stage runs
    took ~1.8 s of every Snakemake start, i.e. of every cluster job and every planning test). A line that looks like
    an import but does not parse on its own (a docstring's prose) is skipped; one that parses (a docstring's example
    "import tyreroad.x") is counted, which can only add a file to a stage's hash, never drop one.
    """
    nodes = []
    for match in _IMPORT_LINE.finditer(source):
        indent, statement = match.groups()
        if top_level_only and indent:
            continue
        try:
            nodes.extend(ast.parse(statement.split("#", 1)[0].strip() if "(" not in statement else statement).body)
        except SyntaxError:
            continue
    return nodes


@lru_cache(maxsize=256)
def _imports_in_source(module: str, package_dir: Path, mtime_ns: int, top_level_only: bool) -> frozenset[str]:
    path = _module_file(module, package_dir)
    is_pkg = path.name == "__init__.py"
    if module == "__init__":
        parent: list[str] = []
    else:
        parent = module.split(".") if is_pkg else module.split(".")[:-1]
    found: set[str] = set()
    for node in _import_statements(path.read_text(), top_level_only):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "tyreroad" or alias.name.startswith("tyreroad."):
                    found.add(alias.name[len("tyreroad."):] if "." in alias.name else "__init__")
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = parent[: len(parent) - (node.level - 1)] if node.level > 1 else parent
                mod = ".".join(base + ([node.module] if node.module else []))
            elif node.module and (node.module == "tyreroad" or node.module.startswith("tyreroad.")):
                mod = node.module[len("tyreroad."):] if "." in node.module else ""
            else:
                continue
            for alias in node.names:
                sub = f"{mod}.{alias.name}" if mod else alias.name
                if _module_file(sub, package_dir) is not None:
                    found.add(sub)
                elif mod:
                    found.add(mod)
                else:
                    found.add("__init__")
    return frozenset(found)


def stage_modules(stage: str, package_dir: str | Path | None = None) -> list[str]:
    """All tyreroad modules a stage runs: its entry modules and what they import, recursively.

    Parameters
    ----------
    stage : str
        A key of :data:`STAGE_MODULES`.
    package_dir : path-like, optional
        The ``tyreroad`` package folder to read (default: this package).

    Returns
    -------
    list of str
        Dotted module names relative to the package (``__init__`` for ``tyreroad/__init__.py``),
        sorted.

    Notes
    -----
    Imports anywhere in a module count (also those inside functions), except for
    ``tyreroad.pipeline``, ``tyreroad.stiffness`` and ``tyreroad/__init__.py``, whose functions
    import other modules lazily on behalf of one stage or of a user: only their module-level
    imports count, the per-stage ones are the entries of :data:`STAGE_MODULES`. Package
    ``__init__`` files on the way are included (Python runs them on import). An entry that names a
    subpackage brings in all of its modules.
    """
    package_dir = Path(package_dir) if package_dir is not None else _PACKAGE_DIR
    if stage not in STAGE_MODULES:
        raise KeyError(f"unknown stage {stage!r}; expected one of {sorted(STAGE_MODULES)}")
    todo = ["__init__"]
    for entry in STAGE_MODULES[stage]:
        todo += [entry, *_package_members(entry, package_dir)]
    seen: set[str] = set()
    while todo:
        mod = todo.pop()
        if mod in seen:
            continue
        seen.add(mod)
        parts = mod.split(".")
        for k in range(1, len(parts)):
            todo.append(".".join(parts[:k]))  # the subpackage's __init__
        todo.extend(_imports_of(mod, package_dir, top_level_only=mod in _LAZY_DISPATCH) - seen)
    return sorted(seen)


def stage_files(stage: str, package_dir: str | Path | None = None) -> list[str]:
    """The source files :func:`source_hash` reads for ``stage``, relative to the package folder, in
    hashing order (that of :func:`stage_modules`)."""
    package_dir = Path(package_dir) if package_dir is not None else _PACKAGE_DIR
    return [str(_module_file(mod, package_dir).relative_to(package_dir)) for mod in stage_modules(stage, package_dir)]


def source_hash(stage: str, package_dir: str | Path | None = None) -> str:
    """SHA-256 (first 16 hex digits) of the source of every tyreroad module the stage runs.

    Each file contributes its path relative to the package folder and its bytes, in the order of
    :func:`stage_modules`, so the hash does not depend on where the package is installed.
    """
    package_dir = Path(package_dir) if package_dir is not None else _PACKAGE_DIR
    digest = hashlib.sha256()
    for rel in stage_files(stage, package_dir):
        digest.update(rel.encode() + b"\0")
        digest.update((package_dir / rel).read_bytes() + b"\0")
    return digest.hexdigest()[:16]
