"""Config validation: the JSON schema and the cross-reference checks, before any job runs."""

import copy
import dataclasses
import subprocess
import sys
from pathlib import Path

import pytest

import _synthetic
import yaml
from snakemake.utils import validate

from tyreroad import config as C
from tyreroad import provenance as P
from tyreroad.config import ConfigError, check_references, load_config, merge
from tyreroad.greens import GreensSettings
from tyreroad.material import material_from_config
from tyreroad.solver import SolverSettings
from tyreroad.springs import SpringModel

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = str(ROOT / "workflow" / "schemas" / "config.schema.yaml")


@pytest.fixture(scope="module")
def config():
    return load_config(ROOT / "config" / "config.yaml")


def _validate(cfg):
    validate(copy.deepcopy(cfg), SCHEMA)


def test_default_and_test_configs_are_valid(config):
    _validate(config)
    check_references(config)
    for name in ("test.yaml", "footprint.yaml"):
        overlay = load_config(ROOT / "config" / "config.yaml", ROOT / "config" / name)
        _validate(overlay)
        check_references(overlay)


@pytest.mark.parametrize(
    "mutate, expected",
    [
        (lambda c: c["solver"].update(tolerence=1e-9), "tolerence"),
        (lambda c: c["surfaces"]["iso10844"].update(element_size=-1e-3), "element_size"),
        (lambda c: c["greens"].update(sample_rate="fast"), "sample_rate"),
        (lambda c: c["materials"]["tread"].update(poisson_ratio=0.5), "poisson_ratio"),
        (lambda c: c["study"].update(accelerations=[500, -50]), "accelerations"),
        (lambda c: c.update(extra_section={}), "extra_section"),
    ],
)
def test_schema_rejects_bad_values_naming_the_key(config, mutate, expected):
    cfg = copy.deepcopy(config)
    mutate(cfg)
    with pytest.raises(Exception, match=expected):
        _validate(cfg)


def test_yaml_exponent_without_sign_is_caught_as_a_string(config):
    cfg = copy.deepcopy(config)
    cfg["materials"]["tread"]["E0"] = yaml.safe_load("x: 2.2e7")["x"]  # PyYAML reads this as the string '2.2e7'
    with pytest.raises(Exception, match="E0"):
        _validate(cfg)


@pytest.mark.parametrize(
    "mutate, expected",
    [
        (lambda c: c["study"].update(surface="nowhere"), "study.surface"),
        (lambda c: c["study"]["materials"].append("tread-x"), r"study.materials\[5\]"),
        (lambda c: c["materials"].update({"tread-y": {"base": "missing"}}), "materials.tread-y.base"),
        (lambda c: c["study"].update(saturation_range=[2e-4, 1e-4]), "saturation_range"),
    ],
)
def test_cross_references_are_checked(config, mutate, expected):
    cfg = copy.deepcopy(config)
    mutate(cfg)
    with pytest.raises(ConfigError, match=expected):
        check_references(cfg)


def test_merge_is_recursive_and_replaces_lists():
    base = {"a": {"x": 1, "y": [1, 2]}, "b": 2}
    out = merge(base, {"a": {"y": [3]}, "c": 4})
    assert out == {"a": {"x": 1, "y": [3]}, "b": 2, "c": 4}
    assert base["a"]["y"] == [1, 2]


def test_bad_config_stops_snakemake_before_any_job(tmp_path):
    _synthetic.copy_workflow(tmp_path)
    bad = tmp_path / "bad.yaml"
    bad.write_text("surfaces:\n  iso10844:\n    element_size: -0.001\n")
    proc = subprocess.run(
        [sys.executable, "-m", "snakemake", "-n", "-j1", "--configfile", "config/config.yaml", str(bad)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
    )
    assert proc.returncode != 0
    assert "element_size" in proc.stdout + proc.stderr
    assert not (tmp_path / "results").exists()


@pytest.mark.parametrize("section, cls", [("solver", SolverSettings), ("greens", GreensSettings),
                                          ("springs", SpringModel)])
def test_schema_defaults_are_the_package_defaults(config, section, cls):
    """Each default of these sections has one value: the schema states the settings class's own.

    Snakemake inserts the schema's defaults into the config; a section given empty must build the
    same settings as the class's defaults (1e-5 m for solver.quasistatic_step, say).
    """
    props = yaml.safe_load(Path(SCHEMA).read_text())["properties"][section]["properties"]
    fields = {f.name: f.default for f in dataclasses.fields(cls)}
    assert set(props) == set(fields)
    assert {k: v.get("default") for k, v in props.items()} == fields
    cfg = copy.deepcopy(config)
    cfg[section] = {}
    validate(cfg, SCHEMA)
    assert cfg[section] == fields
    assert cls.from_config(cfg[section]) == cls()


def test_default_study_settings_build_from_the_validated_config(config):
    cfg = copy.deepcopy(config)
    validate(cfg, SCHEMA)
    solver = SolverSettings.from_config(cfg["solver"])
    assert solver.quasistatic_step == 1e-5 and solver.d_max == 2.5e-4
    assert GreensSettings.from_config(cfg["greens"]).n_lags == 256
    assert SpringModel.from_config(cfg["springs"]).zeta_step == 1e-6
    assert [material_from_config(name, cfg["materials"]).thickness for name in cfg["materials"]] == [0.01] * len(cfg["materials"])


def test_planning_takes_the_quasistatic_step_default_from_the_solver():
    """Without solver.quasistatic_step, the grid check uses SolverSettings' 1e-5 m: d_max = 8e-6 m is
    less than one step (the 1e-6 m that config.py used to assume would have let it through)."""
    cfg = load_config(ROOT / "config" / "config.yaml")
    cfg["solver"] = {"d_max": 8.0e-6}
    with pytest.raises(ConfigError, match=r"^solver\.quasistatic_step = 1e-05: expected at most solver\.d_max / 2"):
        C._check_solver_and_study(cfg)
    cfg["solver"]["quasistatic_step"] = 4.0e-6  # 0, 4e-6, 8e-6: the 3 points a run needs
    with pytest.raises(ConfigError, match=r"^study"):  # passes the grid check, fails on the study's own range
        C._check_solver_and_study(cfg)


def test_duplicate_key_is_an_error_naming_key_file_and_line(tmp_path):
    f = tmp_path / "dup.yaml"
    f.write_text("solver:\n  d_max: 1.0e-4\n  tolerance: 1.0e-12\n  d_max: 2.0e-4\n")
    with pytest.raises(ConfigError, match=r"dup\.yaml, line 4: duplicate key 'd_max' \(first given on line 2\)"):
        load_config(f)


def test_schema_error_is_one_paragraph_with_the_key_path(config):
    cfg = copy.deepcopy(config)
    cfg["solver"]["tolerence"] = 1e-9
    with pytest.raises(ConfigError) as err:
        C.validate_schema(cfg, SCHEMA)
    msg = str(err.value)
    assert msg.startswith("solver.tolerence: unknown key; did you mean 'tolerance'? expected one of: d_max, krylov_forcing, long_memory, max_iterations")
    assert "\n" not in msg and len(msg) < 300
    cfg = copy.deepcopy(config)
    cfg["surfaces"]["iso10844"]["element_size"] = -1e-3
    with pytest.raises(ConfigError, match=r"^surfaces\.iso10844\.element_size = -0\.001: .*Lateral size c of one contact element \[m\]"):
        C.validate_schema(cfg, SCHEMA)


def test_default_configs_pass_every_planning_check(config):
    for names in (["config.yaml"], ["config.yaml", "test.yaml"], ["config.yaml", "footprint.yaml"]):
        cfg = load_config(*(ROOT / "config" / n for n in names))
        C.validate_schema(cfg, SCHEMA)
        validate(cfg, SCHEMA)
        C.check_config(cfg, base_dir=ROOT)


def test_overlays_write_to_their_own_results_dirs():
    dirs = {n: load_config(ROOT / "config" / "config.yaml", *([ROOT / "config" / n] if n != "config.yaml" else []))["results_dir"]
            for n in ("config.yaml", "test.yaml", "footprint.yaml")}
    assert dirs == {"config.yaml": "results", "test.yaml": "results-test", "footprint.yaml": "results-footprint"}


# the sensitivity sweep's adapters call tyreroad.sensitivity directly, not a pipeline.run_* function
@pytest.mark.parametrize("stage", sorted(set(P.STAGE_MODULES) - {"sensitivity"}))
def test_stage_map_covers_what_the_stage_function_imports(stage):
    """Every module a pipeline.run_<stage> function imports is an entry of STAGE_MODULES[stage]."""
    import ast

    tree = ast.parse((ROOT / "tyreroad" / "pipeline.py").read_text())
    fn = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == f"run_{stage}")
    helpers = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    imported, todo, seen = set(), [fn], set()
    while todo:  # the function and the module-level helpers it calls
        node = todo.pop()
        if node.name in seen:
            continue
        seen.add(node.name)
        for sub in ast.walk(node):
            if isinstance(sub, ast.ImportFrom) and sub.level == 1 and sub.module:
                imported.add(sub.module)
            elif isinstance(sub, ast.Call) and isinstance(sub.func, ast.Name) and sub.func.id in helpers:
                todo.append(helpers[sub.func.id])
    assert imported and imported <= set(P.stage_modules(stage)), imported - set(P.stage_modules(stage))


def test_stage_modules_follow_imports_and_hash_the_source(tmp_path):
    import shutil

    assert set(P.stage_modules("prepare_surface")) >= {"surface", "texture", "scans", "io", "pipeline"}
    assert "greens" not in P.stage_modules("prepare_surface")
    assert {"greens", "layer", "material", "reference.love"} <= set(P.stage_modules("greens"))
    assert "greens" not in P.stage_modules("contact")  # contact reads the greens file, not the code
    pkg = tmp_path / "tyreroad"
    shutil.copytree(ROOT / "tyreroad", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    before = {s: P.source_hash(s, pkg) for s in P.STAGE_MODULES}
    assert before == {s: P.source_hash(s) for s in P.STAGE_MODULES}  # the location does not matter
    (pkg / "greens.py").write_text((pkg / "greens.py").read_text() + "\n# a change\n")
    after = {s: P.source_hash(s, pkg) for s in P.STAGE_MODULES}
    # the sweep computes its points' Green's functions itself; K*(f) evaluates the element FRF (greens.ElementFRF),
    # and the report and figure 9 read its settings from tyreroad.stiffness, which imports it; claim 6's seed
    # variants get their K* from the element FRF too; the belt's mobility is the element FRF plus the belt's part;
    # the pattern's block tables come from the FE model (fe_pattern, whose flat-layer checks use the layer kernel)
    # and its K*(f) slick reference is the element FRF, as do its modal forms (pattern_modes); the pattern's runs
    # (static and dynamic) and studies are not
    assert {s for s in before if before[s] != after[s]} == {"greens", "sensitivity", "stiffness_spectrum", "report",
                                                            "stiffness_figure", "claim6", "belt_mobility",
                                                            "pattern_greens", "pattern_stiffness_spectrum",
                                                            "pattern_modes"}
    (pkg / "io.py").write_text((pkg / "io.py").read_text() + "\n# a change\n")
    assert all(P.source_hash(s, pkg) != after[s] for s in P.STAGE_MODULES)  # every stage writes through io


def test_a_stage_entry_naming_a_subpackage_hashes_all_its_modules(tmp_path):
    """The rolling package (tyreroad/rolling/): every module of the folder is code of the rolling stages,
    also one that its __init__ does not import; an imported subpackage (plots) is not expanded."""
    import shutil

    pkg = tmp_path / "tyreroad"
    shutil.copytree(ROOT / "tyreroad", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    assert "plots.study" not in P.stage_modules("rolling_figures", pkg)  # plots.rolling only, not its siblings
    (pkg / "rolling" / "spare.py").write_text('"""Not imported by rolling/__init__.py."""\nX = 1\n')
    mods = P.stage_modules("rolling", pkg)
    assert {"rolling", "rolling.spare", "contact"} <= set(mods)
    assert "rolling/spare.py" in P.stage_files("rolling", pkg)
    before = {s: P.source_hash(s, pkg) for s in P.STAGE_MODULES}
    (pkg / "rolling" / "spare.py").write_text('"""Not imported by rolling/__init__.py."""\nX = 2\n')
    after = {s: P.source_hash(s, pkg) for s in P.STAGE_MODULES}
    changed = {s for s in before if before[s] != after[s]}
    # the rolling report section lives in tyreroad.report: the report of a pass does not run the pass's code
    assert changed == {"rolling", "rolling_study"}


def _validated(*overlays):
    cfg = load_config(ROOT / "config" / "config.yaml")
    for overlay in overlays:
        cfg = merge(cfg, overlay)
    validate(cfg, SCHEMA)
    return cfg


def test_stiffness_spectrum_is_checked_with_the_config():
    """Moved from workflow/rules/stiffness.smk: the section and its grid below fs / 2."""
    C._check_stiffness_spectrum(_validated())
    with pytest.raises(ConfigError, match=r"^stiffness_spectrum: frequency grid: f_min = 30000 Hz must be below "
                                          r"f_max = fs/2 = 25600 Hz"):
        C.check_config(_validated({"stiffness_spectrum": {"f_min": 3.0e4}}), ROOT)  # fs = 51200 Hz
    with pytest.raises(ConfigError, match=r"^stiffness_spectrum\.figure_preload: expected one of the preloads"):
        C._check_stiffness_spectrum(_validated({"stiffness_spectrum": {"figure_preload": 3.3e-5}}))


def test_sensitivity_points_are_checked_and_returned():
    """Moved from workflow/rules/sensitivity.smk: the section, each point's material and surface."""
    cfg = _validated()
    points = C.sensitivity_points(cfg, SCHEMA)
    assert len(points) == 10 and points["seed2"]["surface"] == {"seed": 20140102}
    assert C.sensitivity_points({k: v for k, v in cfg.items() if k != "sensitivity"}, SCHEMA) == {}
    bad_surface = copy.deepcopy(cfg)
    bad_surface["sensitivity"]["points"]["seed2"]["surface"] = {"seed": -3}
    with pytest.raises(ConfigError, match=r"^sensitivity\.points\.seed2\.surface\.seed = -3: "):
        C.sensitivity_points(bad_surface, SCHEMA)
    unknown = copy.deepcopy(cfg)
    unknown["sensitivity"]["points"]["seed2"]["surface"] = {"sead": 1}
    with pytest.raises(ConfigError, match=r"^sensitivity\.points\.seed2\.surface\.sead: unknown key; did you mean 'seed'"):
        C.sensitivity_points(unknown, SCHEMA)
    bad_material = copy.deepcopy(cfg)
    bad_material["sensitivity"]["points"]["alpha0.4"]["material"] = {"alpha": 1.5}
    with pytest.raises(ConfigError, match=r"^sensitivity\.points\.alpha0\.4\.material"):
        C.sensitivity_points(bad_material, SCHEMA)


def test_rolling_materials_default_to_the_study_and_its_first():
    cfg = _validated()
    assert C.rolling_materials(cfg) == (cfg["rolling"]["materials"], "tread")
    del cfg["rolling"]["materials"], cfg["rolling"]["reference_material"]
    assert C.rolling_materials(cfg) == (cfg["study"]["materials"], cfg["study"]["materials"][0])
    # the schema's defaults of the study keys are inserted by validation (common.smk reads them)
    flat = _validated({"rolling": {"surfaces": ["iso10844-strip"], "speeds": [5, 20]}})
    flat["rolling"].pop("quasistatic_speeds")
    validate(flat, SCHEMA)
    assert flat["rolling"]["quasistatic_speeds"] == [5, 30]


# --------------------------------------------------------------------------------------------
# Every overlay under config/ runs as shipped
# --------------------------------------------------------------------------------------------
#: The targets each shipped overlay documents (its header's snakemake command); () is the default target.
OVERLAY_TARGETS = {"test.yaml": (), "footprint.yaml": (), "rolling-flat.yaml": ("rolling",), "springs-qlv.yaml": (),
                   "compound-temperature.yaml": (), "rolling-narrow.yaml": ("rolling",), "rolling-qlv.yaml": ("rolling",)}
#: Overlays documented on top of others (their header's command): those come first.
OVERLAY_BASES = {"rolling-qlv.yaml": ("rolling-narrow.yaml",)}
_SURFACES_DONE: dict = {}  # surface specs already run, across overlays (YAML text -> heights)


def test_every_shipped_overlay_is_covered():
    shipped = {p.name for p in (ROOT / "config").glob("*.yaml")} - {"config.yaml"}
    assert shipped == set(OVERLAY_TARGETS)


@pytest.mark.parametrize("overlay", sorted(OVERLAY_TARGETS))
def test_every_shipped_overlay_runs_its_surfaces_and_plans_the_rest(overlay, tmp_path):
    """Each overlay's surface presets run through the surface stage as the validated config gives
    them (schema defaults filled in, as Snakemake does), and its documented target plans."""
    from tyreroad.surface import prepare_surface

    files = [*OVERLAY_BASES.get(overlay, ()), overlay]
    cfg = load_config(ROOT / "config" / "config.yaml", *(ROOT / "config" / f for f in files))
    validate(cfg, SCHEMA)  # fills in the schema's defaults, as the workflow does
    used = {cfg["study"]["surface"]}
    if "rolling" in OVERLAY_TARGETS[overlay]:
        used |= set(cfg["rolling"]["surfaces"])
    for name in sorted(used):
        key = yaml.safe_dump(cfg["surfaces"][name], sort_keys=True)
        if key not in _SURFACES_DONE:
            ds = prepare_surface(name, cfg["surfaces"][name])
            _SURFACES_DONE[key] = ds["z1"].shape
        nx, ny = cfg["surfaces"][name]["patch_elements"]
        assert _SURFACES_DONE[key] == (nx, ny), name
    _synthetic.copy_workflow(tmp_path)
    # targets before --configfile: its list of files would take them for config files
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-n", "-j2", *OVERLAY_TARGETS[overlay],
                           "--configfile", "config/config.yaml", *(f"config/{f}" for f in files)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert "prepare_surface" in proc.stdout + proc.stderr


# --------------------------------------------------------------------------------------------
# causal loss variants in the time domain (issue 24)
# --------------------------------------------------------------------------------------------
def _planned(cfg):
    cfg = copy.deepcopy(cfg)
    validate(cfg, SCHEMA)
    C.check_config(cfg)
    C.sensitivity_points(cfg, SCHEMA)
    return cfg


@pytest.mark.parametrize("overlay", [None, "test.yaml", "footprint.yaml"])
def test_every_material_reaching_a_time_domain_run_is_causal(overlay):
    """Every material of the shipped configs that a time-domain stage runs is causal, and the seed's
    constant-|E| variants the default config keeps reach no time-domain stage."""
    from tyreroad.sensitivity import SensitivitySettings, loss_variant_preset, point_material_preset, scale_moduli

    files = [ROOT / "config" / "config.yaml"] + ([ROOT / "config" / overlay] if overlay else [])
    cfg = _planned(load_config(*files))
    mats = cfg["materials"]
    used = C.time_domain_materials(cfg)
    names = {m for _, m, _ in used}
    assert {"tread-eta0.5", "tread-eta1.5"} <= names or overlay
    for key, name, _ in used:
        assert material_from_config(name, mats).is_causal, key
    seeds = {n for n in mats if not material_from_config(n, mats).is_causal}
    assert seeds == {"tread-eta0.5-seed", "tread-eta1.5-seed"}
    assert not seeds & names
    # the sweep: every point's material and its loss variants
    sweep = SensitivitySettings.from_config(cfg["sensitivity"])
    from tyreroad.pipeline import resolved_material_config

    base = resolved_material_config(cfg["study"]["reference_material"], mats)
    for name, point in sweep.points.items():
        preset = scale_moduli(point_material_preset(base, point["material"]), 1.0)
        assert material_from_config(name, {name: preset}).is_causal, name
        for s in sweep.loss_scales:
            assert material_from_config(name, {name: loss_variant_preset(preset, s, sweep)}).is_causal, (name, s)


@pytest.mark.parametrize("where, mutate", [
    ("study.materials[1]", lambda c: c["study"].update(materials=["tread", "tread-eta1.5-seed"])),
    ("study.loadings.cycle[1]", lambda c: c["study"]["loadings"].update(cycle=["tread", "tread-eta0.5-seed"])),
    ("rolling.materials[2]", lambda c: c["rolling"].update(materials=["tread", "tread-rho2", "tread-eta0.5-seed"])),
    ("study.claim6.anchor_variants[0]", lambda c: c["study"]["claim6"].update(anchor_variants=["tread-eta1.5-seed"])),
    ("study.claim6.storage_checks[1]",
     lambda c: c["study"]["claim6"].update(storage_checks=["tread-eta0.5-storage", "tread-eta0.5-seed"])),
    ("study.materials[1]", lambda c: c["materials"]["tread-eta0.5"].pop("loss_anchor")),
    ("sensitivity.points.lowloss.material",
     lambda c: c["sensitivity"]["points"]["lowloss"]["material"].pop("loss_anchor")),
])
def test_a_seed_variant_in_a_time_domain_stage_stops_planning(config, where, mutate):
    cfg = copy.deepcopy(config)
    mutate(cfg)
    with pytest.raises(ConfigError) as err:
        _planned(cfg)
    msg = str(err.value)
    assert msg.startswith(where), msg
    assert "not causal" in msg and ".loss_anchor: 1000.0" in msg, msg


@pytest.mark.parametrize("target, wildcards", [
    ("results/greens/tread-eta0.5-seed.nc", {"material": "tread-eta0.5-seed"}),
    ("results/contact/iso10844/tread-eta1.5-seed/dynamic_500.nc",
     {"surface": "iso10844", "material": "tread-eta1.5-seed", "mode": "dynamic", "accel": "500"}),
    ("results/loading/iso10844/tread-eta1.5-seed/quasistatic_cycle.nc",
     {"surface": "iso10844", "material": "tread-eta1.5-seed", "mode": "quasistatic", "loading": "cycle"}),
])
def test_a_requested_time_domain_target_of_a_seed_variant_is_refused(config, target, wildcards):
    cfg = _planned(config)
    with pytest.raises(ConfigError, match=r"not causal.*loss_anchor: 1000\.0"):
        C.check_job(cfg, target, wildcards)
    # its springs (quasi-static modulus only) are no time-domain stage
    C.check_job(cfg, "results/springs/iso10844/tread-eta0.5-seed.nc",
                {"surface": "iso10844", "material": "tread-eta0.5-seed"})


def test_claim6_section_is_checked(config):
    for mutate, expected in [
        (lambda c: c["study"]["claim6"].update(seed_variants=["tread-eta0.5"]), "study.claim6.seed_variants[0]"),
        (lambda c: c["study"]["claim6"].update(springs_checks=["nothing"]), "study.claim6.springs_checks[0]"),
        (lambda c: c["study"]["claim6"].update(preload=3.0e-4), "study.claim6.preload"),
        (lambda c: c["study"]["claim6"].update(frequency=3.0e4), "study.claim6.frequency"),
        (lambda c: c["materials"].update({"tread-eta1.5": {"base": "tread", "loss_scale": 4.5, "loss_anchor": 1.0e3}}),
         "materials.tread-eta1.5.loss_scale"),
    ]:
        cfg = copy.deepcopy(config)
        mutate(cfg)
        with pytest.raises(ConfigError, match=expected.replace(".", r"\.").replace("[", r"\[")):
            _planned(cfg)


def test_rolling_strip_past_the_radau_dense_limit_stops_planning_of_rolling_only(tmp_path):
    """A radau config with the default 150 x 20 strip (3000 elements > 1600) is refused when the rolling jobs
    are planned, naming the key and the limit; the shipped narrow strip (150 x 10) passes."""
    qlv = load_config(ROOT / "config" / "config.yaml", ROOT / "config" / "springs-qlv.yaml")
    with pytest.raises(ConfigError, match=r"surfaces\.iso10844-strip\.patch_elements = \[150, 20\] \(3000 elements\)"
                                          r".*up to 1600 elements"):
        C.check_rolling_kernel(qlv)
    C.check_rolling_kernel(load_config(ROOT / "config" / "config.yaml", ROOT / "config" / "rolling-narrow.yaml"))
    C.check_rolling_kernel(load_config(ROOT / "config" / "config.yaml"))  # passive: any strip
    _synthetic.copy_workflow(tmp_path)

    def plan(*args):
        return subprocess.run([sys.executable, "-m", "snakemake", "-n", "-j1", *args, "--configfile",
                               "config/config.yaml", "config/springs-qlv.yaml"], cwd=tmp_path, capture_output=True,
                              text=True)

    # (the same overlay planning the study: test_every_shipped_overlay_runs_its_surfaces_and_plans_the_rest)
    refused = plan("rolling")
    assert refused.returncode != 0 and "up to 1600 elements" in refused.stdout + refused.stderr
