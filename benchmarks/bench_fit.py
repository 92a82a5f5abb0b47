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

Run: ``python benchmarks/bench_fit.py``.
"""

from __future__ import annotations

import os

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


def main() -> None:
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


if __name__ == "__main__":
    main()
