"""unfold.placenta against `unfold placenta` on the same slab."""

import json
import math
import subprocess

import meshio
import numpy as np
import pytest

import unfold


@pytest.fixture(scope="module")
def slab():
    return unfold.shapes.placenta_slab(6)


@pytest.fixture(scope="module")
def both(slab, unfold_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("placenta")
    unfold.write_mesh(d / "slab.vtu", slab)
    subprocess.run([unfold_bin, "placenta", str(d / "slab.vtu"), "-o", str(d / "out"),
                    "--no-figures"], check=True, capture_output=True)
    calls = []
    result = unfold.placenta(slab.points, slab.cells["tetra"], name=str(d / "slab.vtu"),
                             progress=lambda s, i, v: calls.append((s, i, v)))
    return result, d / "out", calls


def test_points_equal_the_cli(both):
    result, out, _ = both
    cli = meshio.read(out / "flattened.vtu")
    assert result.points.dtype == np.float64
    np.testing.assert_allclose(result.points, cli.points, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(result.cells["tetra"], cli.cells_dict["tetra"])


def test_arrays_equal_the_cli(both):
    result, out, _ = both
    cli = meshio.read(out / "flattened.vtu")
    assert set(result.arrays) == set(cli.point_data) | set(cli.cell_data)
    np.testing.assert_array_equal(result.arrays["side"], cli.point_data["side"].ravel())
    for name in cli.cell_data:
        np.testing.assert_allclose(result.arrays[name], cli.cell_data[name][0].ravel(), atol=1e-12)
    orig = meshio.read(out / "original.vtu")
    np.testing.assert_array_equal(result.original.points, orig.points)


def test_report_has_the_cli_keys(both):
    result, out, _ = both
    cli = json.loads((out / "report.json").read_text())
    assert set(result.report) == set(cli)
    assert result.report["mesh"] == cli["mesh"]
    for key in ("iterations", "converged", "theta", "boundary", "inverted_tets"):
        assert result.report[key] == cli[key], key
    assert math.isclose(result.report["objective"], cli["objective"], rel_tol=0, abs_tol=1e-12)
    assert result.report["provenance"]["interface"] == "python"
    assert set(result.report["memory"]) == set(cli["memory"])


def test_progress_is_called(both):
    _, _, calls = both
    stages = [s for s, _, _ in calls]
    assert "parcellation" in stages
    assert any(s.startswith("optimization") for s in stages)
    assert all(isinstance(i, int) and isinstance(v, float) for _, i, v in calls)


def test_progress_exception_is_raised(slab):
    def boom(stage, iteration, value):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        unfold.placenta(slab.points, slab.cells["tetra"], progress=boom)


def test_two_components_raise_the_cli_message(slab, unfold_bin, tmp_path):
    n = len(slab.points)
    points = np.vstack([slab.points, slab.points + [500.0, 0.0, 0.0]])
    tets = np.vstack([slab.cells["tetra"], slab.cells["tetra"] + n])
    path = tmp_path / "two.vtu"
    unfold.write_mesh(path, points, {"tetra": tets})
    cli = subprocess.run([unfold_bin, "placenta", str(path), "-o", str(tmp_path / "o")],
                         capture_output=True, text=True)
    assert cli.returncode != 0
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.placenta(points, tets, name=str(path))
    assert "2 connected components" in str(e.value)
    assert f"unfold: error: {e.value}" in cli.stderr


@pytest.mark.parametrize("kwargs, flags", [
    ({"lam": -1.0}, ["--lambda", "-1"]),
    ({"tol": float("nan")}, ["--tol", "NaN"]),
    ({"margin_mm": 0.0}, ["--margin-mm", "0"]),
    ({"gamma": 0.0}, ["--gamma", "0"]),
    ({"rings": 7}, ["--rings", "7"]),
    ({"rings": 0}, ["--rings", "0"]),
    ({"fix_h": -2.0}, ["--fix-h", "-2"]),
    ({"fix_h": 5.0, "template": "ellipsoid"}, ["--fix-h", "5", "--template", "ellipsoid"]),
    ({"voxel_mm": -3.0}, ["--voxel-mm", "-3"]),
    ({"spacing_mm": float("inf")}, ["--spacing-mm", "inf"]),
    ({"max_iterations": 0}, ["--max-iterations", "0"]),
])
def test_bad_settings_raise_the_cli_message(slab, unfold_bin, tmp_path, kwargs, flags):
    path = tmp_path / "slab.vtu"
    unfold.write_mesh(path, slab)
    cli = subprocess.run([unfold_bin, "placenta", str(path), "-o", str(tmp_path / "o"), *flags],
                         capture_output=True, text=True)
    assert cli.returncode == 1, cli.stderr
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.placenta(slab.points, slab.cells["tetra"], **kwargs)
    assert cli.stderr.strip() == f"unfold: error: {e.value}"


@pytest.mark.parametrize("kwargs, message", [
    ({"template": "cube"}, "--template must be one of planes, ellipsoid, single-plane, got 'cube'"),
    ({"solver": "lbfgs"}, "--solver must be one of newton, gd, got 'lbfgs'"),
    ({"energy": "dirichlet"},
     "--energy must be one of symmetric-dirichlet, mips, arap, area-ratio, got 'dirichlet'"),
    ({"interp": "cubic"}, "--interp must be one of linear, nearest, got 'cubic'"),
    ({"max_iterations": -3}, "--max-iterations must not be negative, got -3"),
])
def test_bad_choices(slab, kwargs, message):
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.placenta(slab.points, slab.cells["tetra"], **kwargs)
    assert str(e.value) == message


def test_the_energy_equals_the_cli(slab, unfold_bin, tmp_path):
    unfold.write_mesh(tmp_path / "slab.vtu", slab)
    subprocess.run([unfold_bin, "placenta", str(tmp_path / "slab.vtu"), "-o", str(tmp_path / "out"),
                    "--energy", "arap", "--no-figures"], check=True, capture_output=True)
    result = unfold.placenta(slab.points, slab.cells["tetra"], energy="arap")
    cli = meshio.read(tmp_path / "out" / "flattened.vtu")
    np.testing.assert_allclose(result.points, cli.points, rtol=0, atol=1e-12)
    assert result.report["pieces"]["energy"] == "arap"


def test_bad_indices(slab):
    tets = slab.cells["tetra"].copy()
    tets[3, 2] = len(slab.points)
    with pytest.raises(unfold.UnfoldError, match="tets row 3 refers to point"):
        unfold.placenta(slab.points, tets)


def test_the_margin_starts_at_five_voxels(slab):
    # Without margin_mm the margin starts at five voxels of voxel_mm: a fixed
    # 15 mm was refused at 1.5 mm voxels, whose limit is 10 voxels (15 mm).
    for voxel_mm, start in [(1.5, 7.5), (3.0, 15.0)]:
        result = unfold.placenta(slab.points, slab.cells["tetra"], voxel_mm=voxel_mm,
                                 max_iterations=2)
        parcellation = result.report["boundary"]["parcellation"]
        assert parcellation["margin_radius_initial_mm"] == start


def test_fix_h_holds_the_half_thickness(slab):
    for template in ["planes", "single-plane"]:
        result = unfold.placenta(slab.points, slab.cells["tetra"], template=template, fix_h=4.5)
        assert result.report["theta"] == {"h": 4.5}
        assert result.report["theta_initial"] == {"h": 4.5}


def test_a_slab_in_metres_is_named(slab, unfold_bin, tmp_path):
    # As the command line: the failure ends with a note that unfold reads
    # millimetres; the Python fix is to multiply the points.
    metres = slab.points / 1000.0
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.placenta(metres, slab.cells["tetra"], name="slab_m")
    message = str(e.value)
    assert "; note: slab_m is only 0." in message
    assert "reads coordinates as millimetres: if it is in metres, multiply the points by 1000" in message
    path = tmp_path / "slab_m.vtu"
    unfold.write_mesh(path, metres, {"tetra": slab.cells["tetra"]})
    cli = subprocess.run([unfold_bin, "placenta", str(path), "-o", str(tmp_path / "o")],
                         capture_output=True, text=True)
    assert cli.returncode == 1
    assert message.split("; note:")[0].replace("slab_m", str(path)) in cli.stderr
    assert "--scale 1000" in cli.stderr
