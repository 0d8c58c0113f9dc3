"""`unfold deform` against libigl's SLIM on the bowl benchmark (issue 21:
at 60k tets, at least 3x less time than SLIM at equal or lower energy).

The problem (benches/deform.rs): the bowl-shaped shell flattened into an
8 mm slab, top-surface vertices pulled to (x, y, +4), bottom-surface
vertices to (x, y, -4), rim free, on 7,056 and 60,516 tets, with the
benchmark's weight W = 1000 and with W = 1. Both sides minimize, from the
rest shape,

    E(x) = sum_k (V_k / V) (|J_k|_F^2 + |J_k^-1|_F^2) + W sum_b |x_b - t_b|^2

with V_k the rest volumes and V their sum. libigl's SLIM minimizes
sum_k V_k D(J_k) + p sum_b |x_b - t_b|^2 (its soft constraints), so it is
given p = W V: its objective is then V E, with the same minimizer. The
script first checks on one tet that the installed wheel weights a tet by
its volume and the soft term by p (older libigl versions weighted a tet by
the area of two of its faces instead, which is another problem).

Every energy printed here is E computed by `energy()` below with numpy,
from the rest mesh, the targets and the deformed positions: ours read back
from `CASE.ours.vtu`, SLIM's after each of its iterations. So the two
cannot differ by a normalization.

Steps:
1. `cargo bench --bench deform` (unless --no-bench): times our side
   (median of criterion's runs of the command's library call, Newton to
   |grad E|_F < 1e-4) and writes the meshes, targets, our results and
   their summaries into target/deform-bench/ (or DEFORM_BENCH_DIR).
2. SLIM (`igl.slim_precompute` with SYMMETRIC_DIRICHLET and the targets as
   soft constraints, then `igl.slim_solve` one iteration at a time) until
   its E is at or below ours, or it stalls (E fell by less than 1e-12
   relative over 10 iterations), or --max-iterations / --max-seconds.
   SLIM's time counts the precomputation and its iterations only, not the
   energy evaluations between them, and only up to the iteration that
   first reached its final E (a stall's idle iterations are not counted).
3. Prints per case: seconds, iterations and E of both, and the time ratio
   SLIM / ours. Where SLIM stops above our E, the ratio is SLIM's time to
   its final E over our whole solve (which ends at a lower E), and the
   script also prints how long our Newton took to get below SLIM's final E
   (the median run's time less that of the later iterations, from the
   per-iteration trace in CASE.ours.json).

Needs: libigl's wheel (PyPI `libigl`; 2.6.3 was used), meshio and numpy,
in a venv of their own, and cargo for step 1:

    python3 -m venv /tmp/slimenv
    /tmp/slimenv/bin/pip install libigl meshio numpy
    /tmp/slimenv/bin/python benches/slim_compare.py [--no-bench] [--max-seconds 900]
"""

import argparse
import importlib.metadata
import json
import os
import pathlib
import subprocess
import sys
import time

import igl
import meshio
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
CASES = ["bowl_7k_w1000", "bowl_60k_w1000", "bowl_7k_w1", "bowl_60k_w1"]


def jacobians(rest, tets, x):
    """Per-tet rest edge matrices' volumes and deformation gradients J."""
    dm = np.stack([rest[tets[:, i]] - rest[tets[:, 0]] for i in (1, 2, 3)], axis=2)
    ds = np.stack([x[tets[:, i]] - x[tets[:, 0]] for i in (1, 2, 3)], axis=2)
    volumes = np.abs(np.linalg.det(dm)) / 6.0
    return volumes, ds @ np.linalg.inv(dm)


def energy(rest, tets, x, b, bc, weight):
    """E(x) above, its distortion part and the number of tets with det J <= 0
    (E is infinite if there is one)."""
    volumes, j = jacobians(rest, tets, x)
    det = np.linalg.det(j)
    inverted = int(np.count_nonzero(det <= 0))
    if inverted:
        return np.inf, np.inf, inverted
    d = (j**2).sum(axis=(1, 2)) + (np.linalg.inv(j) ** 2).sum(axis=(1, 2))
    distortion = float((volumes * d).sum() / volumes.sum())
    target = float(weight * ((x[b] - bc) ** 2).sum())
    return distortion + target, distortion, inverted


def check_slim_weights():
    """SLIM on one stretched tet must reach the minimizer of
    V D(J) + p |x_b - t_b|^2 with V the tet's volume (not of the same with
    the area of two of its faces)."""
    import scipy.optimize

    rest = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    tets = np.array([[0, 1, 2, 3]], np.int32)
    b = np.array([0, 1], np.int32)
    bc = np.array([[0, 0, 0], [2, 0, 0]], float)
    p = 1.0

    def tri(a, c, d):
        return 0.5 * np.linalg.norm(np.cross(rest[c] - rest[a], rest[d] - rest[a]))

    lengths = {}
    for name, weight in [("volume", 1 / 6), ("two faces", tri(0, 1, 2) + tri(2, 3, 0))]:
        def f(flat):
            e, _, _ = energy(rest, tets, flat.reshape(4, 3), b, bc, p / weight)
            return e if np.isfinite(e) else 1e30
        r = scipy.optimize.minimize(f, rest.ravel(), method="BFGS", options={"gtol": 1e-10})
        x = r.x.reshape(4, 3)
        lengths[name] = np.linalg.norm(x[1] - x[0])
    data = igl.slim_precompute(rest, tets, rest, igl.MappingEnergyType.SYMMETRIC_DIRICHLET, b, bc, p)
    x = igl.slim_solve(data, 300)
    slim = np.linalg.norm(x[1] - x[0])
    print(f"one-tet check: SLIM stretches the tet to {slim:.6f}; the volume-weighted minimum "
          f"is {lengths['volume']:.6f}, the face-area-weighted one {lengths['two faces']:.6f}")
    if abs(slim - lengths["volume"]) > 1e-5:
        sys.exit("this libigl wheel does not weight a tet by its volume: SLIM would minimize "
                 "another energy than ours, so no comparison")


def load(directory, case):
    summary = json.loads((directory / f"{case}.ours.json").read_text())
    mesh = summary["mesh"]
    rest_mesh = meshio.read(directory / f"{mesh}.vtu")
    rest = np.asarray(rest_mesh.points, dtype=np.float64)
    tets = np.asarray(rest_mesh.cells_dict["tetra"], dtype=np.int32)
    t = np.loadtxt(directory / f"{mesh}.targets.csv", delimiter=",", skiprows=1)
    b = t[:, 0].astype(np.int32)
    bc = np.ascontiguousarray(t[:, 1:])
    ours_x = np.asarray(meshio.read(directory / f"{case}.ours.vtu").points, dtype=np.float64)
    return rest, tets, b, bc, ours_x, summary


def run_slim(rest, tets, b, bc, weight, e_ours, max_iterations, max_seconds):
    """SLIM until E <= e_ours or a stall; returns (seconds, iterations, E, inverted, trace)."""
    volume = jacobians(rest, tets, rest)[0].sum()
    start = time.perf_counter()
    data = igl.slim_precompute(
        np.asfortranarray(rest), np.asfortranarray(tets), np.asfortranarray(rest),
        igl.MappingEnergyType.SYMMETRIC_DIRICHLET, b, np.asfortranarray(bc), weight * volume)
    seconds = time.perf_counter() - start
    trace = [(0, seconds, energy(rest, tets, rest, b, bc, weight)[0])]
    inverted = 0
    for it in range(1, max_iterations + 1):
        start = time.perf_counter()
        x = igl.slim_solve(data, 1)
        seconds += time.perf_counter() - start
        e, _, inverted = energy(rest, tets, x, b, bc, weight)
        trace.append((it, seconds, e))
        if e <= e_ours:
            break
        if it >= 10 and trace[-11][2] - e <= 1e-12 * e:
            break
        if seconds > max_seconds:
            break
    return seconds, it, e, inverted, trace


def ours_until(summary, e):
    """Seconds our solve needed to get to E <= e (None if it never did):
    the median run's time less the time of the Newton iterations after the
    first one at or below e (their times from the traced run)."""
    trace = summary["trace"]
    hit = next((t for t in trace if t["objective"] <= e), None)
    if hit is None:
        return None, None
    return summary["seconds_median"] - (trace[-1]["seconds"] - hit["seconds"]), hit["iteration"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-bench", action="store_true",
                        help="reuse the files of an earlier `cargo bench --bench deform`")
    parser.add_argument("--dir", type=pathlib.Path,
                        default=pathlib.Path(os.environ.get("DEFORM_BENCH_DIR",
                                                            ROOT / "target" / "deform-bench")))
    parser.add_argument("--max-iterations", type=int, default=100000)
    parser.add_argument("--max-seconds", type=float, default=900.0,
                        help="SLIM's time limit per case (default 900)")
    parser.add_argument("--cases", nargs="*", default=CASES, choices=CASES)
    args = parser.parse_args()

    print(f"libigl {importlib.metadata.version('libigl')}, numpy {np.__version__}")
    check_slim_weights()
    if not args.no_bench:
        subprocess.run(["cargo", "bench", "--bench", "deform"], cwd=ROOT, check=True,
                       env={**os.environ, "DEFORM_BENCH_DIR": str(args.dir)})

    rows = []
    for case in args.cases:
        rest, tets, b, bc, ours_x, summary = load(args.dir, case)
        weight = summary["weight"]
        report = summary["report"]
        e_ours, _, inv_ours = energy(rest, tets, ours_x, b, bc, weight)
        # Our report's objective is the same E, up to rounding.
        assert abs(e_ours - report["objective"]) <= 1e-9 * e_ours, (e_ours, report["objective"])
        assert inv_ours == 0
        ours_s = summary["seconds_median"]
        print(f"\n{case}: {len(tets)} tets, {len(rest)} vertices, {len(b)} targets, W = {weight:g}")
        print(f"  ours: {ours_s:.3f} s (median of {summary['runs']}), {report['iterations']} "
              f"iterations, E = {e_ours:.12e} (its report: {report['objective']:.12e})")
        s, it, e, inverted, trace = run_slim(rest, tets, b, bc, weight, e_ours,
                                             args.max_iterations, args.max_seconds)
        for gap in (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7):
            hit = next((t for t in trace if t[2] <= e_ours * (1 + gap)), None)
            if hit:
                print(f"  SLIM within {gap:.0e} of our E: {hit[1]:8.2f} s, {hit[0]:5d} iterations")
        # SLIM's time: to its final E (a stall's idle iterations not counted).
        best = next(t for t in trace if t[2] <= e)
        reached = e <= e_ours
        why = "reached our E" if reached else (
            "stalled" if s <= args.max_seconds and it < args.max_iterations else "time limit")
        print(f"  SLIM: {it} iterations, {s:.3f} s, {inverted} inverted tets, {why}; final "
              f"E = {e:.12e} ({(e - e_ours) / e_ours:+.1e} relative to ours), first reached at "
              f"iteration {best[0]}, {best[1]:.3f} s")
        ratio = best[1] / ours_s
        if reached:
            print(f"  SLIM / ours at equal E: {ratio:.1f}x")
        else:
            until, k = ours_until(summary, e)
            print(f"  SLIM's time to its final E / our whole solve (to a lower E): {ratio:.1f}x")
            print(f"  ours was below SLIM's final E after iteration {k}, about {until:.3f} s: "
                  f"SLIM / ours at SLIM's E: {best[1] / until:.1f}x")
        rows.append((case, len(tets), weight, best[1], best[0], e, why, ours_s,
                     report["iterations"], e_ours, ratio))

    print("\n| mesh | W | SLIM s | SLIM it | SLIM E | ours s | ours it | ours E | SLIM / ours |")
    print("|---|---|---|---|---|---|---|---|---|")
    for case, n, w, s, it, e, why, os_, oit, oe, ratio in rows:
        mark = "" if why == "reached our E" else f" ({why})"
        print(f"| {n:,} tets | {w:g} | {s:.2f} | {it} | {e:.10g}{mark} | {os_:.3f} | {oit} "
              f"| {oe:.10g} | {ratio:.1f}x |")


if __name__ == "__main__":
    main()
