"""The ``tyreroad`` command (tyreroad.cli) and the K* export behind it (tyreroad.kstar).

A synthetic K* file with the stiffness-spectrum layout (docs/data_contracts.md) whose K' and K''
are closed-form functions of d0 and f, so the interpolated and band values are checked by hand.
"""

from __future__ import annotations

import io
import math
import os

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner
from scipy.integrate import quad

from tyreroad import cli, kstar, runner
from tyreroad import io as tio

PRELOADS = np.array([5e-5, 1e-4, 1.5e-4, 2e-4])
FREQ = np.geomspace(10.0, 25600.0, 40)


def storage(d0, f):
    """K' [N/m]: quadratic in d0 (so linear interpolation differs from the function), linear in ln f."""
    return 1e6 + 4e13 * d0 ** 2 + 2e4 * np.log(f)


def loss(d0, f):
    """K'' [N/m]: linear in d0, quadratic in ln f (not linear between grid points)."""
    return 1e5 + 1e9 * d0 + 300.0 * np.log(f) ** 2


def synthetic_spectrum(material="tread", transient=True) -> xr.Dataset:
    d, f = np.meshgrid(PRELOADS, FREQ, indexing="ij")
    k1, k2 = storage(d, f), loss(d, f)

    def a(u, n):
        return {"units": u, "long_name": n}

    pf = ("preload", "frequency")
    data = {
        "storage_stiffness": (pf, k1, a("N/m", "K'")),
        "loss_stiffness": (pf, k2, a("N/m", "K''")),
        "loss_factor": (pf, k2 / k1, a("1", "loss factor")),
        "stiffness_magnitude": (pf, np.hypot(k1, k2), a("N/m", "|K*|")),
        "relaxed_stiffness": ("preload", k1[:, 0], a("N/m", "K*(f->0)")),
        "tangent_stiffness_qs": ("preload", k1[:, 0], a("N/m", "K_qs")),
        "preload_force": ("preload", 1e6 * PRELOADS, a("N", "F")),
        "contact_fraction": ("preload", PRELOADS / 4e-4, a("1", "fraction")),
    }
    if transient:
        data["storage_stiffness_transient"] = (pf, 1.1 * k1, a("N/m", "K' transient"))
        data["loss_stiffness_transient"] = (pf, 1.2 * k2, a("N/m", "K'' transient"))
        data["loss_factor_transient"] = (pf, 1.2 * k2 / (1.1 * k1), a("1", "loss factor transient"))
    return xr.Dataset(data, coords={"preload": ("preload", PRELOADS, a("m", "d0")),
                                    "frequency": ("frequency", FREQ, a("Hz", "frequency"))},
                      attrs={"material": material, "sample_rate": 51200.0, "surface": "iso10844"})


@pytest.fixture
def results(tmp_path):
    """A results folder holding the synthetic K* file of 'tread' as the pipeline writes it."""
    tio.write_dataset(synthetic_spectrum(), tmp_path / "stiffness_spectrum" / "iso10844" / "tread.nc",
                      {"stiffness_spectrum": {}}, stage="stiffness_spectrum", surface="iso10844", material="tread")
    return tmp_path


def read_csv(text):
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    header = lines[0].split(",")
    rows = np.array([[float(x) for x in ln.split(",")] for ln in lines[1:]])
    return {h: rows[:, i] for i, h in enumerate(header)}


@pytest.mark.parametrize("text, metres", [("0.12mm", 1.2e-4), ("120um", 1.2e-4), ("1.2e-4", 1.2e-4),
                                          ("120 µm", 1.2e-4), ("0.012cm", 1.2e-4), ("1.2e-4m", 1.2e-4)])
def test_parse_length(text, metres):
    assert kstar.parse_length(text) == pytest.approx(metres, rel=1e-12)


@pytest.mark.parametrize("text", ["0.12 inch", "mm", "-0.1mm", "0"])
def test_parse_length_rejects(text):
    with pytest.raises(ValueError, match="length"):
        kstar.parse_length(text)


def test_run_places_targets_before_configfile(monkeypatch):
    seen = {}
    monkeypatch.setattr(runner, "run_snakemake", lambda cmd, directory: seen.setdefault("cmd", cmd) and 0)
    out = CliRunner().invoke(cli.main, ["run", "rolling", "-c", "config/rolling-flat.yaml", "-n"])
    assert out.exit_code == 0, out.output
    assert seen["cmd"] == ["snakemake", "rolling", "-j", "2", "-n", "--configfile", "config/config.yaml",
                           "config/rolling-flat.yaml"]
    assert "$ snakemake rolling -j 2 -n --configfile config/config.yaml config/rolling-flat.yaml" in out.output


def test_run_command_order_with_overlays_and_results_dir():
    cmd = runner.snakemake_command(["results/a.nc", "rolling"], ["x.yaml", "y.yaml"], jobs=1, results_dir="/tmp/r")
    # every target before the first option; the config files last, the study's first
    assert cmd[1:3] == ["results/a.nc", "rolling"]
    assert cmd[cmd.index("--configfile"):] == ["--configfile", "config/config.yaml", "x.yaml", "y.yaml"]
    assert cmd[cmd.index("--config") + 1] == "results_dir=/tmp/r"
    with pytest.raises(ValueError, match="always read first"):
        runner.snakemake_command([], ["config/config.yaml"])


def test_run_refuses_outside_the_repository(tmp_path):
    out = CliRunner().invoke(cli.main, ["run", "-n", "-d", str(tmp_path)])
    assert out.exit_code != 0 and "no Snakefile" in out.output


def test_kstar_interpolates_linearly_in_d0(results):
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.12mm", "--results", str(results)])
    assert out.exit_code == 0, out.output
    table = read_csv(out.stdout)  # the CSV alone on standard output; which file was read goes to standard error
    f = table["frequency_Hz"]
    np.testing.assert_allclose(f, FREQ, rtol=1e-9)
    # by hand: 0.12 mm lies 0.4 of the way from 0.10 to 0.15 mm
    k1 = 0.6 * storage(1e-4, f) + 0.4 * storage(1.5e-4, f)
    k2 = 0.6 * loss(1e-4, f) + 0.4 * loss(1.5e-4, f)
    np.testing.assert_allclose(table["storage_relaxed_N_per_m"], k1, rtol=1e-9)
    np.testing.assert_allclose(table["loss_relaxed_N_per_m"], k2, rtol=1e-9)
    np.testing.assert_allclose(table["magnitude_relaxed_N_per_m"], np.hypot(k1, k2), rtol=1e-9)
    np.testing.assert_allclose(table["loss_factor_relaxed"], k2 / k1, rtol=1e-9)
    np.testing.assert_allclose(table["storage_transient_N_per_m"], 1.1 * k1, rtol=1e-9)
    # the quadratic K'(d0) differs from its chord: the interpolation is stated, not exact physics
    assert abs(k1[0] / storage(1.2e-4, f[0]) - 1) > 1e-3
    assert "# interpolation: K' and K'' linear in d0 between the computed preloads 0.1 and 0.15 mm" in out.stdout


def test_kstar_at_a_computed_preload_is_the_file(results):
    ds = synthetic_spectrum()
    table = kstar.at_preload(ds, kstar.parse_length("150um"))
    np.testing.assert_array_equal(table["storage_relaxed"].values, ds["storage_stiffness"].values[2])
    assert "no interpolation" in table.attrs["interpolation"]


def test_kstar_refuses_outside_the_range(results):
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.3mm", "--results", str(results)])
    assert out.exit_code != 0
    assert "outside the computed preloads 0.05-0.2 mm" in out.output
    out = CliRunner().invoke(cli.main, ["kstar", "rubber", "--preload", "0.1mm", "--results", str(results)])
    assert out.exit_code != 0 and "no K* file for material 'rubber'" in out.output


def test_kstar_third_octave_band_means(results, tmp_path):
    csv = tmp_path / "bands.csv"
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "1e-4", "--results", str(results),
                                        "--third-octave", "--csv", str(csv)])
    assert out.exit_code == 0, out.output
    table = read_csv(csv.read_text())
    centre = table["centre_Hz"]
    # IEC 61260 base 10: the whole bands inside 10 Hz .. 25.6 kHz are 12.5 Hz .. 20 kHz
    assert table["nominal_Hz"][0] == 12.5 and table["nominal_Hz"][-1] == 20000
    np.testing.assert_allclose(centre, 1000 * 10 ** (np.arange(-19, 14) / 10), rtol=1e-11)
    np.testing.assert_allclose(table["upper_Hz"] / table["lower_Hz"], 10 ** 0.1, rtol=1e-11)
    # K' is linear in ln f: its log-frequency band mean is its value at the band's centre
    np.testing.assert_allclose(table["storage_relaxed_N_per_m"], storage(1e-4, centre), rtol=1e-11)
    # K'' is quadratic in ln f; the band value is the log-frequency mean of its piecewise-linear-in-ln f
    # interpolant, integrated here independently by quadrature
    x = np.log(FREQ)
    y = loss(1e-4, FREQ)
    for i in (0, 10, len(centre) - 1):
        lo, hi = math.log(table["lower_Hz"][i]), math.log(table["upper_Hz"][i])
        hand = quad(lambda s: np.interp(s, x, y), lo, hi, points=x[(x > lo) & (x < hi)], limit=200)[0] / (hi - lo)
        assert table["loss_relaxed_N_per_m"][i] == pytest.approx(hand, rel=1e-10)
        # and close to the exact band mean of the quadratic (the grid is 4.7 points per band)
        exact = quad(lambda s: loss(1e-4, math.exp(s)), lo, hi)[0] / (hi - lo)
        assert table["loss_relaxed_N_per_m"][i] == pytest.approx(exact, rel=1e-3)
    np.testing.assert_allclose(table["loss_factor_relaxed"],
                               table["loss_relaxed_N_per_m"] / table["storage_relaxed_N_per_m"], rtol=1e-9)


def test_combine_spectra_has_a_material_dimension():
    a, b = synthetic_spectrum("tread"), synthetic_spectrum("tread-rho2")
    b["storage_stiffness"] = 2 * b["storage_stiffness"]
    combined = kstar.combine_spectra([a, b])
    assert combined["storage_stiffness"].dims == ("material", "preload", "frequency")
    assert list(combined["material"].values) == ["tread", "tread-rho2"]
    np.testing.assert_array_equal(combined["storage_stiffness"].sel(material="tread-rho2"),
                                  2 * a["storage_stiffness"])
    tio.check_metadata(combined)
    # a combined file's material reads back through at_preload as the single file does
    one = kstar.at_preload(combined.sel(material="tread"), 1.2e-4)
    np.testing.assert_allclose(one["storage_relaxed"], kstar.at_preload(a, 1.2e-4)["storage_relaxed"], rtol=1e-12)
    with pytest.raises(ValueError, match="other frequency values"):
        kstar.combine_spectra([a, synthetic_spectrum("x").isel(frequency=slice(1, None))])
    with pytest.raises(ValueError, match="given twice"):
        kstar.combine_spectra([a, a])


def _combined(results, materials=("tread", "tread-rho2")):
    """RESULTS/stiffness_spectrum.nc as rule stiffness_combined writes it; K' of material i scaled by (i + 2)."""
    from tyreroad import pipeline

    parts = []
    for i, m in enumerate(materials):
        ds = synthetic_spectrum(m)
        ds["storage_stiffness"] = (i + 2) * ds["storage_stiffness"]
        parts.append(tio.write_dataset(ds, results / "parts" / f"{m}.nc", {}, stage="stiffness_spectrum",
                                       surface="iso10844", material=m))
    path = results / "stiffness_spectrum.nc"
    pipeline.run_stiffness_combined(parts, path, compounds={m: [m, None] for m in materials})
    return path


def test_kstar_reads_the_combined_file(results):
    path = _combined(results)
    os.utime(results / "stiffness_spectrum" / "iso10844" / "tread.nc", (1e9, 1e9))  # older than the combined file
    for material, scale in (("tread", 2), ("tread-rho2", 3)):
        out = CliRunner().invoke(cli.main, ["kstar", material, "--preload", "0.1mm", "--results", str(results)])
        assert out.exit_code == 0, out.output
        assert out.stderr.strip() == f"read K* of {material} from the combined file {path}"
        assert f"# material: {material}\n" in out.stdout and f"# source: {path}\n" in out.stdout
        table = read_csv(out.stdout)
        # the combined file's values (the per-material tread file has K' x 1)
        np.testing.assert_allclose(table["storage_relaxed_N_per_m"], scale * storage(1e-4, FREQ), rtol=1e-9)
    # a per-material file newer than the combined one: read the combined file, and say it may be stale
    os.utime(results / "stiffness_spectrum" / "iso10844" / "tread.nc")
    os.utime(path, (1e9 + 10, 1e9 + 10))
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.1mm", "--results", str(results)])
    assert out.exit_code == 0 and "from the combined file" in out.stderr
    assert "is newer than the combined file, which may be stale" in out.stderr


def test_kstar_falls_back_to_the_per_material_file_only_without_the_combined_file(results):
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.1mm", "--results", str(results)])
    assert out.exit_code == 0, out.output
    single = results / "stiffness_spectrum" / "iso10844" / "tread.nc"
    assert out.stderr.strip() == (f"read K* of tread from the per-material file {single} "
                                  f"({results / 'stiffness_spectrum.nc'} is absent)")
    np.testing.assert_allclose(read_csv(out.stdout)["storage_relaxed_N_per_m"], storage(1e-4, FREQ), rtol=1e-9)


def test_kstar_combined_file_without_the_material_is_an_error(results):
    path = _combined(results, materials=("tread-rho2", "tread-eta0.5"))
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.1mm", "--results", str(results)])
    assert out.exit_code != 0
    single = results / "stiffness_spectrum" / "iso10844" / "tread.nc"
    assert (f"{path}: material 'tread' is not in the combined K* file (materials: tread-rho2, tread-eta0.5)"
            in out.output)
    assert f"{single} exists: read it with --file {single.as_posix()}" in out.output
    # ... which reads it, saying so
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.1mm", "--file", str(single)])
    assert out.exit_code == 0 and out.stderr.strip() == f"read K* of tread from {single} (--file)"
    # --file with a combined file picks the material
    out = CliRunner().invoke(cli.main, ["kstar", "tread-eta0.5", "--preload", "0.1mm", "--file", str(path)])
    assert out.exit_code == 0, out.output
    np.testing.assert_allclose(read_csv(out.stdout)["storage_relaxed_N_per_m"], 3 * storage(1e-4, FREQ), rtol=1e-9)
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.1mm", "--file", str(path)])
    assert out.exit_code != 0 and "material 'tread' is not in the file (tread-rho2, tread-eta0.5)" in out.output


def test_kstar_combined_file_of_another_surface_is_an_error(results):
    _combined(results)
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.1mm", "--results", str(results),
                                        "--surface", "myroad"])
    assert out.exit_code != 0
    assert "the combined K* file is of surface 'iso10844', not 'myroad'" in out.output


def test_kstar_without_any_file_names_both(tmp_path):
    out = CliRunner().invoke(cli.main, ["kstar", "tread", "--preload", "0.1mm", "--results", str(tmp_path)])
    assert out.exit_code != 0
    assert "stiffness_spectrum.nc: no combined K* file" in out.output
    assert "no K* file for material 'tread' on surface 'iso10844'" in out.output


def test_info_summarises_a_result_file(results):
    out = CliRunner().invoke(cli.main, ["info", str(results / "stiffness_spectrum" / "iso10844" / "tread.nc")])
    assert out.exit_code == 0, out.output
    for text in ("stage:        stiffness_spectrum", "material:     tread", "code version: 0.1.0", "config hash:",
                 "storage_stiffness", "[N/m]", "preload", "[m]"):
        assert text in out.output
    out = CliRunner().invoke(cli.main, ["info", str(results / "nope.nc")])
    assert out.exit_code != 0 and "no such file" in out.output
