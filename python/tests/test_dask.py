"""unfold.dask.run_cohort on a 2-worker LocalCluster against `unfold batch` + `unfold cohort`."""

import csv
import json
import math
import pathlib
import subprocess
import sys

import meshio
import numpy as np
import pytest

import unfold

distributed = pytest.importorskip("distributed")
from unfold.dask import run_cohort  # noqa: E402

# Columns that describe the run, not the organ: its wall-clock times
# (`seconds` and every `timings.*` stage), the
# process's measured peak, the memory limit it ran under (the batch's machine
# share per job vs the dask worker's limit per thread) and the predicted peak,
# which is the process's resident size plus the stage's estimate (a Python
# interpreter's process is larger than the unfold binary's).
RUN_COLUMNS = {"seconds", "memory.peak_bytes", "memory.limit_bytes",
               "memory.predicted_peak_bytes"}


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        with distributed.Client(cluster) as c:
            yield c


@pytest.fixture(scope="module")
def manifest(tmp_path_factory):
    """Two slabs (one on the ellipsoid template) and a file that is not a mesh."""
    d = tmp_path_factory.mktemp("inputs")
    unfold.write_mesh(d / "a.vtu", unfold.shapes.placenta_slab(4))
    unfold.write_mesh(d / "b.vtu", unfold.shapes.placenta_slab(5))
    (d / "broken.vtu").write_text("not a mesh")
    m = d / "manifest.csv"
    m.write_text("id,organ,input,template,age_weeks\n"
                 "s1,placenta,a.vtu,,30\n"
                 "s2,placenta,b.vtu,ellipsoid,34\n"
                 "bad,placenta,broken.vtu,,31\n")
    return m


@pytest.fixture(scope="module")
def both(manifest, client, unfold_bin, tmp_path_factory):
    """(cli_out, dask_out, summary): the same manifest both ways."""
    d = tmp_path_factory.mktemp("cohorts")
    cli = d / "cli"
    batch = subprocess.run([unfold_bin, "batch", str(manifest), "-o", str(cli), "--jobs", "2"],
                           capture_output=True, text=True)
    assert batch.returncode == 1, batch.stderr  # the broken subject
    subprocess.run([unfold_bin, "cohort", str(cli)], check=True, capture_output=True)
    summary = run_cohort(manifest, client, d / "dask")
    return cli, d / "dask", summary


def files(root: pathlib.Path):
    return {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()}


def read_table(path: pathlib.Path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def assert_tables_equal(a: pathlib.Path, b: pathlib.Path):
    ha, ra = read_table(a)
    hb, rb = read_table(b)
    assert ha == hb, a.name
    assert len(ra) == len(rb), a.name
    for row_a, row_b in zip(ra, rb):
        for col, x, y in zip(ha, row_a, row_b):
            if col in RUN_COLUMNS or col.startswith("timings.") or x == y:
                continue
            try:
                fx, fy = float(x), float(y)
            except ValueError:
                pytest.fail(f"{a.name} {row_a[0]} {col}: {x!r} != {y!r}")
            assert math.isclose(fx, fy, rel_tol=1e-12, abs_tol=1e-12), (a.name, col, x, y)


def test_the_same_files(both):
    cli, dask, _ = both
    assert files(dask) == files(cli)
    assert "s1/flattened.vtu" in files(dask) and "logs/bad.log" in files(dask)
    assert not (dask / "bad").exists()


def test_the_tables_are_equal(both):
    cli, dask, _ = both
    tables = sorted(p for p in files(cli) if p.endswith(".csv"))
    assert {"cohort.csv", "subjects.csv", "failures.csv"} <= set(tables)
    for t in tables:
        assert_tables_equal(cli / t, dask / t)


def test_failures_are_the_same(both):
    cli, dask, summary = both
    assert (dask / "failures.csv").read_text() == (cli / "failures.csv").read_text()
    _, rows = read_table(dask / "failures.csv")
    assert [r[0] for r in rows] == ["bad"]
    assert "not a VTK XML file" in rows[0][3]
    assert summary.failed == {"bad": rows[0][3]}
    assert summary.ran == ["s1", "s2"]
    assert summary.skipped == [] and summary.not_converged == []


def test_the_maps_are_equal(both):
    cli, dask, _ = both
    for s in ("s1", "s2"):
        a = meshio.read(cli / s / "flattened.vtu")
        b = meshio.read(dask / s / "flattened.vtu")
        np.testing.assert_allclose(b.points, a.points, rtol=0, atol=1e-12)
        ra = json.loads((cli / s / "report.json").read_text())
        rb = json.loads((dask / s / "report.json").read_text())
        assert rb["provenance"]["run_hash"] == ra["provenance"]["run_hash"]
        assert rb["iterations"] == ra["iterations"]


def test_the_cohort_step_is_the_command_lines(both, unfold_bin):
    cli, dask, _ = both
    before = (dask / "cohort.csv").read_text()
    unfold._native.cohort(str(dask), [])
    assert (dask / "cohort.csv").read_text() == before
    bad = subprocess.run([unfold_bin, "cohort", str(cli), "--plot", "nope"],
                         capture_output=True, text=True)
    with pytest.raises(unfold.UnfoldError) as e:
        unfold._native.cohort(str(dask), ["nope"])
    assert bad.returncode == 2
    assert "'nope' is not MEASURE:COVARIATE" in bad.stderr and "'nope' is not" in str(e.value)


def test_a_rerun_skips_what_is_done(both, manifest, client):
    _, dask, _ = both
    before = (dask / "s1" / "report.json").read_bytes()
    calls = []
    again = run_cohort(manifest, client, dask, jobs=1, progress=lambda *a: calls.append(a))
    assert again.skipped == ["s1", "s2"]
    assert again.ran == [] and list(again.failed) == ["bad"]
    assert (dask / "s1" / "report.json").read_bytes() == before
    assert sorted(c[0] for c in calls) == ["bad", "s1", "s2"]
    assert [c[2:] for c in calls] == [(1, 3), (2, 3), (3, 3)]


def test_the_command_lines_outputs_are_skipped_too(both, manifest, client):
    cli, _, _ = both
    again = run_cohort(manifest, client, cli)
    assert again.skipped == ["s1", "s2"]


def test_a_bad_manifest_raises_the_command_lines_error(tmp_path, client, unfold_bin):
    m = tmp_path / "m.csv"
    m.write_text("id,organ,input\ns1,liver,x.vtu\n")
    cli = subprocess.run([unfold_bin, "batch", str(m), "-o", str(tmp_path / "cli")],
                         capture_output=True, text=True)
    msg = cli.stderr.strip().removeprefix("unfold: error: ")
    assert "row 2: organ 'liver'" in msg
    with pytest.raises(unfold.UnfoldError) as e:
        run_cohort(m, client, tmp_path / "out")
    assert str(e.value) == msg
    assert not (tmp_path / "out").exists()


def test_an_output_that_is_a_file_is_refused(manifest, client, tmp_path):
    f = tmp_path / "taken"
    f.write_text("x")
    with pytest.raises(unfold.UnfoldError, match="is a file"):
        run_cohort(manifest, client, f)
    with pytest.raises(ValueError, match="jobs must be at least 1"):
        run_cohort(manifest, client, tmp_path / "o", jobs=0)


def test_a_directory_holding_somebodys_files_fails_alone(manifest, client, tmp_path):
    out = tmp_path / "out"
    (out / "s1").mkdir(parents=True)
    (out / "s1" / "notes.txt").write_text("mine")
    summary = run_cohort(manifest, client, out)
    assert sorted(summary.failed) == ["bad", "s1"]
    assert "notes.txt" in summary.failed["s1"]
    assert summary.ran == ["s2"]
    assert (out / "s1" / "notes.txt").read_text() == "mine"
    _, rows = read_table(out / "failures.csv")
    assert [r[0] for r in rows] == ["s1", "bad"]


def test_python_m_unfold_is_the_command_line(manifest, unfold_bin):
    for args in (["info", str(manifest.parent / "a.vtu")], ["info", "--bogus"]):
        py = subprocess.run([sys.executable, "-m", "unfold", *args], capture_output=True, text=True)
        cli = subprocess.run([unfold_bin, *args], capture_output=True, text=True)
        assert (py.returncode, py.stdout, py.stderr) == (cli.returncode, cli.stdout, cli.stderr)
