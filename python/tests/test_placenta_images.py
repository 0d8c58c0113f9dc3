"""unfold.placenta with images against `unfold placenta --image` on the same slab."""

import nibabel as nib
import numpy as np
import pytest

import unfold
from conftest import cli


@pytest.fixture(scope="module")
def slab():
    return unfold.shapes.placenta_slab(5)


def mri(points, spacing=2.0, shift=0.0):
    """A 3D image around the points: bright (about 200) in their bounding box, 20 outside,
    plus a smooth ramp; voxel-to-RAS affine with the given spacing."""
    lo, hi = points.min(0) - 6.0, points.max(0) + 6.0
    n = np.ceil((hi - lo) / spacing).astype(int) + 1
    affine = np.diag([spacing, spacing, spacing, 1.0])
    affine[:3, 3] = lo + [shift, 0.0, 0.0]
    # NIfTI stores the affine as float32: the command line reads the rounded one.
    affine = affine.astype(np.float32).astype(np.float64)
    ijk = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1)
    xyz = ijk * spacing + affine[:3, 3]
    inside = np.all((xyz >= points.min(0)) & (xyz <= points.max(0)), axis=-1)
    data = np.where(inside, 200.0, 20.0) + 0.3 * xyz[..., 0] + 0.1 * xyz[..., 1] + xyz[..., 2]
    return data.astype(np.float32), affine


def assert_same_affine(ours, file_affine):
    """The file holds the affine rounded to float32 (NIfTI's srow)."""
    np.testing.assert_array_equal(ours.astype(np.float32), file_affine.astype(np.float32))


@pytest.fixture(scope="module")
def both(slab, unfold_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("placenta_images")
    unfold.write_mesh(d / "slab.vtu", slab)
    data, affine = mri(slab.points)
    labels = (data > 100).astype(np.float32) * 3.0
    nib.save(nib.Nifti1Image(data, affine), d / "mri.nii.gz")
    nib.save(nib.Nifti1Image(labels, affine), d / "labels.nii.gz")
    cli(unfold_bin, "placenta", d / "slab.vtu", "--image", d / "mri.nii.gz", "-o", d / "lin",
        "--no-figures", "--spacing-mm", 2.5)
    cli(unfold_bin, "placenta", d / "slab.vtu", "--image", d / "labels.nii.gz", "-o", d / "nn",
        "--no-figures", "--interp", "nearest")
    lin = unfold.placenta(slab.points, slab.cells["tetra"], images={"mri": (data, affine)},
                          spacing_mm=2.5, name=str(d / "slab.vtu"))
    nn = unfold.placenta(slab.points, slab.cells["tetra"],
                         images={"labels": nib.load(d / "labels.nii.gz")}, interp="nearest",
                         name=str(d / "slab.vtu"))
    return lin, nn, d


def test_linear_image_equals_the_cli(both):
    lin, _, d = both
    cli_img = nib.load(d / "lin" / "mri_flat.nii.gz")
    data, affine = lin.images["mri"]
    assert data.shape == cli_img.shape and data.dtype == np.float32
    np.testing.assert_allclose(data, cli_img.get_fdata(), rtol=0, atol=1e-12)
    assert_same_affine(affine, cli_img.affine)
    np.testing.assert_allclose(np.diag(affine)[:3], 2.5)
    assert np.count_nonzero(data) > 0


def test_nearest_image_equals_the_cli(both):
    _, nn, d = both
    cli_img = nib.load(d / "nn" / "labels_flat.nii.gz")
    data, affine = nn.images["labels"]
    np.testing.assert_array_equal(data, cli_img.get_fdata())
    assert_same_affine(affine, cli_img.affine)
    assert set(np.unique(data)) <= {0.0, 3.0}


def test_points_and_report_equal_the_cli(both):
    import json

    import meshio

    lin, _, d = both
    np.testing.assert_allclose(lin.points, meshio.read(d / "lin" / "flattened.vtu").points,
                               rtol=0, atol=1e-12)
    cli_report = json.loads((d / "lin" / "report.json").read_text())
    assert set(lin.report) == set(cli_report)
    assert [i["name"] for i in lin.report["images"]] == ["mri"]
    assert set(lin.report["images"][0]) <= set(cli_report["images"][0])


def test_an_image_away_from_the_mesh_fails_like_the_cli(slab, unfold_bin, tmp_path):
    data, affine = mri(slab.points, shift=500.0)
    unfold.write_mesh(tmp_path / "slab.vtu", slab)
    nib.save(nib.Nifti1Image(data, affine), tmp_path / "far.nii.gz")
    out = cli(unfold_bin, "placenta", tmp_path / "slab.vtu", "--image", tmp_path / "far.nii.gz",
              "-o", tmp_path / "o", ok=False)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.placenta(slab.points, slab.cells["tetra"], images={"far": (data, affine)})
    assert "far" in str(e.value)
    # The same message, the image named by its path on the command line.
    line = next(l for l in out.stderr.splitlines() if l.startswith("unfold: error:"))
    assert line.replace(str(tmp_path / "far.nii.gz"), "far").replace(
        str(tmp_path / "slab.vtu"), "mesh") == f"unfold: error: {e.value}"


def test_bad_images(slab):
    data, affine = mri(slab.points)
    with pytest.raises(unfold.UnfoldError, match="expected a 3D or 4D array"):
        unfold.placenta(slab.points, slab.cells["tetra"], images={"a": (data[0], affine)})
    with pytest.raises(unfold.UnfoldError, match="expected \\(data, affine\\) or a nibabel image"):
        unfold.placenta(slab.points, slab.cells["tetra"], images={"a": data})
    with pytest.raises(unfold.UnfoldError, match="images must be a dict"):
        unfold.placenta(slab.points, slab.cells["tetra"], images=[(data, affine)])
    with pytest.raises(unfold.UnfoldError, match="--interp must be one of linear, nearest"):
        unfold.placenta(slab.points, slab.cells["tetra"], interp="cubic")


def test_a_4d_image_keeps_its_frames(slab):
    data, affine = mri(slab.points)
    series = np.stack([data, 2.0 * data], axis=-1)
    r = unfold.placenta(slab.points, slab.cells["tetra"],
                        images={"series": (series, affine), "mri": (data, affine)},
                        spacing_mm=4.0)
    pulled, _ = r.images["series"]
    assert pulled.ndim == 4 and pulled.shape[3] == 2
    np.testing.assert_allclose(pulled[..., 1], 2.0 * pulled[..., 0], rtol=1e-6)
    np.testing.assert_array_equal(pulled[..., 0], r.images["mri"][0])
    assert [i["name"] for i in r.report["images"]] == ["series", "mri"]
