"""The Snakemake call behind ``tyreroad run``: targets first, then the config files, so none is swallowed.

Snakemake's ``--configfile`` takes every following word that does not start with ``-`` as a further
config file, so ``snakemake -j2 --configfile config/config.yaml my.yaml rolling`` reads ``rolling``
as a config file and fails with FileNotFoundError. :func:`snakemake_command` places the targets
before every option and the config files last: ``snakemake TARGET ... -j N [-n] [--config
results_dir=DIR] --configfile config/config.yaml OVERLAY ...`` (the study's config first, the
overlays after it in the order given, later ones overriding earlier ones).
"""

from __future__ import annotations

import shlex
import subprocess
from pathlib import Path
from typing import Sequence

__all__ = ["DEFAULT_CONFIG", "snakemake_command", "run_snakemake"]

#: The study's config, always the first config file.
DEFAULT_CONFIG = "config/config.yaml"


def snakemake_command(targets: Sequence[str] = (), overlays: Sequence[str] = (), jobs: int = 2,
                      dry_run: bool = False, results_dir: str | None = None) -> list[str]:
    """The argument list of the Snakemake call for ``targets`` with the config ``overlays``.

    Parameters
    ----------
    targets : sequence of str
        Rule names or output files (none: the default target, the whole study).
    overlays : sequence of str
        Overlay config files, applied over config/config.yaml in this order.
    jobs : int
        Parallel jobs (``-j``), >= 1.
    dry_run : bool
        Plan only (``-n``).
    results_dir : str, optional
        Results directory (``--config results_dir=...``), overriding the config files.

    Raises
    ------
    ValueError
        For jobs < 1, a target that looks like an option, or config/config.yaml given as an overlay.
    """
    if int(jobs) < 1:
        raise ValueError(f"jobs: expected >= 1, got {jobs!r}")
    for t in targets:
        if str(t).startswith("-"):
            raise ValueError(f"target {t!r} looks like an option; pass Snakemake options through the tyreroad options")
    overlays = [str(o) for o in overlays]
    if any(Path(o) == Path(DEFAULT_CONFIG) for o in overlays):
        raise ValueError(f"{DEFAULT_CONFIG} is always read first; give only the overlays with -c")
    cmd = ["snakemake", *map(str, targets), "-j", str(int(jobs))]
    if dry_run:
        cmd.append("-n")
    if results_dir is not None:
        cmd += ["--config", f"results_dir={results_dir}"]
    cmd += ["--configfile", DEFAULT_CONFIG, *overlays]
    return cmd


def run_snakemake(cmd: Sequence[str], directory: str | Path = ".") -> int:
    """Run ``cmd`` in ``directory`` (the repository: its Snakefile and config/), return the exit code.

    Raises
    ------
    FileNotFoundError
        When ``directory`` has no Snakefile or no config/config.yaml, or an overlay does not exist.
    """
    directory = Path(directory)
    for need in ("Snakefile", DEFAULT_CONFIG):
        if not (directory / need).is_file():
            raise FileNotFoundError(f"{directory.resolve()}: no {need}; run tyreroad run in the repository "
                                    "(the folder with the Snakefile) or pass --directory")
    if "--configfile" in cmd:
        for path in cmd[list(cmd).index("--configfile") + 1:]:
            if not (directory / path).is_file():
                raise FileNotFoundError(f"config file {path}: not found in {directory.resolve()}")
    return subprocess.call(list(cmd), cwd=directory)


def format_command(cmd: Sequence[str]) -> str:
    """The command as a shell line."""
    return shlex.join(cmd)
