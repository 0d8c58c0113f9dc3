"""unfold.cohort.compare on a tiny generated two-group placenta study against the files
`unfold cohort --compare` writes."""

import json

import nibabel as nib
import numpy as np
import pytest

import unfold
from conftest import cli


def image(points, k, brighter):
    """An image around the points at 4 mm: 100 plus noise (seeded by k), 5 more where
    x > 0 when `brighter`."""
    spacing = 4.0
    lo, hi = points.min(0) - 6.0, points.max(0) + 6.0
    n = np.ceil((hi - lo) / spacing).astype(int) + 1
    affine = np.diag([spacing, spacing, spacing, 1.0])
    affine[:3, 3] = lo
    ijk = np.stack(np.meshgrid(*[np.arange(m) for m in n], indexing="ij"), -1)
    xyz = ijk * spacing + lo
    data = 100.0 + np.random.default_rng(k).uniform(-1.0, 1.0, size=tuple(n))
    if brighter:
        data += np.where(xyz[..., 0] > 0.0, 5.0, 0.0)
    return data.astype(np.float32), affine


@pytest.fixture(scope="module")
def study(unfold_bin, tmp_path_factory):
    """Eight slabs (two sizes), groups A and B (B brighter in one half), run by `unfold batch`."""
    d = tmp_path_factory.mktemp("study")
    rows = ["id,organ,input,image,spacing-mm,no-figures,group,age"]
    for k in range(8):
        mesh = unfold.shapes.placenta_slab(3 + k % 2)
        unfold.write_mesh(d / f"p{k}.vtu", mesh)
        data, affine = image(mesh.points, k, brighter=k >= 4)
        (d / f"p{k}").mkdir()
        nib.save(nib.Nifti1Image(data, affine), d / f"p{k}" / "t2.nii.gz")
        group = "B" if k >= 4 else "A"
        rows.append(f"p{k},placenta,p{k}.vtu,p{k}/t2.nii.gz,4,true,{group},{30 + k % 3}")
    (d / "manifest.csv").write_text("\n".join(rows) + "\n")
    cli(unfold_bin, "batch", d / "manifest.csv", "-o", d / "out", "--jobs", "2")
    return d / "out"


def test_compare_returns_the_maps_and_summary(study):
    r = unfold.cohort.compare(study, "group", covariates=["age"], permutations=200, seed=1)
    summary = r["compare"]
    stats = study / "cohort" / "stats"
    assert summary == json.loads((stats / "compare.json").read_text())
    assert (summary["column"], summary["kind"], summary["covariates"]) == (
        "group", "categorical", ["age"])
    (a,) = summary["analyses"]
    assert a["groups"] == {"A": 4, "B": 4}
    assert a["design"].startswith("t: B - A (2 groups: A 4, B 4), covariates age")
    assert a["significant"] > 0
    assert list(r["images"]) == ["t2"]
    name = "t2"
    m = r["images"][name]
    assert set(m) == {"t", "p", "pfwe", "affine"}
    for key, suffix in (("t", "t"), ("p", "p"), ("pfwe", "pfwe")):
        f = nib.load(stats / f"{name}_group_{suffix}.nii.gz")
        assert m[key].shape == f.shape
        np.testing.assert_array_equal(m[key], np.asarray(f.dataobj, dtype=np.float32))
    np.testing.assert_allclose(m["affine"], f.affine, atol=1e-5)
    untested = np.isnan(m["t"])
    assert untested.any() and (~untested).sum() == a["tested"]
    assert np.all(m["pfwe"][untested] == 1.0) and np.all(m["p"][untested] == 1.0)
    assert (m["pfwe"][~untested] < 0.05).sum() == a["significant"]
    assert r["ventricle"] == [] and r["mitral"] == [] and r["mitral_segments"] == []
    again = unfold.cohort.compare(study, "group", covariates="age", permutations=200, seed=1)
    np.testing.assert_array_equal(again["images"][name]["pfwe"], m["pfwe"])


def test_bad_columns_raise_the_command_lines_message(study):
    with pytest.raises(unfold.UnfoldError, match="--compare site: not a column"):
        unfold.cohort.compare(study, "site")
    with pytest.raises(unfold.UnfoldError, match="'group' is not numeric"):
        unfold.cohort.compare(study, "age", covariates=["group"])
    with pytest.raises(unfold.UnfoldError, match="permutations must be"):
        unfold.cohort.compare(study, "group", permutations=0)
