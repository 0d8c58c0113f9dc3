"""unfold.ventricle_inverse against `unfold ventricle-inverse` on the demo's cup."""

import json

import meshio
import numpy as np
import pytest

import unfold
from conftest import assert_mesh_equal, coords, cli

GRID = 2.0


@pytest.fixture(scope="module")
def cup():
    return unfold.shapes.ventricle_cup()


@pytest.fixture(scope="module")
def forward(cup):
    s = cup.surface
    return unfold.ventricle(s.points, s.cells["triangle"], anterior=cup.anterior,
                            inferior=cup.inferior, apex=cup.apex, anatomy=cup.anatomy,
                            grid_mm=GRID)


def heart(cup):
    s = cup.surface
    return (s.points, s.cells["triangle"]), {"anterior": cup.anterior,
                                             "inferior": cup.inferior, "apex": cup.apex}


def test_equals_the_cli_and_undoes_the_forward_map(cup, forward, unfold_bin, tmp_path):
    unfold.write_mesh(tmp_path / "s.vtu", cup.surface)
    unfold.write_mesh(tmp_path / "normalized.vtu", forward.mesh)
    cli(unfold_bin, "ventricle-inverse", tmp_path / "normalized.vtu", "--surface",
        tmp_path / "s.vtu", "--anterior", coords(cup.anterior), "--inferior",
        coords(cup.inferior), "--apex", coords(cup.apex), "--grid-mm", GRID, "--layers", 4,
        "-o", tmp_path / "out")
    (p, t), kw = heart(cup)
    r = unfold.ventricle_inverse(forward.mesh, p, t, grid_mm=GRID, layers=4,
                                 normalized_name=str(tmp_path / "normalized.vtu"),
                                 surface_name=str(tmp_path / "s.vtu"), **kw)
    assert_mesh_equal(meshio.read(tmp_path / "out" / "mapped.vtu"), r.points, r.cells,
                      r.arrays)
    cli_report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert set(r.report) == set(cli_report)
    for key in ["inputs", "points", "mapped", "failed", "failures", "grid_mm", "apex_mm"]:
        assert r.report[key] == cli_report[key], key
    assert r.report["provenance"]["interface"] == "python"
    # psi^-1(psi(v)) = v: the anatomy comes back where it was
    assert r.report["failed"] == 0
    assert np.all(r.arrays["inverse_status"] == 0)
    assert np.abs(r.points - cup.anatomy.points).max() < 1e-3
    assert set(np.unique(r.arrays["layer"])) <= {1, 2, 3, 4}
    # the triangles and every array of the input come along
    assert np.array_equal(r.cells["triangle"], forward.cells["triangle"])
    assert np.array_equal(r.arrays["aha"], forward.arrays["aha"])


def test_points_in_the_cylinder_read_as_x_y_depth(cup, forward):
    (p, t), kw = heart(cup)
    # the normalized points themselves, without their arrays: the displayed disk
    r = unfold.ventricle_inverse(forward.points, p, t, grid_mm=GRID, **kw)
    assert r.report["inputs"]["coordinates"] == "points"
    assert r.cells["vertex"].shape == (len(forward.points), 1)
    assert np.abs(r.points - cup.anatomy.points).max() < 1e-3
    # a point off the cylinder gets a status, the others are mapped
    bad = np.vstack([forward.points, [[0.0, 0.0, 2.0]]])
    r = unfold.ventricle_inverse(bad, p, t, grid_mm=GRID, **kw)
    assert r.report["failed"] == 1 and r.arrays["inverse_status"][-1] == 1


def test_bad_inputs_raise_the_cli_message(cup, forward, unfold_bin, tmp_path):
    (p, t), kw = heart(cup)
    with pytest.raises(unfold.UnfoldError,
                       match="--coordinates must be one of auto, arrays, points, got 'xyz'"):
        unfold.ventricle_inverse(forward.mesh, p, t, coordinates="xyz", **kw)
    with pytest.raises(unfold.UnfoldError, match="--layers must be between 1 and 100, got 0"):
        unfold.ventricle_inverse(forward.mesh, p, t, layers=0, **kw)
    # one of the three arrays alone: the command line's message
    only_xi = unfold.Mesh(forward.points, forward.cells, {"xi": forward.arrays["xi"]})
    unfold.write_mesh(tmp_path / "s.vtu", cup.surface)
    unfold.write_mesh(tmp_path / "xi.vtu", only_xi)
    out = cli(unfold_bin, "ventricle-inverse", tmp_path / "xi.vtu", "--surface",
              tmp_path / "s.vtu", "--anterior", coords(cup.anterior), "--inferior",
              coords(cup.inferior), "-o", tmp_path / "o", ok=False)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.ventricle_inverse(only_xi, p, t, normalized_name=str(tmp_path / "xi.vtu"), **kw)
    assert "but not all of xi, zeta, depth" in str(e.value)
    assert f"unfold: error: {e.value}" in out.stderr
    # nothing maps: every point off the cylinder
    with pytest.raises(unfold.UnfoldError, match="none of its 2 points maps onto the heart"):
        unfold.ventricle_inverse(np.array([[0.0, 0.0, 3.0], [0.0, 0.0, -1.0]]), p, t,
                                 grid_mm=GRID, **kw)
