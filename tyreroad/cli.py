"""The ``tyreroad`` command: the workflow and the data from the shell (thin layer over the package).

    tyreroad run [TARGET ...] [-c overlay.yaml ...] [-j N] [-n]     the right Snakemake call
    tyreroad kstar MATERIAL --preload 0.12mm [--third-octave] [--csv out.csv]
    tyreroad info FILE

The logic is in :mod:`tyreroad.runner`, :mod:`tyreroad.kstar` and :mod:`tyreroad.info`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

__all__ = ["main"]


@click.group(help="tyreroad: tyre tread / rough road contact study. Snakemake is the engine; "
                  "run from the repository folder (the one with the Snakefile).")
def main() -> None:
    pass


@main.command(help="Run (or with -n plan) the study or TARGETs, with overlay config files after "
                   "config/config.yaml. Prints the Snakemake command it runs.")
@click.argument("targets", nargs=-1)
@click.option("-c", "--config", "overlays", multiple=True, metavar="OVERLAY.yaml",
              help="Overlay config file over config/config.yaml (repeatable; later ones win).")
@click.option("-j", "--jobs", default=2, show_default=True, type=click.IntRange(min=1), help="Parallel jobs.")
@click.option("-n", "--dry-run", is_flag=True, help="Plan only: list the jobs, run nothing.")
@click.option("--results-dir", default=None, metavar="DIR", help="Results folder (overrides results_dir).")
@click.option("-d", "--directory", default=".", show_default=True, type=click.Path(file_okay=False),
              help="The repository folder (Snakefile, config/).")
def run(targets, overlays, jobs, dry_run, results_dir, directory) -> None:
    from .runner import format_command, run_snakemake, snakemake_command

    try:
        cmd = snakemake_command(targets, overlays, jobs, dry_run, results_dir)
        click.echo(f"$ {format_command(cmd)}", err=True)
        code = run_snakemake(cmd, directory)
    except (ValueError, FileNotFoundError) as err:
        raise click.ClickException(str(err)) from None
    sys.exit(code)


@main.command(help="The contact spring K*(f) of MATERIAL at a preload d0 (interpolated linearly in d0 "
                   "between the computed preloads), as CSV or 1/3-octave bands: K', K'', |K*| [N/m] "
                   "and the loss factor, for the relaxed and (if computed) transient state.")
@click.argument("material")
@click.option("--preload", required=True, metavar="LENGTH", help="d0: 0.12mm, 120um or 1.2e-4 (metres).")
@click.option("--surface", default="iso10844", show_default=True, help="The study surface.")
@click.option("--results", default="results", show_default=True, type=click.Path(file_okay=False),
              help="The results folder.")
@click.option("--third-octave", is_flag=True,
              help="IEC 61260 1/3-octave bands: band value = mean of K' and K'' over the band on a log "
                   "frequency axis.")
@click.option("--csv", "csv_path", default=None, type=click.Path(dir_okay=False),
              help="Write the CSV here instead of standard output.")
def kstar(material, preload, surface, results, third_octave, csv_path) -> None:
    from . import io, kstar as ks

    try:
        d0 = ks.parse_length(preload)
        path = Path(results) / "stiffness_spectrum" / surface / f"{material}.nc"
        if not path.is_file():
            raise FileNotFoundError(f"{path}: no K* file for material {material!r} on surface {surface!r}; "
                                    f"make it with: tyreroad run {path.as_posix()}")
        table = ks.at_preload(io.read_dataset(path), d0)
        if third_octave:
            table = ks.third_octave_bands(table)
    except (ValueError, FileNotFoundError) as err:
        raise click.ClickException(str(err)) from None
    text = ks.to_csv(table)
    if csv_path:
        Path(csv_path).write_text(text)
        click.echo(f"wrote {csv_path} ({table.attrs['interpolation']})", err=True)
    else:
        click.echo(text, nl=False)


@main.command(help="A short summary of a result file: stage, material, code version, config hash, "
                   "variables with units.")
@click.argument("file", type=click.Path(dir_okay=False))
def info(file) -> None:
    from .info import describe

    try:
        click.echo(describe(file))
    except (FileNotFoundError, OSError, ValueError) as err:
        raise click.ClickException(str(err)) from None


if __name__ == "__main__":  # pragma: no cover
    main()
