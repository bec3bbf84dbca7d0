"""Memory and run-time requests of the workflow's cluster jobs, from the config.

The rules' ``resources:`` call :func:`job_resources`; a SLURM run (``profiles/slurm``) turns them
into ``sbatch --mem`` and ``--time``. The estimates scale with what drives the cost of each stage
(patch size, scan samples, Green's-function lags, run length in steps) and are calibrated on the
measured peaks of the stage's own process (``results/benchmarks/`` of the paper's study, 20 x 20:
0.20-0.33 GB; jobs of ``config/footprint.yaml`` on the test cluster of tests/slurm, 150 x 200:
surface 2.4 GB, springs 1.4 GB, Green's functions 1.6 GB, contact 1.6-1.8 GB), with head room:
1.25x on memory and 3x on run time. On top come the
two Snakemake processes of every SLURM job (the batch step and the job step that runs the rule:
~0.2 GB each, measured with sacct on the test cluster, where a 20 x 20 contact job peaked at
0.19 + 0.45 GB) and a fixed start-up time (interpreter, imports, a numba cache that may have to
be compiled on the node). A retried job (Snakemake ``attempt`` 2, 3, ...) asks for
``attempt`` times as much.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

__all__ = ["CLUSTER_RULES", "job_resources", "run_steps"]

#: Rules that run as cluster jobs (the others are ``localrules``).
CLUSTER_RULES = ("prepare_surface", "element_springs", "greens", "contact", "loading_run", "stiffness_spectrum")

_BASE_MB = 280.0          # MB, a stage's process: interpreter, numpy/scipy/numba/xarray, small arrays
_SNAKEMAKE_MB = 400.0     # MB, the job's two Snakemake processes (batch step, job step)
_STARTUP_MIN = 5.0        # min, interpreter start, imports, possibly a cold numba compile
_FFT_ABOVE = 400          # elements; solver.method 'auto' switches to the FFT path above this
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
        Steps from first contact to ``d_max``, both ends included: ``d_max / quasistatic_step + 1``
        (quasi-static) or ``ceil(sqrt(2 d_max / accel) * sample_rate) + 1`` (dynamic, constant
        acceleration from rest, time step ``1 / sample_rate``).
    """
    d_max = float(solver["d_max"])
    if mode == "quasistatic":
        return _ceil(d_max / float(solver["quasistatic_step"])) + 1
    if mode != "dynamic":
        raise ValueError(f"mode: expected 'dynamic' or 'quasistatic', got {mode!r}")
    if not float(accel) > 0:
        raise ValueError(f"accel: expected a positive acceleration [m/s^2], got {accel!r}")
    return _ceil(math.sqrt(2.0 * d_max / float(accel)) * float(sample_rate)) + 1


def _ceil(x: float) -> int:
    """Ceiling that ignores round-off above an integer (2.5e-4 / 1e-6 is 250.00000000000003)."""
    return int(math.ceil(x - 1e-9 * max(1.0, abs(x))))


def _elements(config: Mapping[str, Any], surface: str) -> tuple[int, int]:
    nx, ny = config["surfaces"][surface]["patch_elements"]
    return int(nx), int(ny)


def _greens_elements(config: Mapping[str, Any]) -> tuple[int, int]:
    """The Green's tables cover the largest configured patch (see the workflow's max_patch_elements);
    the rolling strips (rolling.surfaces) have their own Green's functions and do not count."""
    strips = set(config["rolling"].get("surfaces", ["iso10844-strip"])) if "rolling" in config else set()
    sizes = [_elements(config, name) for name in config["surfaces"] if name not in strips] or [
        _elements(config, name) for name in config["surfaces"]]
    return max(s[0] for s in sizes), max(s[1] for s in sizes)


def _kernel_mb(config: Mapping[str, Any]) -> float:
    """Size of one time-domain kernel table g[dx, dy, lag] [MB]."""
    nx, ny = _greens_elements(config)
    return (2 * nx - 1) * (2 * ny - 1) * int(config["greens"]["n_lags"]) * 8 / 1e6


def _field_mb(spec: Mapping[str, Any], patch_only: bool = False) -> float:
    """Size of one height array of a surface's generated field (or of its patch) [MB]."""
    nx, ny = spec["patch_elements"]
    per_element = int(spec.get("samples_per_element", 26))
    size = float(spec.get("element_size", 1.0e-3))
    field = [0.0, 0.0] if patch_only else (spec.get("field_size") or [_DEFAULT_FIELD, _DEFAULT_FIELD])
    samples = [max(n * per_element, math.ceil(f / size * per_element)) for n, f in zip((nx, ny), field)]
    return samples[0] * samples[1] * 8 / 1e6


def _uses_fft(solver: Mapping[str, Any], elements: int) -> bool:
    method = solver.get("method", "auto")
    return method == "fft" or (method == "auto" and elements > _FFT_ABOVE)


def job_resources(rule: str, config: Mapping[str, Any], wildcards: Mapping[str, Any], attempt: int = 1) -> dict[str, int]:
    """Memory and run time to request for one cluster job.

    Parameters
    ----------
    rule : str
        One of :data:`CLUSTER_RULES`.
    config : mapping
        The validated workflow config.
    wildcards : mapping
        The job's wildcards (``surface``; ``mode``, ``accel`` for ``contact``).
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
    elif rule == "greens":
        kernel = _kernel_mb(config)
        n_fft_scale = int(config["greens"]["n_fft"]) / 4096
        # 150 x 200 on the test cluster: 1.6 GB and 111 s for a 244 MB table
        mem = _BASE_MB + 6 * kernel * max(1.0, n_fft_scale)
        seconds = 0.5 * kernel * n_fft_scale + 10
    else:  # contact, loading_run
        nx, ny = _elements(config, wildcards["surface"])
        m = nx * ny
        solver = config["solver"]
        if rule == "stiffness_spectrum":  # a few quasi-static states and one solve per frequency
            steps = 4 * len(config.get("stiffness_spectrum", {}).get("preloads", [0] * 4)) + 80
        elif rule == "loading_run":
            from .loading import LoadingPreset

            preset = LoadingPreset(wildcards["loading"], config["loadings"][wildcards["loading"]])
            _, d, _ = preset.path(wildcards["mode"], config["greens"]["sample_rate"], solver["quasistatic_step"])
            steps = d.size
        else:
            steps = run_steps(solver, config["greens"]["sample_rate"], wildcards["mode"], float(wildcards["accel"]))
        output = steps * m * 8 * 6 / 1e6          # per-step, per-element variables of the result
        mem = _BASE_MB + 5 * _kernel_mb(config) + 3 * output
        if _uses_fft(solver, m):
            per_step = 2e-5 * m                   # s; 150 x 200, 1 thread, test cluster: 0.55 s (dynamic), 0.23 s (QS)
        else:
            per_step = 1.2e-10 * m**3 + 1e-3      # s, dense elimination over the loaded elements
            mem += 4 * m * m * 8 / 1e6            # dense Jacobian and its factors
        seconds = steps * per_step
    return {
        "mem_mb": int(math.ceil((_SNAKEMAKE_MB + 1.25 * mem) * attempt / 100.0) * 100),
        "runtime": int(math.ceil((_STARTUP_MIN + 3 * seconds / 60.0) * attempt)),
    }
