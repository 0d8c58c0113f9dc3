"""The cost of calling the placenta pipeline from Python (issue 20's target:
at most 5 % over the Rust call on the 7,200-tet slab).

Both in one run, in turns so that the machine's drift falls on both: each
round runs `cargo bench --bench placenta_call -- RUNS` (the library call
from Rust, timed inside the program: `benches/placenta_call.rs`) and then
`unfold.placenta` RUNS times on the same slab (timed around the Python
call: numpy in, the `PlacentaResult` with its report dict out). One warm-up
run each per round is not timed. Prints the median of each and their ratio.

Run with the wheel installed (a release build, as `pip install ./python`
makes):

    python3 -m venv target/bench-venv
    target/bench-venv/bin/pip install ./python
    target/bench-venv/bin/python benches/python_overhead.py [--rounds 3] [--runs 5]
"""

import argparse
import pathlib
import statistics
import subprocess
import time

import unfold

ROOT = pathlib.Path(__file__).resolve().parents[1]


def rust_times(runs):
    out = subprocess.run(
        ["cargo", "bench", "--quiet", "--bench", "placenta_call", "--", str(runs)],
        cwd=ROOT, check=True, capture_output=True, text=True,
    ).stdout
    return [float(line.split()[1]) for line in out.splitlines() if line.startswith("seconds ")]


def python_times(runs, slab):
    points, tets = slab.points, slab.cells["tetra"]
    result = unfold.placenta(points, tets)  # warm-up
    assert result.report["converged"], result.report["stop_reason"]
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        unfold.placenta(points, tets)
        times.append(time.perf_counter() - start)
    return times


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    slab = unfold.shapes.placenta_slab(10)
    print(f"slab: {len(slab.cells['tetra'])} tets; {args.rounds} rounds of {args.runs} runs each")
    subprocess.run(["cargo", "bench", "--quiet", "--bench", "placenta_call", "--no-run"],
                   cwd=ROOT, check=True)
    rust, python = [], []
    for r in range(args.rounds):
        rt = rust_times(args.runs)
        pt = python_times(args.runs, slab)
        print(f"round {r + 1}: Rust median {statistics.median(rt):.4f} s, "
              f"Python median {statistics.median(pt):.4f} s")
        rust += rt
        python += pt
    mr, mp = statistics.median(rust), statistics.median(python)
    print(f"Rust call:   median {mr:.4f} s over {len(rust)} runs")
    print(f"Python call: median {mp:.4f} s over {len(python)} runs")
    print(f"Python / Rust: {mp / mr:.3f} (target <= 1.05)")


if __name__ == "__main__":
    main()
