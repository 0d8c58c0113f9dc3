"""Checks that meshes and images written by unfold read in meshio and nibabel
with the same counts, coordinates, arrays and affine that unfold reports."""

import json
import subprocess
import sys
from pathlib import Path

import meshio
import nibabel
import numpy as np

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
print(f"{checked + 2} passed, 0 failed")
