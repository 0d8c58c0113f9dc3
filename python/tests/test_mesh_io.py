"""read_mesh / write_mesh against meshio reading and writing the same files."""

import meshio
import numpy as np
import pytest

import unfold


def slab():
    return unfold.shapes.placenta_slab(4)


@pytest.mark.parametrize("ext", ["vtu", "vtk"])
def test_written_files_read_in_meshio(tmp_path, ext):
    m = slab()
    rng = np.random.default_rng(1)
    ntet = len(m.cells["tetra"])
    vec = rng.normal(size=(len(m.points), 3))
    scal = rng.normal(size=ntet)
    path = tmp_path / f"slab.{ext}"
    unfold.write_mesh(path, m.points, {"tetra": m.cells["tetra"]},
                      point_data={"side": m.point_data["side"], "vec": vec},
                      cell_data={"scal": scal})
    mm = meshio.read(path)
    np.testing.assert_array_equal(mm.points, m.points)
    np.testing.assert_array_equal(mm.cells_dict["tetra"], m.cells["tetra"])
    np.testing.assert_array_equal(mm.point_data["side"].ravel(), m.point_data["side"])
    np.testing.assert_array_equal(mm.point_data["vec"], vec)
    np.testing.assert_array_equal(mm.cell_data["scal"][0].ravel(), scal)


@pytest.mark.parametrize("ext", ["vtu", "vtk"])
def test_meshio_files_read_back(tmp_path, ext):
    rng = np.random.default_rng(2)
    points = rng.normal(size=(6, 3))
    tris = np.array([[0, 1, 2], [2, 3, 4]])
    lines = np.array([[4, 5]])
    path = tmp_path / f"mixed.{ext}"
    meshio.write(path, meshio.Mesh(points, [("triangle", tris), ("line", lines)],
                                   point_data={"t": np.arange(6.0)},
                                   cell_data={"c": [np.array([1.5, 2.5]), np.array([3.5])]}))
    m = unfold.read_mesh(path)
    np.testing.assert_array_equal(m.points, points)
    np.testing.assert_array_equal(m.cells["triangle"], tris)
    np.testing.assert_array_equal(m.cells["line"], lines)
    assert m.cells["triangle"].dtype == np.int64 and m.points.dtype == np.float64
    np.testing.assert_array_equal(m.point_data["t"], np.arange(6.0))
    np.testing.assert_array_equal(m.cell_data["c"], [1.5, 2.5, 3.5])


@pytest.mark.parametrize("ext", ["vtu", "vtk", "ply", "obj", "stl", "mesh"])
def test_round_trip_every_format(tmp_path, ext):
    rng = np.random.default_rng(3)
    points = rng.normal(size=(5, 3))
    tris = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    path = tmp_path / f"tris.{ext}"
    unfold.write_mesh(path, points, {"triangle": tris})
    m = unfold.read_mesh(path)
    assert m.cells["triangle"].shape == (3, 3)
    # STL is float32 and unindexed: compare geometry of the triangles.
    tol = 1e-6 if ext == "stl" else 1e-12
    np.testing.assert_allclose(m.points[m.cells["triangle"]], points[tris], atol=tol)


def test_mesh_object_round_trip(tmp_path):
    m = slab()
    unfold.write_mesh(tmp_path / "a.vtu", m)
    back = unfold.read_mesh(tmp_path / "a.vtu")
    np.testing.assert_array_equal(back.points, m.points)
    np.testing.assert_array_equal(back.cells["tetra"], m.cells["tetra"])
    np.testing.assert_array_equal(back.point_data["side"], m.point_data["side"])


def test_bad_inputs_raise_unfold_error(tmp_path):
    points = np.zeros((3, 3))
    with pytest.raises(unfold.UnfoldError, match="refers to point 7, but there are 3 points"):
        unfold.write_mesh(tmp_path / "x.vtu", points, {"triangle": np.array([[0, 1, 7]])})
    with pytest.raises(unfold.UnfoldError, match="unknown cell type 'triangles'"):
        unfold.write_mesh(tmp_path / "x.vtu", points, {"triangles": np.array([[0, 1, 2]])})
    with pytest.raises(unfold.UnfoldError, match="has 4 columns, a triangle cell has 3"):
        unfold.write_mesh(tmp_path / "x.vtu", points, {"triangle": np.array([[0, 1, 2, 0]])})
    with pytest.raises(unfold.UnfoldError, match="missing.vtu"):
        unfold.read_mesh(tmp_path / "missing.vtu")
    assert issubclass(unfold.UnfoldError, ValueError)
    assert not (tmp_path / "x.vtu").exists()


def test_unwritable_format_says_what_to_write(tmp_path):
    with pytest.raises(unfold.UnfoldError, match="write .vtu or .mesh instead"):
        unfold.write_mesh(tmp_path / "x.msh", np.zeros((3, 3)), {"triangle": np.array([[0, 1, 2]])})
