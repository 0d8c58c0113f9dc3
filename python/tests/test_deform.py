"""unfold.deform against `unfold deform` on the same slab and targets."""

import json

import meshio
import numpy as np
import pytest

import unfold
from conftest import assert_mesh_equal, cli, coords


@pytest.fixture(scope="module")
def problem():
    slab = unfold.shapes.placenta_slab(4)
    p = slab.points
    # The fetal side (side 1) lifted by 1 mm at one end.
    vertices = np.flatnonzero(slab.point_data["side"] == 1)[::3]
    targets = p[vertices] + np.outer(p[vertices, 0] > 0, [0.0, 0.0, 1.0])
    return slab, vertices, targets


def write_targets(path, vertices, targets):
    lines = ["vertex,x,y,z"] + [f"{v},{coords(t)}" for v, t in zip(vertices, targets)]
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def both(problem, unfold_bin, tmp_path_factory):
    slab, vertices, targets = problem
    d = tmp_path_factory.mktemp("deform")
    unfold.write_mesh(d / "slab.vtu", slab)
    write_targets(d / "t.csv", vertices, targets)
    cli(unfold_bin, "deform", d / "slab.vtu", "--targets", d / "t.csv", "-o", d / "out.vtu")
    result = unfold.deform(slab.points, slab.cells["tetra"], vertices, targets,
                           point_data=slab.point_data, name=str(d / "slab.vtu"),
                           targets_name=str(d / "t.csv"))
    return result, d


def test_points_and_arrays_equal_the_cli(both):
    result, d = both
    assert result.points.dtype == np.float64
    assert_mesh_equal(meshio.read(d / "out.vtu"), result.points, result.cells, result.arrays)


def test_report_has_the_cli_keys(both, problem):
    result, d = both
    cli_report = json.loads((d / "out.vtu.report.json").read_text())
    assert set(result.report) == set(cli_report)
    for key in ("mesh", "targets_file", "iterations", "converged", "targets", "repair",
                "end"):
        assert result.report[key] == cli_report[key], key
    assert abs(result.report["objective"] - cli_report["objective"]) <= 1e-12
    assert result.report["provenance"]["interface"] == "python"
    assert result.report["converged"] and result.report["end"]["inverted"] == 0
    _, vertices, targets = problem
    assert np.abs(result.points[vertices] - targets).max() < 0.5


def test_a_cell_dict_and_other_settings(problem):
    slab, vertices, targets = problem
    r = unfold.deform(slab.points, {"tetra": slab.cells["tetra"]}, vertices, targets,
                      energy="arap", weight=10.0)
    assert r.report["energy"] != "symmetric-dirichlet" and r.report["converged"]
    # No input arrays: only where the map is inverted (nowhere).
    assert set(r.arrays) == {"det_j", "inverted"}
    assert (r.arrays["inverted"] == 0).all() and (r.arrays["det_j"] > 0).all()


def test_a_target_out_of_range_raises_the_cli_message(problem, unfold_bin, tmp_path):
    slab, vertices, targets = problem
    n = len(slab.points)
    unfold.write_mesh(tmp_path / "slab.vtu", slab)
    write_targets(tmp_path / "t.csv", [n + 5], targets[:1])
    out = cli(unfold_bin, "deform", tmp_path / "slab.vtu", "--targets", tmp_path / "t.csv",
              "-o", tmp_path / "o.vtu", ok=False)
    message = f"vertex {n + 5} is out of range (the mesh has {n} vertices, numbered from 0)"
    assert message in out.stderr
    with pytest.raises(unfold.UnfoldError, match=r"targets: row 0: vertex \d+ is out of range"):
        unfold.deform(slab.points, slab.cells["tetra"], [n + 5], targets[:1])
    with pytest.raises(unfold.UnfoldError, match="vertex 3 is listed twice"):
        unfold.deform(slab.points, slab.cells["tetra"], [3, 3], targets[:2])


def test_an_inverted_tet_raises_the_cli_message(problem, unfold_bin, tmp_path):
    slab, vertices, targets = problem
    tets = slab.cells["tetra"].copy()
    tets[7, [0, 1]] = tets[7, [1, 0]]
    path = tmp_path / "inv.vtu"
    unfold.write_mesh(path, slab.points, {"tetra": tets})
    write_targets(tmp_path / "t.csv", vertices, targets)
    out = cli(unfold_bin, "deform", path, "--targets", tmp_path / "t.csv",
              "-o", tmp_path / "o.vtu", ok=False)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.deform(slab.points, tets, vertices, targets, name=str(path))
    assert "tet 7 is inverted" in str(e.value)
    assert f"unfold: error: {e.value}" in out.stderr


@pytest.mark.parametrize("kwargs, message", [
    ({"weight": -1.0}, "--weight must be a finite positive number, got -1"),
    ({"tol": float("nan")}, "--tol must be a finite positive number, got NaN"),
    ({"energy": "rigid"}, "--energy must be one of symmetric-dirichlet, mips, arap, area-ratio, got 'rigid'"),
    ({"solver": "lbfgs"}, "--solver must be one of newton, gd, got 'lbfgs'"),
    ({"max_iterations": -1}, "--max-iterations must not be negative, got -1"),
])
def test_bad_settings(problem, kwargs, message):
    slab, vertices, targets = problem
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.deform(slab.points, slab.cells["tetra"], vertices, targets, **kwargs)
    assert str(e.value) == message


def test_triangles_need_a_start(problem):
    slab, vertices, targets = problem
    with pytest.raises(unfold.UnfoldError, match="a triangle mesh is mapped to the plane: give "
                       "its start with init="):
        unfold.deform(slab.points, {"triangle": slab.cells["tetra"][:, :3]}, vertices, targets)


def tangled_grid(n=10):
    """A planar n x n grid (2 n^2 triangles), a start that is a smooth warp
    on the boundary and scrambled inside (so it inverts triangles), and the
    boundary plus one interior vertex as handles, at the warp."""
    xs, ys = np.meshgrid(np.arange(n + 1.0), np.arange(n + 1.0))
    points = np.column_stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)])
    idx = lambda x, y: x + (n + 1) * y
    tris = []
    for y in range(n):
        for x in range(n):
            a, b, c, d = idx(x, y), idx(x + 1, y), idx(x + 1, y + 1), idx(x, y + 1)
            tris += [[a, b, c], [a, c, d]]
    tris = np.array(tris)
    a = 0.08 * n
    warp = np.column_stack([points[:, 0] + a * np.sin(np.pi * points[:, 1] / n),
                            points[:, 1] + a * np.sin(np.pi * points[:, 0] / n)])
    boundary = np.flatnonzero((points[:, 0] % n == 0) | (points[:, 1] % n == 0))
    handles = np.append(boundary, idx(n // 2, n // 2))
    rng = np.random.default_rng(7)
    start = warp + 1.2 * rng.uniform(-1, 1, warp.shape)
    start[handles] = warp[handles]
    return points, tris, start, handles


def signed_areas(p, tris):
    a, b, c = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    return ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
            - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])) / 2


def test_a_tangled_planar_start_gives_an_injective_map_with_exact_handles():
    points, tris, start, handles = tangled_grid()
    assert (signed_areas(start, tris) <= 0).any()
    r = unfold.deform(points, tris, init=start, fixed=handles)
    assert r.report["injective"] and r.report["untangle"]["untangled"]
    assert r.report["start"]["inverted"] > 0 and r.report["end"]["inverted"] == 0
    assert r.report["init"] == "init" and r.report["fixed_file"] == "fixed"
    assert r.report["targets_file"] is None and r.report["repair"] is None
    assert (r.points[:, 2] == 0).all()
    assert (signed_areas(r.points, tris) > 0).all()
    assert (r.points[handles, :2] == start[handles]).all()
    assert (r.cell_data["inverted"] == 0).all() and (r.cell_data["det_j"] > 0).all()
    # The same with the boundary fixed by the flag, and a (n, 3) start.
    interior = handles[-1:]
    s3 = np.column_stack([start, np.zeros(len(start))])
    r2 = unfold.deform(points, {"triangle": tris}, init=s3, fixed=interior, fixed_boundary=True)
    assert r2.report["fixed"] == len(handles)
    assert np.array_equal(r2.points, r.points)


@pytest.mark.parametrize("init, message", [
    (np.zeros((5, 2)), r"init: expected shape \(121, 3\) or, for triangles, \(121, 2\), got \(5, 2\)"),
    (np.zeros((121, 4)), r"got \(121, 4\)"),
    (np.zeros(121), r"got \(121,\)"),
])
def test_a_bad_init_shape_raises_value_error(init, message):
    points, tris, _, handles = tangled_grid()
    with pytest.raises(ValueError, match=message):
        unfold.deform(points, tris, init=init, fixed=handles)


def test_bad_starts_and_handles_raise_the_cli_messages():
    points, tris, start, handles = tangled_grid()
    s3 = np.column_stack([start, np.zeros(len(start))])
    s3[4, 2] = 0.5
    with pytest.raises(unfold.UnfoldError, match="init: vertex 4 has z = 5e-1; a triangle mesh"):
        unfold.deform(points, tris, init=s3, fixed=handles)
    with pytest.raises(unfold.UnfoldError, match="fixed: row 1: vertex 0 is listed twice"):
        unfold.deform(points, tris, init=start, fixed=[0, 0])
    with pytest.raises(unfold.UnfoldError, match="fixed: row 0: vertex 121 is out of range"):
        unfold.deform(points, tris, init=start, fixed=[121])
    with pytest.raises(unfold.UnfoldError, match="nothing to do"):
        unfold.deform(points, tris)
