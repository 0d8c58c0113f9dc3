"""unfold.mitral against `unfold mitral` on the demo's valve."""

import json

import meshio
import numpy as np
import pytest

import unfold
from conftest import assert_mesh_equal, cli, coords


@pytest.fixture(scope="module")
def valve():
    return unfold.shapes.mitral_valve()


def write_valve(d, valve):
    unfold.write_mesh(d / "anterior.vtu", valve.anterior)
    unfold.write_mesh(d / "posterior.vtu", valve.posterior)
    (d / "ring.csv").write_text("".join(coords(p) + "\n" for p in valve.annulus))
    return ["--anterior", d / "anterior.vtu", "--posterior", d / "posterior.vtu",
            "--annulus", d / "ring.csv"]


@pytest.fixture(scope="module")
def both(valve, unfold_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("mitral")
    cli(unfold_bin, "mitral", *write_valve(d, valve), "-o", d / "out", "--no-figures")
    return unfold.mitral(valve.anterior, valve.posterior, valve.annulus), d / "out"


def test_valve2d_equals_the_cli(both):
    result, out = both
    assert result.points.dtype == np.float64
    assert_mesh_equal(meshio.read(out / "valve2d.vtu"), result.points, result.cells, result.arrays)
    assert {"leaflet", "uv", "coaptation", "tenting_mm"} <= set(result.arrays)
    np.testing.assert_array_equal(result.points[:, 2], 0.0)


def test_valve3d_equals_the_cli(both):
    result, out = both
    o = result.original
    assert_mesh_equal(meshio.read(out / "valve3d.vtu"), o.points, o.cells,
                      {**o.point_data, **o.cell_data})


def test_report_has_the_cli_keys(both):
    result, out = both
    cli_report = json.loads((out / "report.json").read_text())
    assert set(result.report) == set(cli_report)
    assert result.report["inputs"] == "valve"
    assert result.report["provenance"]["interface"] == "python"
    for key, value in cli_report.items():
        if key not in ("inputs", "provenance") and "seconds" not in key:
            if isinstance(value, (int, float, str, bool)) and key != "seconds":
                assert result.report[key] == pytest.approx(value, abs=1e-12), key


def test_tuple_leaflets_and_settings(valve):
    a, p = valve.anterior, valve.posterior
    r = unfold.mitral((a.points, a.cells["triangle"]), (p.points, p.cells["triangle"]),
                      valve.annulus, annulus_mode="straight", relax="spring", iterations=3)
    assert r.points.shape == (len(a.points) + len(p.points), 3)
    np.testing.assert_array_equal(r.cells["triangle"].max() + 1, len(r.points))


def test_the_energy_equals_the_cli(valve, unfold_bin, tmp_path):
    cli(unfold_bin, "mitral", *write_valve(tmp_path, valve), "-o", tmp_path / "out",
        "--energy", "mips", "--no-figures")
    result = unfold.mitral(valve.anterior, valve.posterior, valve.annulus, energy="mips")
    assert_mesh_equal(meshio.read(tmp_path / "out" / "valve2d.vtu"), result.points, result.cells,
                      result.arrays)
    assert result.report["pieces"]["energy"] == "mips"


def test_bad_coaptation_raises_the_cli_message(valve, unfold_bin, tmp_path):
    out = cli(unfold_bin, "mitral", *write_valve(tmp_path, valve), "-o", tmp_path / "o",
              "--coaptation-mm=-1", ok=False)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.mitral(valve.anterior, valve.posterior, valve.annulus, coaptation_mm=-1.0)
    assert str(e.value) == "--coaptation-mm must be a finite number > 0, got -1"
    assert f"unfold: error: {e.value}" in out.stderr


def test_bad_inputs(valve):
    with pytest.raises(unfold.UnfoldError, match="--relax must be one of spring, sd, got 'x'"):
        unfold.mitral(valve.anterior, valve.posterior, valve.annulus, relax="x")
    with pytest.raises(unfold.UnfoldError, match="--energy must be one of symmetric-dirichlet, mips, "
                       "arap, area-ratio, got 'x'"):
        unfold.mitral(valve.anterior, valve.posterior, valve.annulus, energy="x")
    with pytest.raises(unfold.UnfoldError, match="--iterations must be a whole number >= 0, got -2"):
        unfold.mitral(valve.anterior, valve.posterior, valve.annulus, iterations=-2)
    with pytest.raises(unfold.UnfoldError, match="annulus must have shape"):
        unfold.mitral(valve.anterior, valve.posterior, valve.annulus[:, :2])
    bad = unfold.Mesh(valve.anterior.points, {"triangle": valve.anterior.cells["triangle"] + 10**6})
    with pytest.raises(unfold.UnfoldError, match="refers to point"):
        unfold.mitral(bad, valve.posterior, valve.annulus)
    lines = unfold.Mesh(valve.anterior.points, {"line": np.array([[0, 1]])})
    with pytest.raises(unfold.UnfoldError,
                       match="^valve: anterior leaflet: has no triangles; a leaflet is a triangle surface$"):
        unfold.mitral(lines, valve.posterior, valve.annulus)
    with pytest.raises(unfold.UnfoldError,
                       match=r"^valve: posterior leaflet: expected a Mesh or \(points, triangles\), got int$"):
        unfold.mitral(valve.anterior, 3, valve.annulus)
    # A ring of two points cannot be laid out: the pipeline's message, about the valve.
    with pytest.raises(unfold.UnfoldError, match="^valve: "):
        unfold.mitral(valve.anterior, valve.posterior, valve.annulus[:2])


def test_the_annulus_is_found_from_the_leaflets_without_one(valve, both):
    # As `unfold mitral` without --annulus: the same layout as with the
    # demo's ring (the found ring is that ring on the synthetic valve).
    given, _ = both
    found = unfold.mitral(valve.anterior, valve.posterior)
    np.testing.assert_allclose(found.points, given.points, rtol=0, atol=1e-9)


def test_leaflets_that_do_not_meet_need_an_annulus(valve):
    apart = unfold.Mesh(valve.posterior.points + np.array([0.0, 0.0, 50.0]),
                        valve.posterior.cells)
    with pytest.raises(unfold.UnfoldError, match="share no boundary"):
        unfold.mitral(valve.anterior, apart)


def test_a_valve_in_metres_is_named(valve):
    def metres(m):
        return unfold.Mesh(m.points / 1000.0, m.cells)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold.mitral(metres(valve.anterior), metres(valve.posterior), valve.annulus / 1000.0)
    assert "; note: the anterior leaflet is only 0.0" in str(e.value)
    assert "reads coordinates as millimetres" in str(e.value)
    # found from the leaflets, the ring fails too, with the same note
    with pytest.raises(unfold.UnfoldError, match="reads coordinates as millimetres"):
        unfold.mitral(metres(valve.anterior), metres(valve.posterior))
