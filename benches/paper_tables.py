#!/usr/bin/env python3
"""The placenta paper's Table I and its solver figures, reproduced on the
synthetic cohort of `unfold demo --cohort` (issue 22: the papers' validation
beside ours).

The eight synthetic placentas (bent slabs of 7,200 tets in different
poses and sizes, `DIR/inputs/placentaNNN/mesh.vtu`) are flattened with each
template (parallel planes, ellipsoid, single plane) by projected Newton,
and with `--solver gd` (the paper's Algorithm 1) for the planes and the
ellipsoid; every run is `unfold placenta MESH --template T --no-figures`.
From each `report.json` the table gives mean +- std over the placentas of

- the Dirichlet excess (`dirichlet_excess_percent`, the paper's metric
  distortion),
- the template error in voxels of 3 mm (`template_error_voxels`),
- the final `h` and `|h_final - h_init|` (planes; the single plane starts
  from the converged planes),
- the iterations and seconds (Newton and gradient descent),

beside the paper's Table I (111 MRI placentas) and its gradient-descent
iteration counts and times (MATLAB on an NVIDIA Titan Xp), as restated in
its text: 5097 iterations (planes) and 7203 (ellipsoid), 17 and 26 min per
placenta.

    cargo build --release --bin unfold
    python3 benches/paper_tables.py [--unfold PATH] [--no-gd]

Standard library only. About a minute on 2 cores (the gradient-descent runs
take most of it). Everything goes to a temporary directory, removed at the
end.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

# The paper's Table I (mean, std) and solver figures.
PAPER = {
    "planes": {"excess": (4.2, 2.0), "error": (0.26, 0.05), "gd_iterations": 5097, "gd_minutes": 17},
    "ellipsoid": {"excess": (3.4, 2.6), "error": (0.45, 0.32), "gd_iterations": 7203, "gd_minutes": 26},
    "single-plane": {"excess": (2.0, 1.0), "error": (0.26, 0.05)},
}
PAPER_H = "final h 13.1 +- 2.6 mm, |h_final - h_init| 1.5 +- 1.0 mm"
TEMPLATES = ("planes", "ellipsoid", "single-plane")


def run(cmd: list[str]) -> None:
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{done.stderr}")


def mean_std(values: list[float]) -> str:
    if not values:
        return "n/a"
    m = statistics.fmean(values)
    s = statistics.stdev(values) if len(values) > 1 else 0.0
    return f"{m:.3g} +- {s:.2g}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--unfold", default="target/release/unfold", help="the unfold binary")
    ap.add_argument("--no-gd", action="store_true", help="skip the gradient-descent runs")
    args = ap.parse_args()
    unfold = str(Path(args.unfold).resolve())
    work = Path(tempfile.mkdtemp(prefix="unfold-paper-"))
    try:
        run([unfold, "demo", "--cohort", "-o", str(work / "demo")])
        meshes = sorted((work / "demo" / "inputs").glob("placenta*/mesh.vtu"))
        if not meshes:
            sys.exit("the demo cohort wrote no placenta meshes")
        rows = {}
        solvers = [("newton", t) for t in TEMPLATES]
        if not args.no_gd:
            solvers += [("gd", "planes"), ("gd", "ellipsoid")]
        for solver, template in solvers:
            reports = []
            for k, mesh in enumerate(meshes):
                out = work / f"{solver}-{template}-{k}"
                run([unfold, "placenta", str(mesh), "--template", template, "--solver", solver,
                     "--no-figures", "-o", str(out)])
                reports.append(json.loads((out / "report.json").read_text()))
            rows[(solver, template)] = reports
        tets = [r["input"]["tets"] for r in rows[("newton", "planes")]]
        print(f"{len(meshes)} synthetic placentas of {min(tets)}-{max(tets)} tets "
              "(unfold demo --cohort); mean +- std over them\n")
        print("| template | solver | Dirichlet excess % (paper) | template error, voxels (paper) | "
              "iterations | seconds |")
        print("| --- | --- | --- | --- | --- | --- |")
        for (solver, template), reports in rows.items():
            paper = PAPER[template]
            excess = mean_std([r["dirichlet_excess_percent"] for r in reports])
            error = mean_std([r["template_error_voxels"] for r in reports])
            iters = mean_std([r["iterations"] for r in reports])
            secs = mean_std([r["seconds"] for r in reports])
            conv = sum(r["converged"] for r in reports)
            pe, pr = paper["excess"], paper["error"]
            if solver == "gd" and "gd_iterations" in paper:
                iters += f" (paper {paper['gd_iterations']})"
                secs += f" (paper {paper['gd_minutes']} min)"
            print(f"| {template} | {solver} ({conv}/{len(reports)} converged) | {excess} "
                  f"({pe[0]} +- {pe[1]}) | {error} ({pr[0]} +- {pr[1]}) | {iters} | {secs} |")
        for template in ("planes",):
            reports = rows[("newton", template)]
            h = [r["theta"]["h"] for r in reports if "h" in r.get("theta", {})]
            dh = [abs(r["theta"]["h"] - r["theta_initial"]["h"]) for r in reports
                  if "h" in r.get("theta", {}) and "h" in r.get("theta_initial", {})]
            print(f"\n{template}: final h {mean_std(h)} mm, |h_final - h_init| {mean_std(dh)} mm "
                  f"(paper: {PAPER_H})")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
