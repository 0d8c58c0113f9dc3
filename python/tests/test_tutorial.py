"""python/examples/tutorial.py runs as written and writes what it says."""

import pathlib
import subprocess
import sys

import meshio
import numpy as np

TUTORIAL = pathlib.Path(__file__).resolve().parents[1] / "examples" / "tutorial.py"


def test_the_tutorial_runs(tmp_path):
    done = subprocess.run([sys.executable, str(TUTORIAL), str(tmp_path)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "UnfoldError: --lambda must be a finite number > 0, got -1" in done.stdout
    assert "cylinders: h = " in done.stdout
    assert "ventricle: " in done.stdout and "mitral: " in done.stdout
    for name in ("ventricle.vtu", "valve2d.vtu"):
        assert len(meshio.read(tmp_path / name).points) > 0
    for name in ("flattened.vtu", "cylinders.vtu"):
        mesh = meshio.read(tmp_path / name)
        assert len(mesh.cells_dict["tetra"]) > 0
        assert set(mesh.point_data) >= {"side"}
        assert np.all(np.isfinite(mesh.cell_data_dict["log2_det_j"]["tetra"]))
    # The cylinders bend the slab: its fetal side is not flat.
    curved = meshio.read(tmp_path / "cylinders.vtu")
    fetal = curved.point_data["side"].ravel() == 1
    assert np.ptp(curved.points[fetal, 2]) > 1.0
