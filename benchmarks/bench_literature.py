"""``metaknot fit`` against the knot placement methods from the literature, at the same tolerance.

Cases: ``bench_fit``'s eleven (the seed curves clean and noisy, a peak function, a closed star;
1e-3 of the diagonal on the maximum deviation) and the tolerance task of ten suite instances
(functions, open and closed curves, a glyph, two noisy instances whose tolerance is an RMSE of
1.05 noise standard deviations). Every method works on the points and parameters ``metaknot
fit`` fitted (its ``params``, ``points``, open or closed alike) and its knots are checked by the
same evaluator; a method that cannot reach the tolerance is listed as ``-``. The table gives,
per case, each method's control points and seconds, and the best literature method. The last
lines are

    fit_cp_ratio_vs_best_literature: <geometric mean over cases of fit's CP / the best method's>
    fit_cases_worse_than_literature: <cases where fit needs more control points>

Run: ``python benchmarks/bench_literature.py`` (one kernel thread; several minutes).
"""

from __future__ import annotations

import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np
from _timing import timed
from bench_fit import TOLERANCE
from bench_fit import cases as fit_cases

import metaknot as mk
from metaknot.algorithms.literature import METHODS
from metaknot.bspline.curve import curve_model
from metaknot.suite import get_instance
from metaknot.suite.tasks import get_task

#: suite instances whose tolerance task is a case
SUITE_CASES = ("kang_spline", "humps", "galvez_f3", "dj_heavisine", "aspline_spa_het",
               "runge+noise0.01s0", "cubic_bump+noise0.01s0", "digit_3", "digit_8",
               "titanium")


def cases() -> list[tuple[str, dict]]:
    """``(name, keyword arguments of mk.fit)`` for every case."""
    out = [(name, {"points": points, "tolerance": TOLERANCE, "relative": True,
                   "function": function, "closed": closed})
           for name, points, function, closed in fit_cases()]
    for instance_id in SUITE_CASES:
        problem = get_task(instance_id, "tolerance").problem()
        objective = problem.objective
        data = get_instance(instance_id).point_set()
        out.append((instance_id, {"points": problem.points, "params": data.params,
                                  "tolerance": objective.bound(problem.info),
                                  "metric": objective.metric, "closed": problem.closed}))
    return out


def main() -> None:
    mk.fit(np.linspace(0, 1, 40) ** 2, 1e-2, relative=True)  # compile
    names = sorted(METHODS)
    print(f"{'case':<26} {'fit':>9} " + " ".join(f"{n[:15]:>15}" for n in names) + "  best")
    ratios, worse = [], 0
    for case, options in cases():
        fitted, seconds = timed(mk.fit, **options)
        extra = curve_model(fitted.closed)(fitted.params, fitted.points,
                                           fitted.degree).extra_control_points
        cells, best = [], None
        for name in names:
            found, took = timed(METHODS[name], fitted.params, fitted.points, fitted.tolerance,
                                degree=fitted.degree, closed=fitted.closed, metric=fitted.metric)
            if not found.within:
                cells.append(f"{'-':>8} {took:>6.2f}")
                continue
            cp = found.knots.size + extra
            cells.append(f"{cp:>8} {took:>6.2f}")
            if best is None or cp < best[0]:
                best = (cp, name)
        fit_cp = fitted.n_control_points
        if best is not None:
            ratios.append(fit_cp / best[0])
            worse += fit_cp > best[0]
        print(f"{case[:26]:<26} {fit_cp:>3} {seconds:>5.1f} " + " ".join(cells)
              + f"  {best[1] if best else '-'}", flush=True)
    print(f"fit_cp_ratio_vs_best_literature: {np.exp(np.mean(np.log(ratios))):.4f}")
    print(f"fit_cases_worse_than_literature: {worse}")


if __name__ == "__main__":
    main()
