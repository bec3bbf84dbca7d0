"""tyreroad.fe_pattern: FE influence matrix of a tread block (issue 27, patterned treads, must-show 2)."""

import numpy as np
import pytest
import yaml

skfem = pytest.importorskip("skfem")

from tyreroad import fe_pattern as fp  # noqa: E402
from tyreroad import greens  # noqa: E402
from tyreroad.pipeline import _material, resolved_material_config  # noqa: E402

C = 1e-3


@pytest.fixture(scope="module")
def tread():
    cfg = yaml.safe_load(open("config/config.yaml"))
    return _material("tread", resolved_material_config("tread", cfg["materials"]))


def test_pattern_validation_names_the_field():
    with pytest.raises(ValueError, match="block_length.*whole multiple"):
        fp.TreadPattern(20.5e-3, 20e-3, 5e-3, 10e-3)
    with pytest.raises(ValueError, match="groove_width.*whole multiple"):
        fp.TreadPattern(20e-3, 20e-3, 2.5e-3, 10e-3)
    with pytest.raises(ValueError, match="block_width.*> 0"):
        fp.TreadPattern(20e-3, 0.0, 5e-3, 10e-3)
    with pytest.raises(ValueError, match="groove_depth.*>= 0"):
        fp.TreadPattern(20e-3, 20e-3, 5e-3, -1e-3)
    with pytest.raises(ValueError, match="groove_depth.*exceeds the tread thickness"):
        fp.TreadPattern(20e-3, 20e-3, 5e-3, 12e-3).check_thickness(10e-3)
    with pytest.raises(ValueError, match="per_element"):
        fp.BlockMesh(per_element=0)
    with pytest.raises(ValueError, match="undertread_edge"):
        fp.BlockMesh(undertread_edge="rollers")
    p = fp.TreadPattern(20e-3, 12e-3, 5e-3, 10e-3)
    assert p.shape == (20, 12) and not p.has_undertread(10e-3) and fp.TreadPattern(
        20e-3, 12e-3, 5e-3, 6e-3).has_undertread(10e-3)
    xy = fp.element_centres(p)
    assert xy.shape == (240, 2)
    np.testing.assert_allclose(xy[12 * 3 + 5], [3.5e-3, 5.5e-3])  # row-major over x then y


@pytest.mark.parametrize("depth", [10e-3, 6e-3])
def test_quarter_model_equals_full_cell_and_mean_field_is_reciprocal(tread, depth):
    """The four symmetry classes recombine to the full cell's influence (without symmetry; periodic ties at the
    undertread's cell boundary) to round-off, on an odd x even block (the middle column straddles the mirror
    plane). Element-mean displacements are reciprocal (G = G^T to round-off); centre values only nearly so."""
    pat = fp.TreadPattern(5e-3, 4e-3, 2e-3, depth)
    mesh = fp.BlockMesh(per_element=2, coarse=3e-3)
    _, g4 = fp.block_static_influence(pat, tread, mesh)
    _, g1 = fp.block_static_influence(pat, tread, mesh, symmetry=False)
    _, gm = fp.block_static_influence(pat, tread, mesh, field="mean")
    assert np.abs(g4 - g1).max() < 1e-9 * np.abs(g1).max()
    assert np.abs(gm - gm.T).max() < 1e-10 * np.abs(gm).max()
    asym = np.abs(g4 - g4.T).max() / np.abs(g4).max()
    assert 1e-4 < asym < 0.03, asym  # measured 1.0 % (depth 10 mm) and 1.4 % (6 mm) on a 1-per-element mesh
    assert np.all(np.diag(g4) > 0)
    # the block's two mirror symmetries
    n = pat.shape
    d = np.diag(g4).reshape(n)
    np.testing.assert_allclose(d, d[::-1, :], rtol=1e-9)
    np.testing.assert_allclose(d, d[:, ::-1], rtol=1e-9)
