"""Free knots: the free-knot methods against an independent reference, the index sets and BOBYQA.

On suite instances (functions and curves, open and closed, with and without noise) at both of
the suite's knot counts (tasks ``fixed_k_small.free`` and ``fixed_k_large.free``, objective
RMSE), at one budget (3,000 evaluations by default) and over several seeds:

1. ``varpro`` (variable projection, its Jacobians charged to the budget), ``nlopt:LD_LBFGS``
   (the same exact gradient) and ``nlopt:LN_BOBYQA`` (20 restarts), each run by
   :func:`metaknot.minimize`; the median RMSE over seeds per method.
2. A reference written here, sharing no code with metaknot's fits: a multi-start of scipy's
   ``minimize`` (L-BFGS-B on the knots' log spans, then Nelder-Mead from its end) over the
   least-squares fit of scipy's B-splines (``make_lsq_spline`` on an open curve; on a closed
   outline the periodic basis, ``BSpline.design_matrix`` with its last ``p`` columns folded
   onto the first, and numpy's ``lstsq``), started from the best-known index set of the same
   K, uniform knots and random ones, until ``--reference-fits`` fits are spent per task.
   Its best RMSE is the attainable value as far as this search knows.
3. The shipped best-known index-set value of the same K.

Printed per task, then the summary lines::

    free_vs_attainable_worst_ratio: <worst over tasks of varpro's median RMSE / the
                                     reference's>                     (target <= 1.01)
    free_vs_index_worst_ratio: <worst over tasks of varpro's best RMSE / the best-known
                                index-set value>                      (target <= 1.0)
    free_vs_bobyqa_median_ratio: <median over tasks of varpro's median / BOBYQA's median>
    lbfgs_vs_bobyqa_median_ratio: <the same for nlopt LD_LBFGS>
    jacobian_cost_ratio: <one residual and Jacobian of varpro / one kernel fit, time, the
                          largest over the instances>
    kang_recovery_rmse: <varpro on kang_spline with its 11 knots and multiple knots allowed
                         (merge_spacing 1e-4), from its own starts, RMSE / the data's range>
                                                                      (target <= 1e-9)
    kang_recovery_from_sites_rmse: <the same, started from the data sites nearest the true
                                    knots, the double one split>

Run: ``python benchmarks/bench_free.py [--budget 3000] [--seeds 5] [--reference-fits 50000]
[--instances ID,...]``; ``--quick`` takes three instances, one seed and 5,000 reference fits.
The figures are measured in one run (ratios; the machine may be shared).
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from _timing import best_time
from scipy.interpolate import BSpline, make_lsq_spline
from scipy.optimize import minimize

import metaknot as mk
from metaknot.algorithms.variable_projection import residual_jacobian
from metaknot.suite import get_instance
from metaknot.suite.best import load_best_known
from metaknot.suite.functions import KANG_KNOTS
from metaknot.suite.tasks import get_task

INSTANCES = ("titanium", "galvez_f1", "kang_spline", "dj_heavisine", "humps",
             "humps+noise0.01s0", "archimedean", "clothoid+noise0.01s0", "epitrochoid",
             "heart", "digit_3", "galvez_f1+noise0.01s0")
QUICK = ("titanium", "galvez_f1", "heart")
TASKS = ("fixed_k_small.free", "fixed_k_large.free")
METHODS = {"varpro": ("varpro", {}), "lbfgs": ("nlopt:LD_LBFGS", {}),
           "bobyqa": ("nlopt:LN_BOBYQA", {"restarts": 20})}


class ReferenceFit:
    """The least-squares fit of scipy's B-splines for given interior knots (no metaknot
    code): its RMSE, ``inf`` where the fit cannot be made."""

    def __init__(self, problem) -> None:
        self.u = np.asarray(problem.params, dtype=np.float64)
        self.q = np.asarray(problem.points, dtype=np.float64)
        self.p = int(problem.degree)
        self.closed = bool(problem.closed)
        self.lo, self.hi = problem.knot_bounds
        self.fits = 0

    def rmse(self, knots: np.ndarray) -> float:
        self.fits += 1
        knots = np.sort(knots)
        if not (knots[0] > self.lo and knots[-1] < self.hi and np.all(np.diff(knots) > 0)):
            return math.inf
        p, u, q = self.p, self.u, self.q
        try:
            if not self.closed:
                t = np.r_[[self.lo] * (p + 1), knots, [self.hi] * (p + 1)]
                spline = make_lsq_spline(u, q, t, k=p)
                residual = q - spline(u)
            else:
                breaks = np.r_[0.0, knots]
                m = breaks.size
                if m < p:
                    return math.inf
                t = np.r_[breaks[m - p:] - 1.0, breaks, 1.0, np.r_[breaks, 1.0][1: p + 1] + 1.0]
                full = BSpline.design_matrix(u, t, p).toarray()
                basis = full[:, :m].copy()
                basis[:, :p] += full[:, m:]
                coef, _, rank, _ = np.linalg.lstsq(basis, q, rcond=None)
                if rank < m:
                    return math.inf
                residual = q - basis @ coef
        except (ValueError, np.linalg.LinAlgError):
            return math.inf
        return float(np.sqrt(np.mean(np.sum(residual**2, axis=1))))


def _knots(z: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Interior knots from log spans (softmax of (0, z)), written out here."""
    logits = np.r_[0.0, z]
    weights = np.exp(logits - logits.max())
    return lo + (hi - lo) * np.cumsum(weights / weights.sum())[:-1]


def _spans(knots: np.ndarray, lo: float, hi: float) -> np.ndarray:
    logs = np.log(np.diff(np.r_[lo, np.sort(knots), hi]))
    return logs[1:] - logs[0]


def reference(problem, starts: list[np.ndarray], fits: int, rng: np.random.Generator
              ) -> float:
    """The best RMSE of a multi-start L-BFGS-B then Nelder-Mead over the log spans, from the
    given starts and then random ones, until ``fits`` fits are spent."""
    fit = ReferenceFit(problem)
    lo, hi, k = fit.lo, fit.hi, problem.n_knots
    best = math.inf

    def objective(z: np.ndarray) -> float:
        value = fit.rmse(_knots(z, lo, hi))
        return value if math.isfinite(value) else 1e300

    queue = list(starts)
    while fit.fits < fits:
        start = queue.pop(0) if queue else np.sort(rng.uniform(lo, hi, k))
        if fit.rmse(start) == math.inf:
            continue
        z = _spans(start, lo, hi)
        share = max(200, (fits - fit.fits) // 4)
        found = minimize(objective, z, method="L-BFGS-B", options={"maxfun": share})
        polished = minimize(objective, found.x, method="Nelder-Mead",
                            options={"maxfev": share // 2, "xatol": 1e-12, "fatol": 1e-15})
        best = min(best, found.fun, polished.fun)
    return best


def median_runs(problem_factory, name: str, options: dict, budget: int, seeds: int
                ) -> list[float]:
    return [float(mk.minimize(problem_factory(), name, budget=budget, seed=seed,
                              optimizer_kwargs=options).best_f) for seed in range(seeds)]


def jacobian_cost(problem) -> float:
    """Time of one residual and Jacobian of varpro / time of one kernel fit (best of 20)."""
    knots = np.sort(problem.start_knots(problem.n_knots))
    args = (problem.params, problem.points, problem.degree, knots, problem.knot_bounds)
    residual_jacobian(*args, closed=bool(problem.closed))
    problem.evaluate(knots[None, :])

    jac = best_time(lambda: residual_jacobian(*args, closed=bool(problem.closed)), 20)
    fit = best_time(lambda: problem.curve.evaluate_positions(knots[None, :],
                                                             max_deviation=False), 200)
    return jac / fit


def kang_recovery(budget: int, start: np.ndarray | None) -> float:
    from metaknot.problems import FreeKnots

    data = get_instance("kang_spline").point_set()
    problem = FreeKnots(data, n_knots=11, objective="rmse", merge_spacing=1e-4)
    options = {} if start is None else {"initial": list(start)}
    result = mk.minimize(problem, "varpro", budget=budget, seed=0, optimizer_kwargs=options)
    return float(result.best_f) / float(np.ptp(data.points))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", type=int, default=3000)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--reference-fits", type=int, default=50_000)
    parser.add_argument("--instances", default=",".join(INSTANCES))
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    instances = QUICK if args.quick else tuple(args.instances.split(","))
    seeds = 1 if args.quick else args.seeds
    reference_fits = 5_000 if args.quick else args.reference_fits
    stored = load_best_known()
    rng = np.random.default_rng(0)

    attainable, versus_index, versus_bobyqa, lbfgs_bobyqa, costs = [], [], [], [], []
    print(f"{'instance':24s} {'task':20s} {'K':>3s} {'varpro':>10s} {'lbfgs':>10s} "
          f"{'bobyqa':>10s} {'reference':>10s} {'index set':>10s}")
    for instance_id in instances:
        instance = get_instance(instance_id)
        for task_id in TASKS:
            task = get_task(instance, task_id)
            medians = {}
            best_varpro = math.inf
            for key, (name, options) in METHODS.items():
                values = median_runs(task.problem, name, options, args.budget, seeds)
                medians[key] = float(np.median(values))
                if key == "varpro":
                    best_varpro = min(values)
            problem = task.problem()
            index_entry = stored.get((instance_id, task_id.replace(".free", ".indices")))
            index_value = index_entry.value if index_entry is not None else math.inf
            starts = [] if index_entry is None else [np.asarray(index_entry.knots)]
            starts.append(np.linspace(*problem.knot_bounds, problem.n_knots + 2)[1:-1])
            best_reference = reference(problem, starts, reference_fits, rng)
            attainable.append(medians["varpro"] / best_reference)
            versus_index.append(best_varpro / index_value)
            versus_bobyqa.append(medians["varpro"] / medians["bobyqa"])
            lbfgs_bobyqa.append(medians["lbfgs"] / medians["bobyqa"])
            print(f"{instance_id:24s} {task_id:20s} {problem.n_knots:3d} "
                  f"{medians['varpro']:10.4g} {medians['lbfgs']:10.4g} "
                  f"{medians['bobyqa']:10.4g} {best_reference:10.4g} {index_value:10.4g}",
                  flush=True)
        costs.append(jacobian_cost(get_task(instance, TASKS[0]).problem()))

    sites = np.round(np.array(KANG_KNOTS), 3)
    sites[6:8] = 0.540, 0.542
    print(f"free_vs_attainable_worst_ratio: {max(attainable):.4f}")
    print(f"free_vs_index_worst_ratio: {max(versus_index):.5f}")
    print(f"free_vs_bobyqa_median_ratio: {float(np.median(versus_bobyqa)):.4f}")
    print(f"lbfgs_vs_bobyqa_median_ratio: {float(np.median(lbfgs_bobyqa)):.4f}")
    print(f"jacobian_cost_ratio: {max(costs):.1f}")
    print(f"kang_recovery_rmse: {kang_recovery(args.budget, None):.3g}")
    print(f"kang_recovery_from_sites_rmse: {kang_recovery(args.budget, sites):.3g}")


if __name__ == "__main__":
    main()
