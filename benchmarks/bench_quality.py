"""Fit quality at FITPACK's knot counts: every method against FITPACK, side by side.

For each seed curve (centripetal parameters, cubic) FITPACK (``splprep``) picks a knot count
at smoothing ``s = N * 1e-4`` and ``s = N * 1e-6``: six cases. In each case every method gets
that same number of interior knots K and the same budget, for several seeds, minimising the
error (objective ``paper`` without error floor: with K fixed it is K x Euclidean distance):
DE and GA on ordered data indices (``KnotIndices``), nlopt on free knots (``FreeKnots``),
random search on indices, and the classical baselines. The table shows each method's median
RMSE divided by FITPACK's own RMSE (its smoothing spline at that s). The last two lines are

    best_rmse_ratio_vs_fitpack: <geometric mean over cases of the best method's median ratio>
    dolphin_rmse_ratio_vs_fitpack: <the same for DE on ordered indices>

Run: ``python benchmarks/bench_quality.py [--budget 20000] [--seeds 5]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.interpolate import splev, splprep

import metaknot as mk
from metaknot.bspline import parameterize
from metaknot.problems import FreeKnots, KnotIndices, get_curve

CURVES = ("epitrochoid", "archimedean", "vivaldi")
SMOOTHING = (1e-4, 1e-6)
DEGREE = 3

# (label, optimizer name, optimizer options, problem class)
METHODS = [
    ("dolphin", "dolphin", {}, KnotIndices),
    ("ga", "ga", {}, KnotIndices),
    ("random", "random_search", {}, KnotIndices),
    ("nlopt-bobyqa", "nlopt", {"algorithm": "LN_BOBYQA", "restarts": 20}, FreeKnots),
    ("nlopt-crs2", "nlopt", {"algorithm": "GN_CRS2_LM"}, FreeKnots),
    ("averaging", "averaging", {}, FreeKnots),
    ("fitpack", "fitpack", {}, FreeKnots),
]


def fitpack_case(points: np.ndarray, u: np.ndarray, factor: float) -> tuple[int, float]:
    """FITPACK's interior-knot count and RMSE at ``s = N * factor``."""
    tck, _ = splprep(points.T, u=u, k=DEGREE, s=points.shape[0] * factor)
    fitted = np.column_stack(splev(u, tck))
    rmse = float(np.sqrt(np.mean(np.sum((points - fitted) ** 2, axis=1))))
    return len(tck[0]) - 2 * (DEGREE + 1), rmse


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=20_000)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--methods", nargs="*", default=[m[0] for m in METHODS])
    args = parser.parse_args()
    methods = [m for m in METHODS if m[0] in args.methods]

    rows = []
    best_ratios, dolphin_ratios = [], []
    start = time.perf_counter()
    for curve in CURVES:
        data = get_curve(curve)
        u = parameterize(data.points, "centripetal")
        for factor in SMOOTHING:
            k, fitpack_rmse = fitpack_case(data.points, u, factor)
            medians = {}
            for label, name, options, problem_cls in methods:
                problem = problem_cls(data, n_knots=k, degree=DEGREE, objective="paper",
                                      objective_options={"error_floor": 0.0})
                ratios = []
                for seed in range(args.seeds):
                    result = mk.minimize(problem, name, budget=args.budget, seed=seed,
                                         optimizer_kwargs=options)
                    ratios.append(result.solution.fit.rmse / fitpack_rmse)
                medians[label] = float(np.median(ratios))
            best = min(medians, key=medians.get)
            best_ratios.append(medians[best])
            if "dolphin" in medians:
                dolphin_ratios.append(medians["dolphin"])
            rows.append((curve, factor, k, fitpack_rmse, medians, best))
            print(f"{curve:<12} s=N*{factor:g}  K={k:<3} fitpack rmse {fitpack_rmse:.3e}  "
                  f"best {best} {medians[best]:.3f}", flush=True)

    labels = [m[0] for m in methods]
    print()
    print(f"{'case':<22} {'K':>3} " + " ".join(f"{lab:>12}" for lab in labels))
    for curve, factor, k, _, medians, best in rows:
        cells = " ".join(
            f"{medians[lab]:>11.3f}{'*' if lab == best else ' '}" for lab in labels
        )
        print(f"{curve + f' N*{factor:g}':<22} {k:>3} {cells}")
    worse = [r[0] for r in rows if r[4][r[5]] > 1.0]
    print(f"\nmedian RMSE / FITPACK RMSE, {args.seeds} seeds, budget {args.budget}; "
          f"* = best; {time.perf_counter() - start:.0f} s")
    print(f"cases where the best method is worse than FITPACK: {len(worse)}")
    print(f"best_rmse_ratio_vs_fitpack: {np.exp(np.mean(np.log(best_ratios))):.3f}")
    if dolphin_ratios:
        print(f"dolphin_rmse_ratio_vs_fitpack: {np.exp(np.mean(np.log(dolphin_ratios))):.3f}")


if __name__ == "__main__":
    main()
