"""Bad configs stop `snakemake -n` (planning), with a message naming the key path or file, and touch nothing.

Each case is an overlay on config/config.yaml + config/test.yaml (plus, for some, extra files or a
target) that passed planning before issue 14 and failed inside a job, after Snakemake had removed
the job's previous result, or that was accepted silently, or that gave a weak message.

* Every case runs in-process through the planning checks exactly as workflow/rules/common.smk
  calls them (fast), and the first :data:`N_SNAKEMAKE` cases (at least 30, the issue's own cases
  first) and issue 24's (:data:`SNAKEMAKE_CASES`) also through a real `snakemake -n`, two at a time (about 3 s each), in one copy of the
  workflow that holds results trees of the default and the test study: both trees must be
  byte-identical afterwards.
* A few cases also run without -n (a real run): planning stops them before any job.
"""

from __future__ import annotations

import hashlib
import re
import subprocess
import sys
import textwrap
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import _synthetic
import xarray as xr

CONFIGS = ["config/config.yaml", "config/test.yaml"]
STEP = 1e-3 / 26  # the element grid step of the default surface [m]


def _scan(rng, n=(520, 520), pv=1.5e-3):
    """A plausible road-like height field [m]: smooth random bumps, peak to valley ``pv``."""
    h = rng.standard_normal(n)
    k = np.fft.rfft2(h)
    qx = np.fft.fftfreq(n[0])[:, None]
    qy = np.fft.rfftfreq(n[1])[None, :]
    k *= np.exp(-((qx**2 + qy**2) / 0.02**2))
    h = np.fft.irfft2(k, s=n)
    return (h - h.min()) / (h.max() - h.min()) * pv


def _file_preset(path, **kw):
    items = {"generator": "file", "path": path, "step": STEP, "patch_elements": [6, 6],
             "patch_selection": "centre", **kw}
    return "surfaces:\n  scan:\n" + "".join(f"    {k}: {v}\n" for k, v in items.items()) + "study:\n  surface: scan\n"


# (id, overlay YAML or None, extra target or None, expected text in the message)
CASES = [
    # --- measured in the issue: passed planning, failed in the job
    ("n_fft", "greens:\n  n_fft: 5000\n", None, "greens.n_fft"),
    ("n_lags", "greens:\n  n_lags: 3000\n", None, "greens.n_lags"),
    ("quasistatic-step", "solver:\n  quasistatic_step: 1.0e-3\n", None, "solver.quasistatic_step"),
    ("zeta-step", "springs:\n  zeta_step: 3.0e-7\n", None, "springs.zeta_step"),
    ("accel-labels", "study:\n  accelerations: [500, 500.0000001]\n", None, "study.accelerations[1]"),
    # --- measured: silently accepted
    ("scan-metres-as-mm", _file_preset("scans/metres.npy", height_unit="mm"), None, "metres.npy"),
    ("d-max-5mm", "solver:\n  d_max: 5.0e-3\n", None, "solver.d_max"),
    # --- measured: weak messages
    ("flat-scan", _file_preset("scans/flat.npy"), None, "flat.npy"),
    ("empty-npy", _file_preset("scans/empty.npy"), None, "empty.npy"),
    ("unknown-surface-target", None, "results-test/surface/foo.nc", "surface 'foo'"),
    ("scan-as-large-as-patch", _file_preset("scans/20mm.npy", step="5.0e-05", patch_elements="[20, 20]"), None,
     "surfaces.scan.patch_elements"),
    ("unknown-key", "solver:\n  tolerence: 1.0e-9\n", None, "solver.tolerence"),
    # --- others of the same kinds
    ("duplicate-key", "solver:\n  d_max: 1.0e-4\n  d_max: 2.0e-4\n", None, "duplicate key 'd_max'"),
    ("d-max-half-thickness", "materials:\n  tread:\n    thickness: 1.5e-4\n", None, "solver.d_max"),
    ("preset-underscore", "surfaces:\n  iso_x: {generator: iso10844}\n", None, "iso_x"),
    ("preset-dotdot", "materials:\n  '..': {base: tread}\n", None, "'..'"),
    ("study-unknown-material", "study:\n  materials: [tread, tread-eta0.5, tread-rho2, tread-x]\n", None,
     "study.materials[3]"),
    ("study-unknown-surface", "study:\n  surface: nowhere\n", None, "study.surface"),
    ("saturation-range", "study:\n  saturation_range: [1.0e-4, 6.0e-5]\n", None, "study.saturation_range"),
    ("indentation-step", "study:\n  indentation_step: 3.0e-6\n", None, "study.indentation_step"),
    ("accel-too-large", "study:\n  accelerations: [1.0e+9]\n", None, "study.accelerations[0]"),
    ("sample-rate-too-low", "greens:\n  sample_rate: 100.0\n", None, "study.accelerations[0]"),
    ("scan-missing", _file_preset("scans/nothere.npy"), None, "nothere.npy"),
    ("scan-3d", _file_preset("scans/cube.npy"), None, "cube.npy"),
    ("scan-truncated", _file_preset("scans/truncated.npy"), None, "truncated.npy"),
    ("scan-border-nan", _file_preset("scans/border.npy"), None, "border.npy"),
    ("scan-unknown-unit", _file_preset("scans/furlong.nc"), None, "furlong.nc"),
    ("scan-crop-outside", _file_preset("scans/metres.npy", crop="{origin: [0.015, 0.0], size: [0.01, 0.01]}"),
     None, "metres.npy"),
    ("scan-bad-format", _file_preset("scans/words.txt"), None, "words.txt"),
    ("results-dir-up", "results_dir: ../elsewhere\n", None, "results_dir"),
    ("yaml-exponent", "materials:\n  tread:\n    E0: 2.5e7\n", None, "materials.tread.E0"),
    ("poisson", "materials:\n  tread:\n    poisson_ratio: 0.5\n", None, "materials.tread.poisson_ratio"),
    ("quasistatic-with-accel", None, "results-test/contact/iso10844/tread/quasistatic_5.nc", "quasi-static"),
    ("unknown-material-target", None, "results-test/greens/nomat.nc", "material 'nomat'"),
    ("origin-outside-field", "surfaces:\n  iso10844:\n    origin: [0.099, 0.0]\n", None,
     "surfaces.iso10844.origin"),
    ("patch-larger-than-field", "surfaces:\n  iso10844:\n    patch_elements: [120, 6]\n", None,
     "surfaces.iso10844.patch_elements"),
    ("case-collision", "materials:\n  Tread: {base: tread, loss_scale: 0.5}\n", None, "materials.Tread"),
    ("element-size-mismatch", "surfaces:\n  coarse: {generator: iso10844, element_size: 2.0e-3, patch_elements: [6, 6]}\n",
     "results-test/contact/coarse/tread/dynamic_500.nc", "element_size"),
    ("fraction-range", "surfaces:\n  iso10844:\n    target_fraction: 0.9\n", None, "surfaces.iso10844"),
    ("spectral-cutoff", "surfaces:\n  spec: {generator: spectral, short_cutoff: 0.2, patch_elements: [6, 6]}\n",
     None, "surfaces.spec.short_cutoff"),
    ("table-precision", "springs:\n  table_precision: float16\n", None, "springs.table_precision"),
    ("springs-rheology", "springs:\n  rheology: visco\n", None, "springs.rheology"),
    ("qlv-modulus", "springs:\n  rheology: qlv\n  modulus: 3.0e+7\n", None, "springs.rheology"),
    # --- issue 24: a seed (constant-|E|, not causal) loss variant in a time-domain stage; a non-passive one
    ("seed-variant-study", "materials:\n  tread-eta0.5: {base: tread, loss_scale: 0.5, loss_anchor: null}\n", None,
     "study.materials[1] = 'tread-eta0.5'"),
    ("seed-variant-loading", "study:\n  loadings:\n    cycle: [tread, tread-eta1.5-seed]\n", None,
     "study.loadings.cycle[1] = 'tread-eta1.5-seed'"),
    ("seed-variant-claim6", "study:\n  claim6:\n    anchor_variants: [tread-eta0.5-seed]\n", None,
     "study.claim6.anchor_variants[0]"),
    ("seed-variant-sweep", "sensitivity:\n  points:\n    lowloss: {material: {loss_scale: 0.3, loss_anchor: null}}\n",
     None, "sensitivity.points.lowloss.material"),
    ("seed-variant-target", None, "results-test/contact/iso10844/tread-eta1.5-seed/dynamic_500.nc",
     "'tread-eta1.5-seed'"),
    ("causal-not-passive", "materials:\n  tread-eta0.5: {base: tread, loss_scale: 4.5, loss_anchor: 1000.0}\n", None,
     "materials.tread-eta0.5.loss_scale"),
]

#: The issue-24 cases: the message also names the causal alternative.
SEED_CASES = ("seed-variant-study", "seed-variant-loading", "seed-variant-claim6", "seed-variant-sweep",
              "seed-variant-target")

#: The first N_SNAKEMAKE cases also run through a real `snakemake -n`.
N_SNAKEMAKE = 32
#: The cases that run through a real `snakemake -n`: the first N_SNAKEMAKE and issue 24's.
SNAKEMAKE_CASES = CASES[:N_SNAKEMAKE] + [c for c in CASES if c[0] in SEED_CASES + ("causal-not-passive",)]
#: Cases also run for real (no -n): planning must stop them before any job.
REAL_RUNS = {"n_fft", "accel-labels"}


def _write_scans(scans: Path) -> None:
    rng = np.random.default_rng(14)
    scans.mkdir()
    h = _scan(rng)
    np.save(scans / "metres.npy", h)  # metres, declared as mm in the case above
    np.save(scans / "flat.npy", np.full((520, 520), 2.5e-4))
    (scans / "empty.npy").write_bytes(b"")
    np.save(scans / "20mm.npy", _scan(rng, n=(400, 400)))  # 400 x 50 um = 20 mm, spans 19.95 mm
    np.save(scans / "cube.npy", np.zeros((4, 4, 4)))
    np.save(scans / "truncated.npy", h)
    data = (scans / "truncated.npy").read_bytes()
    (scans / "truncated.npy").write_bytes(data[: len(data) // 2])
    b = h.copy()
    b[:12] = np.nan
    np.save(scans / "border.npy", b)
    xr.Dataset({"z": (("x", "y"), h, {"units": "furlong"})}).to_netcdf(scans / "furlong.nc")
    (scans / "words.txt").write_text("height map exported by hand\nsee attached\n")


def _fake_tree(root: Path, folder: str) -> None:
    """A results tree as left by a completed study (content: random bytes, it is only compared)."""
    rng = np.random.default_rng(len(folder))
    for rel in ("surface/iso10844.nc", "greens/tread.nc", "springs/iso10844/tread.nc",
                "contact/iso10844/tread/dynamic_500.nc", "contact/iso10844/tread/quasistatic_0.nc",
                "study.nc", "report.md", "figures/fig5_force.png", "logs/greens/tread.log"):
        path = root / folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(rng.bytes(256))


def _digest(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for folder in ("results", "results-test")
        for p in sorted((root / folder).rglob("*"))
        if p.is_file()
    }


def _run(workdir: Path, case, dry=True):
    cid, overlay, target, _ = case
    args = [sys.executable, "-m", "snakemake", "-j1", "--configfile", *CONFIGS]
    if overlay is not None:
        path = workdir / f"bad-{cid}.yaml"
        path.write_text(overlay)
        args.append(path.name)
    if dry:
        args.append("-n")
    if target is not None:
        args.append(target)
    proc = subprocess.run(args, cwd=workdir, capture_output=True, text=True)
    return proc.returncode, proc.stdout + proc.stderr


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    wd = tmp_path_factory.mktemp("bad")
    _synthetic.copy_workflow(wd)
    _write_scans(wd / "scans")
    _fake_tree(wd, "results")
    _fake_tree(wd, "results-test")
    return wd


@pytest.fixture(scope="module")
def outcomes(workdir):
    """Run the snakemake cases (two at a time); the results trees are compared before and after."""
    before = _digest(workdir)
    cases = SNAKEMAKE_CASES
    real = [c for c in CASES if c[0] in REAL_RUNS]
    with ThreadPoolExecutor(max_workers=2) as pool:
        dry = dict(zip([c[0] for c in cases], pool.map(lambda c: _run(workdir, c), cases)))
        ran = dict(zip([c[0] for c in real], pool.map(lambda c: _run(workdir, c, dry=False), real)))
    return {"dry": dry, "real": ran, "before": before, "after": _digest(workdir)}


_TARGETS = [
    (r"surface/(?P<surface>[^/]+)\.nc", "prepare_surface"),
    (r"greens/(?P<material>[^/]+)\.nc", "greens"),
    (r"springs/(?P<surface>[^/]+)/(?P<material>[^/]+)\.nc", "element_springs"),
    (r"contact/(?P<surface>[^/]+)/(?P<material>[^/]+)/(?P<mode>dynamic|quasistatic)_(?P<accel>[^/]+)\.nc", "contact"),
]


def _plan_in_process(workdir: Path, case) -> str:
    """What common.smk (and sensitivity.smk) do at planning time, plus check_job for a target; returns the error message."""
    from snakemake.utils import validate

    from tyreroad import config as C

    cid, overlay, target, _ = case
    paths = [workdir / p for p in CONFIGS]
    if overlay is not None:
        (workdir / f"inproc-{cid}.yaml").write_text(overlay)
        paths.append(workdir / f"inproc-{cid}.yaml")
    try:
        cfg = C.load_config(*paths)
        C.validate_schema(cfg, workdir / "workflow/schemas/config.schema.yaml")
        validate(cfg, str(workdir / "workflow/schemas/config.schema.yaml"))
        C.check_config(cfg, base_dir=workdir)
        C.sensitivity_points(cfg, workdir / "workflow/schemas/config.schema.yaml")  # as workflow/rules/sensitivity.smk
        if target is not None:
            rel = target.split("/", 1)[1]
            for pattern, _rule in _TARGETS:
                m = re.fullmatch(pattern, rel)
                if m:
                    C.check_job(cfg, target, m.groupdict())
    except C.ConfigError as exc:
        return str(exc)
    return ""


def test_there_are_at_least_30_snakemake_cases():
    assert len({c[0] for c in CASES}) == len(CASES)
    assert len(CASES[:N_SNAKEMAKE]) >= 30


def test_the_good_config_plans(workdir):
    code, out = _run(workdir, ("good", None, None, ""))
    assert code == 0, out[-2000:]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_planning_checks_name_the_key(workdir, case):
    msg = _plan_in_process(workdir, case)
    assert case[3] in msg, msg
    assert "\n" not in msg.strip() and len(msg) < 600, msg  # one short paragraph


def _error_section(out: str) -> list[str]:
    """The lines of Snakemake's output after its banner, without traceback 'File' lines."""
    lines = out.splitlines()
    for marker in ("Building DAG of jobs...", "  Config MD5"):
        idx = [i for i, line in enumerate(lines) if line.startswith(marker)]
        if idx:
            lines = lines[idx[-1] + 1 :]
            break
    return [line for line in lines if not line.strip().startswith("File ") and line.strip()]


@pytest.mark.parametrize("case", SNAKEMAKE_CASES, ids=[c[0] for c in SNAKEMAKE_CASES])
def test_snakemake_n_stops_with_a_clear_message(outcomes, case):
    code, out = outcomes["dry"][case[0]]
    assert code != 0, out[-2000:]
    section = _error_section(out)
    assert "Traceback (most recent call last)" not in out
    # one short paragraph, not a schema dump: the key is in the first lines of the error
    assert any(case[3] in line for line in section[:4]), out[-3000:]
    assert len(section) <= 10, out[-3000:]


@pytest.mark.parametrize("cid", sorted(REAL_RUNS))
def test_real_run_stops_before_any_job(outcomes, cid):
    code, out = outcomes["real"][cid]
    assert code != 0
    assert "Building DAG" not in out and "rule " not in out, out[-2000:]


def test_results_trees_are_untouched(outcomes):
    assert outcomes["before"] and outcomes["after"] == outcomes["before"]


def test_duplicate_key_names_the_file(outcomes):
    _, out = outcomes["dry"]["duplicate-key"]
    assert "bad-duplicate-key.yaml, line 3: duplicate key 'd_max'" in out


def test_unit_message_names_the_suspected_unit(workdir):
    msg = _plan_in_process(workdir, next(c for c in CASES if c[0] == "scan-metres-as-mm"))
    assert re.search(r"look like m \(set height_unit: m, giving 1\.\d+ mm\)", msg), msg


def test_border_nan_message_suggests_a_crop_window(workdir):
    msg = _plan_in_process(workdir, next(c for c in CASES if c[0] == "scan-border-nan"))
    # rows 0-11 are NaN: the largest NaN-free window starts at x = 12 steps and is 508 x 520 samples
    assert f"crop: {{origin: [{12 * STEP:.6g}, 0], size: [{508 * STEP:.6g}, {520 * STEP:.6g}]}}" in msg, msg


@pytest.mark.parametrize("cid", SEED_CASES)
def test_a_seed_variant_in_the_time_domain_names_the_causal_alternative(outcomes, cid):
    """snakemake -n stops with the key, the material and the alternative `loss_anchor: ...` (issue 24)."""
    code, out = outcomes["dry"][cid]
    assert code != 0
    section = " ".join(_error_section(out)[:4])
    assert "not causal" in section and ".loss_anchor: 1000.0" in section, out[-3000:]
