#!/usr/bin/env python3
"""The two placenta targets at the 1.5 mm voxel size in one command: time,
CPU time and peak memory of

1. `unfold placenta --seg MASK --dense` (the uniform 1.5 mm lattice:
   2.7M tets, 487k vertices; target: under 3 minutes and 6 GiB), and
2. `unfold placenta --seg MASK --size-mm 1.5` (the interior graded at the
   voxel size: 259k tets, 75k vertices, with the default planes template;
   target: under 60 s),

on the mask of an ellipsoid of semi-axes 105 x 85 x 20 mm at 1.5 mm voxels
(748 cm^3, what `unfold.shapes.ellipsoid_mask((105, 85, 20), 1.5)` makes).
Both runs include meshing the mask; the stages of the pipeline come from
`report.json` (`timings`), meshing and writing are the rest of the wall
clock (`mesh+io`).

The machine may be shared: beside each wall clock the table gives the CPU
seconds the command used (user + system, `getrusage` of the child) and the
1-minute load average when it ended. On an otherwise idle machine a run's
wall clock is at most its CPU seconds (it never waits for input), so the
CPU column bounds what the lead measures on an idle machine even when the
wall clock is inflated by other jobs. With `--before PATH` each case runs
with that binary too, alternately with the current one, so the two are
compared under the same load; the rows give the template error, Dirichlet
excess, Newton iterations, `h` and the side counts of each, which should
agree to the printed digits.

A second table puts the predictions beside what was measured: the
`--max-memory` prediction after meshing (`report.json`'s
`predicted_peak_bytes`, the highest check of the run) and the mask's
before meshing (`segmentation.prediction`: tets, bytes to flatten,
seconds), each with its ratio to the measured peak or seconds (a memory
ratio below 1 is an under-prediction: `--max-memory` would let the run be
killed); then the parts of the highest prediction (`predicted_parts`).
`--voxel-mm 5,4,3,2.5,2,1.5` runs every size (20k to 2.72M tets, both
solvers, uniform and graded: the runs the predictions are fitted on).

    cargo build --release --bin unfold
    python3 benches/placenta_dense.py [--unfold PATH] [--before PATH] [--cases dense,graded]
                                      [--voxel-mm 1.5 | 5,4,3,2.5,2,1.5]

Needs numpy and nibabel (e.g. the CI's `target/ci-venv`). At most about
3 minutes on 2 idle cores (the two runs used 98 and 68 s of CPU); the dense
run needs about 4 GiB. `--voxel-mm 4` checks the script in a minute. The mask and outputs go
to a temporary directory under /tmp, removed at the end. Never run two of
these at once on a small machine.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nibabel as nib

sys.path.insert(0, str(Path(__file__).resolve().parent))
from placenta_scale import ellipsoid_mask  # noqa: E402

RADII_MM = (105.0, 85.0, 20.0)
VOXEL_MM = 1.5
STAGES = ("parcellation", "initialization", "optimization", "evaluation")
CASES = {
    # name: (extra arguments, target seconds, target GiB or None); the
    # graded case adds `--size-mm VOXEL`
    "dense": (["--dense"], 180.0, 6.0),
    "graded": ([], 60.0, None),
}
GIB = 1024.0**3
MIB = 1024.0**2


def run(cmd: list[str], peak_file: Path) -> tuple[float, float]:
    """Runs `cmd` with UNFOLD_PEAK_FILE set; its wall-clock and CPU
    (user + system) seconds."""
    env = dict(os.environ, UNFOLD_PEAK_FILE=str(peak_file))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    return seconds, cpu


def measure(binary: str, case: str, mask: Path, work: Path, max_memory: str,
            voxel: float) -> dict:
    extra = CASES[case][0] or ["--size-mm", str(voxel)]
    out = work / f"out_{case}"
    peak_file = work / f"peak_{case}"
    seconds, cpu = run(
        [binary, "placenta", "--seg", str(mask), *extra, "--no-figures",
         "-o", str(out), "--max-memory", max_memory],
        peak_file,
    )
    report = json.loads((out / "report.json").read_text())
    shutil.rmtree(out)
    stages = report["timings"]
    b = report["boundary"]
    seg = report["segmentation"]["prediction"]
    return {
        "case": case,
        "binary": binary,
        "tets": report["input"]["tets"],
        "vertices": report["input"]["vertices"],
        "seconds": seconds,
        "cpu": cpu,
        "load": os.getloadavg()[0],
        "peak": float(peak_file.read_text()),
        "predicted": float(report["memory"]["predicted_peak_bytes"]),
        "stages": stages,
        "rest": seconds - sum(stages[k] for k in STAGES),
        "iterations": report["iterations"],
        "error_mm": report["template_error_mm"],
        "excess": report["dirichlet_excess_percent"],
        "h": report["theta"].get("h", float("nan")),
        "sides": (b["fetal"], b["maternal"], b["margin"]),
        "voxel": voxel,
        # the prediction before meshing (from the mask) and the parts of
        # the flattening's (after meshing)
        "seg_tets": seg["tets"],
        "seg_bytes": seg["flatten_bytes"],
        "seg_seconds": seg["seconds"],
        "parts": {p["what"]: p["bytes"] for p in report["memory"].get("predicted_parts", [])},
    }


def main() -> None:
    here = Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--unfold", default=str(here / "target/release/unfold"))
    ap.add_argument("--before", help="a second binary to compare with, run alternately")
    ap.add_argument("--cases", default="dense,graded", help="dense, graded or both")
    ap.add_argument("--max-memory", default="12G")
    ap.add_argument("--voxel-mm", default=str(VOXEL_MM),
                    help="voxel sizes of the mask, comma-separated (the targets are for 1.5; "
                    "4 checks the script quickly; 5,4,3,2.5,2,1.5 spans the predictions' fit)")
    args = ap.parse_args()
    cases = [c for c in args.cases.split(",") if c]
    for c in cases:
        if c not in CASES:
            sys.exit(f"unknown case '{c}': expected one of {', '.join(CASES)}")
    voxels = [float(v) for v in args.voxel_mm.split(",") if v]
    binaries = [args.unfold] + ([args.before] if args.before else [])
    work = Path(tempfile.mkdtemp(prefix="placenta_dense.", dir="/tmp"))
    rows = []
    try:
        for voxel in voxels:
            mask, affine = ellipsoid_mask(voxel, radii=RADII_MM)
            mask_path = work / "mask.nii.gz"
            nib.save(nib.Nifti1Image(mask, affine), str(mask_path))
            for case in cases:
                # the "before" binary first when there is one, then the current
                for binary in reversed(binaries):
                    r = measure(binary, case, mask_path, work, args.max_memory, voxel)
                    rows.append(r)
                    print(f"  {voxel} mm {case} ({binary}): {r['tets']:,} tets, "
                          f"{r['seconds']:.1f} s, {r['cpu']:.1f} s CPU, "
                          f"{r['peak'] / GIB:.2f} GiB, load {r['load']:.1f}",
                          file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)

    print("| voxel mm | case | binary | tets | vertices | seconds | CPU s | load | peak GiB | "
          "predicted GiB | " + " | ".join(STAGES) + " | mesh+io | iterations | "
          "template error mm | Dirichlet excess % | h mm | fetal, maternal, margin |")
    print("|" + "---|" * (16 + len(STAGES)))
    for r in rows:
        stages = " | ".join(f"{r['stages'][k]:.1f}" for k in STAGES)
        print(f"| {r['voxel']} | {r['case']} | {Path(r['binary']).name} | {r['tets']:,} | "
              f"{r['vertices']:,} | {r['seconds']:.1f} | {r['cpu']:.1f} | {r['load']:.1f} | "
              f"{r['peak'] / GIB:.2f} | {r['predicted'] / GIB:.2f} | {stages} | {r['rest']:.1f} | "
              f"{r['iterations']} | {r['error_mm']:.4f} | {r['excess']:.3f} | {r['h']:.3f} | "
              f"{', '.join(map(str, r['sides']))} |")
    print()
    # The predictions beside what was measured: the highest check of the run
    # (report.json's predicted_peak_bytes: the flattening's after meshing,
    # or, with --max-memory, the mask's before meshing when higher) and the
    # mask's (tets, bytes to flatten, seconds). A memory ratio below 1 is an under-prediction
    # (the run could be killed where --max-memory let it through).
    print("| voxel mm | case | binary | highest check | tets | predicted tets | peak MiB | "
          "predicted MiB (highest check) | ratio | predicted MiB (mask) | ratio | seconds | "
          "CPU s | load | predicted s (mask) | ratio to wall | ratio to CPU |")
    print("|" + "---|" * 17)
    for r in rows:
        # which check made the highest prediction: the flattening's (by
        # its solver), the mask's (with --max-memory) or the mesher's
        solver = ("flattening, multigrid" if "multigrid matrix" in r["parts"]
                  else "flattening, Cholesky" if "factor" in r["parts"]
                  else "mask" if any("from the mask" in k for k in r["parts"])
                  else "meshing")
        print(f"| {r['voxel']} | {r['case']} | {Path(r['binary']).name} | {solver} | "
              f"{r['tets']:,} | {r['seg_tets']:,.0f} | {r['peak'] / MIB:.0f} | "
              f"{r['predicted'] / MIB:.0f} | {r['predicted'] / r['peak']:.2f} | "
              f"{r['seg_bytes'] / MIB:.0f} | {r['seg_bytes'] / r['peak']:.2f} | "
              f"{r['seconds']:.1f} | {r['cpu']:.1f} | {r['load']:.1f} | {r['seg_seconds']:.1f} | "
              f"{r['seg_seconds'] / r['seconds']:.2f} | {r['seg_seconds'] / r['cpu']:.2f} |")
    print()
    print("parts of the highest prediction (MiB):")
    for r in rows:
        parts = ", ".join(f"{k} {v / MIB:.0f}" for k, v in r["parts"].items())
        print(f"  {r['voxel']} mm {r['case']} ({r['tets']:,} tets): {parts}")
    print()
    for r in rows:
        if r["binary"] != args.unfold or r["voxel"] != VOXEL_MM:
            continue
        target_s, target_gib = CASES[r["case"]][1:]
        memory = "" if target_gib is None else (
            f", {r['peak'] / GIB:.2f} GiB against {target_gib:.0f} GiB: "
            f"{r['peak'] / GIB < target_gib}")
        print(f"{r['case']}: {r['seconds']:.1f} s wall ({r['cpu']:.1f} s CPU, load "
              f"{r['load']:.1f}) against {target_s:.0f} s: wall {r['seconds'] < target_s}, "
              f"CPU {r['cpu'] < target_s}{memory}")


if __name__ == "__main__":
    main()
