"""The ``tyreroad`` command: the workflow and the data from the shell (thin layer over the package).

    tyreroad run [TARGET ...] [-c overlay.yaml ...] [-j N] [-n]     the right Snakemake call
    tyreroad kstar MATERIAL --preload 0.12mm [--third-octave] [--csv out.csv]
    tyreroad info FILE
    tyreroad material TABLE.csv --reference-temperature 23 --wlf 8.86 101.6 --temperature 0 [-o preset.yaml]

The logic is in :mod:`tyreroad.runner`, :mod:`tyreroad.kstar`, :mod:`tyreroad.info` and :mod:`tyreroad.dma`.
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
                   "and the loss factor, for the relaxed and (if computed) transient state. Reads "
                   "RESULTS/stiffness_spectrum.nc (the study's materials), or only when that file is absent "
                   "RESULTS/stiffness_spectrum/SURFACE/MATERIAL.nc; says which on standard error.")
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
@click.option("--file", "file_path", default=None, type=click.Path(dir_okay=False),
              help="Read this K* file (combined or per-material) instead of RESULTS/stiffness_spectrum.nc.")
def kstar(material, preload, surface, results, third_octave, csv_path, file_path) -> None:
    from . import io, kstar as ks

    try:
        d0 = ks.parse_length(preload)
        if file_path is not None:
            ds = io.read_dataset(file_path)
            if "material" in ds.dims:
                names = [str(m) for m in ds["material"].values]
                if material not in names:
                    raise ValueError(f"{file_path}: material {material!r} is not in the file ({', '.join(names)})")
                ds = ds.sel(material=material).drop_vars(
                    [c for c in ("material", "compound", "temperature") if c in ds.coords])
                ds.attrs["material"] = material
            elif str(ds.attrs.get("material", material)) != material:
                raise ValueError(f"{file_path}: a K* file of material {ds.attrs['material']!r}, not {material!r}")
            ds.attrs["source_file"] = str(file_path)
            note = f"read K* of {material} from {file_path} (--file)"
        else:
            ds, note = ks.open_material(results, material, surface)
        click.echo(note, err=True)
        table = ks.at_preload(ds, d0)
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


@main.command(help="Fit and check a compound from a DMA master curve (CSV: frequency [Hz], storage_modulus [Pa], "
                   "loss_factor [-] or loss_modulus [Pa]) and print a materials: preset block to paste into a "
                   "config: the causal fit's error, the Kramers-Kronig check (E' implied by the table's loss "
                   "against its E'), and per study temperature the shift factor a_T and E', eta at 1 kHz.")
@click.argument("table", type=click.Path(dir_okay=False))
@click.option("--name", default=None, help="Preset name (default: from the file name).")
@click.option("--reference-temperature", type=float, default=None, metavar="DEGC",
              help="Temperature of the master curve [degC].")
@click.option("--wlf", nargs=2, type=float, default=None, metavar="C1 C2",
              help="WLF shift: log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref), C2 in K.")
@click.option("--arrhenius", type=float, default=None, metavar="EA",
              help="Arrhenius shift with activation energy E_a [J/mol].")
@click.option("-t", "--temperature", "temperatures", type=float, multiple=True, metavar="DEGC",
              help="Study temperature [degC] (repeatable): each becomes the variant <name>-T<T>.")
@click.option("--quasi-static-modulus", type=float, default=None, metavar="PA",
              help="Relaxed modulus from data [Pa] (default: the fit's extrapolation below the table).")
@click.option("--fit-tolerance", type=float, default=None, help="Largest relative fit error [-] (default 0.02).")
@click.option("--poisson-ratio", type=float, default=0.49, show_default=True, help="nu [-].")
@click.option("--density", type=float, default=1100.0, show_default=True, help="rho [kg/m^3].")
@click.option("--thickness", type=float, default=0.01, show_default=True, help="Tread thickness h [m].")
@click.option("-o", "--output", default=None, type=click.Path(dir_okay=False),
              help="Write the preset block here instead of standard output.")
def material(table, name, reference_temperature, wlf, arrhenius, temperatures, quasi_static_modulus, fit_tolerance,
             poisson_ratio, density, thickness, output) -> None:
    from .dma import check_compound, preset_block

    if wlf and arrhenius is not None:
        raise click.UsageError("give one shift: --wlf C1 C2 or --arrhenius EA, not both")
    shift = ({"model": "wlf", "C1": wlf[0], "C2": wlf[1]} if wlf
             else {"model": "arrhenius", "activation_energy": arrhenius} if arrhenius is not None else None)
    try:
        check = check_compound(table, name=name, reference_temperature=reference_temperature, shift=shift,
                               temperatures=temperatures, quasi_static_modulus=quasi_static_modulus,
                               fit_tolerance=fit_tolerance, poisson_ratio=poisson_ratio, density=density,
                               thickness=thickness)
    except (ValueError, FileNotFoundError) as err:
        raise click.ClickException(str(err)) from None
    text = preset_block(check)
    if output:
        Path(output).write_text(text)
        click.echo(check.summary(), err=True)
        click.echo(f"wrote {output}", err=True)
    else:
        click.echo(text, nl=False)


if __name__ == "__main__":  # pragma: no cover
    main()
