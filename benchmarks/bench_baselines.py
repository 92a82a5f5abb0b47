"""Every optimizer side by side, in the seed's setting and the index setting, plus fronts.

Three studies, run with ``metaknot run -m`` (the commands are in ``SWEEPS`` below) and read back
from the results store:

* ``baselines_seed`` — the seed paper's setting: its three curves (centripetal, cubic), 0/1
  masks, the guarded ``paper`` objective, 3,000 and 20,000 evaluations, 10 seeds;
* ``baselines_index`` — K = 20 interior knots, minimising the error (``paper`` without floor:
  with K fixed it is K x Euclidean distance, so the RMSE decides), 20,000 evaluations, 10 seeds:
  the index methods on ordered data indices and the free-knot methods (nlopt, CMA-ES) on free
  knots;
* ``baselines_front`` — the objective ``pareto`` (control points against RMSE), 20,000
  evaluations, 10 seeds: NSGA-II on 0/1 masks from the averaging knots (``nsga2``), the
  averaging scan on masks (``averaging``), and the free-knot front (``method=front_free``,
  label ``free-front``: the averaging knots at every count, each count refined by BOBYQA on
  free knot positions).

For the first two, each cell (curve, budget) lists every method's median and the p-value of a
two-sided Wilcoxon signed-rank test, paired by seed, against the method with the lowest median
(``best``; ``=`` where the two are identical on every seed). Ranks are of the medians within a
cell (ties averaged). The last lines are

    front_hv_ratio_vs_fitpack_unit_box: <the same ratio in the records' unit box>
    front_hv_ratio_vs_fitpack: <geometric mean over curves of the free-knot front's
                                (free-front) median hypervolume divided by FITPACK's>
    dolphin_rank_seed_setting: <Dolphin Echolocation's mean rank in the seed setting>

``front_hv_ratio_vs_fitpack`` is the ratio of the free-knot front (``FRONT_HEADLINE``); the
lines before it give every front method's ratio (NSGA-II on masks and the averaging scan too),
per curve and as the geometric mean over curves.

The front ratio uses pymoo's hypervolume indicator on the scaled objectives of ``pareto``
(control points / N, log relative error), normalised per curve by the ideal and nadir points of
the union of all fronts compared there (FITPACK's and every method's in the study), with the
reference point at 1.1 in each normalised objective: the region where the fronts differ.
Every run's own record keeps the fixed unit-box hypervolume; its ratio is printed as well.

Run: ``python benchmarks/bench_baselines.py [--seeds 10] [--workers 2] [--results DIR]
[--only-front]`` (about 20 minutes on two free cores; a study already in ``--results`` is
resumed). ``--only-front`` runs and reports the front study alone (a few minutes): its last
lines are the two front ratios.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from _timing import metaknot_run
from scipy.stats import rankdata, wilcoxon

from metaknot.bspline import fitpack
from metaknot.experiments import load_study
from metaknot.front import nondominated_mask
from metaknot.problems import KnotSelection, get_curve

CURVES = "epitrochoid,archimedean,vivaldi"
INDEX_ALGORITHMS = "dolphin,ga,random_search,one_plus_one,local_search,averaging,uniform,fitpack"

#: The front method whose ratio is the last line's ``front_hv_ratio_vs_fitpack``.
FRONT_HEADLINE = "free-front"

#: (study, overrides) of every sweep; ``{seeds}`` is the replicate range.
SWEEPS = [
    ("baselines_seed", ["encoding=mask", "objective=paper", "budget=3000,20000",
                        f"optimizer={INDEX_ALGORITHMS}"]),
    ("baselines_seed", ["encoding=mask", "objective=paper", "budget=3000,20000",
                        "optimizer=pymoo", "optimizer.variant=GA,DE,BRKGA",
                        "label=pymoo:${optimizer.variant}"]),
    ("baselines_seed", ["encoding=mask", "objective=paper", "budget=3000,20000",
                        "optimizer=nevergrad", "optimizer.variant=NGOpt,DiscreteOnePlusOne",
                        "label=nevergrad:${optimizer.variant}"]),
    ("baselines_index", ["encoding=indices", "encoding.n_knots=20", "objective=paper",
                         "objective.error_floor=0", "budget=20000",
                         f"optimizer={INDEX_ALGORITHMS}"]),
    ("baselines_index", ["encoding=indices", "encoding.n_knots=20", "objective=paper",
                         "objective.error_floor=0", "budget=20000", "optimizer=pymoo",
                         "optimizer.variant=GA,BRKGA", "label=pymoo:${optimizer.variant}"]),
    ("baselines_index", ["encoding=indices", "encoding.n_knots=20", "objective=paper",
                         "objective.error_floor=0", "budget=20000", "optimizer=nevergrad",
                         "optimizer.variant=NGOpt", "label=nevergrad:${optimizer.variant}"]),
    ("baselines_index", ["encoding=free", "encoding.n_knots=20", "objective=paper",
                         "objective.error_floor=0", "budget=20000", "optimizer=nlopt",
                         "optimizer.variant=LN_BOBYQA,GN_CRS2_LM,GN_ISRES,G_MLSL_LDS",
                         "label=nlopt:${optimizer.variant}"]),
    ("baselines_index", ["encoding=free", "encoding.n_knots=20", "objective=paper",
                         "objective.error_floor=0", "budget=20000", "optimizer=cmaes",
                         "label=cmaes-free"]),
    ("baselines_front", ["objective=pareto", "budget=20000", "method=nsga2_mask"]),
    ("baselines_front", ["objective=pareto", "budget=20000", "method=front_free"]),
    ("baselines_front", ["objective=pareto", "budget=20000", "encoding=mask",
                         "optimizer=averaging"]),
]


def run_sweeps(results: Path, seeds: int, workers: int, only: str | None = None) -> None:
    for study, overrides in SWEEPS:
        if only is not None and study != only:
            continue
        shown = [f"study={study}", f"problem={CURVES}", "problem.parameterization=centripetal",
                 f"seed=range(0,{seeds})", *overrides]
        print("$ metaknot run -m " + " ".join(shown), flush=True)
        done = metaknot_run([*shown, f"results_dir={results}", "launcher=joblib",
                             f"hydra.launcher.n_jobs={workers}"])
        if done.returncode != 0:
            raise SystemExit(f"the sweep failed (exit {done.returncode})")


def paired_p(a: pd.Series, b: pd.Series) -> str:
    """Two-sided Wilcoxon signed-rank p of ``a`` against ``b``, paired by seed."""
    both = pd.concat([a, b], axis=1, join="inner").dropna()
    diff = both.iloc[:, 0] - both.iloc[:, 1]
    if len(both) == 0:
        return "n/a"
    if np.allclose(diff, 0, rtol=0, atol=0):
        return "="
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return f"{wilcoxon(both.iloc[:, 0], both.iloc[:, 1]).pvalue:.2g}"


def compare(runs: pd.DataFrame, value: str, title: str) -> dict[str, list[float]]:
    """Print one table per (curve, budget); return every method's rank per cell."""
    ranks: dict[str, list[float]] = {}
    for (curve, budget), cell in runs.groupby(["data", "budget"]):
        by_method = {m: part.set_index("seed")[value] for m, part in cell.groupby("label")}
        medians = pd.Series({m: float(v.median()) for m, v in by_method.items()})
        best = medians.idxmin()
        for method, rank in zip(medians.index, rankdata(medians.to_numpy()), strict=True):
            ranks.setdefault(method, []).append(float(rank))
        print(f"\n{title}: {curve}, {int(budget):,} evaluations ({value}, median of "
              f"{cell.seed.nunique()} seeds; p: Wilcoxon vs {best})")
        for method in medians.sort_values().index:
            p = "best" if method == best else paired_p(by_method[method], by_method[best])
            print(f"  {method:<30} {medians[method]:>12.5g}   p {p}")
    print(f"\n{title}: mean rank over {len(next(iter(ranks.values())))} cells (1 = best)")
    for method, r in sorted(ranks.items(), key=lambda kv: np.mean(kv[1])):
        print(f"  {method:<30} {np.mean(r):6.2f}")
    return ranks


def front_ratios(runs: pd.DataFrame) -> dict[str, tuple[float, float]]:
    """Every front method's geometric mean over curves of its median hypervolume / FITPACK's:
    normalised to the union of the fronts (see the module notes), and in the records' unit
    box; by label."""
    from pymoo.indicators.hv import HV

    normalised: dict[str, list[float]] = {}
    unit: dict[str, list[float]] = {}
    print("\nfronts: control points against RMSE (objective pareto); hypervolume ratios to "
          "FITPACK's front, median over seeds")
    for curve, part in runs.groupby("data"):
        problem = KnotSelection(get_curve(curve), objective="pareto")
        fp = fitpack.front(problem.params, problem.points, problem.degree, n_smoothing=400)
        scaled_fitpack = problem.objective.scale(fp["n_control_points"], fp["rmse"], problem.info)
        fronts = {(r.label, r.seed): np.column_stack([json.loads(r.front)["objective_0"],
                                                      json.loads(r.front)["objective_1"]])
                  for r in part.itertuples()}
        union = np.vstack([scaled_fitpack, *fronts.values()])
        union = union[nondominated_mask(union)]
        ideal, nadir = union.min(axis=0), union.max(axis=0)
        indicator = HV(ref_point=np.full(2, 1.1))

        def hv(F, ideal=ideal, nadir=nadir, indicator=indicator):
            return float(indicator((F - ideal) / (nadir - ideal)))

        reference_hv = hv(scaled_fitpack)
        inside = scaled_fitpack[(scaled_fitpack < 1).all(axis=1)]
        reference_unit = float(HV(ref_point=np.ones(2))(inside))
        line = []
        for label in sorted(part.label.unique()):
            ratios = [hv(F) / reference_hv for (lab, _), F in fronts.items() if lab == label]
            units = part[part.label == label].hypervolume / reference_unit
            line.append(f"{label} {np.median(ratios):.3f} (unit box {units.median():.3f})")
            normalised.setdefault(label, []).append(float(np.median(ratios)))
            unit.setdefault(label, []).append(float(units.median()))
        nadir_cp = nadir[0] * problem.info.n_points
        print(f"  {curve:<12} {'; '.join(line)}  [nadir at {nadir_cp:.0f} control points]")
    return {label: (float(np.exp(np.mean(np.log(normalised[label])))),
                    float(np.exp(np.mean(np.log(unit[label]))))) for label in normalised}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--results", type=Path, default=None)
    parser.add_argument("--only-front", action="store_true",
                        help="run and report only the front study (baselines_front)")
    args = parser.parse_args()
    names = ("baselines_front",) if args.only_front else \
        ("baselines_seed", "baselines_index", "baselines_front")

    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        results = args.results or Path(scratch)
        run_sweeps(results, args.seeds, args.workers,
                   "baselines_front" if args.only_front else None)
        studies = {name: load_study(results / name).runs for name in names}
    keep = {k: v[(v.status == "ok") & (v.seed < args.seeds)] for k, v in studies.items()}
    if not args.only_front:
        seed_ranks = compare(keep["baselines_seed"], "best_f", "seed setting (masks, paper)")
        compare(keep["baselines_index"], "rmse", "index setting (K = 20)")
    ratios = front_ratios(keep["baselines_front"])
    print("\nfronts: geometric mean over curves of the median hypervolume / FITPACK's "
          "(normalised; unit box)")
    for label, (normalised, unit) in sorted(ratios.items(), key=lambda kv: -kv[1][0]):
        print(f"  {label:<30} {normalised:.3f}   unit box {unit:.3f}"
              + ("   <- front_hv_ratio_vs_fitpack" if label == FRONT_HEADLINE else ""))
    hv_ratio, unit_ratio = ratios[FRONT_HEADLINE]
    print(f"\n{time.perf_counter() - start:.0f} s")
    print(f"front_hv_ratio_vs_fitpack_unit_box: {unit_ratio:.3f}")
    print(f"front_hv_ratio_vs_fitpack: {hv_ratio:.3f}")
    if not args.only_front:
        print(f"dolphin_rank_seed_setting: {np.mean(seed_ranks['dolphin']):.2f}")


if __name__ == "__main__":
    main()
