"""Fit quality at FITPACK's knot counts: every method against FITPACK, side by side.

This is the study ``experiment=fitpack_front`` (``metaknot run -m experiment=fitpack_front``),
run and then read from the results store: one code path for the study and the benchmark.
For each seed curve (centripetal parameters, cubic) FITPACK picks a knot count
at smoothing ``s = N * 1e-4`` and ``s = N * 1e-6``: six cases. In each case every method gets
that same number of interior knots K and the same budget, for several seeds, minimising the
error (objective ``paper`` without error floor: with K fixed it is K x Euclidean distance):
DE and GA on ordered data indices (``KnotIndices``), nlopt and varpro on free knots (``FreeKnots``),
random search on indices, and the classical baselines. The table shows each method's median
RMSE divided by FITPACK's own RMSE (its smoothing spline at that s). The last two lines are

    best_rmse_ratio_vs_fitpack: <geometric mean over cases of the best method's median ratio>
    dolphin_rmse_ratio_vs_fitpack: <the same for DE on ordered indices>

Run: ``python benchmarks/bench_quality.py [--budget 20000] [--seeds 5] [--workers 2]
[--results DIR]`` (a temporary results directory unless ``--results`` is given; a study
already there is resumed, not recomputed).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from _timing import metaknot_run

from metaknot.bspline import fitpack, parameterize
from metaknot.experiments import load_study
from metaknot.problems import get_curve

CURVES = ("epitrochoid", "archimedean", "vivaldi")
DEGREE = 3
LABELS = ("dolphin", "ga", "random", "nlopt-bobyqa", "nlopt-lbfgs", "varpro", "nlopt-crs2",
          "averaging", "fitpack")


def fitpack_rmse(curve: str, factor: float) -> float:
    """RMSE of FITPACK's own smoothing spline at ``s = N * factor``."""
    points = get_curve(curve).points
    u = parameterize(points, "centripetal")
    spline = fitpack.smoothing_spline(u, points, DEGREE, points.shape[0] * factor)
    return float(np.sqrt(np.mean(spline.distances(u, points) ** 2)))


def run_study(results: Path, budget: int, seeds: int, workers: int) -> None:
    done = metaknot_run(["experiment=fitpack_front", f"budget={budget}",
                         f"seed=range(0,{seeds})", f"results_dir={results}", "launcher=joblib",
                         f"hydra.launcher.n_jobs={workers}"])
    if done.returncode != 0:
        raise SystemExit(f"the study failed (exit {done.returncode})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=20_000)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--results", type=Path, default=None)
    args = parser.parse_args()

    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        results = args.results or Path(scratch)
        run_study(results, args.budget, args.seeds, args.workers)
        runs = load_study(results / "fitpack_front").runs
    runs = runs[(runs.budget == args.budget) & (runs.seed < args.seeds)]
    runs = runs.assign(factor=[float(json.loads(c)["encoding"]["n_knots"].split(":")[1])
                               for c in runs.config])

    rows, best_ratios, dolphin_ratios = [], [], []
    for curve in CURVES:
        for factor in sorted(set(runs.factor), reverse=True):
            case = runs[(runs.data == curve) & (runs.factor == factor)]
            reference = fitpack_rmse(curve, factor)
            medians = (case.groupby("label").rmse.median() / reference).to_dict()
            best = min(medians, key=medians.get)
            best_ratios.append(medians[best])
            if "dolphin" in medians:
                dolphin_ratios.append(medians["dolphin"])
            rows.append((curve, factor, int(case.n_knots.iloc[0]), medians, best))

    labels = [lab for lab in LABELS if any(lab in r[3] for r in rows)]
    print()
    print(f"{'case':<22} {'K':>3} " + " ".join(f"{lab:>12}" for lab in labels))
    for curve, factor, k, medians, best in rows:
        cells = " ".join(
            f"{medians.get(lab, np.nan):>11.3f}{'*' if lab == best else ' '}" for lab in labels
        )
        print(f"{curve + f' N*{factor:g}':<22} {k:>3} {cells}")
    worse = [r[0] for r in rows if r[3][r[4]] > 1.0]
    print(f"\nmedian RMSE / FITPACK RMSE, {args.seeds} seeds, budget {args.budget}; "
          f"* = best; {time.perf_counter() - start:.0f} s")
    print(f"cases where the best method is worse than FITPACK: {len(worse)}")
    print(f"best_rmse_ratio_vs_fitpack: {np.exp(np.mean(np.log(best_ratios))):.3f}")
    if dolphin_ratios:
        print(f"dolphin_rmse_ratio_vs_fitpack: {np.exp(np.mean(np.log(dolphin_ratios))):.3f}")


if __name__ == "__main__":
    main()
