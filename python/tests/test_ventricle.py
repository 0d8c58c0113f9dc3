"""unfold.ventricle against `unfold ventricle` on the demo's cup."""

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


def landmark_flags(cup):
    return ["--anterior", coords(cup.anterior), "--inferior", coords(cup.inferior),
            "--apex", coords(cup.apex)]


@pytest.fixture(scope="module")
def both(cup, unfold_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("ventricle")
    unfold.write_mesh(d / "s.vtu", cup.surface)
    unfold.write_mesh(d / "anatomy.vtu", cup.anatomy)
    cli(unfold_bin, "ventricle", d / "anatomy.vtu", "--surface", d / "s.vtu",
        *landmark_flags(cup), "--grid-mm", GRID, "--to-hemisphere", 30, "-o", d / "out",
        "--no-figures")
    s = cup.surface
    result = unfold.ventricle(s.points, s.cells["triangle"], anterior=cup.anterior,
                              inferior=cup.inferior, apex=cup.apex, anatomy=cup.anatomy,
                              grid_mm=GRID, to_hemisphere=30.0,
                              anatomy_name=str(d / "anatomy.vtu"), surface_name=str(d / "s.vtu"))
    return result, d / "out"


def test_normalized_equals_the_cli(both):
    result, out = both
    assert result.points.dtype == np.float64
    assert_mesh_equal(meshio.read(out / "normalized.vtu"), result.points, result.cells,
                      result.arrays)
    assert {"xi", "zeta", "depth", "aha"} <= set(result.arrays)


@pytest.mark.parametrize("attr, file", [("anatomy", "anatomy.vtu"), ("disk", "disk.vtu"),
                                        ("transferred", "transferred.vtu")])
def test_other_meshes_equal_the_cli(both, attr, file):
    result, out = both
    m = getattr(result, attr)
    assert_mesh_equal(meshio.read(out / file), m.points, m.cells, {**m.point_data, **m.cell_data})


def test_report_has_the_cli_keys(both):
    result, out = both
    cli_report = json.loads((out / "report.json").read_text())
    assert set(result.report) == set(cli_report)
    assert result.report["inputs"] == cli_report["inputs"]
    assert set(result.report["transfer"]) == set(cli_report["transfer"])
    assert set(result.report["memory"]) == set(cli_report["memory"])
    assert result.report["anatomy_points"] == cli_report["anatomy_points"]
    assert result.report["aha_points"] == cli_report["aha_points"]


def test_points_and_no_anatomy(cup):
    s = cup.surface
    pts = unfold.ventricle(s.points, s.cells["triangle"], anterior=cup.anterior,
                           inferior=cup.inferior, anatomy=cup.anatomy_points, grid_mm=GRID)
    assert pts.points.shape == cup.anatomy_points.shape
    assert pts.cells["vertex"].shape == (len(cup.anatomy_points), 1)
    assert pts.transferred is None and "transfer" not in pts.report
    own = unfold.ventricle(s.points, s.cells["triangle"], anterior=cup.anterior,
                           inferior=cup.inferior, grid_mm=GRID)
    assert own.points.shape == s.points.shape


def test_bad_grid_raises_the_cli_message(cup, unfold_bin, tmp_path):
    unfold.write_mesh(tmp_path / "s.vtu", cup.surface)
    out = cli(unfold_bin, "ventricle", tmp_path / "s.vtu", "--surface", tmp_path / "s.vtu",
              *landmark_flags(cup), "--grid-mm", "-1", "-o", tmp_path / "o", ok=False)
    s = cup.surface
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.ventricle(s.points, s.cells["triangle"], anterior=cup.anterior,
                         inferior=cup.inferior, grid_mm=-1.0)
    assert str(e.value) == "--grid-mm must be a finite number > 0, got -1"
    assert f"unfold: error: {e.value}" in out.stderr


def test_a_landmark_off_the_rim_raises_the_cli_message(cup, unfold_bin, tmp_path):
    unfold.write_mesh(tmp_path / "s.vtu", cup.surface)
    far = np.asarray(cup.anterior) + [0.0, 0.0, -50.0]
    out = cli(unfold_bin, "ventricle", tmp_path / "s.vtu", "--surface", tmp_path / "s.vtu",
              "--anterior", coords(far), "--inferior", coords(cup.inferior),
              "--grid-mm", GRID, "-o", tmp_path / "o", ok=False)
    s = cup.surface
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.ventricle(s.points, s.cells["triangle"], anterior=far, inferior=cup.inferior,
                         grid_mm=GRID, anatomy_name=str(tmp_path / "s.vtu"),
                         surface_name=str(tmp_path / "s.vtu"))
    assert f"unfold: error: {e.value}" in out.stderr


def test_bad_inputs(cup):
    s = cup.surface
    kw = {"anterior": cup.anterior, "inferior": cup.inferior}
    with pytest.raises(unfold.UnfoldError, match="--chamber must be one of lv, rv, got 'la'"):
        unfold.ventricle(s.points, s.cells["triangle"], chamber="la", **kw)
    with pytest.raises(unfold.UnfoldError, match="anterior must be three coordinates"):
        unfold.ventricle(s.points, s.cells["triangle"], anterior=[1.0, 2.0],
                         inferior=cup.inferior)
    with pytest.raises(unfold.UnfoldError, match="needs --to-anterior and --to-inferior"):
        unfold.ventricle(s.points, s.cells["triangle"], to_surface=s, **kw)
    with pytest.raises(unfold.UnfoldError, match="surface triangles must have shape"):
        unfold.ventricle(s.points, s.cells["triangle"][:, :2], **kw)


def test_a_transfer_to_a_second_surface_equals_the_cli(cup, unfold_bin, tmp_path):
    # The second heart: the cup scaled by 1.2 about the origin (its landmarks with it).
    s = cup.surface
    s2 = unfold.Mesh(s.points * 1.2, s.cells)
    unfold.write_mesh(tmp_path / "s.vtu", s)
    unfold.write_mesh(tmp_path / "s2.vtu", s2)
    pts = cup.anatomy_points[::4]
    unfold.write_mesh(tmp_path / "pts.vtu", pts, {"vertex": np.arange(len(pts))[:, None]})
    cli(unfold_bin, "ventricle", tmp_path / "pts.vtu", "--surface", tmp_path / "s.vtu",
        *landmark_flags(cup), "--grid-mm", GRID, "--to-surface", tmp_path / "s2.vtu",
        "--to-anterior", coords(cup.anterior * 1.2), "--to-inferior", coords(cup.inferior * 1.2),
        "-o", tmp_path / "out", "--no-figures")
    r = unfold.ventricle(s.points, s.cells["triangle"], anterior=cup.anterior,
                         inferior=cup.inferior, apex=cup.apex, anatomy=pts, grid_mm=GRID,
                         to_surface=s2, to_anterior=cup.anterior * 1.2,
                         to_inferior=cup.inferior * 1.2, to_name=str(tmp_path / "s2.vtu"))
    t = r.transferred
    assert_mesh_equal(meshio.read(tmp_path / "out" / "transferred.vtu"), t.points, t.cells,
                      {**t.point_data, **t.cell_data})
    assert r.report["transfer"]["surface"] == str(tmp_path / "s2.vtu")
    # Scaling the heart scales the carried points (to the grid's accuracy).
    assert np.abs(t.points - 1.2 * pts).max() < 0.5 * GRID


BUILT_FLAGS = ["--surface-voxel-mm", 1, "--surface-margin-mm", 2]


def test_s_built_from_the_anatomy_equals_the_cli(cup, unfold_bin, tmp_path):
    # The cup's own wall as the anatomy (an open surface): S is built outside it.
    anatomy = tmp_path / "wall.vtu"
    unfold.write_mesh(anatomy, cup.surface)
    cli(unfold_bin, "ventricle", anatomy, *landmark_flags(cup), *BUILT_FLAGS,
        "--grid-mm", GRID, "-o", tmp_path / "out", "--no-figures")
    r = unfold.ventricle(anatomy=cup.surface, anterior=cup.anterior, inferior=cup.inferior,
                         apex=cup.apex, surface_voxel_mm=1, surface_margin_mm=2,
                         grid_mm=GRID, anatomy_name=str(anatomy))
    out = tmp_path / "out"
    assert_mesh_equal(meshio.read(out / "normalized.vtu"), r.points, r.cells, r.arrays)
    s = r.surface
    assert_mesh_equal(meshio.read(out / "surface.vtu"), s.points, s.cells,
                      {**s.point_data, **s.cell_data})
    cli_report = json.loads((out / "report.json").read_text())
    assert set(r.report) == set(cli_report)
    assert r.report["inputs"] == cli_report["inputs"]
    assert r.report["inputs"]["surface"] == f"S built from {anatomy}"
    built = {k: v for k, v in r.report["enclosing_surface"].items() if k != "seconds"}
    assert built == {k: v for k, v in cli_report["enclosing_surface"].items() if k != "seconds"}
    assert built["voxel_mm"] == 1.0 and built["margin_mm"] == 2.0
    assert r.report["anatomy_points"] == len(cup.surface.points)


def test_a_given_s_has_no_built_surface(both):
    result, _ = both
    assert result.surface is None
    assert "enclosing_surface" not in result.report


def test_bad_inputs_of_a_built_s(cup, unfold_bin, tmp_path):
    s = cup.surface
    kw = {"anterior": cup.anterior, "inferior": cup.inferior}
    with pytest.raises(unfold.UnfoldError, match="give both points and triangles of S"):
        unfold.ventricle(s.points, anatomy=s, **kw)
    with pytest.raises(unfold.UnfoldError, match="or the anatomy to build it from"):
        unfold.ventricle(**kw)
    with pytest.raises(unfold.UnfoldError, match="are for S built from the anatomy"):
        unfold.ventricle(s.points, s.cells["triangle"], surface_voxel_mm=1.0, **kw)
    anatomy = tmp_path / "wall.vtu"
    unfold.write_mesh(anatomy, s)
    out = cli(unfold_bin, "ventricle", anatomy, *landmark_flags(cup),
              "--surface-voxel-mm", "-1", "-o", tmp_path / "o", ok=False)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.ventricle(anatomy=s, surface_voxel_mm=-1.0, **kw)
    assert str(e.value) == "--surface-voxel-mm must be a finite number > 0, got -1"
    assert f"unfold: error: {e.value}" in out.stderr


def test_a_cup_in_metres_is_named(cup):
    s = cup.surface
    anatomy = unfold.Mesh(cup.anatomy.points / 1000.0, cup.anatomy.cells)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.ventricle(s.points / 1000.0, s.cells["triangle"],
                         anterior=np.asarray(cup.anterior) / 1000.0,
                         inferior=np.asarray(cup.inferior) / 1000.0,
                         anatomy=anatomy, grid_mm=GRID, anatomy_name="cup_m")
    assert "; note: cup_m is only 0.0" in str(e.value)
    assert "reads coordinates as millimetres" in str(e.value)
    assert "if it is in metres, multiply the points by 1000" in str(e.value)


def test_a_cup_in_centimetres_is_named_as_such(cup):
    s = cup.surface
    anatomy = unfold.Mesh(cup.anatomy.points / 10.0, cup.anatomy.cells)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.ventricle(s.points / 10.0, s.cells["triangle"],
                         anterior=np.asarray(cup.anterior) / 10.0,
                         inferior=np.asarray(cup.inferior) / 10.0,
                         anatomy=anatomy, grid_mm=GRID, anatomy_name="cup_cm")
    assert "; note: cup_cm is only " in str(e.value)
    assert "if it is in centimetres, multiply the points by 10" in str(e.value)
