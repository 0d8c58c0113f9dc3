"""unfold.tet_mesh against `unfold mesh` on the same mask."""

import meshio
import nibabel as nib
import numpy as np
import pytest

import unfold
from conftest import cli


@pytest.fixture(scope="module")
def mask():
    return unfold.shapes.ellipsoid_mask((12.0, 9.0, 6.0), spacing_mm=1.5)


@pytest.fixture(scope="module")
def both(mask, unfold_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("tet_mesh")
    data, affine = mask
    path = d / "mask.nii.gz"
    nib.save(nib.Nifti1Image(data, affine), path)
    out = cli(unfold_bin, "mesh", path, "-o", d / "mesh.vtu")
    return unfold.tet_mesh(data, affine, name=str(path)), meshio.read(d / "mesh.vtu"), out, path


def test_mesh_equals_the_cli(both):
    result, cli_mesh, _, _ = both
    assert result.points.dtype == np.float64 and result.points.shape[1] == 3
    np.testing.assert_allclose(result.points, cli_mesh.points, rtol=0, atol=1e-12)
    assert set(result.cells) == {"tetra"}
    np.testing.assert_array_equal(result.cells["tetra"], cli_mesh.cells_dict["tetra"])
    assert result.arrays == {}


def test_report_has_the_printed_figures(both):
    result, cli_mesh, out, path = both
    r = result.report
    assert r["mask"] == str(path)
    assert r["quality"]["tets"] == len(cli_mesh.cells_dict["tetra"])
    assert f"{r['quality']['tets']} tets, {r['quality']['vertices']} vertices" in out.stdout
    assert set(r) == {"mask", "mask_voxels", "mask_volume_mm3", "size_mm", "smooth_voxels",
                      "dilate", "level", "graded_collapses", "pinches", "components",
                      "dropped_components", "quality", "provenance"}
    # a smooth ellipsoid touches itself nowhere: nothing to resolve
    assert r["pinches"]["vertices_split"] == 0
    assert r["mask_voxels"] == int(np.count_nonzero(unfold.shapes.ellipsoid_mask(
        (12.0, 9.0, 6.0), spacing_mm=1.5)[0]))


def test_a_nibabel_image_is_a_mask(mask, both):
    result, _, _, path = both
    again = unfold.tet_mesh(nib.load(path), name=str(path))
    np.testing.assert_array_equal(again.points, result.points)
    np.testing.assert_array_equal(again.cells["tetra"], result.cells["tetra"])


def test_options_change_the_mesh(mask):
    data, affine = mask
    coarse = unfold.tet_mesh(data, affine, size_mm=3.0, smooth_voxels=0.0, level=0.5)
    fine = unfold.tet_mesh(data, affine)
    assert len(coarse.cells["tetra"]) < len(fine.cells["tetra"])
    assert coarse.report["size_mm"] == 3.0 and coarse.report["level"] == 0.5


def test_a_label_map_raises_the_cli_message(mask, unfold_bin, tmp_path):
    data, affine = mask
    labels = data.astype(np.float32) * 2.0
    labels[0, 0, 0] = 1.0
    path = tmp_path / "labels.nii.gz"
    nib.save(nib.Nifti1Image(labels, affine), path)
    out = cli(unfold_bin, "mesh", path, "-o", tmp_path / "m.vtu", ok=False)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.tet_mesh(labels, affine, name=str(path))
    assert "holds 2 values besides 0 (1, 2)" in str(e.value)
    assert "(--label N: the voxels equal to N; --threshold T: those above T)" in str(e.value)
    assert f"unfold: error: {e.value}" in out.stderr
    # With the label or a threshold it meshes, the same mesh.
    label = unfold.tet_mesh(labels, affine, label=2)
    above = unfold.tet_mesh(labels, affine, threshold=1.5)
    assert len(label.cells["tetra"]) > 0
    np.testing.assert_array_equal(label.cells["tetra"], above.cells["tetra"])
    with pytest.raises(unfold.UnfoldError, match="no voxel of the mask holds the label 3"):
        unfold.tet_mesh(labels, affine, label=3)
    with pytest.raises(unfold.UnfoldError, match="cannot be used with"):
        unfold.tet_mesh(labels, affine, label=2, threshold=1.0)


def test_any_one_value_besides_0_is_the_mask(mask, both):
    data, affine = mask
    result, _, _, _ = both
    for value in (255.0, 3.0):
        other = unfold.tet_mesh(data.astype(np.float32) * value, affine)
        np.testing.assert_array_equal(other.cells["tetra"], result.cells["tetra"])


@pytest.mark.parametrize("kwargs, flags, message", [
    ({"level": 1.5}, ["--level", "1.5"], "--level must be in (0, 1), got 1.5"),
    ({"size_mm": -1.0}, ["--size-mm", "-1"], "--size-mm must be a finite number > 0, got -1"),
    ({"smooth_voxels": -1.0}, ["--smooth-voxels", "-1"],
     "--smooth-voxels must be a finite number >= 0, got -1"),
])
def test_bad_settings_raise_the_cli_message(mask, unfold_bin, tmp_path, kwargs, flags, message):
    data, affine = mask
    path = tmp_path / "mask.nii.gz"
    nib.save(nib.Nifti1Image(data, affine), path)
    out = cli(unfold_bin, "mesh", path, "-o", tmp_path / "m.vtu", *flags, ok=False)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.tet_mesh(data, affine, **kwargs)
    assert str(e.value) == message
    assert f"unfold: error: {message}" in out.stderr


def test_bad_arrays(mask):
    data, affine = mask
    with pytest.raises(unfold.UnfoldError, match="expected a 3D or 4D array"):
        unfold.tet_mesh(data[0], affine)
    with pytest.raises(unfold.UnfoldError, match="4x4"):
        unfold.tet_mesh(data, affine[:3])
    with pytest.raises(unfold.UnfoldError, match="--dilate must be 0 or 1, got 2"):
        unfold.tet_mesh(data, affine, dilate=2)
    with pytest.raises(unfold.UnfoldError, match="give the mask's 4x4 affine"):
        unfold.tet_mesh(data)
