"""One function per workflow stage: read inputs, call the physics, write outputs.

The Snakemake scripts in ``workflow/scripts/`` are thin adapters around these functions, so every
stage can also be run (and tested) from Python without Snakemake. Each function receives the
config *sections* it depends on (never the whole config), which is also what it records as the
provenance of the file it writes.

Outputs are written atomically (see :mod:`tyreroad.io`): if a stage fails, no result file is left.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any, Mapping, Sequence

import xarray as xr

from . import io

logger = logging.getLogger(__name__)

__all__ = [
    "resolved_material_config",
    "material_variants",
    "spring_material_inputs",
    "run_prepare_surface",
    "run_element_springs",
    "run_springs_figure",
    "run_greens",
    "run_greens_figures",
    "run_contact",
    "run_study",
    "run_study_figures",
    "run_claim6",
    "run_report",
    "run_stiffness_spectrum",
    "run_stiffness_figure",
    "run_stiffness_combined",
    "run_pattern_greens",
    "run_pattern_contact",
    "run_pattern_study",
    "run_pattern_report",
    "run_pattern_figures",
]


def resolved_material_config(material_name: str, materials: Mapping[str, Any]) -> dict[str, Any]:
    """The preset ``materials.<material_name>`` with its ``base:`` chain and scalings resolved.

    Raises
    ------
    KeyError, ValueError
        Naming ``materials.<name>`` when the preset is unknown or invalid.
    """
    from .material import material_from_config

    return dict(material_from_config(material_name, materials).config)


def _material(material_name: str, material_cfg: Mapping[str, Any]):
    """Build a :class:`tyreroad.material.Material` from one resolved preset."""
    from .material import material_from_config

    return material_from_config(material_name, {material_name: dict(material_cfg)})


def material_variants(
    reference: str, study_materials: Sequence[str], materials: Mapping[str, Any]
) -> dict[str, list[list[Any]]]:
    """Group the study's materials into the loss-factor and density variants of ``reference``.

    A material is a loss (density) variant when its preset has ``base: <reference>`` and only a
    ``loss_scale`` (and its ``loss_anchor``) (``density_scale``). The reference itself is the scale-1
    member of both groups.

    Returns
    -------
    dict
        ``{"loss": [[scale, name], ...], "density": [[scale, name], ...]}`` sorted by scale.
    """
    groups: dict[str, list[list[Any]]] = {"loss": [[1.0, reference]], "density": [[1.0, reference]]}
    for name in study_materials:
        preset = materials.get(name, {})
        if name == reference or preset.get("base") != reference:
            continue
        extra = set(preset) - {"base", "loss_scale", "density_scale", "loss_anchor"}
        if extra:
            continue
        if "loss_scale" in preset and "density_scale" not in preset:
            groups["loss"].append([float(preset["loss_scale"]), name])
        elif "density_scale" in preset and "loss_scale" not in preset:
            groups["density"].append([float(preset["density_scale"]), name])
    return {key: sorted(members) for key, members in groups.items()}


def spring_material_inputs(material_name: str, materials: Mapping[str, Any],
                           springs: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The material properties the element springs depend on (and nothing else).

    Elastic springs depend on the quasi-static modulus, Poisson's ratio and the layer thickness
    only; the workflow passes exactly these as the rule's params, so that changing, e.g., a
    variant's density does not re-run its springs. Viscoelastic springs (``springs.rheology: qlv``)
    also relax with the modulus E(omega): their inputs add the resolved material preset (``preset``).

    Returns
    -------
    dict
        ``quasi_static_modulus`` [Pa], ``poisson`` [-], ``thickness`` [m] (and ``preset`` for QLV springs).
    """
    from .material import material_from_config

    mat = material_from_config(material_name, materials)
    out: dict[str, Any] = {
        "quasi_static_modulus": float(mat.quasi_static_modulus),
        "poisson": float(mat.poisson),
        "thickness": float(mat.thickness),
    }
    if (springs or {}).get("rheology", "elastic") != "elastic":
        out["preset"] = dict(mat.config)
    return out


def run_prepare_surface(name: str, spec: Mapping[str, Any], out_nc: str | Path, out_png: str | Path) -> None:
    """Stage ``prepare_surface``: generate or read the road patch, write its netCDF and figure 4."""
    from .plots.surface import plot_patch
    from .surface import prepare_surface

    ds = prepare_surface(name, spec)
    io.write_dataset(ds, out_nc, {"surfaces": {name: dict(spec)}}, stage="prepare_surface", surface=name)
    with io.atomic_path(out_png) as tmp:
        plot_patch(ds, tmp)


def run_element_springs(
    surface_nc: str | Path,
    surface_name: str,
    material_name: str,
    material_inputs: Mapping[str, float],
    springs_cfg: Mapping[str, Any],
    out_nc: str | Path,
) -> None:
    """Stage ``element_springs``: one nonlinear contact spring per element of the patch."""
    from .springs import SpringModel, element_springs, resolve_spring_modulus

    model = SpringModel.from_config(springs_cfg)
    surface = io.read_dataset(surface_nc)
    modulus = resolve_spring_modulus(model, material_inputs["quasi_static_modulus"])
    ds = element_springs(
        surface, model, modulus=modulus, poisson=material_inputs["poisson"], thickness=material_inputs["thickness"]
    )
    if model.rheology == "qlv":
        from .qlv import check_relaxed_modulus, fit_relaxation, relaxation_variables

        material = _material(material_name, material_inputs["preset"])
        check_relaxed_modulus(float(material.modulus([0.0]).real[0]), modulus, material_name)
        data, attrs = relaxation_variables(fit_relaxation(material.modulus, modulus, name=material_name))
        ds = ds.assign(data)
        ds.attrs.update(attrs)
    provenance = {"springs": dict(springs_cfg), "material": {material_name: dict(material_inputs)}}
    io.write_dataset(ds, out_nc, provenance, stage="element_springs", surface=surface_name, material=material_name)


def run_springs_figure(springs_nc: str | Path, out_png: str | Path) -> None:
    """Figure of k(zeta) for a few elements and the patch sum."""
    from .plots.springs import plot_springs

    with io.atomic_path(out_png) as tmp:
        plot_springs(io.read_dataset(springs_nc), tmp)


def run_greens(
    material_name: str,
    material_cfg: Mapping[str, Any],
    greens_cfg: Mapping[str, Any],
    n_elements: Sequence[int],
    element_size: float,
    out_nc: str | Path,
    belt_cfg: Mapping[str, Any] | None = None,
    margin_window: Sequence[int] | None = None,
) -> None:
    """Stage ``greens``: the layer's element Green's functions for one material (:func:`build_greens`);
    with ``belt_cfg`` (the config's ``belt`` section), tread + flexible belt (:mod:`tyreroad.belt_stage`);
    with ``margin_window`` (a rolling strip's contact window [elements along x, y]), the correction and the
    margin on that window."""
    from .belt_stage import belt_settings
    from .greens import GreensSettings

    material = _material(material_name, material_cfg)
    ds = build_greens(material, n_elements, float(element_size), GreensSettings.from_config(greens_cfg),
                      belt=belt_settings(belt_cfg), margin_window=margin_window)
    provenance = {
        "material": {material_name: dict(material.config)},
        "greens": dict(greens_cfg),
        "n_elements": list(n_elements),
        "element_size": element_size,
        **({} if margin_window is None else {"margin_window": [int(v) for v in margin_window]}),
        **({} if belt_cfg is None else {"belt": dict(belt_cfg)}),
    }
    io.write_dataset(ds, out_nc, provenance, stage="greens", material=material_name)


def build_greens(material, n_elements: Sequence[int], element_size: float, settings, belt=None,
                 margin_window: Sequence[int] | None = None) -> xr.Dataset:
    """The kernel the greens stage makes for a material and patch, under ``settings.construction``.

    One place for what every time-domain user of a kernel runs on (the greens stage, the sensitivity
    sweep): the fold, its spring-safe correction (``passive``) or the Radau stage tables (``radau``), and
    the checks of :func:`_judge_kernel` (margin and fidelity stored; an unfaithful kernel refused).

    Parameters
    ----------
    material : tyreroad.material.Material
    n_elements : (int, int)
        Patch [elements].
    element_size : float
        [m].
    settings : tyreroad.greens.GreensSettings
    belt : (tyreroad.belt.BeltProperties, str), optional
        A flexible belt behind the tread and the indentation's reference (:func:`tyreroad.belt_stage.add_belt`,
        added before the spring-safe correction, so that it and the checks see the whole kernel); None: rigid.
    margin_window : (int, int), optional
        The largest contact the kernel must be stable on [elements along x, y], when it is smaller than the
        patch (a rolling strip: the contact spans ~2 sqrt(2 R d0) of its 150 mm). The passive correction is
        designed, and the stability margin computed, on this window: every contact set inside any such window
        of the patch is a principal submatrix of the window's matrices (the kernel is translation invariant),
        so the margin holds for it; a run must check that its contact stays inside (recorded in the file's
        ``margin_window`` attribute). None: the whole patch. The Radau kernel is stable for every spring on
        any patch and ignores it.

    Returns
    -------
    xarray.Dataset
        The greens dataset as the greens file holds it (without provenance).
    """
    from .greens import greens_dataset

    support = None
    shape = tuple(int(n) for n in n_elements)
    check = shape if margin_window is None else tuple(min(int(w), n) for w, n in zip(margin_window, shape))
    if min(check) < 1:
        raise ValueError(f"margin_window: expected positive element counts, got {list(margin_window)}")
    ds = greens_dataset(
        material,
        n_elements=shape,
        element_size=float(element_size),
        sample_rate=settings.sample_rate,
        n_lags=settings.n_lags,
        n_fft=settings.n_fft,
        construction=settings.construction,
    )
    response = None
    if belt is not None:
        from .belt_stage import add_belt

        if settings.construction == "radau":
            raise ValueError("greens.construction = 'radau' with a flexible belt: the Radau stage kernel has no belt "
                             "memory; use passive, fold or seed")
        ds, response = add_belt(ds, material, belt[0], belt[1], shape)
    if settings.construction == "passive":
        from .construction import correct_greens

        from .margin import uses_dense_margin, uses_strip_bound

        # designed on the matrices the margin below evaluates (the window's own, every block within the dense
        # limit; or a long narrow patch's strip bound): a design on a sub-patch does not bound the whole patch
        # (interlacing runs the other way: tread-eta0.5 designed for 1.05e5 N/m on the centre 20 x 20 of 40 x 20
        # had k_crit 6.1e4 there, designed on 40 x 20 itself 7.6e4). Only a patch beyond both (a footprint) gets
        # the correction of its central 20 x 20 and, from the margin, the conservative circulant bound alone.
        strip = uses_strip_bound(check)
        design = check if strip or uses_dense_margin(check) else (min(check[0], 20), min(check[1], 20))
        # the targets in turn on one eigen-solve pass; checked on the margin's whole theta grid (n_dense), so a
        # target met is met by the margin below, which reuses the design's eigenvalues (same patch)
        # a low-loss variant that misses the stiffest target with 128 taps gets the next target up with 256 (the
        # longer FIR reaches it within the same fidelity budget: tread-eta0.5 9e4 -> 1.05e5 N/m)
        ds, correction = correct_greens(ds, shape=design, n_theta=256, n_phi=8, k_target=PASSIVE_TARGETS,
                                        n_dense=PASSIVE_DENSE, max_rounds=30, n_taps=PASSIVE_TAPS[0],
                                        longer_taps=PASSIVE_TAPS[1], strip=strip)
        for note in correction.notes:  # a target not reachable within the fidelity budget (low-loss variants)
            logger.warning("greens %s: %s", material.name, note)
        logger.info("greens %s: %s", material.name, correction.summary())
        if design == check:
            support = correction.margin_support()
    if settings.construction == "radau":
        from .stage import radau_greens

        # the stage kernel beside the fold kernel: its tables, margin (inf by construction) and fidelity
        return radau_greens(ds, material, shape)
    if check != shape:
        ds.attrs["margin_window"] = list(check)
    return _judge_kernel(ds, material, shape, settings.construction, support, response, margin_shape=check)


#: Springs [N/m] the passive correction is designed for, tried in turn until the LP meets one (the last
#: is kept whatever it reaches): 3x, 2.6x, 2.3x, 1.9x and 1.5x the default tread's stiffest spring.
PASSIVE_TARGETS = (1.2e5, 1.05e5, 9.0e4, 7.5e4, 6.0e4)

#: Taps of the correction: the first design, and the longer one a missed stiffest target gets one step up with.
PASSIVE_TAPS = (128, 256)

#: The correction's spring safety is checked on theta = pi k / PASSIVE_DENSE above 5 kHz: the margin's grid.
PASSIVE_DENSE = 1024


def _judge_kernel(ds, material, shape, construction: str, support=None, response=None, margin_shape=None):
    """The greens stage's checks of its own kernel (issue 23): the stability margin over the unit circle
    and the fidelity to the element FRF, both stored in the file; a kernel that misses its FRF is refused.

    Raises
    ------
    ValueError
        If a causal material's kernel misses its FRF by more than :data:`tyreroad.fidelity.MAGNITUDE_LIMIT`
        / :data:`tyreroad.fidelity.PHASE_LIMIT` under any construction but the paper's own (``seed``, kept
        so that the report can show what the paper's method gives). A material that is not causal (the
        seed's loss variants) cannot meet its FRF with any causal kernel: its file is written (the
        frequency-domain stages read it) and the time-domain stages refuse it.
    """
    from .fidelity import kernel_fidelity
    from .kernel import LayerKernel
    from .margin import patch_margin

    kernel = LayerKernel.from_greens(ds, "dynamic")
    fidelity = kernel_fidelity(kernel, material, shape, response=response)  # response: tread + belt
    logger.info("greens %s (%s): fidelity to the element FRF %s", material.name, construction, fidelity.describe())
    if not fidelity.faithful and construction != "seed" and int(ds.attrs.get("causal_material", 1)):
        raise ValueError(
            f"greens {material.name}: the '{construction}' kernel misses the element FRF by "
            f"{fidelity.magnitude:.2%} of |G_0| / {fidelity.phase:.4f} rad over {fidelity.band[0]:g}-"
            f"{fidelity.band[1]:g} Hz (limits 1 % / 0.01 rad, tyreroad.fidelity): refused, no file written")
    # support: the correction's eigenvalues, reused; margin_shape: a rolling strip's contact window (build_greens)
    margin = patch_margin(kernel, shape if margin_shape is None else tuple(margin_shape), support=support)
    theta = xr.DataArray(margin.theta, dims="theta", attrs={"units": "rad", "long_name": "theta = 2 pi f / fs "
                                                            "on the unit circle z = exp(i theta)"})
    ds = ds.assign_coords(theta=theta)
    return ds.assign({**margin.variables(), **fidelity.variables()})


def run_greens_figures(greens_ncs: Sequence[str | Path], out_material_png: str | Path, out_frf_png: str | Path) -> None:
    """Figures 2 (material curves) and 3 (FRF at the excitation element) for every material."""
    from .plots.greens import plot_frf, plot_materials

    datasets = [io.read_dataset(p) for p in greens_ncs]
    with io.atomic_path(out_material_png) as tmp:
        plot_materials(datasets, tmp)
    with io.atomic_path(out_frf_png) as tmp:
        plot_frf(datasets, tmp)


#: The springs file's variables the contact solver reads (not the overlap area).
SPRING_TABLES = ("stiffness", "force")


#: The relaxation function of viscoelastic (QLV) springs (:mod:`tyreroad.qlv`), read with the tables.
SPRING_RELAXATION = ("relaxation_weight", "relaxation_time")


def _solver_inputs(surface_nc, springs_nc, greens_nc) -> tuple[xr.Dataset, xr.Dataset, xr.Dataset]:
    """Surface, springs (only :data:`SPRING_TABLES`, with :data:`SPRING_RELAXATION` for QLV springs) and
    greens datasets of a solver stage."""
    qlv = False
    if Path(springs_nc).is_file():  # (a missing file: read_dataset names it)
        with xr.open_dataset(springs_nc, engine="netcdf4") as header:  # attributes only
            qlv = header.attrs.get("spring_rheology", "elastic") == "qlv"
    springs = io.read_dataset(springs_nc, SPRING_TABLES + (SPRING_RELAXATION if qlv else ()))
    return io.read_dataset(surface_nc), springs, io.read_dataset(greens_nc)


def run_contact(
    surface_nc: str | Path,
    springs_nc: str | Path,
    greens_nc: str | Path,
    surface_name: str,
    material_name: str,
    material_cfg: Mapping[str, Any],
    mode: str,
    acceleration: float,
    solver_cfg: Mapping[str, Any],
    out_nc: str | Path,
    threads: int = 1,
) -> None:
    """Stage ``contact``: one dynamic or quasi-static indentation run.

    Raises
    ------
    tyreroad.contact.ContactConvergenceError
        If a time step does not converge; no file is written then.
    """
    from .contact import SolverSettings, contact_dataset, solve_run

    settings = SolverSettings.from_config(solver_cfg)
    material = _material(material_name, material_cfg)
    surface, springs, greens = _solver_inputs(surface_nc, springs_nc, greens_nc)
    result = solve_run(
        surface=surface,
        springs=springs,
        greens=greens,
        material=material,
        mode=mode,
        acceleration=float(acceleration),
        settings=settings,
        threads=threads,
    )
    ds = contact_dataset(result, mode, float(acceleration), surface_name, material_name)
    provenance = {"solver": dict(solver_cfg), "material": {material_name: dict(material.config)}}
    io.write_dataset(
        ds, out_nc, provenance, stage="contact", surface=surface_name, material=material_name, mode=mode
    )


def material_compounds(names: Sequence[str], materials: Mapping[str, Any]) -> dict[str, list]:
    """Compound and temperature of each material, as the study and combined K* files record them.

    Parameters
    ----------
    names : sequence of str
        Material preset names (the study's).
    materials : mapping
        The ``materials`` config section (temperature variants expanded).

    Returns
    -------
    dict
        Name -> ``[compound, temperature]``, temperature [degC] or None for a material without one
        (None, not NaN: Snakemake compares a rule's params between runs, and NaN != NaN).
    """
    from .material import compound_and_temperature

    out = {}
    for name in names:
        compound, temperature = compound_and_temperature(name, materials)
        out[name] = [compound, None if math.isnan(temperature) else temperature]
    return out


def run_study(
    contact_ncs: Sequence[str | Path], study_cfg: Mapping[str, Any], d_max: float, out_nc: str | Path,
    compounds: Mapping[str, Sequence[Any]] | None = None,
) -> None:
    """Stage ``study``: all runs on one indentation grid, with stiffness and K_sat per case.

    ``compounds`` (:func:`material_compounds`) adds the case coordinates ``compound`` and
    ``temperature`` [degC] (:func:`tyreroad.io.assign_compound_coords`)."""
    from .study import StudySettings, aggregate

    settings = StudySettings.from_config(study_cfg, d_max=d_max)
    ds = aggregate([io.read_dataset(p) for p in contact_ncs], settings)
    if compounds is not None:
        ds = io.assign_compound_coords(ds, compounds, "case")
    io.write_dataset(ds, out_nc, {"study": dict(study_cfg), "d_max": d_max}, stage="study")


def run_study_figures(
    study_nc: str | Path, study_cfg: Mapping[str, Any], variants: Mapping[str, Any], outputs: Sequence[str | Path]
) -> None:
    """Figures 5-8: F(d) and K(d) of the reference material, and K(d) of the loss and density variants."""
    from .plots.study import plot_study_figures
    from .study import open_study

    plot_study_figures(
        open_study(study_nc), variants, [str(p) for p in outputs], reference_material=study_cfg["reference_material"],
        source=study_nc,
    )


def run_report(
    study_nc: str | Path,
    surface_nc: str | Path,
    greens_ncs: Sequence[str | Path],
    study_cfg: Mapping[str, Any],
    variants: Mapping[str, Any],
    out_md: str | Path,
    loading_nc: str | Path | None = None,
    spectra_ncs: Sequence[str | Path] = (),
    construction_ncs: Sequence[str | Path] = (),
    construction_greens_ncs: Sequence[str | Path] = (),
    spring_comparison: Mapping[str, Any] | None = None,
    claim6_nc: str | Path | None = None,
    figure_pngs: Sequence[str | Path] = (),
    belt_ncs: Sequence[str | Path] = (),
    pattern_nc: str | Path | None = None,
) -> None:
    """``results/report.md``: the seed's claims checked against the measured numbers; given the
    stiffness-spectrum files, the section on K*(f; d0); given ``loading_nc`` (results/loading.nc),
    the hysteresis of the load-unload cycles; given comparison studies of other kernel constructions
    (``results/constructions/<name>/study.nc`` and their greens files), the study beside them. (The
    rolling section is ``results/rolling.md`` of the named target ``rolling``.) Given
    ``spring_comparison`` (config key, issue 24), the section comparing this study with the
    elastic-springs study in ``spring_comparison['elastic_results']``. The figures ``figure_pngs``
    are embedded with their captions, linked relative to the report. ``belt_ncs``: the study repeated on a
    flexible belt (results/belt/study.nc, its greens files and stiffness spectra, by folder), set beside this one.
    ``pattern_nc``: the pattern study (results/pattern/study.nc, issue 27; with pattern.study), its section
    appended (:func:`tyreroad.report.pattern.pattern_section`)."""
    import os

    from .report import build_report, write_report
    from .study import StudySettings, open_study

    study = open_study(study_nc)
    settings = StudySettings.from_config(study_cfg, d_max=float(study.attrs["d_max_m"]))
    text = build_report(
        study,
        io.read_dataset(surface_nc),
        [io.read_dataset(p) for p in greens_ncs],
        settings,
        variants,
        config={"study": dict(study_cfg), "variants": dict(variants)},
        spectra=[io.read_dataset(p) for p in spectra_ncs],
        loading=None if loading_nc is None else io.read_dataset(loading_nc),
        constructions=_construction_studies(construction_ncs, construction_greens_ncs),
        claim6=None if claim6_nc is None else io.read_dataset(claim6_nc),
        figures=[Path(os.path.relpath(p, Path(out_md).parent)).as_posix() for p in figure_pngs],
        belt=_belt_study(belt_ncs),
    )
    if spring_comparison:
        from .report.spring_comparison import spring_comparison_section

        lines = spring_comparison_section(study, [io.read_dataset(p) for p in spectra_ncs], settings, variants,
                                          Path(out_md).parent, spring_comparison["elastic_results"])
        text = text.rstrip("\n") + "\n\n" + "\n".join(lines).rstrip("\n") + "\n"
    if pattern_nc is not None:
        from .report.pattern import pattern_section

        text = text.rstrip("\n") + "\n\n" + "\n".join(pattern_section(io.read_dataset(pattern_nc))).rstrip("\n") + "\n"
    write_report(text, out_md)


def _belt_study(belt_ncs):
    """(study, greens datasets, K* datasets) of the belt study's files (results/belt/...), or None without them."""
    from .study import open_study

    paths = [Path(p) for p in belt_ncs]
    study = [p for p in paths if p.name == "study.nc"]
    if not study:
        return None
    greens = [io.read_dataset(p) for p in paths if p.parent.name == "greens"]
    spectra = [io.read_dataset(p) for p in paths if "stiffness_spectrum" in p.parts]
    return open_study(study[0]), greens, spectra


def _construction_studies(study_ncs, greens_ncs) -> dict:
    """{construction: (study dataset, [greens datasets])} of the comparison studies (the construction is the
    folder name: results/constructions/<name>/study.nc, .../<name>/greens/<material>.nc)."""
    from .study import open_study

    out = {}
    for p in study_ncs:
        name = Path(p).parent.name
        greens = [io.read_dataset(g) for g in greens_ncs if Path(g).parent.parent.name == name]
        out[name] = (open_study(p), greens)
    return out


def run_claim6(
    surface_nc: str | Path,
    springs_nc: str | Path,
    greens_nc: str | Path,
    contact_ncs: Sequence[str | Path],
    materials_cfg: Mapping[str, Any],
    study_cfg: Mapping[str, Any],
    variants: Mapping[str, Any],
    solver_cfg: Mapping[str, Any],
    out_nc: str | Path,
    threads: int = 1,
) -> None:
    """Stage ``claim6``: claim 6 by loss-variant definition (results/claim6.nc, :mod:`tyreroad.claim6`).

    The seed variants' K*(f_c; d0) about the reference's relaxed state (surface, springs and greens of
    the reference; frequency domain only) and of their two controls (:func:`tyreroad.claim6.seed_controls`);
    K_sat of the reference, the study's loss variants, the anchor variants and the checks from their
    dynamic runs at the highest study acceleration.
    """
    from .claim6 import Claim6Settings, claim6_dataset
    from .claim6_runs import saturated_stiffness_of_runs, seed_controls, seed_storage_stiffness
    from .contact import SolverSettings
    from .material import material_from_config

    settings = Claim6Settings.from_config(study_cfg.get("claim6"))
    reference = study_cfg["reference_material"]
    loss = [name for scale, name in variants.get("loss", []) if name != reference]
    names = [reference, *loss, *settings.seed_variants, *settings.time_domain]
    materials = {n: material_from_config(n, materials_cfg) for n in names}
    solver = SolverSettings.from_config(solver_cfg)
    surface, springs, greens = _solver_inputs(surface_nc, springs_nc, greens_nc)
    k_star = seed_storage_stiffness(surface, springs, greens, [materials[n] for n in [reference, *settings.seed_variants]],
                                    settings.frequency, settings.preload, solver, threads)
    controls = [c for n in settings.seed_variants
                for c in seed_controls(materials[reference], materials[n]).values()]
    k_star.update(seed_storage_stiffness(surface, springs, greens, controls, settings.frequency, settings.preload,
                                         solver, threads, same_relaxed_state=False))
    ksat = saturated_stiffness_of_runs(list(contact_ncs), study_cfg, float(solver_cfg["d_max"]))
    ds = claim6_dataset(materials, reference, ksat, k_star, settings, max(float(a) for a in study_cfg["accelerations"]),
                        loss)
    provenance = {"study": dict(study_cfg), "solver": dict(solver_cfg),
                  "materials": {n: dict(materials[n].config) for n in names}}
    io.write_dataset(ds, out_nc, provenance, stage="claim6")


def run_loading(
    surface_nc: str | Path,
    springs_nc: str | Path,
    greens_nc: str | Path,
    surface_name: str,
    material_name: str,
    material_cfg: Mapping[str, Any],
    mode: str,
    loading_name: str,
    loading_cfg: Mapping[str, Any],
    solver_cfg: Mapping[str, Any],
    out_nc: str | Path,
    threads: int = 1,
    base_dir: str | Path = ".",
) -> None:
    """Stage ``loading_run``: one run of a loading preset (cycle, harmonic, table; SPEC 10).

    Raises
    ------
    tyreroad.contact.ContactConvergenceError
        If a step does not converge or a cycle's path ends before every element has separated;
        no file is written then.
    """
    from .contact import SolverSettings, loading_dataset, solve_loading
    from .loading import LoadingPreset

    settings = SolverSettings.from_config(solver_cfg)
    material = _material(material_name, material_cfg)
    preset = LoadingPreset(loading_name, loading_cfg, base_dir=base_dir)
    surface, springs, greens = _solver_inputs(surface_nc, springs_nc, greens_nc)
    result = solve_loading(
        surface=surface,
        springs=springs,
        greens=greens,
        material=material,
        mode=mode,
        preset=preset,
        settings=settings,
        threads=threads,
    )
    ds = loading_dataset(result, mode, preset, surface_name, material_name)
    provenance = {"solver": dict(solver_cfg), "material": {material_name: dict(material.config)},
                  "loading": {loading_name: dict(loading_cfg)}}
    io.write_dataset(ds, out_nc, provenance, stage="loading", surface=surface_name, material=material_name,
                     mode=mode, loading=loading_name)


def run_loading_study(loading_ncs: Sequence[str | Path], out_nc: str | Path) -> None:
    """``results/loading.nc``: dissipated energy, loading work, peak force and the loop of every loading run."""
    from .hysteresis import aggregate_loading

    ds = aggregate_loading([io.read_dataset(p) for p in loading_ncs])
    io.write_dataset(ds, out_nc, {"loading_runs": [str(p) for p in loading_ncs]}, stage="loading_study")


def run_hysteresis_figure(loading_nc: str | Path, out_png: str | Path) -> None:
    """Figure 10: the hysteresis loops F(d) of the quasi-static and dynamic cycles, every material."""
    from .plots.hysteresis import plot_hysteresis

    with io.atomic_path(out_png) as tmp:
        plot_hysteresis(io.read_dataset(loading_nc), tmp)


def run_stiffness_spectrum(
    surface_nc: str | Path,
    springs_nc: str | Path,
    greens_nc: str | Path,
    surface_name: str,
    material_name: str,
    material_cfg: Mapping[str, Any],
    solver_cfg: Mapping[str, Any],
    spectrum_cfg: Mapping[str, Any] | None,
    out_nc: str | Path,
    threads: int = 1,
) -> None:
    """Stage ``stiffness_spectrum``: K*(f; d0) of one material about its relaxed preload states (SPEC 11)."""
    from .contact import SolverSettings
    from .stiffness import SpectrumSettings, spectrum_from_datasets

    settings = SolverSettings.from_config(solver_cfg)
    spectrum = SpectrumSettings.from_config(spectrum_cfg)
    material = _material(material_name, material_cfg)
    ds = spectrum_from_datasets(
        *_solver_inputs(surface_nc, springs_nc, greens_nc), material, spectrum, settings, threads=threads
    )
    provenance = {
        "stiffness_spectrum": dict(spectrum_cfg or {}),
        "solver": dict(solver_cfg),
        "material": {material_name: dict(material.config)},
    }
    io.write_dataset(ds, out_nc, provenance, stage="stiffness_spectrum", surface=surface_name, material=material_name)


def run_stiffness_figure(
    spectra_ncs: Sequence[str | Path],
    reference: str,
    variants: Mapping[str, Any],
    spectrum_cfg: Mapping[str, Any] | None,
    out_png: str | Path,
) -> None:
    """Figure 9: K' and K'' against f, per preload for the reference (relaxed and transient), all materials at one."""
    from .plots.stiffness import plot_stiffness_spectrum
    from .stiffness import SpectrumSettings

    spectra = [io.read_dataset(p) for p in spectra_ncs]
    figure_preload = SpectrumSettings.from_config(spectrum_cfg).figure_preload
    with io.atomic_path(out_png) as tmp:
        plot_stiffness_spectrum(spectra, reference, variants, figure_preload, tmp)


def run_stiffness_combined(spectra_ncs: Sequence[str | Path], out_nc: str | Path,
                           compounds: Mapping[str, Sequence[Any]] | None = None) -> None:
    """``results/stiffness_spectrum.nc``: the study materials' K*(f; d0) in one file with a material dimension.

    ``compounds`` (:func:`material_compounds`) adds the material coordinates ``compound`` and
    ``temperature`` [degC], so that ``ds.set_index(material=["compound", "temperature"]).unstack("material")``
    gives compound x temperature arrays."""
    from .kstar import combine_spectra

    ds = combine_spectra([io.read_dataset(p) for p in spectra_ncs])
    if compounds is not None:
        ds = io.assign_compound_coords(ds, compounds, "material")
    io.write_dataset(ds, out_nc, {"stiffness_spectra": [str(p) for p in spectra_ncs]}, stage="stiffness_combined")


def run_rolling(
    surface_nc: str | Path,
    springs_nc: str | Path,
    greens_nc: str | Path,
    surface_name: str,
    material_name: str,
    mode: str,
    speed: float,
    rolling_cfg: Mapping[str, Any],
    solver_cfg: Mapping[str, Any],
    out_nc: str | Path,
    threads: int = 1,
    material_cfg: Mapping[str, Any] | None = None,
) -> None:
    """Stage ``rolling_run``: one pass of the rolling tyre over the strip (SPEC 12).

    On a greens file built with the flexible belt (rule belt_rolling_run), the pass also records every step's
    element forces and adds the belt's normal velocity just ahead of and behind the contact and the 1/3-octave
    spectra (:func:`add_belt_vibration`; needs ``material_cfg``). Every pass records its wall time and the
    process's peak memory (attrs ``wall_seconds``, ``peak_rss_mb``).

    Raises
    ------
    ValueError
        If the pass starts or ends with the contact on the strip; no file is written then.
    tyreroad.contact.ContactConvergenceError
        If a step does not converge.
    """
    from .contact import SolverSettings
    from .rolling import RollingSettings, rolling_dataset, solve_rolling_run

    import resource
    import time

    from .belt_kernel import belt_of_greens

    t0 = time.perf_counter()
    settings = RollingSettings.from_config(rolling_cfg)
    solver = SolverSettings.from_config(solver_cfg)
    surface, springs, greens = _solver_inputs(surface_nc, springs_nc, greens_nc)
    belt = belt_of_greens(greens)
    if belt is not None and material_cfg is None:
        raise ValueError(f"{greens_nc}: a pass on the flexible belt needs the material (material_cfg) for the belt's "
                         "vibration")
    result, info = solve_rolling_run(surface, springs, greens, mode, float(speed), settings, solver, threads,
                                     record_forces=belt is not None)
    ds = rolling_dataset(result, info, mode, float(speed), settings, surface, surface_name, material_name)
    if belt is not None:
        ds = add_belt_vibration(ds, result, info, surface, _material(material_name, material_cfg), belt[0], settings)
    ds.attrs["wall_seconds"] = time.perf_counter() - t0
    ds.attrs["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    # what the pass ran on (the rolling report compares spring laws and kernels by these)
    ds.attrs["spring_rheology"] = str(springs.attrs.get("spring_rheology", "elastic"))
    ds.attrs["kernel_construction"] = str(greens.attrs.get("construction", "unknown"))
    provenance = {"rolling": dict(rolling_cfg), "solver": dict(solver_cfg)}
    io.write_dataset(ds, out_nc, provenance, stage="rolling_run", surface=surface_name, material=material_name,
                     mode=mode)


#: How far ahead of the contact's leading edge and behind its trailing edge the belt's velocity is taken [m].
BELT_OBSERVATION_GAP = 0.01


def add_belt_vibration(ds: xr.Dataset, result, info: Mapping[str, float], surface: xr.Dataset, material, belt,
                       settings) -> xr.Dataset:
    """The belt's normal velocity just ahead of and behind the contact of a rolling pass on the flexible belt.

    The points move with the contact on the strip's centre line, ``BELT_OBSERVATION_GAP`` ahead of the contact's
    leading edge and behind its trailing edge (the edges: the median over the steady part of the extreme x - x_c of
    the elements in contact). The velocity is the belt material's, from every step's element forces
    (:func:`tyreroad.belt_vibration.belt_velocity_at_points`); its 1/3-octave levels over the steady part, and the
    contact force's, are added.

    Returns
    -------
    xarray.Dataset
        ``ds`` with coords belt_point (ahead, behind), band; belt_velocity[belt_point, step] [m/s],
        belt_observation_offset[belt_point] [m], belt_velocity_level[belt_point, band] [dB re 5e-8 m/s],
        contact_force_level[band] [dB re 1 N].
    """
    import numpy as np

    from .belt_vibration import VELOCITY_REFERENCE, belt_velocity_at_points, belt_vibration_spectra, force_spectrum
    from .rolling.analysis import steady_mask

    forces = result.element_force
    ex, ey = surface["element_x"].values, surface["element_y"].values
    fs = 1.0 / float(result.time[1] - result.time[0])
    steady = steady_mask(result.x_c, info, settings.steady_margin, settings.steady_entry)
    in_contact = forces > 0.0
    rel = ex[None, :] - result.x_c[:, None]
    touched = in_contact.any(axis=2)
    front = np.where(touched, rel, -np.inf).max(axis=1)
    rear = np.where(touched, rel, np.inf).min(axis=1)
    use = steady & np.isfinite(front)
    if not use.any():
        raise ValueError("rolling: no steady step with contact; the belt's vibration needs a steady part")
    offsets = np.array([np.median(front[use]) + BELT_OBSERVATION_GAP, np.median(rear[use]) - BELT_OBSERVATION_GAP])
    y_centre = 0.5 * (ey[0] + ey[-1])
    run = {}
    velocity = belt_velocity_at_points(forces, ex, ey, fs, result.x_c[None, :] + offsets[:, None],
                                       np.full(2, y_centre), material, belt, float(info["element_size"]), info=run)
    band_limits = tuple(settings.band_limits)
    centres, v_levels = belt_vibration_spectra(velocity, fs, steady, band_limits)
    _, f_levels = force_spectrum(result.force, fs, steady, band_limits)
    out = ds.assign_coords(
        belt_point=("belt_point", ["ahead", "behind"], {"units": "1", "long_name": "where the belt's velocity is taken"}),
        band=("band", centres, {"units": "Hz", "long_name": "1/3-octave band centre frequency"}))
    out["belt_velocity"] = (("belt_point", "step"), velocity, {
        "units": "m/s", "long_name": "normal velocity of the belt (material frame, positive into the tyre) at points "
        "moving with the contact, on the strip's centre line"})
    out["belt_observation_offset"] = ("belt_point", offsets, {
        "units": "m", "long_name": "x of the observation point from the contact centre x_c"})
    out["belt_velocity_level"] = (("belt_point", "band"), v_levels, {
        "units": "dB", "long_name": f"1/3-octave level of the belt velocity over the steady part, re {VELOCITY_REFERENCE:g} "
        "m/s"})
    out["contact_force_level"] = ("band", f_levels, {
        "units": "dB", "long_name": "1/3-octave level of the total contact force's fluctuation over the steady part, "
        "re 1 N"})
    out.attrs.update({"belt": 1, **{f"belt_vibration_{k}": v for k, v in run.items() if np.isscalar(v)}})
    return out


def run_belt_mobility(material_name: str, material_cfg: Mapping[str, Any], belt_cfg_or_None, out_nc: str | Path,
                      out_png: str | Path) -> None:
    """Stage ``belt_mobility``: the tread-surface point and transfer mobilities on the flexible belt, with the figure
    (:func:`tyreroad.belt_mobility.run_belt_mobility`)."""
    from .belt_mobility import run_belt_mobility as run

    run(material_name, material_cfg, belt_cfg_or_None, out_nc, out_png)


def run_belt_rolling_spectra(belt_ncs: Sequence[str | Path], rigid_ncs: Sequence[str | Path], out_nc: str | Path,
                             out_png: str | Path) -> None:
    """``results/belt/rolling_spectra.nc`` and its figure: per speed, the pass on the flexible belt beside the pass on
    the rigid belt (same strip, material, load): 1/3-octave levels of the contact force (both), of the belt's
    velocity ahead of and behind the contact, the steady and rolling-loss forces, and each pass's cost (wall time,
    peak memory)."""
    import numpy as np

    from .belt_vibration import force_spectrum
    from .plots.belt import plot_belt_rolling_spectra

    rows = []
    for b_path, r_path in zip(belt_ncs, rigid_ncs):
        belt, rigid = io.read_dataset(b_path), io.read_dataset(r_path)
        if float(belt.attrs["speed"]) != float(rigid.attrs["speed"]):
            raise ValueError(f"{b_path} and {r_path}: passes at different speeds")
        fs = 1.0 / float(rigid["time"].values[1] - rigid["time"].values[0])
        centres, rigid_levels = force_spectrum(rigid["force"].values, fs, rigid["steady"].values.astype(bool),
                                               (float(belt["band"].values[0]) / 1.01, float(belt["band"].values[-1]) * 1.01))
        if centres.size != belt.sizes["band"]:
            raise ValueError(f"{r_path}: its bands do not match the belt pass's")
        scalars = {}
        for tag, ds in (("belt", belt), ("rigid", rigid)):
            for key, units in (("steady_force", "N"), ("rolling_loss_force", "N"), ("d0", "m")):
                scalars[f"{key}_{tag}"] = ((), float(ds[key]), {"units": units, "long_name": f"{ds[key].attrs.get('long_name', key)} ({tag} belt)"})
            for key, units in (("wall_seconds", "s"), ("peak_rss_mb", "MB")):
                scalars[f"{key}_{tag}"] = ((), float(ds.attrs.get(key, np.nan)), {"units": units, "long_name": f"{key} of the {tag}-belt pass job"})
            scalars[f"steps_{tag}"] = ((), int(ds.sizes["step"]), {"units": "1", "long_name": f"steps of the {tag}-belt pass"})
        rows.append(xr.Dataset({
            "contact_force_level_belt": ("band", belt["contact_force_level"].values, {"units": "dB", "long_name": "contact force level, flexible belt, re 1 N"}),
            "contact_force_level_rigid": ("band", rigid_levels, {"units": "dB", "long_name": "contact force level, rigid belt, re 1 N"}),
            "belt_velocity_level": (("belt_point", "band"), belt["belt_velocity_level"].values, dict(belt["belt_velocity_level"].attrs)),
            "belt_observation_offset": ("belt_point", belt["belt_observation_offset"].values, dict(belt["belt_observation_offset"].attrs)),
            **scalars,
        }, coords={"band": belt["band"].values, "belt_point": belt["belt_point"].values,
                   "speed": float(belt.attrs["speed"])}))
    ds = xr.concat(rows, dim="speed")
    ds["speed"].attrs.update(units="m/s", long_name="rolling speed")
    ds["belt_point"].attrs.update(units="1", long_name="where the belt's velocity is taken (ahead of / behind the "
                                  "contact)")
    ds["band"].attrs.update(units="Hz", long_name="1/3-octave band centre frequency")
    ds.attrs["material"] = str(io.read_dataset(belt_ncs[0]).attrs.get("material", ""))
    io.write_dataset(ds, out_nc, {"belt_runs": [str(p) for p in belt_ncs], "rigid_runs": [str(p) for p in rigid_ncs]},
                     stage="belt_rolling_spectra")
    plot_belt_rolling_spectra(ds, out_png)


def run_rolling_study(rolling_ncs: Sequence[str | Path], rolling_cfg: Mapping[str, Any], out_nc: str | Path) -> None:
    """``results/rolling.nc``: per case the steady force, rolling-loss force and coefficient, force spectra."""
    from .rolling import RollingSettings, aggregate_rolling

    settings = RollingSettings.from_config(rolling_cfg)
    ds = aggregate_rolling([io.read_dataset(p) for p in rolling_ncs], settings.band_limits)
    io.write_dataset(ds, out_nc, {"rolling": dict(rolling_cfg), "runs": [str(p) for p in rolling_ncs]},
                     stage="rolling_study")


def run_rolling_figures(rolling_nc: str | Path, map_ncs: Sequence[str | Path], outputs: Sequence[str | Path]) -> None:
    """Figures 11-14 of the rolling study (F(x_c), spectra, rolling loss, contact map)."""
    from .plots.rolling import plot_rolling_figures

    plot_rolling_figures(io.read_dataset(rolling_nc), [io.read_dataset(p) for p in map_ncs], [str(p) for p in outputs])


def run_rolling_report(rolling_nc: str | Path, out_md: str | Path, figure_pngs: Sequence[str | Path] = (),
                       spring_comparison: Mapping[str, Any] | None = None) -> None:
    """``results/rolling.md``: the report's rolling section (table per material and speed), and the
    figures ``figure_pngs`` embedded with their captions, linked relative to the report. With
    ``spring_comparison`` (config key), the section comparing these passes with the elastic-springs rolling
    study in ``spring_comparison['elastic_results']``/rolling.nc (a missing file is said, not an error)."""
    import os

    from .report import build_rolling_report, write_report

    figures = [Path(os.path.relpath(p, Path(out_md).parent)).as_posix() for p in figure_pngs]
    reference, label = None, ""
    if spring_comparison:
        label = str(spring_comparison["elastic_results"])
        path = Path(label) / "rolling.nc"
        if path.exists():
            reference = io.read_dataset(path)
        else:
            logger.warning("rolling report: %s is missing; the spring comparison says so", path)
    write_report(build_rolling_report(io.read_dataset(rolling_nc), figures=figures, reference=reference,
                                      reference_label=label), out_md)


# ----------------------------------------------------------------------------------------------
# Patterned treads (issue 27; tyreroad.pattern, workflow/rules/pattern.smk)
# ----------------------------------------------------------------------------------------------
def run_pattern_greens(
    pattern_name: str,
    pattern_cfg: Mapping[str, Any] | None,
    influence: str,
    material_name: str,
    material_cfg: Mapping[str, Any],
    element_size: float,
    patch_elements: Sequence[int],
    out_nc: str | Path,
) -> None:
    """Stage ``pattern_greens``: the block influence table of a pattern preset (``pattern_cfg``), or, for
    ``pattern_name = 'slick'`` (``pattern_cfg`` None), the flat layer's static offset table over the patch
    (``patch_elements``), with its memory and compute time."""
    from .pattern import PatternGeometry
    from .pattern_stage import pattern_greens_dataset, slick_greens_dataset

    material = _material(material_name, material_cfg)
    if pattern_cfg is None:
        ds = slick_greens_dataset(tuple(patch_elements), float(element_size), material)
    else:
        ds = pattern_greens_dataset(PatternGeometry.from_config(pattern_name, pattern_cfg, float(element_size)),
                                    material, influence)
    provenance = {"pattern": {pattern_name: None if pattern_cfg is None else dict(pattern_cfg)},
                  "influence": influence, "material": {material_name: dict(material.config)},
                  "element_size": float(element_size), "patch_elements": list(patch_elements)}
    io.write_dataset(ds, out_nc, provenance, stage="pattern_greens", material=material_name)


def run_pattern_contact(
    surface_nc: str | Path,
    springs_nc: str | Path,
    greens_nc: str | Path,
    surface_name: str,
    material_name: str,
    pattern_name: str,
    patch_origin: Sequence[float],
    solver_cfg: Mapping[str, Any],
    out_nc: str | Path,
    threads: int = 1,
    grooves_nc: str | Path | None = None,
) -> None:
    """Stage ``pattern_contact``: one quasi-static run on a patterned (or the slick) tread, grooved elements out
    of contact (:func:`tyreroad.pattern.solve_pattern_run`); with ``grooves_nc`` (the pattern's greens file, and
    the slick one as ``greens_nc``) the grooves-only run of that pattern."""
    from .contact import SolverSettings
    from .pattern import pattern_contact_dataset, solve_pattern_run

    settings = SolverSettings.from_config(solver_cfg)
    surface, springs, greens = io.read_dataset(surface_nc), io.read_dataset(springs_nc, SPRING_TABLES), \
        io.read_dataset(greens_nc)
    grooves = None if grooves_nc is None else io.read_dataset(grooves_nc)
    result, grooved, elapsed = solve_pattern_run(surface, springs, greens, settings, tuple(patch_origin), threads,
                                                 grooves)
    shape = grooved.shape
    path = ("pattern: block-diagonal dense" if str(greens.attrs.get("kind")) == "pattern"
            else f"slick: {settings.resolved_method(shape[0] * shape[1])}")
    ds = pattern_contact_dataset(result, grooved, elapsed, surface_name, material_name, pattern_name, path,
                                 "" if grooves is None else "grooves-only")
    provenance = {"solver": dict(solver_cfg), "patch_origin": list(patch_origin), "pattern": pattern_name,
                  "grooves_only": grooves is not None}
    io.write_dataset(ds, out_nc, provenance, stage="pattern_contact", surface=surface_name, material=material_name)


def run_pattern_stiffness_spectrum(
    surface_nc: str | Path,
    springs_nc: str | Path,
    greens_nc: str | Path,
    slick_nc: str | Path,
    surface_name: str,
    material_name: str,
    material_cfg: Mapping[str, Any],
    patch_origin: Sequence[float],
    solver_cfg: Mapping[str, Any],
    spectrum_cfg: Mapping[str, Any],
    out_nc: str | Path,
    threads: int = 1,
) -> None:
    """Stage ``pattern_stiffness_spectrum``: K*(f; d0) on a patterned tread and on the slick tread of the same patch
    (:func:`tyreroad.pattern_spectrum.pattern_stiffness_spectrum`)."""
    from .contact import SolverSettings
    from .pattern_spectrum import pattern_stiffness_spectrum
    from .stiffness import frequency_grid

    settings = SolverSettings.from_config(solver_cfg)
    cfg = dict(spectrum_cfg or {})
    f_max = float(cfg.get("f_max", 5000.0))
    freq = frequency_grid(float(cfg.get("f_min", 10.0)), f_max, int(cfg.get("n_frequencies", 31)),
                          [f for f in (100.0, 1000.0) if f < f_max])
    ds = pattern_stiffness_spectrum(
        io.read_dataset(surface_nc), io.read_dataset(springs_nc, SPRING_TABLES), io.read_dataset(greens_nc),
        io.read_dataset(slick_nc), _material(material_name, material_cfg), [float(d) for d in cfg.get("preloads",
        [1.0e-4])], freq, settings, int(cfg.get("n_modes", 40)), tuple(patch_origin), threads)
    provenance = {"solver": dict(solver_cfg), "patch_origin": list(patch_origin), "stiffness_spectrum": cfg,
                  "material": {material_name: dict(material_cfg)}}
    io.write_dataset(ds, out_nc, provenance, stage="pattern_stiffness_spectrum", surface=surface_name,
                     material=material_name)


def run_pattern_study(
    contact_ncs: Sequence[str | Path], greens_ncs: Sequence[str | Path], study_cfg: Mapping[str, Any], d_max: float,
    out_nc: str | Path,
) -> None:
    """Stage ``pattern_study``: K(d), K_sat per pattern beside the slick tread's (the study's definitions), the
    grooved fraction, the influence tables' memory and the stage times (:func:`tyreroad.pattern.pattern_study`)."""
    from .pattern import pattern_study
    from .study import StudySettings

    settings = StudySettings.from_config(study_cfg, d_max=d_max)
    ds = pattern_study([io.read_dataset(p) for p in contact_ncs], [io.read_dataset(p) for p in greens_ncs], settings)
    io.write_dataset(ds, out_nc, {"study": dict(study_cfg), "d_max": d_max}, stage="pattern_study")


def run_pattern_report(study_nc: str | Path, out_md: str | Path, spectrum_ncs: Sequence[str | Path] = (),
                       figure_pngs: Sequence[str | Path] = (), dynamic_ncs: Sequence[str | Path] = ()) -> None:
    """Stage ``pattern_report``: the pattern study's section (and K*(f; d0) of the analysed patterns, and the dynamic
    runs on the modal forms) as ``pattern.md``, with the figures ``figure_pngs`` (stage ``pattern_figures``) linked
    relative to it."""
    import os

    from .report.pattern import write_pattern_report
    from .report.pattern_dynamic import dynamic_section

    study = io.read_dataset(study_nc)
    extra = [line for p in dynamic_ncs for line in dynamic_section(io.read_dataset(p), study)]
    write_pattern_report(study, out_md, source=str(study_nc), spectra=[io.read_dataset(p) for p in spectrum_ncs],
                         figures=[Path(os.path.relpath(p, Path(out_md).parent)).as_posix() for p in figure_pngs],
                         extra=extra)


def run_pattern_modes(pattern_name: str, pattern_cfg: Mapping[str, Any], material_name: str,
                      material_cfg: Mapping[str, Any], element_size: float, dynamic_cfg: Mapping[str, Any] | None,
                      out_nc: str | Path) -> None:
    """Stage ``pattern_modes``: the block's modal form for dynamic runs (:func:`tyreroad.pattern_stage.pattern_modes_dataset`),
    for ``material_name``'s thickness, Poisson's ratio and density (every pattern material shares the first two:
    checked at planning time; the density is rescaled per run)."""
    from .pattern import PatternGeometry
    from .pattern_stage import pattern_modes_dataset

    cfg = dict(dynamic_cfg or {})
    material = _material(material_name, material_cfg)
    ds = pattern_modes_dataset(PatternGeometry.from_config(pattern_name, pattern_cfg, float(element_size)), material,
                               int(cfg.get("n_modes", 40)), float(cfg.get("check_frequency", 5000.0)))
    provenance = {"pattern": {pattern_name: dict(pattern_cfg)}, "material": {material_name: dict(material.config)},
                  "element_size": float(element_size), "dynamic": cfg}
    io.write_dataset(ds, out_nc, provenance, stage="pattern_modes", material=material_name)


def run_pattern_dynamic(surface_nc: str | Path, springs_nc: str | Path, modes_nc: str | Path, surface_name: str,
                        material_name: str, material_cfg: Mapping[str, Any], pattern_name: str, mode: str,
                        acceleration: float, patch_origin: Sequence[float], solver_cfg: Mapping[str, Any],
                        greens_cfg: Mapping[str, Any], out_nc: str | Path, threads: int = 1) -> None:
    """Stage ``pattern_dynamic``: a run on the block's modal form (:func:`tyreroad.pattern_dynamic.solve_modal_run`):
    dynamic at ``acceleration``, or quasi-static on the same form's relaxed table."""
    from .contact import SolverSettings
    from .pattern_dynamic import modal_contact_dataset, solve_modal_run

    settings = SolverSettings.from_config(solver_cfg)
    material = _material(material_name, material_cfg)
    result, grooved, info = solve_modal_run(
        io.read_dataset(surface_nc), io.read_dataset(springs_nc, SPRING_TABLES), io.read_dataset(modes_nc), material,
        mode, float(acceleration), settings, float(greens_cfg["sample_rate"]), int(greens_cfg["n_lags"]),
        tuple(patch_origin), threads)
    ds = modal_contact_dataset(result, grooved, info, mode, float(acceleration), surface_name, material_name,
                               pattern_name)
    provenance = {"solver": dict(solver_cfg), "patch_origin": list(patch_origin), "pattern": pattern_name,
                  "greens": {k: greens_cfg[k] for k in ("sample_rate", "n_lags")},
                  "material": {material_name: dict(material.config)}}
    io.write_dataset(ds, out_nc, provenance, stage="pattern_dynamic", surface=surface_name, material=material_name)


def run_pattern_dynamic_study(contact_ncs: Sequence[str | Path], modes_ncs: Sequence[str | Path],
                              study_cfg: Mapping[str, Any], d_max: float, out_nc: str | Path) -> None:
    """Stage ``pattern_dynamic_study``: K(d), K_sat of the runs on the modal forms
    (:func:`tyreroad.pattern_dynamic.dynamic_study`)."""
    from .pattern_dynamic import dynamic_study
    from .study import StudySettings

    settings = StudySettings.from_config(study_cfg, d_max=d_max)
    ds = dynamic_study([io.read_dataset(p) for p in contact_ncs], [io.read_dataset(p) for p in modes_ncs], settings)
    io.write_dataset(ds, out_nc, {"study": dict(study_cfg), "d_max": float(d_max)}, stage="pattern_dynamic_study")


def run_pattern_figures(greens_ncs: Sequence[str | Path], spectrum_ncs: Sequence[str | Path],
                        out_compliance_png: str | Path, out_spectrum_png: str | Path | None = None) -> None:
    """Stage ``pattern_figures``: the blocks' edge softening from the pattern greens files (the patterns' block
    tables, not the slick tread's) and, given ``out_spectrum_png``, K'(f) and eta(f) of the K* files beside the
    slick tread's (:mod:`tyreroad.plots.pattern`)."""
    from .plots.pattern import compliance_map_figure, pattern_spectrum_figure

    compliance_map_figure([io.read_dataset(p) for p in greens_ncs], out_compliance_png)
    if out_spectrum_png is not None:
        pattern_spectrum_figure([io.read_dataset(p) for p in spectrum_ncs], out_spectrum_png)
