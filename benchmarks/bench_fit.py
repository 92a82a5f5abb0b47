"""``metaknot fit`` against FITPACK at the same tolerance, side by side in one run.

Cases: the three seed curves, each clean and with Gaussian noise of 1e-4 and 2e-4 of the
bounding-box diagonal per coordinate; function data (500 samples of a sharp Gaussian peak on a
slope); and a closed outline (a 400-point rounded star) this script generates. Tolerance: 1e-3
of the diagonal on the maximum deviation. For each case FITPACK's answer (the fewest control
points of FITPACK's own spline within the tolerance, scanning its smoothing factor) and
``metaknot fit``'s, with both times, on one kernel thread. Closed curves (the outline, and the
Vivaldi curve, whose ends meet) get periodic splines on both sides (FITPACK's ``per=1``). The
last lines are

    fit_cp_ratio_vs_fitpack: <geometric mean over cases of metaknot's / FITPACK's control points>
    fit_seconds_max: <slowest metaknot fit, seconds>

then, for a large file (``--large``, default one million points of a noisy epitrochoid outline,
0 to skip), ``metaknot fit``'s default in a fresh process on one core: its time, its peak
resident memory beside the size of the points themselves, and its answer beside FITPACK's:

    fit_large_seconds: <s>
    fit_large_peak_over_points: <peak resident memory / bytes of the points array>

Run: ``python benchmarks/bench_fit.py [--large 1000000]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np
from _timing import timed

import metaknot as mk
from metaknot.problems import add_noise, get_curve

TOLERANCE = 1e-3


def cases() -> list[tuple[str, np.ndarray, bool, bool | None]]:
    out = []
    for name in ("epitrochoid", "archimedean", "vivaldi"):
        data = get_curve(name)
        out.append((name, data.points, False, None))
        for level in (1e-4, 2e-4):
            noisy = add_noise(data, level * data.scale, np.random.SeedSequence(7))
            out.append((f"{name} noise {level:g}", noisy.points, False, None))
    x = np.linspace(0.0, 1.0, 500)
    out.append(("peak f(x)", np.column_stack((x, np.exp(-((x - 0.6) / 0.015) ** 2)
                                               + 0.3 * x)), True, None))
    angle = np.linspace(0.0, 2 * np.pi, 400, endpoint=False)
    radius = 1.0 + 0.25 * np.cos(5 * angle) ** 3
    out.append(("star outline (closed)",
                np.column_stack((radius * np.cos(angle), radius * np.sin(angle))), False, True))
    return out


#: The large case, in a fresh process: the points made there, then the default fit of them.
LARGE = """
import json, sys, time
import numpy as np
import metaknot as mk

def memory(field):  # bytes; VmHWM is this process's peak
    with open("/proc/self/status") as status:
        return 1024 * int(next(line.split()[1] for line in status if line.startswith(field)))

n = int(sys.argv[1])
t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
points = np.column_stack((6 * np.cos(t) - 4 * np.cos(6 * t), 6 * np.sin(t) - 4 * np.sin(6 * t)))
points += np.random.default_rng(0).normal(0.0, 1e-3, points.shape)
mk.fit(points[:: max(1, n // 500)], 1e-3, relative=True)  # compile outside the timing
before = memory("VmRSS:")
start = time.perf_counter()
result = mk.fit(points, 1e-3, relative=True)
print(json.dumps({"seconds": time.perf_counter() - start, "added": memory("VmHWM:") - before,
                  "array": points.nbytes, "cp": result.n_control_points,
                  "fitpack": result.fitpack["n_control_points"], "method": result.method,
                  "stages": result.stages}))
"""


def large(n: int) -> None:
    """``metaknot fit``'s default on ``n`` points, in a fresh process on one core."""
    done = subprocess.run([sys.executable, "-c", LARGE, str(n)], capture_output=True,
                          text=True, check=True, env={**os.environ, "NUMBA_NUM_THREADS": "1"})
    found = json.loads(done.stdout.strip().splitlines()[-1])
    print(f"\nnoisy epitrochoid outline of {n:,} points, tolerance 1e-3 of the diagonal:")
    for stage in found["stages"]:
        print(f"  {stage}")
    print(f"  {found['cp']} control points by {found['method']} (FITPACK: {found['fitpack']})"
          f" in {found['seconds']:.1f} s; peak memory added {found['added'] / 2**20:.0f} MB, "
          f"the points {found['array'] / 2**20:.0f} MB")
    print(f"fit_large_seconds: {found['seconds']:.1f}")
    print(f"fit_large_peak_over_points: {found['added'] / found['array']:.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--large", type=int, default=1_000_000,
                        help="points of the large case (0: skip it)")
    args = parser.parse_args()
    mk.fit(get_curve("archimedean", n_points=40).points, 1e-2, relative=True)  # compile
    ring = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    mk.fit(np.column_stack((np.cos(ring), np.sin(ring))), 1e-2, relative=True, closed=True)
    ratios, slowest = [], 0.0
    print(f"{'case':<28} {'N':>4} {'FITPACK CP':>10} {'s':>7} {'metaknot CP':>11} {'ratio':>6} "
          f"{'s':>7}  method")
    for name, points, function, closed in cases():
        result, seconds = timed(mk.fit, points, TOLERANCE, relative=True, function=function,
                                closed=closed)
        ratio = result.n_control_points / result.fitpack["n_control_points"]
        ratios.append(ratio)
        slowest = max(slowest, seconds)
        print(f"{name:<28} {len(points):>4} {result.fitpack['n_control_points']:>10} "
              f"{result.fitpack['seconds']:>7.2f} {result.n_control_points:>11} {ratio:>6.3f} "
              f"{seconds:>7.2f}  {result.method}{', periodic' if result.closed else ''}")
    print(f"fit_cp_ratio_vs_fitpack: {np.exp(np.mean(np.log(ratios))):.3f}")
    print(f"fit_seconds_max: {slowest:.2f}")
    if args.large:
        large(args.large)


if __name__ == "__main__":
    main()
