"""Memory and run-time requests of the workflow's cluster jobs, from the config.

The rules' ``resources:`` call :func:`job_resources`; a SLURM run (``profiles/slurm``) turns them
into ``sbatch --mem`` and ``--time``. The estimates scale with what drives the cost of each stage
(patch size, scan samples, Green's-function lags, run length in steps) and are calibrated on the
measured peaks of the stage's own process (``results/benchmarks/`` of the paper's study, 20 x 20:
0.20-0.33 GB; jobs of ``config/footprint.yaml`` on the test cluster of tests/slurm, 150 x 200:
surface 2.4 GB, springs 1.4 GB, Green's functions 1.6 GB, contact 1.6-1.8 GB), with head room:
1.25x on memory and 3x on run time. The solver path (dense or FFT) of a run is the one the solver
itself takes (:meth:`tyreroad.solver.SolverSettings.resolved_method`), and run lengths are the
loadings' own step counts (:mod:`tyreroad.loading`, :func:`tyreroad.rolling.pass_positions`).
On top come the
two Snakemake processes of every SLURM job (the batch step and the job step that runs the rule:
~0.2 GB each, measured with sacct on the test cluster, where a 20 x 20 contact job peaked at
0.19 + 0.45 GB) and a fixed start-up time (interpreter, imports, a numba cache that may have to
be compiled on the node). A retried job (Snakemake ``attempt`` 2, 3, ...) asks for
``attempt`` times as much.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from .loading import LoadingPreset, constant_acceleration_steps, uniform_grid_steps
from .solver import SolverSettings

__all__ = ["CLUSTER_RULES", "job_resources", "run_steps", "rolling_pass_steps", "solver_path"]

#: Rules that run as cluster jobs (the others are ``localrules``).
CLUSTER_RULES = ("prepare_surface", "element_springs", "greens", "contact", "loading_run", "stiffness_spectrum",
                 "rolling_greens", "rolling_run", "sensitivity_point", "construction_greens", "construction_contact",
                 "belt_greens", "belt_contact", "belt_stiffness_spectrum", "belt_rolling_greens", "belt_rolling_run",
                 "pattern_greens", "pattern_contact", "pattern_grooves_only", "pattern_stiffness_spectrum",
                 "pattern_modes", "pattern_dynamic")
#: Rules that request what another rule of the same work does (the study's comparison constructions, the belt
#: study and rolling; a belt greens job also fits the belt's model, 10-25 s on the default patch, within the greens
#: stage's runtime request)
_SAME_AS = {"construction_greens": "greens", "construction_contact": "contact", "belt_greens": "greens",
            "belt_contact": "contact", "belt_stiffness_spectrum": "stiffness_spectrum",
            "belt_rolling_greens": "rolling_greens", "belt_rolling_run": "rolling_run"}

_BASE_MB = 280.0          # MB, a stage's process: interpreter, numpy/scipy/numba/xarray, small arrays
_SNAKEMAKE_MB = 400.0     # MB, the job's two Snakemake processes (batch step, job step)
_STARTUP_MIN = 5.0        # min, interpreter start, imports, possibly a cold numba compile
_D0_SOLVE_STEPS = 60      # static solves of the d0 search of a rolling pass given its load (doubling + Brent)
_LOAD_PASSES = 4          # passes of the search for the d0 that carries the load (tyreroad.rolling.run)
_DEFAULT_FIELD = 0.1      # m, schema default of surfaces.*.field_size


def run_steps(solver: Mapping[str, Any], sample_rate: float, mode: str, accel: float) -> int:
    """Number of time steps of one contact run.

    Parameters
    ----------
    solver : mapping
        The ``solver`` config section (``d_max`` [m], ``quasistatic_step`` [m]).
    sample_rate : float
        Green's-function sample rate [Hz]: the time step of dynamic runs is its inverse.
    mode : {'dynamic', 'quasistatic'}
        Run mode.
    accel : float
        Indentation acceleration [m/s^2] (dynamic runs).

    Returns
    -------
    int
        Steps from first contact to ``d_max``, both ends included, as the run counts them:
        :func:`tyreroad.loading.uniform_grid_steps` (quasi-static) or
        :func:`tyreroad.loading.constant_acceleration_steps` (dynamic, constant acceleration from
        rest, time step ``1 / sample_rate``).
    """
    d_max = float(solver["d_max"])
    if mode == "quasistatic":
        return uniform_grid_steps(d_max, float(solver["quasistatic_step"]))
    if mode != "dynamic":
        raise ValueError(f"mode: expected 'dynamic' or 'quasistatic', got {mode!r}")
    if not float(accel) > 0:
        raise ValueError(f"accel: expected a positive acceleration [m/s^2], got {accel!r}")
    return constant_acceleration_steps(float(sample_rate), float(accel), d_max)


def rolling_pass_steps(config: Mapping[str, Any], surface: str, mode: str, speed: float) -> int:
    """Number of steps of one rolling pass over a strip, as planned before d0 is known.

    Parameters
    ----------
    config : mapping
        The validated workflow config (sections ``rolling``, ``surfaces``, ``springs``, ``greens``).
    surface : str
        The strip's surface preset.
    mode : {'dynamic', 'quasistatic'}
        Pass type.
    speed : float
        Rolling speed v [m/s].

    Returns
    -------
    int
        Contact-centre positions of the pass (:func:`tyreroad.rolling.pass_positions` over
        :func:`tyreroad.rolling.pass_limits`): pass length * fs / v (dynamic) or pass length /
        ``rolling.quasistatic_step`` (quasi-static), plus one. With ``rolling.load`` the indentation
        d0 is found only in the job (it sets the contact half-length sqrt(2 R d0) by which the
        automatic pass overhangs the strip): the count takes ``springs.zeta_max``, the largest d0
        the job's search accepts, an upper bound (default 150 x 20 strip at 5 m/s: 2090 steps
        planned; the measured 44 s at ~0.024 s per step are about 1800).
    """
    # deferred on purpose: tyreroad.rolling imports the contact solver (numba, scipy); the other
    # rules' requests need only the light tyreroad.solver and tyreroad.loading
    from .rolling import RollingSettings, pass_limits, pass_positions

    settings = RollingSettings.from_config(config["rolling"])
    spec = config["surfaces"][surface]
    size = float(spec.get("element_size", 1.0e-3))
    nx, _ = _elements(config, surface)
    d0 = settings.d0 if settings.d0 is not None else float(config["springs"]["zeta_max"])
    x_start, x_end = pass_limits(settings, d0, (np.arange(nx) + 0.5) * size, size)
    _, x_c = pass_positions(mode, speed, x_start, x_end, float(config["greens"]["sample_rate"]),
                            settings.quasistatic_step)
    return int(x_c.size)


def _elements(config: Mapping[str, Any], surface: str) -> tuple[int, int]:
    nx, ny = config["surfaces"][surface]["patch_elements"]
    return int(nx), int(ny)


def _lag_terms(steps: int, n_lags: int) -> int:
    """Lags summed over a dynamic run on the dense path: sum over steps n of min(n, n_lags).

    Times 1.2e-9 s m^2 it is the history-sum time of :func:`job_resources`, calibrated on the 20 x 20
    load-unload cycle of 755 steps on 256 lags that took 38 s dense (5 s on the FFT path, whose
    model gives 6 s; :meth:`tyreroad.solver.SolverSettings.resolved_method`). Since session 24's loop
    order of the dense lag sum the same cycle takes 12.7 s dense (3.8 s FFT): the estimate is kept, ~3x
    generous for the dense path, since a run-time request that is too short kills the job.
    """
    short = min(steps, n_lags)
    return short * (short - 1) // 2 + max(0, steps - n_lags) * n_lags


def _greens_elements(config: Mapping[str, Any], rolling: bool = False) -> tuple[int, int]:
    """The Green's tables cover the largest configured patch (see the workflow's max_patch_elements);
    the rolling strips (rolling.surfaces) have their own Green's functions (``rolling=True``)."""
    strips = set(config["rolling"]["surfaces"]) if "rolling" in config else set()
    # the pattern study's patch (pattern.surface) has its own static tables (tyreroad.pattern), not the study's greens
    own = {(config.get("pattern") or {}).get("surface")} - strips
    sizes = [_elements(config, name) for name in config["surfaces"]
             if (name in strips) == rolling and name not in own] or [
        _elements(config, name) for name in config["surfaces"]]
    return max(s[0] for s in sizes), max(s[1] for s in sizes)


def _pattern_job(rule: str, config: Mapping[str, Any], wildcards: Mapping[str, Any]) -> tuple[float, float]:
    """(MB, s) of a pattern stage job (tyreroad.pattern): the block table N x N of the pattern (the slick
    tread: its offset table and the study's quasi-static model of a contact run on the patch).

    Static tables: the analytic stand-in costs ~1 ms per unique offset (measured: docs/pattern.md). A pattern
    run factorises each block's loaded set: B N^3 per Newton correction, ~4 corrections and a tangent per state.
    """
    section = config.get("pattern") or {}
    surface = section.get("surface") or config["study"]["surface"]
    nx, ny = _elements(config, surface)
    c = float(config["surfaces"][surface].get("element_size", 1.0e-3))
    preset = (section.get("presets") or {}).get(wildcards.get("pattern"))
    if preset is None or rule == "pattern_grooves_only":  # the slick layer
        n_table, n_offsets, blocks = (2 * nx - 1) * (2 * ny - 1), nx * ny, 1
        n_block = nx * ny
    else:
        bx, by = round(float(preset["block_length"]) / c), round(float(preset["block_width"]) / c)
        gw = round(float(preset["groove_width"]) / c)
        n_block = bx * by
        n_table, n_offsets = n_block * n_block, bx * by
        blocks = math.ceil(nx / (bx + gw)) * math.ceil(ny / (by + gw)) + 2
    table_mb = 8 * n_table / 1e6
    if rule == "pattern_greens":
        if preset is None or section.get("influence", "fe") != "fe":
            return _BASE_MB + 3 * table_mb, 10 + 2e-3 * n_offsets
        # the FE cell model (tyreroad.fe_pattern, 2 x 2 hexahedra per element): measured 1.4 GB / 60 s for a 20 x 20
        # block (N = 400) and 7.5 GB / 1010 s for 40 x 40 (N = 1600) on one core; DOFs grow with N, the factors and
        # the N right-hand sides faster
        return _BASE_MB + 1.7 * n_block * (1 + n_block / 800) + 3 * table_mb, 30 + 4.5e-4 * n_block**2
    if rule in ("pattern_stiffness_spectrum", "pattern_modes"):
        # the eigen-decomposition of every symmetry class and one direct complex frequency: measured 245 s for a
        # 20 x 20 block, 2370 s and 11.3 GB for 40 x 40 (the complex factors hold twice the real ones' memory)
        return _BASE_MB + 2.5 * n_block * (1 + n_block / 800) + 3 * table_mb, 200 + 1.5e-3 * n_block**2
    d_max = float(config["solver"]["d_max"])
    if rule == "pattern_dynamic" and wildcards.get("mode") == "dynamic":
        # the Radau stage kernel on the modal form (tyreroad.pattern_dynamic): per block a dense 3 N x 3 N W_0 and an
        # LU of the loaded stage set whenever it changes (most steps of a loading run); measured on the 85 x 40 patch:
        # 0.17 s per step on 20 mm blocks (163 steps in 27 s), up to 2.5 s per step on 40 mm blocks
        steps = constant_acceleration_steps(float(config["greens"]["sample_rate"]), float(wildcards["accel"]), d_max)
        output = steps * nx * ny * 8 * 6 / 1e6
        return (_BASE_MB + blocks * 72 * n_block**2 / 1e6 + 3 * output,
                60 + steps * (blocks * 5e-12 * (3 * n_block) ** 3 + 0.1))
    steps = uniform_grid_steps(d_max, float(config["solver"]["quasistatic_step"]))
    output = steps * nx * ny * 8 * 6 / 1e6
    if preset is None and solver_path(config, nx * ny, steps, False) == "fft":
        seconds = steps * 2e-5 * nx * ny * 5
    else:
        seconds = steps * (5 * blocks * 1.2e-10 * n_block**3 + 1e-3)
    return _BASE_MB + 4 * table_mb + 3 * output, seconds


def _kernel_mb(config: Mapping[str, Any], rolling: bool = False) -> float:
    """Size of one time-domain kernel table g[dx, dy, lag] [MB] (of the study's or the strips' greens)."""
    nx, ny = _greens_elements(config, rolling)
    return (2 * nx - 1) * (2 * ny - 1) * int(config["greens"]["n_lags"]) * 8 / 1e6


def _field_mb(spec: Mapping[str, Any], patch_only: bool = False) -> float:
    """Size of one height array of a surface's generated field (or of its patch) [MB]."""
    nx, ny = spec["patch_elements"]
    per_element = int(spec.get("samples_per_element", 26))
    size = float(spec.get("element_size", 1.0e-3))
    field = [0.0, 0.0] if patch_only else (spec.get("field_size") or [_DEFAULT_FIELD, _DEFAULT_FIELD])
    samples = [max(n * per_element, math.ceil(f / size * per_element)) for n, f in zip((nx, ny), field)]
    return samples[0] * samples[1] * 8 / 1e6


def solver_path(config: Mapping[str, Any], n_elements: int, n_steps: int, dynamic: bool) -> str:
    """``"dense"`` or ``"fft"``: the path the solver takes for a run, asked of the solver itself.

    Parameters
    ----------
    config : mapping
        The workflow config (sections ``solver`` and ``greens``).
    n_elements : int
        Elements of the patch or strip.
    n_steps : int
        Steps of the run.
    dynamic : bool
        A dynamic run is compared with the kernel's kept lags (``greens.n_lags``): longer, it takes
        the FFT path under ``solver.method: auto``; a quasi-static kernel has 1 lag.

    Returns
    -------
    str
        :meth:`tyreroad.solver.SolverSettings.resolved_method` of the run.
    """
    n_lags = int(config["greens"]["n_lags"]) if dynamic else 1
    return SolverSettings.from_config(config["solver"]).resolved_method(n_elements, n_steps, n_lags)


def job_resources(rule: str, config: Mapping[str, Any], wildcards: Mapping[str, Any], attempt: int = 1) -> dict[str, int]:
    """Memory and run time to request for one cluster job.

    Parameters
    ----------
    rule : str
        One of :data:`CLUSTER_RULES`.
    config : mapping
        The validated workflow config.
    wildcards : mapping
        The job's wildcards: ``surface`` (``material`` for the Green's functions); ``mode`` and
        ``accel`` (``contact``), ``loading`` (``loading_run``) or ``speed`` [m/s] (``rolling_run``).
    attempt : int
        Snakemake's attempt counter (1 for the first submission).

    Returns
    -------
    dict
        ``mem_mb`` [MB] and ``runtime`` [min], both integers.
    """
    if rule not in CLUSTER_RULES:
        raise ValueError(f"rule: expected one of {CLUSTER_RULES}, got {rule!r}")
    attempt = max(1, int(attempt))
    rule = _SAME_AS.get(rule, rule)
    if rule == "prepare_surface":
        field = _field_mb(config["surfaces"][wildcards["surface"]])
        # 150 x 200 on the test cluster: 2.4 GB and 49 s for a 182 MB field (20 x 20: 0.2 GB, 54 MB)
        mem, seconds = _BASE_MB + 12 * field, 0.3 * field
    elif rule == "element_springs":
        spec = config["surfaces"][wildcards["surface"]]
        nx, ny = _elements(config, wildcards["surface"])
        springs = config["springs"]
        tables = nx * ny * (int(float(springs["zeta_max"]) / float(springs["zeta_step"])) + 1) * 8 / 1e6
        patch = _field_mb(spec, patch_only=True)
        # 150 x 200 on the test cluster: 1.4 GB and 34 s (240 MB of tables)
        mem, seconds = _BASE_MB + 4 * tables + 4 * patch, 0.15 * (tables + patch)
    elif rule == "sensitivity_point":
        # a small study of its own on the study surface (springs, Green's functions, the contact runs of
        # one material): measured 15-23 s and 0.40-0.43 GB peak per point on the 20 x 20 patch, 1 thread,
        # two points at a time on 2 cores (results/benchmarks/sensitivity/*.tsv); scaled by the patch
        nx, ny = _elements(config, config["study"]["surface"])
        m = nx * ny
        mem, seconds = _BASE_MB + 0.4 * m, 0.06 * m
    elif rule in ("pattern_greens", "pattern_contact", "pattern_grooves_only", "pattern_stiffness_spectrum",
                  "pattern_modes", "pattern_dynamic"):
        mem, seconds = _pattern_job(rule, config, wildcards)
    elif rule in ("greens", "rolling_greens"):
        kernel = _kernel_mb(config, rolling=rule == "rolling_greens")
        n_fft_scale = int(config["greens"]["n_fft"]) / 4096
        # 150 x 200 on the test cluster: 1.6 GB and 111 s for a 244 MB table
        mem = _BASE_MB + 6 * kernel * max(1.0, n_fft_scale)
        seconds = 0.5 * kernel * n_fft_scale + 10
    else:  # contact, loading_run, stiffness_spectrum, rolling_run
        nx, ny = _elements(config, wildcards["surface"])
        m = nx * ny
        solver = config["solver"]
        dynamic = wildcards.get("mode") == "dynamic"
        output = 0.0
        if rule == "stiffness_spectrum":
            # a few quasi-static states, one solve per frequency for each of the relaxed and the
            # transient states, and the transient states' dynamic runs (d0 fs / v steps each)
            section = config.get("stiffness_spectrum", {})
            preloads = [float(d) for d in section.get("preloads", [5e-5, 1e-4, 1.5e-4, 2e-4])]
            speed = float(section.get("transient_speed", 0.1))
            fs = float(config["greens"]["sample_rate"])
            steps = 4 * len(preloads) + 160 + sum(math.ceil(d * fs / speed) + 1 for d in preloads)
            dynamic = True
        elif rule == "rolling_run":
            # a pass stores per-step sums and a few element maps only: its memory is the kernel's and
            # the FFT work arrays' (150 x 20 strip, 20 m/s, 2 threads: 0.4 GB peak, benchmarks/
            # bench_rolling.py; this model asks for 0.4 GB of the process plus head room). Run time: the
            # FFT step below gives 0.06 s per step on 1 thread for 150 x 20; measured 0.023-0.025 s per
            # step with 2 threads (10 s at 20 m/s, 44 s at 5 m/s, docs/rolling.md).
            steps = rolling_pass_steps(config, wildcards["surface"], wildcards["mode"], float(wildcards["speed"]))
            if config["rolling"].get("d0") is None:
                # with a wheel load: the static d0 search, then passes until the steady force is the load
                steps = _LOAD_PASSES * steps + _D0_SOLVE_STEPS
        elif rule == "loading_run":
            preset = LoadingPreset(wildcards["loading"], config["loadings"][wildcards["loading"]])
            _, d, _ = preset.path(wildcards["mode"], config["greens"]["sample_rate"], solver["quasistatic_step"])
            steps = d.size
        else:
            steps = run_steps(solver, config["greens"]["sample_rate"], wildcards["mode"], float(wildcards["accel"]))
        if rule != "rolling_run":
            output = steps * m * 8 * 6 / 1e6      # per-step, per-element variables of the result
        mem = _BASE_MB + 5 * _kernel_mb(config, rolling=rule == "rolling_run") + 3 * output
        if solver_path(config, m, steps, dynamic) == "fft":
            seconds = steps * 2e-5 * m            # s; 150 x 200, 1 thread, test cluster: 0.55 s (dynamic), 0.23 s (QS)
        else:
            seconds = steps * (1.2e-10 * m**3 + 1e-3)  # s, dense elimination over the loaded elements
            if dynamic:  # the offset-table history sum: m^2 products per kept lag reached
                seconds += 1.2e-9 * m * m * _lag_terms(steps, int(config["greens"]["n_lags"]))
            mem += 4 * m * m * 8 / 1e6            # dense Jacobian and its factors
    return {
        "mem_mb": int(math.ceil((_SNAKEMAKE_MB + 1.25 * mem) * attempt / 100.0) * 100),
        "runtime": int(math.ceil((_STARTUP_MIN + 3 * seconds / 60.0) * attempt)),
    }
