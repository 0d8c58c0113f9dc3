#!/usr/bin/env python3
"""The placenta at fine resolution (issue 21, point 2): time and peak memory
of `unfold placenta` against the tet count, from 50k to 1.25M tets.

A placenta-like mask, the ellipsoid of semi-axes 90 x 75 x 17 mm (483 cm^3,
what `unfold.shapes.ellipsoid_mask((90, 75, 17), s)` makes), is written at
voxel size `s` for each cube side `s` of the list and meshed uniformly by
`unfold mesh MASK --size-mm s` (the BCC lattice of `placenta --seg --dense`);
the mesh is flattened by `unfold placenta MESH --voxel-mm s --no-figures`.
For each mesh the table gives the tets, the command's wall-clock seconds and
its measured peak resident memory (`UNFOLD_PEAK_FILE`: the kernel's VmHWM),
the `--max-memory` prediction (`report.json`), the seconds of each stage of
the pipeline, the Newton iterations, the template error and the Dirichlet
excess; then the peak per tet from 100k tets up (memory grows no faster
than the mesh when it does not rise).

Targets (issue 21): 1.25M tets in under 6 GiB and 3 minutes on 2 cores.

    cargo build --release --bin unfold
    python3 benches/placenta_scale.py [--sizes 5,3.9,...] [--unfold PATH]

Needs numpy and nibabel (e.g. the CI's `target/ci-venv`). 1 to 2 minutes on
2 cores (the 1.25M-tet run takes 30 to 40 s and 2.5 GiB; its mesh file is
55 MB). The masks, meshes and outputs go to a temporary directory under /tmp,
removed at the end. Never run two of these at once on a small machine: the
largest run needs its memory (`--max-memory` protects the machine).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nibabel as nib
import numpy as np

RADII_MM = (90.0, 75.0, 17.0)
# Cube sides (mm) giving ~50k, 100k, 160k, 250k, 380k, 500k and 1.25M tets.
DEFAULT_SIZES = "5,3.9,3.35,2.9,2.5,2.3,1.68"
STAGES = ("parcellation", "initialization", "optimization", "evaluation")
MIB = 1024.0 * 1024.0


def ellipsoid_mask(spacing: float, margin: int = 3, radii=RADII_MM):
    """`unfold.shapes.ellipsoid_mask(radii, spacing)`: voxel [i, j, k]
    is 1 when its centre x has sum (x_a / r_a)^2 <= 1."""
    r = np.asarray(radii)
    n = (2 * np.ceil(r / spacing) + 1 + 2 * margin).astype(int)
    origin = -spacing * (n - 1) / 2.0
    affine = np.diag([spacing, spacing, spacing, 1.0])
    affine[:3, 3] = origin
    axes = [origin[a] + spacing * np.arange(n[a]) for a in range(3)]
    x, y, z = np.meshgrid(*axes, indexing="ij")
    inside = (x / r[0]) ** 2 + (y / r[1]) ** 2 + (z / r[2]) ** 2 <= 1.0
    return inside.astype(np.uint8), affine


def run(cmd: list[str], peak_file: Path) -> float:
    """Runs `cmd` with UNFOLD_PEAK_FILE set; its wall-clock seconds."""
    env = dict(os.environ, UNFOLD_PEAK_FILE=str(peak_file))
    start = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    return seconds


def main() -> None:
    here = Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default=DEFAULT_SIZES, help="cube sides, mm")
    ap.add_argument("--unfold", default=str(here / "target/release/unfold"))
    ap.add_argument("--max-memory", default="12G")
    args = ap.parse_args()
    sizes = [float(s) for s in args.sizes.split(",")]
    work = Path(tempfile.mkdtemp(prefix="placenta_scale.", dir="/tmp"))
    rows = []
    try:
        for s in sizes:
            mask, affine = ellipsoid_mask(s)
            mask_path = work / f"mask_{s}.nii.gz"
            nib.save(nib.Nifti1Image(mask, affine), str(mask_path))
            mesh_path = work / f"mesh_{s}.vtu"
            mesh_seconds = run(
                [args.unfold, "mesh", str(mask_path), "--size-mm", str(s),
                 "-o", str(mesh_path)],
                work / "peak_mesh",
            )
            out = work / f"out_{s}"
            peak_file = work / f"peak_{s}"
            seconds = run(
                [args.unfold, "placenta", str(mesh_path), "--voxel-mm", str(s),
                 "--no-figures", "-o", str(out), "--max-memory", args.max_memory],
                peak_file,
            )
            report = json.loads((out / "report.json").read_text())
            rows.append({
                "size": s,
                "tets": report["input"]["tets"],
                "vertices": report["input"]["vertices"],
                "seconds": seconds,
                "mesh_seconds": mesh_seconds,
                "peak": float(peak_file.read_text()),
                "predicted": float(report["memory"]["predicted_peak_bytes"]),
                "stages": report["timings"],
                "iterations": report["iterations"],
                "error_mm": report["template_error_mm"],
                "excess": report["dirichlet_excess_percent"],
                "parts": {q["what"]: q["bytes"]
                          for q in report["memory"].get("predicted_parts", [])},
            })
            r = rows[-1]
            print(f"  {s} mm: {r['tets']:,} tets, {seconds:.1f} s, "
                  f"{r['peak'] / MIB:.0f} MiB", file=sys.stderr, flush=True)
            shutil.rmtree(out)
            mesh_path.unlink()
    finally:
        shutil.rmtree(work, ignore_errors=True)

    print("| cube mm | tets | vertices | peak MiB | predicted MiB | predicted / peak | seconds | "
          + " | ".join(STAGES) + " | iterations | template error mm | Dirichlet excess % |")
    print("|" + "---|" * (10 + len(STAGES)))
    for r in rows:
        stages = " | ".join(f"{r['stages'][k]:.1f}" for k in STAGES)
        print(f"| {r['size']} | {r['tets']:,} | {r['vertices']:,} | {r['peak'] / MIB:.0f} | "
              f"{r['predicted'] / MIB:.0f} | {r['predicted'] / r['peak']:.2f} | "
              f"{r['seconds']:.1f} | {stages} | "
              f"{r['iterations']} | {r['error_mm']:.3f} | {r['excess']:.2f} |")
    print()
    # the parts of the highest prediction (report.json's memory.predicted_parts:
    # the resident size at its check, then the estimate's parts); a ratio
    # below 1 above is an under-prediction
    print("parts of the prediction (MiB):")
    for r in rows:
        parts = ", ".join(f"{k} {v / MIB:.0f}" for k, v in r["parts"].items())
        print(f"  {r['size']} mm ({r['tets']:,} tets): {parts}")
    print()
    big = [r for r in rows if r["tets"] >= 100_000]
    per_tet = [r["peak"] / r["tets"] for r in big]
    print("peak per tet from 100k tets up (KiB): "
          + ", ".join(f"{p / 1024:.2f}" for p in per_tet))
    largest = max(rows, key=lambda r: r["tets"])
    print(f"largest: {largest['tets']:,} tets in {largest['seconds']:.1f} s and "
          f"{largest['peak'] / MIB / 1024:.2f} GiB (targets: < 180 s, < 6 GiB); "
          f"memory no faster than linear from 100k: "
          f"{all(b <= a * 1.05 for a, b in zip(per_tet, per_tet[1:]))}")


if __name__ == "__main__":
    main()
