"""The stability record: the kernel's fs/2 limit k_crit = -1/lambda_min(G_d(-1)) against a march that
chatters exactly past it, the Lanczos path against the dense one, and the alternation measure."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from tyreroad.contact import SolverSettings, contact_dataset, solve_path
from tyreroad.influence import offset_matrix
from tyreroad.kernel import LayerKernel
from tyreroad.springs import linear_tables
from tyreroad.study import _fs2_limit_indentation
from tyreroad.stability import fs2_alternation, nyquist_critical_stiffness, nyquist_table, stability_record

FS = 51200.0


def test_alternation_of_a_pure_fs2_component():
    n = np.arange(200)
    assert fs2_alternation(100.0 + 3.0 * (-1.0) ** n) == pytest.approx(0.03, rel=1e-12)
    # a loading curve does not alternate (cubic: no fourth difference)
    assert fs2_alternation(100.0 + 0.5 * n + 1e-3 * n**2 + 1e-5 * n**3) == pytest.approx(0.0, abs=1e-12)
    assert np.isnan(fs2_alternation(np.zeros(50)))
    window = n >= 150
    assert fs2_alternation(np.where(window, 10.0 + (-1.0) ** n, 5.0), window=window) == pytest.approx(0.1)


@pytest.mark.parametrize("factor, grows", [(0.8, False), (1.25, True)])
def test_one_element_march_chatters_exactly_past_k_crit(factor, grows, caplog):
    """One element, g = [g0, g1] with g1 > g0: G_d(-1) = g0 - g1 < 0, k_crit = 1 / (g1 - g0). A hold at
    constant d: the step-to-step ratio of the force's deviation is -k g1 / (1 + k g0), larger than 1 in
    magnitude exactly for k > k_crit."""
    g0, g1 = 1e-5, 3e-5
    lags = np.zeros((1, 1, 220))  # a two-lag response, kept to the run's length
    lags[0, 0, :2] = g0, g1
    kernel = LayerKernel.dynamic(lags, FS)
    k_crit, lam = nyquist_critical_stiffness(kernel, (1, 1))
    assert lam == pytest.approx(g0 - g1, rel=1e-14) and k_crit == pytest.approx(1 / (g1 - g0), rel=1e-14)
    k = factor * k_crit
    stiffness, force = linear_tables(1, k, zeta_step=1e-6)
    d = np.concatenate([np.linspace(0.0, 1e-5, 5), np.full(200, 1e-5)])
    res = solve_path([[0.0]], stiffness, force, 1e-6, kernel, d, SolverSettings(), time=np.arange(d.size) / FS)
    deviation = res.force[5:] - 1e-5 / (1 / k + g0 + g1)  # the static force of the hold
    ratio = -k * g1 / (1 + k * g0)
    # (until a growing alternation lifts the spring off the road: F >= 0 bounds it)
    np.testing.assert_allclose(deviation[1:10] / deviation[:9], ratio, rtol=1e-6)
    assert (abs(ratio) > 1) == grows
    with caplog.at_level(logging.INFO, logger="tyreroad.stability"):
        record = stability_record(kernel, (1, 1), res.max_spring_stiffness, res.force)
    assert record.critical_stiffness == pytest.approx(k_crit)
    assert (record.first_step_past_limit is not None) == grows
    assert ("past the kernel's fs/2 limit" in caplog.text) == grows
    ds = contact_dataset(
        res.__class__(**{**res.__dict__, "backing_force": res.force, "stability": record}), "dynamic", 1.0, "s", "m")
    assert float(ds["nyquist_critical_stiffness"]) == pytest.approx(k_crit)
    assert ds["max_spring_stiffness"].values.max() == pytest.approx(k, rel=1e-12)
    limit_d = _fs2_limit_indentation(ds, res.indentation)
    if grows:
        assert float(ds["fs2_alternation"]) > 1.0
        # the study's record: the indentation of the first step past k_crit (the first loaded one here)
        assert limit_d == res.indentation[record.first_step_past_limit] and limit_d > 0
    else:
        assert float(ds["fs2_alternation"]) < 1e-6
        assert np.isnan(limit_d)


def test_record_judges_by_the_whole_circle_margin_where_the_kernel_knows_it(caplog):
    """A kernel that carries its greens file's margin (critical_stiffness) below its fs/2 point: the record
    stores both, and a run stable at fs/2 but past the margin is flagged at the first step past the margin."""
    import dataclasses

    g0, g1 = 1e-5, 3e-5
    lags = np.zeros((1, 1, 120))
    lags[0, 0, :2] = g0, g1
    k_fs2 = 1 / (g1 - g0)
    kernel = dataclasses.replace(LayerKernel.dynamic(lags, FS), critical_stiffness=0.5 * k_fs2)
    k = 0.8 * k_fs2  # below the fs/2 point, above the margin
    stiffness, force = linear_tables(1, k, zeta_step=1e-6)
    d = np.concatenate([np.linspace(0.0, 1e-5, 5), np.full(100, 1e-5)])
    with pytest.raises(ValueError, match="past the stability limit"):  # refused before the first step ...
        solve_path([[0.0]], stiffness, force, 1e-6, kernel, d, SolverSettings(), time=np.arange(d.size) / FS)
    res = solve_path([[0.0]], stiffness, force, 1e-6, kernel, d, SolverSettings(stability="warn"),  # ... or recorded
                     time=np.arange(d.size) / FS)
    with caplog.at_level(logging.INFO, logger="tyreroad.stability"):
        record = stability_record(kernel, (1, 1), res.max_spring_stiffness, res.force)
    assert record.critical_stiffness == pytest.approx(k_fs2) and record.margin_stiffness == 0.5 * k_fs2
    assert record.limit == 0.5 * k_fs2
    assert record.first_step_past_limit == int(np.flatnonzero(res.max_spring_stiffness > 0.5 * k_fs2)[0])
    assert "margin over the unit circle" in caplog.text
    ds = contact_dataset(
        res.__class__(**{**res.__dict__, "backing_force": res.force, "stability": record}), "dynamic", 1.0, "s", "m")
    assert float(ds["margin_critical_stiffness"]) == 0.5 * k_fs2
    assert _fs2_limit_indentation(ds, res.indentation) == res.indentation[record.first_step_past_limit]
    # a kernel without a known margin records NaN and is judged at fs/2
    plain = stability_record(LayerKernel.dynamic(lags, FS), (1, 1), res.max_spring_stiffness, res.force)
    assert np.isnan(plain.margin_stiffness) and plain.limit == pytest.approx(k_fs2)
    assert plain.first_step_past_limit is None


def test_lanczos_path_equals_the_dense_eigenvalue():
    """Above the FFT threshold (21 x 20 elements) lambda_min comes from Lanczos over the FFT product:
    equal to the dense eigenvalue of the same matrix."""
    nx, ny = 21, 20
    dx = np.arange(-(nx - 1), nx)[:, None, None]
    dy = np.arange(-(ny - 1), ny)[None, :, None]
    lag = np.arange(6)[None, None, :]
    # an even kernel whose odd lags outweigh the even ones near the centre: indefinite at fs/2
    g = 1e-5 * np.exp(-0.3 * (dx**2 + dy**2)) * (1.0 + 0.8 * (lag % 2)) * 0.7**lag
    kernel = LayerKernel.dynamic(g, FS)
    k_crit, lam = nyquist_critical_stiffness(kernel, (nx, ny))
    dense = np.linalg.eigvalsh(offset_matrix(nyquist_table(kernel, (nx, ny))))[0]
    assert lam == pytest.approx(dense, rel=1e-7)
    assert lam < 0 and k_crit == pytest.approx(-1 / lam, rel=1e-12)
