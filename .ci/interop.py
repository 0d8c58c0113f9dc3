"""Checks that meshes and images written by unfold read in meshio and nibabel
with the same counts, coordinates, arrays and affine that unfold reports, and
that SimpleITK resamples through unfold's displacement field as unfold does."""

import json
import subprocess
import sys
from pathlib import Path

import meshio
import nibabel
import numpy as np
import SimpleITK as sitk

demo = Path(sys.argv[1])
exe = sys.argv[2]


def unfold(*args):
    out = subprocess.run([exe, *args], check=True, capture_output=True, text=True)
    return out.stdout


def info(path):
    return json.loads(unfold("info", str(path), "--json"))


src = demo / "placenta.vtu"
variants = {
    "placenta.vtu": [],
    "placenta_zlib_b64.vtu": ["--encoding", "appended-base64", "--compress"],
    "placenta_inline.vtu": ["--encoding", "inline-base64"],
    "placenta_ascii.vtu": ["--ascii"],
    "placenta_bin42.vtk": [],
    # meshio 5.3 misreads binary 5.1 `int` arrays as 64-bit (VTK reads them
    # right and rejects the `vtktypeint32` spelling), so 5.1 is checked in ASCII.
    "placenta_ascii51.vtk": ["--vtk-version", "5.1", "--ascii"],
    "placenta_ascii42.vtk": ["--ascii"],
}
ref = meshio.read(src)
ref_info = info(src)
checked = 0
for name, opts in variants.items():
    path = demo / name
    if name != "placenta.vtu":
        unfold("convert", str(src), str(path), *opts)
    m = meshio.read(path)
    i = info(path)
    n_tets = sum(len(c.data) for c in m.cells if c.type == "tetra")
    assert len(m.points) == i["points"] == ref_info["points"], name
    assert n_tets == i["cells"] == ref_info["cells"], name
    assert np.array_equal(m.points, ref.points), f"{name}: points differ"
    side = np.asarray(m.point_data["side"]).ravel()
    assert np.array_equal(side, np.asarray(ref.point_data["side"]).ravel()), name
    assert set(np.unique(side)) <= {0, 1, 2, 3}, name
    print(f"meshio read {name}: {len(m.points)} points, {n_tets} tets, 'side' ok")
    checked += 1

img_path = demo / "placenta_mri.nii.gz"
img = nibabel.load(img_path)
ii = info(img_path)
data = np.asarray(img.dataobj, dtype=np.float64)
assert list(img.shape) == [d for d in ii["dims"] if d > 1] or list(img.shape) == ii["dims"][:3], (
    img.shape,
    ii["dims"],
)
assert np.allclose(img.affine, np.array(ii["affine"]), rtol=1e-6, atol=1e-4), (img.affine, ii["affine"])
assert np.allclose(img.get_qform(), img.get_sform(), atol=1e-3), "qform and sform disagree"
lo, hi = ii["value_range"]
assert abs(data.min() - lo) <= 1e-4 * max(1.0, abs(lo)) and abs(data.max() - hi) <= 1e-4 * max(1.0, abs(hi))
print(f"nibabel read {img_path.name}: shape {img.shape}, affine and value range ok")

# And back: a NIfTI written by nibabel reads in unfold with the same affine.
back = demo / "from_nibabel.nii"
nibabel.save(nibabel.Nifti1Image(data.astype(np.float32), img.affine), back)
bi = info(back)
assert np.allclose(np.array(bi["affine"]), img.affine, atol=1e-4)
print(f"unfold read a nibabel-written NIfTI: affine ok")

# NRRD: pynrrd reads what `unfold convert` writes from the demo NIfTI with the
# same values, and (after the LPS -> RAS flip) the affine nibabel reads.
import nrrd  # noqa: E402 (pynrrd)

nrrd_path = demo / "placenta_mri.nrrd"
unfold("convert", str(img_path), str(nrrd_path))
nd, nh = nrrd.read(str(nrrd_path))
assert nh["space"] == "left-posterior-superior", nh["space"]
assert nd.dtype == np.float32 and nd.shape == img.shape, (nd.dtype, nd.shape, img.shape)
assert np.array_equal(nd, np.asarray(img.dataobj)), "pynrrd and nibabel values differ"
lps = np.eye(4)
lps[:3, :3] = np.asarray(nh["space directions"], dtype=np.float64).T
lps[:3, 3] = np.asarray(nh["space origin"], dtype=np.float64)
ras = np.diag([-1.0, -1.0, 1.0, 1.0]) @ lps
assert np.array_equal(ras, img.affine), (ras, img.affine)
print(f"pynrrd read {nrrd_path.name}: shape {nd.shape}, values and affine equal to nibabel's")
# And back: a NRRD written by pynrrd (its own header layout) reads in unfold.
from_pynrrd = demo / "from_pynrrd.nrrd"
nrrd.write(str(from_pynrrd), nd, {k: nh[k] for k in ["space", "space directions", "space origin", "kinds"]})
fi = info(from_pynrrd)
assert np.allclose(np.array(fi["affine"]), img.affine, rtol=0, atol=1e-9), (fi["affine"], img.affine)
assert fi["dims"][:3] == list(nd.shape) and fi["datatype"] == "float32", fi
print("unfold read a pynrrd-written NRRD: affine ok")
nrrd_path.unlink()
from_pynrrd.unlink()
checked += 1


# The placenta pipeline's outputs (`unfold demo` runs it into placenta/): silent
# when they are right, one clear line and a non-zero exit when not.
def fail(msg):
    sys.exit(f"interop: placenta: {msg}")


pl = demo / "placenta"
for name in ["original.vtu", "flattened.vtu", "report.json", "placenta_mri_flat.nii.gz"]:
    if not (pl / name).is_file():
        fail(f"{pl / name} is missing (did `unfold demo` run the placenta pipeline?)")

meshes = {}
for name in ["original.vtu", "flattened.vtu"]:
    m = meshio.read(pl / name)
    types = {c.type for c in m.cells}
    if types != {"tetra"}:
        fail(f"{name}: cell types {sorted(types)}, expected only tetra")
    n_tets = sum(len(c.data) for c in m.cells)
    if "side" not in m.point_data:
        fail(f"{name}: no point array 'side' (has {sorted(m.point_data)})")
    side = np.asarray(m.point_data["side"]).ravel()
    if len(side) != len(m.points):
        fail(f"{name}: 'side' has {len(side)} values for {len(m.points)} points")
    if set(np.unique(side).tolist()) != {0, 1, 2, 3}:
        fail(f"{name}: 'side' values {np.unique(side).tolist()}, expected 0, 1, 2 and 3")
    if not np.all(np.isfinite(m.points)):
        fail(f"{name}: non-finite coordinates")
    meshes[name] = (m, n_tets, side)

orig, n_orig, side_orig = meshes["original.vtu"]
flat, n_flat, side_flat = meshes["flattened.vtu"]
if (len(orig.points), n_orig) != (len(flat.points), n_flat):
    fail(f"original has {len(orig.points)} points / {n_orig} tets, flattened {len(flat.points)} / {n_flat}")
if not np.array_equal(side_orig, side_flat):
    fail("'side' differs between original.vtu and flattened.vtu")
if not np.array_equal(np.concatenate([c.data for c in orig.cells]), np.concatenate([c.data for c in flat.cells])):
    fail("the tets of original.vtu and flattened.vtu differ")
for arr in ["log2_det_j", "sym_dirichlet"]:
    if arr not in flat.cell_data:
        fail(f"flattened.vtu: no cell array '{arr}' (has {sorted(flat.cell_data)})")
    values = np.concatenate([np.asarray(b).ravel() for b in flat.cell_data[arr]])
    if len(values) != n_flat:
        fail(f"flattened.vtu: '{arr}' has {len(values)} values for {n_flat} tets")
    if not np.all(np.isfinite(values)):
        fail(f"flattened.vtu: '{arr}' has non-finite values")

try:
    report = json.loads((pl / "report.json").read_text())
except json.JSONDecodeError as e:
    fail(f"report.json does not parse: {e}")
required = [
    "template", "lambda", "solver", "iterations", "seconds", "converged", "objective",
    "template_error_mm", "template_error_voxels", "dirichlet_excess_percent", "min_det_j",
    "inverted_tets", "theta", "theta_initial", "log2_det_j", "log2_edge_ratio",
    "log2_area_ratio", "boundary", "transform",
]
missing = [k for k in required if k not in report]
if missing:
    fail(f"report.json lacks {missing}")
for k in ["log2_det_j", "log2_edge_ratio", "log2_area_ratio"]:
    summary = report[k]
    if not isinstance(summary, dict) or any(not isinstance(summary.get(s), (int, float)) for s in ["mean", "std", "p5", "p50", "p95"]):
        fail(f"report.json: {k} should have numbers mean, std, p5, p50, p95, got {summary}")
if any(not isinstance(report["boundary"].get(s), int) for s in ["fetal", "maternal", "margin"]):
    fail(f"report.json: boundary should count fetal, maternal and margin, got {report['boundary']}")
if report["inverted_tets"] != 0:
    fail(f"report.json: {report['inverted_tets']} inverted tets")
if report["min_det_j"] <= 0:
    fail(f"report.json: min_det_j {report['min_det_j']} <= 0")

flat_img_path = pl / "placenta_mri_flat.nii.gz"
flat_img = nibabel.load(flat_img_path)
flat_data = np.asarray(flat_img.dataobj, dtype=np.float64)
if flat_data.ndim != 3:
    fail(f"{flat_img_path.name}: {flat_data.ndim}D, expected 3D (shape {flat_data.shape})")
if not np.any(flat_data != 0):
    fail(f"{flat_img_path.name}: all zero")
entries = [i for i in report.get("images", []) if Path(i["output"]).name == flat_img_path.name]
if len(entries) != 1:
    fail(f"report.json: expected one images entry for {flat_img_path.name}, got {report.get('images')}")
entry = entries[0]
if list(flat_data.shape) != entry["dims"]:
    fail(f"{flat_img_path.name}: shape {flat_data.shape}, report.json says {entry['dims']}")
if not np.allclose(flat_img.affine, np.array(entry["affine"]), rtol=1e-6, atol=1e-4):
    fail(f"{flat_img_path.name}: affine {flat_img.affine.tolist()} is not the template grid's {entry['affine']}")
inside = int(np.count_nonzero(flat_data))
if inside != entry["sampled"]:
    fail(f"{flat_img_path.name}: {inside} non-zero voxels, report.json says {entry['sampled']} sampled")
# The mitral pipeline's outputs (surfaces written as VTU so meshio reads
# them directly).
mi = pl.parent / "mitral"
mreport = json.loads((mi / "report.json").read_text())
for key in ["annulus_length_mm", "u_extent_mm", "leaflet_area_mm2", "saddle_horn_height_mm",
            "area_above_plane_mm2", "distortion", "flipped_triangles", "relax", "seconds"]:
    if key not in mreport:
        fail(f"mitral/report.json: missing {key}")
if mreport["flipped_triangles"] != 0:
    fail(f"mitral/report.json: {mreport['flipped_triangles']} flipped triangles")
m2 = meshio.read(mi / "valve2d.vtu")
for name in ["leaflet", "carpentier", "coaptation", "tenting_mm", "uv"]:
    if name not in m2.point_data:
        fail(f"valve2d.vtu: no point array {name}")
if not np.all(m2.points[:, 2] == 0):
    fail("valve2d.vtu: z is not 0")
if set(np.unique(m2.point_data["carpentier"]).tolist()) != {1, 2, 3, 4, 5, 6}:
    fail(f"valve2d.vtu: carpentier labels {np.unique(m2.point_data['carpentier'])}")
# The ventricle pipeline's outputs (`unfold demo` runs it into ventricle/).
ve = pl.parent / "ventricle"
vreport = json.loads((ve / "report.json").read_text())
for key in ["roundtrip_error_um", "flipped_disk_triangles", "grid_mm", "seconds", "aha_points"]:
    if key not in vreport:
        fail(f"ventricle/report.json: missing {key}")
for key in ["disk", "laplace", "streamlines", "inverse"]:
    if key not in vreport["seconds"]:
        fail(f"ventricle/report.json: missing seconds.{key}")
if vreport["flipped_disk_triangles"] != 0 or vreport["roundtrip_error_um"]["max"] >= 5:
    fail(f"ventricle/report.json: {vreport['flipped_disk_triangles']} flips, round trip {vreport['roundtrip_error_um']}")
nv = meshio.read(ve / "normalized.vtu")
av = meshio.read(ve / "anatomy.vtu")
for m, name in [(nv, "normalized.vtu"), (av, "anatomy.vtu")]:
    for arr in ["xi", "zeta", "depth", "aha"]:
        if arr not in m.point_data:
            fail(f"ventricle/{name}: no point array {arr}")
if len(nv.points) != vreport["anatomy_points"] or len(av.points) != len(nv.points):
    fail("ventricle: point counts differ from report.json")
if not np.allclose(nv.points[:, 2], np.ravel(nv.point_data["depth"])):
    fail("ventricle/normalized.vtu: z is not the depth")
if set(np.unique(np.ravel(nv.point_data["aha"])).tolist()) != set(range(1, 18)):
    fail(f"ventricle/normalized.vtu: aha labels {np.unique(nv.point_data['aha'])}")
dv = meshio.read(ve / "disk.vtu")
if not np.all(dv.points[:, 2] == 0) or np.hypot(dv.points[:, 0], dv.points[:, 1]).max() > 1 + 1e-9:
    fail("ventricle/disk.vtu: not in the unit disk at z = 0")
# The map as an ITK displacement field, with SimpleITK as the client:
# resampling the subject image through the field onto the flat image's grid
# reproduces unfold's pull-back.
itk_dir = demo / "placenta_itk"
disp = itk_dir / "displacement.nii.gz"
unfold("placenta", str(demo / "placenta.vtu"), "--image", str(img_path), "-o", str(itk_dir),
       "--displacement", str(disp), "--no-figures")
flat_itk = sitk.ReadImage(str(itk_dir / "placenta_mri_flat.nii.gz"), sitk.sitkFloat64)
field = sitk.ReadImage(str(disp))
if field.GetNumberOfComponentsPerPixel() != 3 or field.GetSize() != flat_itk.GetSize():
    fail(f"{disp.name}: {field.GetNumberOfComponentsPerPixel()} components, size {field.GetSize()}, "
         f"expected 3 on the flat image's grid {flat_itk.GetSize()}")
if not np.allclose(field.GetOrigin(), flat_itk.GetOrigin(), atol=1e-4) or not np.allclose(
        field.GetDirection(), flat_itk.GetDirection()):
    fail(f"{disp.name}: its grid is not the flat image's")
transform = sitk.DisplacementFieldTransform(sitk.Cast(field, sitk.sitkVectorFloat64))
subject = sitk.ReadImage(str(img_path), sitk.sitkFloat64)
resampled = sitk.GetArrayFromImage(sitk.Resample(subject, flat_itk, transform, sitk.sitkLinear, 0.0))
ours = sitk.GetArrayFromImage(flat_itk)
moved = np.abs(sitk.GetArrayFromImage(field)).sum(axis=-1) > 0
if moved.sum() < 1000:
    fail(f"{disp.name}: only {moved.sum()} voxels carry a displacement")
err = np.abs(resampled - ours)[moved].max()
scale = np.abs(ours).max()
if not err <= 1e-5 * scale:
    fail(f"SimpleITK through {disp.name} differs from unfold's pull-back by {err} (image max {scale})")
print(f"SimpleITK resampled the subject through {disp.name}: {moved.sum()} voxels, max difference "
      f"{err:.2e} (image max {scale:.1f})")
checked += 1

# Every mesh the demo and its pipelines wrote reads in meshio (no .vtp left).
meshes_written = sorted(p for p in demo.rglob("*") if p.suffix in {".vtu", ".vtk", ".vtp"})
if any(p.suffix == ".vtp" for p in meshes_written):
    fail(f"a .vtp output meshio cannot read: {[str(p) for p in meshes_written if p.suffix == '.vtp']}")
for p in meshes_written:
    m = meshio.read(p)
    if len(m.points) == 0:
        fail(f"{p}: meshio read no points")
print(f"meshio read all {len(meshes_written)} meshes unfold wrote")
checked += 1

print(f"{checked + 10} passed, 0 failed")
