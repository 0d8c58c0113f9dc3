"""Shared fixtures: the unfold command line to compare with."""

import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def unfold_bin():
    """The CLI: $UNFOLD_BIN, else target/debug/unfold, else target/release/unfold, else PATH."""
    candidates = [os.environ.get("UNFOLD_BIN")]
    candidates += [str(ROOT / "target" / p / "unfold") for p in ("debug", "release")]
    candidates.append(shutil.which("unfold"))
    for c in candidates:
        if c and os.access(c, os.X_OK):
            return c
    pytest.fail("no unfold binary: build it (cargo build) or set UNFOLD_BIN")


def cli(unfold_bin, *args, ok=True):
    """Runs the CLI with ``args`` (str()-ed); asserts success when ``ok``, else failure."""
    r = subprocess.run([unfold_bin, *map(str, args)], capture_output=True, text=True)
    if ok:
        assert r.returncode == 0, r.stderr
    else:
        assert r.returncode != 0, r.stdout
    return r


def coords(p):
    """A point as the CLI's X,Y,Z (repr: exact round trip)."""
    return ",".join(repr(float(x)) for x in p)


def assert_mesh_equal(mesh, points, cells, arrays, atol=1e-12):
    """A meshio mesh equal to a result's points, cells and arrays (every array)."""
    import numpy as np

    np.testing.assert_allclose(points, mesh.points, rtol=0, atol=atol)
    assert set(cells) == set(mesh.cells_dict), (set(cells), set(mesh.cells_dict))
    for k, c in cells.items():
        np.testing.assert_array_equal(c, mesh.cells_dict[k])
    names = set(mesh.point_data) | set(mesh.cell_data)
    assert set(arrays) == names, (set(arrays), names)
    for name, a in mesh.point_data.items():
        np.testing.assert_allclose(arrays[name], a.reshape(np.shape(arrays[name])), rtol=0, atol=atol)
    for name, blocks in mesh.cell_data.items():
        a = np.concatenate([b.reshape(len(b), -1) for b in blocks])
        np.testing.assert_allclose(arrays[name], a.reshape(np.shape(arrays[name])), rtol=0, atol=atol)
