"""Patterned treads (tyreroad.pattern): placement, block-diagonal influence, the pattern kernel in the contact
solver (degenerate pattern == slick run, grooves carry no force, blocks do not interact) and config errors."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from tyreroad.config import ConfigError, check_config, load_config
from tyreroad.contact import run_loading_path
from tyreroad.influence import contact_set_stiffness, offset_matrix
from tyreroad.kernel import LayerKernel
from tyreroad.loading import IndentationPath, uniform_indentation_grid
from tyreroad.material import material_from_config
from tyreroad.pattern import (
    PatchInfluence,
    PatternGeometry,
    PatternKernel,
    groove_springs,
    influence_memory,
    place_pattern,
)
from tyreroad.pattern_stage import standin_block_influence
from tyreroad.solver import SolverSettings
from tyreroad.springs import SpringTable

C = 1.0e-3
E_STAR = 25e6 / (1 - 0.49**2)


def _z1(nx, ny, rng):
    z1 = -rng.exponential(0.15e-3 / math.log(2), size=(nx, ny))
    return z1 - z1.max() + 3e-3


def _springs(n, rng, step=1e-6, zeta_max=4e-4):
    zeta = np.arange(round(zeta_max / step) + 1) * step
    radius = rng.uniform(1e-3, 4e-3, size=n)[:, None]
    area = np.minimum(np.maximum((C / 26) ** 2, np.pi * radius * zeta[None, :]), C**2)
    k = 2 * E_STAR * np.sqrt(area / np.pi)
    f = np.zeros_like(k)
    np.cumsum(0.5 * step * (k[:, 1:] + k[:, :-1]), axis=1, out=f[:, 1:])
    return SpringTable.checked(k, f, step, n)


def _table(nx, ny):
    """A layer-like even offset table g[dx, dy] [m/N] (Boussinesq with a layer cut-off)."""
    dx = np.arange(-(nx - 1), nx)[:, None] * C
    dy = np.arange(-(ny - 1), ny)[None, :] * C
    r = np.hypot(dx, dy)
    with np.errstate(divide="ignore"):
        g = np.where(r > 0, 1 / (np.pi * E_STAR * np.maximum(r, 1e-30)), 1.1222 / (E_STAR * C))
    return g * np.exp(-r / 0.01) * (1 - 0.1 * r / 0.008)


SETTINGS = SolverSettings(d_max=2.5e-4, quasistatic_step=1e-5, method="dense")


def _run(kernel, z1, springs):
    d = uniform_indentation_grid(SETTINGS.d_max, SETTINGS.quasistatic_step)
    return run_loading_path(IndentationPath(z1, d), springs, kernel, SETTINGS)


def test_placement_masks_grooves_and_numbers_blocks():
    geo = PatternGeometry("p", 3e-3, 2e-3, 1e-3, 5e-3, C)  # 3 x 2 blocks, period 4 x 3
    lay = place_pattern(geo, (9, 5), (-1e-3, 0.0))  # the patch starts in a groove along x
    # x: pattern columns -1 ... 7 -> within period 3,0,1,2,3,0,1,2,3 (3 = groove); y: 0,1,2,0,1 (2 = groove)
    gx = np.array([1, 0, 0, 0, 1, 0, 0, 0, 1], bool)
    gy = np.array([0, 0, 1, 0, 0], bool)
    np.testing.assert_array_equal(lay.grooved, gx[:, None] | gy[None, :])
    assert lay.grooved_fraction == pytest.approx(1 - 6 * 4 / 45)
    assert len(lay.blocks) == 4 and lay.whole_blocks() == 4
    # local index: row-major over x then y from the block's corner
    assert lay.local_index[1, 0] == 0 and lay.local_index[1, 1] == 1 and lay.local_index[2, 0] == 2
    assert lay.local_index[3, 1] == 5
    assert lay.block_index[1, 0] == lay.block_index[3, 1] != lay.block_index[5, 0]
    assert np.all(lay.local_index[lay.grooved] == -1) and np.all(lay.block_index[lay.grooved] == -1)
    # a cut block at the patch edge keeps its inside elements
    cut = place_pattern(geo, (5, 5), (0.0, 0.0))
    assert sorted(idx.size for idx, _ in cut.blocks) == [2, 2, 6, 6] and cut.whole_blocks() == 2
    with pytest.raises(ValueError, match=r"pattern.patch_origin\[0\] = 0.0005 m: expected a whole multiple"):
        place_pattern(geo, (5, 5), (0.5e-3, 0.0))
    with pytest.raises(ValueError, match=r"pattern.presets.q.block_length = 0.0025 m: expected a positive whole"):
        PatternGeometry("q", 2.5e-3, 2e-3, 1e-3, 5e-3, C)


def test_patch_influence_is_block_diagonal():
    geo = PatternGeometry("p", 4e-3, 3e-3, 1e-3, 5e-3, C)
    lay = place_pattern(geo, (12, 9), (2e-3, 0.0))
    gb = offset_matrix(_table(4, 3))
    infl = PatchInfluence(lay, gb)
    g = infl.matrix()
    same = (lay.block_index.ravel()[:, None] == lay.block_index.ravel()[None, :]) & (lay.block_index.ravel()[:, None] >= 0)
    assert np.all(g[~same] == 0.0) and np.all(g[same] != 0.0)
    # a force on one block moves no other block (and no groove)
    rng = np.random.default_rng(1)
    for b, (idx, loc) in enumerate(lay.blocks):
        f = np.zeros(lay.shape)
        f.ravel()[idx] = rng.uniform(0.1, 1.0, idx.size)
        w = infl.apply(f)
        assert np.all(w.ravel()[lay.block_index.ravel() != b] == 0.0)
        np.testing.assert_allclose(w.ravel()[idx], gb[np.ix_(loc, loc)] @ f.ravel()[idx], rtol=1e-14)
    active = rng.choice(g.shape[0], 40, replace=False)
    np.testing.assert_array_equal(infl.block(active), g[np.ix_(active, active)])
    k = rng.uniform(0, 1e5, g.shape[0]) * (rng.uniform(size=g.shape[0]) > 0.3) * ~lay.grooved.ravel()
    assert infl.stiffness(k) == pytest.approx(float(contact_set_stiffness(g, k)), rel=1e-12)
    mem = influence_memory(lay)
    assert mem["block_table"] == 8 * 12**2 and mem["dense_patch"] == 8 * 108**2
    with pytest.raises(ValueError, match=r"block_table: expected shape \(12, 12\)"):
        PatchInfluence(lay, gb[:6, :6])


def test_degenerate_pattern_reproduces_slick_run():
    """One block covering the patch, its table the flat kernel's offset matrix: the slick dense run to 1e-12."""
    nx, ny = 8, 6
    rng = np.random.default_rng(7)
    z1, springs, table = _z1(nx, ny, rng), _springs(nx * ny, rng), _table(nx, ny)
    slick = _run(LayerKernel.quasistatic(table, C), z1, springs)
    lay = place_pattern(PatternGeometry("one", nx * C, ny * C, 0.0, 0.0, C), (nx, ny))
    assert not lay.grooved.any() and len(lay.blocks) == 1
    pat = _run(PatternKernel.from_block(lay, offset_matrix(table)), z1, springs)
    assert slick.contact_count[-1] > nx * ny // 3
    np.testing.assert_allclose(pat.force, slick.force, rtol=1e-12, atol=1e-12 * slick.force.max())
    np.testing.assert_allclose(pat.element_force, slick.element_force, rtol=0, atol=1e-12 * slick.element_force.max())
    np.testing.assert_allclose(pat.tangent_stiffness, slick.tangent_stiffness, rtol=1e-12)
    np.testing.assert_allclose(pat.displacement, slick.displacement, rtol=0, atol=1e-12 * slick.displacement.max())


def test_grooves_carry_no_force_and_blocks_do_not_interact():
    geo = PatternGeometry("p", 4e-3, 3e-3, 1e-3, 5e-3, C)
    nx, ny = 12, 9
    lay = place_pattern(geo, (nx, ny), (0.0, 0.0))
    rng = np.random.default_rng(11)
    z1, springs = _z1(nx, ny, rng), _springs(nx * ny, rng)
    kernel = PatternKernel.from_block(lay, offset_matrix(_table(4, 3)))
    res = _run(kernel, z1, groove_springs(springs, lay.grooved))
    assert np.all(res.element_force[:, lay.grooved] == 0.0)
    assert res.contact_count[-1] > 0.3 * (~lay.grooved).sum()
    # each block solved alone (its elements only, the rest of the patch without springs) gives the same forces
    for b, (idx, _) in enumerate(lay.blocks):
        alone = lay.block_index != b
        one = _run(kernel, z1, groove_springs(springs, alone))
        np.testing.assert_allclose(one.element_force[:, ~alone], res.element_force[:, ~alone], rtol=0,
                                   atol=1e-12 * res.element_force.max())
    # the equations hold: zeta = z1 - z2 - G F on every block
    d = res.indentation
    w = np.array([kernel.influence.apply(f) for f in res.element_force])
    zeta = (z1 - z1.max())[None] + d[:, None, None] - w
    np.testing.assert_allclose(res.compression, zeta, rtol=0, atol=2e-12)


def test_standin_block_influence_is_the_layer_kernel_on_the_block():
    cfg = load_config("config/config.yaml")
    tread = material_from_config("tread", cfg["materials"])
    geo = PatternGeometry("b", 4e-3, 3e-3, 1e-3, 5e-3, C)
    xy, g = standin_block_influence(geo, tread)
    assert xy.shape == (12, 2) and g.shape == (12, 12)
    np.testing.assert_allclose(xy[3], [1.5e-3, 0.5e-3])  # element (1, 0): row-major over x then y
    np.testing.assert_array_equal(g, g.T)
    from tyreroad.greens import static_element_kernel

    for i, j in [(0, 11), (5, 7), (3, 3)]:
        ref = static_element_kernel(np.abs(xy[i] - xy[j])[None, :], C, tread.quasi_static_modulus, tread.poisson,
                                    tread.thickness)[0]
        assert g[i, j] == pytest.approx(ref, rel=1e-12)


def _pattern_config():
    cfg = load_config("config/config.yaml")
    cfg.setdefault("pattern", {})
    return cfg


@pytest.mark.parametrize("edit, message", [
    (lambda p: p["presets"]["block20"].update(block_length=0.0205),
     r"pattern.presets.block20.block_length = 0.0205 m: expected a positive whole multiple of the element size"),
    (lambda p: p["presets"]["block20"].update(groove_depth=0.012),
     r"pattern.presets.block20.groove_depth = 0.012 m: expected a depth not above the tread thickness of material "
     r"'tread' \(0.01 m\)"),
    (lambda p: p["presets"]["block40"].update(block_length=0.090),
     r"pattern.patch_origin = \[0.0, 0.0\] m: the patch of surfaces.iso10844-pattern.patch_elements = \[85, 40\] "
     r"holds no whole 90 x 40-element block of pattern 'block40'"),
    (lambda p: p.update(patch_origin=[0.0005, 0.0]),
     r"pattern.patch_origin\[0\] = 0.0005 m: expected a whole multiple of the element size"),
    (lambda p: p["presets"]["block20"].update(groove_width=0.0),
     r"pattern.presets.block20.groove_width = 0.0 m: expected at least one element"),
    (lambda p: p.update(surface="nope"), r"pattern.surface = 'nope': expected a preset in surfaces"),
    (lambda p: p.update(modes=["dynamic"]),
     r"pattern.modes = \['dynamic'\]: expected \['quasistatic'\] or \['quasistatic', 'dynamic'\]"),
    (lambda p: p.update(influence="standin"),
     r"pattern.modes = \['quasistatic', 'dynamic'\] with pattern.influence = 'standin': expected influence 'fe'"),
    (lambda p: p.update(materials=["tread", "tread-thin"]),
     r"pattern materials and dynamic variants: 'tread-thin' \(thickness 0.008 m, poisson 0.49\) differs from 'tread' "
     r"\(thickness 0.01 m"),
    (lambda p: p["dynamic"].update(variants=["tread-rho9"]),
     r"pattern.dynamic.variants\[0\] = 'tread-rho9': expected a preset in materials"),
    (lambda p: p.update(materials=["rubber"]), r"pattern.materials\[0\] = 'rubber': expected a preset in materials"),
    (lambda p: p["presets"].update(slick=dict(p["presets"]["block20"])),
     r"pattern.presets.slick: the name 'slick' is the unpatterned reference"),
])
def test_pattern_config_errors_name_key_value_and_expectation(edit, message):
    cfg = _pattern_config()
    check_config(copy.deepcopy(cfg))  # the shipped section is valid
    cfg["materials"]["tread-thin"] = dict(cfg["materials"]["tread"], thickness=0.008)
    edit(cfg["pattern"])
    with pytest.raises(ConfigError, match=message):
        check_config(cfg)


def test_pattern_study_refuses_qlv_springs_only_when_it_runs():
    """QLV springs: overlays still plan the rest of the study (pattern.study off); with the study on, refused."""
    cfg = load_config("config/config.yaml", "config/springs-qlv.yaml")
    check_config(copy.deepcopy(cfg))
    cfg["pattern"]["study"] = True
    with pytest.raises(ConfigError, match=r"springs.rheology = 'qlv': expected 'elastic' for the pattern study"):
        check_config(cfg)


def test_dynamic_pattern_runs_refuse_stiff_springs_only_when_they_run():
    """Hard contact or linear springs above 1e6 N/m with pattern.modes dynamic: the rest of the study still plans
    (pattern.study off); with the pattern study on, refused naming the key and the way out."""
    cfg = load_config("config/config.yaml")
    cfg["springs"].update(model="linear", linear_stiffness=1e8)
    check_config(copy.deepcopy(cfg))
    cfg["pattern"]["study"] = True
    with pytest.raises(ConfigError, match=r"springs.linear_stiffness = 1e\+08 N/m with springs.model = 'linear' with "
                                          r"pattern.modes = \['quasistatic', 'dynamic'\]: expected springs up to "
                                          r"1e\+06 N/m .* or pattern.modes: \[quasistatic\]"):
        check_config(cfg)
    cfg["pattern"]["modes"] = ["quasistatic"]
    check_config(cfg)


def _attrs(units, long_name):
    return {"units": units, "long_name": long_name}


def stage_datasets(nx, ny, seed=5):
    """A synthetic surface and spring tables as the stages read them: (surface, springs, SpringTable)."""
    import xarray as xr

    rng = np.random.default_rng(seed)
    z1 = _z1(nx, ny, rng)
    table = _springs(nx * ny, rng, step=2e-6)
    surface = xr.Dataset({"z1": (("ex", "ey"), z1, _attrs("m", "element peak height"))}, attrs={"element_size": C})
    springs = xr.Dataset(
        {"stiffness": (("ex", "ey", "zeta"), table.stiffness.reshape(nx, ny, -1), _attrs("N/m", "k")),
         "force": (("ex", "ey", "zeta"), table.force.reshape(nx, ny, -1), _attrs("N", "F"))},
        coords={"zeta": ("zeta", np.arange(table.stiffness.shape[1]) * table.zeta_step, _attrs("m", "compression"))})
    return surface, springs, table


def test_pattern_stages_end_to_end(tmp_path):
    """The stage functions on a 12 x 9 patch: greens (pattern and slick), runs, study and report. The study's K_sat
    uses the study's definitions; grooves carry no force; the report names every case."""
    from tyreroad import io, pipeline

    cfg = load_config("config/config.yaml")
    nx, ny = 12, 9
    surface, springs, _ = stage_datasets(nx, ny)
    io.write_dataset(surface, tmp_path / "surface.nc", {})
    io.write_dataset(springs, tmp_path / "springs.nc", {})
    preset = {"block_length": 0.004, "block_width": 0.003, "groove_width": 0.001, "groove_depth": 0.01}
    solver = dict(cfg["solver"], quasistatic_step=1e-5)
    contacts, greens = [], []
    for name, p in [("slick", None), ("b4", preset)]:
        g = tmp_path / f"greens_{name}.nc"
        pipeline.run_pattern_greens(name, p, "standin", "tread", cfg["materials"]["tread"], C, [nx, ny], g)
        out = tmp_path / f"contact_{name}.nc"
        pipeline.run_pattern_contact(tmp_path / "surface.nc", tmp_path / "springs.nc", g, "synth", "tread", name,
                                     [1e-3, 0.0], solver, out)
        contacts.append(out)
        greens.append(g)
    only = tmp_path / "contact_b4_grooves.nc"
    pipeline.run_pattern_contact(tmp_path / "surface.nc", tmp_path / "springs.nc", greens[0], "synth", "tread", "b4",
                                 [1e-3, 0.0], solver, only, grooves_nc=greens[1])
    contacts.append(only)
    run = io.read_dataset(contacts[1])
    grooved = run["grooved"].values.astype(bool)
    assert grooved.sum() == 12 * 9 - 10 * 7  # origin 1 mm, period 5 x 4: columns 3, 8 and rows 3, 7 are grooves
    assert np.all(run["element_force"].values[:, grooved] == 0.0)
    assert float(run["residual"].max()) <= 1e-12
    pipeline.run_pattern_study(contacts, greens, cfg["study"], cfg["solver"]["d_max"], tmp_path / "study.nc")
    study = io.read_dataset(tmp_path / "study.nc")
    assert list(study["case"].values) == ["tread/slick", "tread/b4", "tread/b4/grooves-only"]
    grooves_only = io.read_dataset(only)
    np.testing.assert_array_equal(grooves_only["grooved"].values, run["grooved"].values)
    assert np.all(grooves_only["element_force"].values[:, grooved] == 0.0)
    # the same springs on the slick layer: the coupling between blocks is kept, so the forces differ from the pattern's
    assert not np.allclose(grooves_only["force"].values[1:], run["force"].values[1:], rtol=1e-6)
    from tyreroad.study import StudySettings, native_samples, case_on_grid, saturated_stiffness

    settings = StudySettings.from_config(dict(cfg["study"], surface="synth"), cfg["solver"]["d_max"])
    grid = case_on_grid(native_samples(run, "b4", settings), settings)
    k_sat = saturated_stiffness(settings.grid, grid["stiffness"], settings.saturation_range)
    assert float(study["saturated_stiffness"][1]) == k_sat
    k = study["saturated_stiffness"].values
    assert float(study["slick_change"][1]) == pytest.approx(k[1] / k[0] - 1, rel=1e-12) and k[1] < k[0]
    assert float(study["slick_change"][2]) == pytest.approx(k[2] / k[0] - 1, rel=1e-12) and k[2] < k[0]
    assert int(study["influence_bytes"][1]) == 8 * 12**2
    pipeline.run_pattern_report(tmp_path / "study.nc", tmp_path / "pattern.md")
    text = (tmp_path / "pattern.md").read_text()
    assert "| tread/b4 | " in text and f"{100 * float(study['slick_change'][1]):+.2f} %" in text


def test_pattern_target_plans_greens_runs_study_and_report(tmp_path):
    """`snakemake -n pattern` plans one table and one run per material and pattern (slick included), outside the
    default target."""
    import subprocess
    import sys

    import _synthetic

    wd = _synthetic.copy_workflow(tmp_path)
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-n", "-j1", "pattern", "--configfile",
                           "config/config.yaml", "config/test.yaml"], cwd=wd, capture_output=True, text=True)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    for rule, n in [("pattern_greens", 3), ("pattern_contact", 3), ("pattern_grooves_only", 2), ("pattern_study", 1),
                    ("pattern_report", 1)]:
        assert any(line.split() == [rule, str(n)] for line in out.splitlines()), (rule, out[-2000:])
    assert "results-test/greens/pattern/block40/tread.nc" in out
    proc = subprocess.run([sys.executable, "-m", "snakemake", "-n", "-j1", "--configfile", "config/config.yaml",
                           "config/test.yaml"], cwd=wd, capture_output=True, text=True)
    assert proc.returncode == 0 and "rule pattern_" not in proc.stdout + proc.stderr
