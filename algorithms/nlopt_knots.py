"""Free-knot baselines: the K interior knot positions of a ``FreeKnots`` problem optimised by nlopt.

Knots stay ordered and separated by construction. nlopt searches ``y`` in the unit box
``[0, 1]^K`` (finite bounds, as the GN_* algorithms need), mapped to knots through their spans.
On the parameter range ``[a, b]`` every one of the K + 1 spans is ``gap`` plus a share of the
``free`` length ``(b - a) - (K + 1) gap``, where ``gap`` is ``data_gap`` times the widest spacing
of the data parameters (half of it by default for the global algorithms, which sample the whole
box: then almost every box point gives a feasible fit), or ``min_gap`` of the range if larger:

* ``box_map="spans"`` (the default of the global algorithms, ``GN_*`` and MLSL): the shares are
  a softmax of log-weights centred on the averaging knots (NURBS Book eqs. 9.68-9.69): span
  ``j < K`` has log-weight ``log p_j + beta (y_j - 1/2)``, the last span ``log p_K``, with ``p``
  the averaging knots' shares and ``beta = ln(span_range)``. The box centre is the averaging
  knots; a corner stretches or shrinks a span by ``sqrt(span_range)`` against the others.
  Global methods (CRS2, ISRES, MLSL) then sample sensible knot vectors instead of uniformly
  random ones.
* ``box_map="sorted"`` (the default of the local ones, which move each knot from the averaging
  start): the shares are the sorted coordinates (knot ``i`` at ``a + (i + 1) gap + free
  sort(y)_i``), uniform over ordered knot vectors.

Infeasible fits (+inf: a numerically singular system) reach nlopt as a finite penalty: the worst
finite value seen plus its magnitude plus 1.

With ``variable_count=True`` an outer search picks K in ``1..n_knots``: about half the budget
goes to short runs (one start each, from the averaging knots) on a coarse grid of ``k_grid``
values and on the midpoints between the best K and its nearest tried neighbours, repeated until
those neighbours are adjacent; the rest polishes the best K (with the restarts). Candidates are
NaN-padded with ``problem.pad``, so ``paper``, ``bic`` and ``error_bounded`` work as for the
discrete methods.
"""

from __future__ import annotations

import nlopt
import numpy as np

from metaknot.bspline import averaging_knots
from metaknot.budget import BudgetExhausted, Evaluator
from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import FreeKnots
from metaknot.registry import register

LOCAL_ALGORITHMS = ("LN_BOBYQA", "LN_SBPLX", "LN_COBYLA", "LN_NELDERMEAD")
GLOBAL_ALGORITHMS = ("GN_CRS2_LM", "GN_ISRES", "G_MLSL_LDS")
ALGORITHMS = LOCAL_ALGORITHMS + GLOBAL_ALGORITHMS
#: How nlopt runs end on these problems; the run goes on with the next start. RuntimeError is
#: nlopt's generic failure. An exception raised by the objective (the problem, the budget) is
#: never one of these: it is caught in the objective and raised again after nlopt returns.
NLOPT_STOPS = (nlopt.RoundoffLimited, nlopt.ForcedStop, RuntimeError)


def _check_name(name: str, value: object, valid: tuple[str, ...]) -> str:
    if value not in valid:
        raise ValueError(f"{name} must be one of {', '.join(valid)}; got {value!r}")
    return str(value)


@register("nlopt")
class NloptKnots(Optimizer):
    """nlopt on free knot positions; local runs start from the averaging knots (NURBS Book).

    Parameters
    ----------
    algorithm
        One of :data:`ALGORITHMS`.
    local_algorithm
        Local optimiser of ``G_MLSL_LDS`` (one of :data:`LOCAL_ALGORITHMS`).
    restarts
        Extra runs from perturbed copies of the best point, sharing the budget equally; budget
        left when runs converge early funds further perturbed restarts, so all of it is used.
    min_gap
        Smallest knot span (end spans included) as a fraction of the parameter range, in
        ``(0, 0.5]``; :meth:`setup` also needs ``(n_knots + 1) * min_gap < 1``.
    data_gap
        Smallest knot span as a multiple of the widest data-parameter spacing (>= 0; 1: every
        span holds a data point); the larger of the two gaps applies, at most half the room.
        ``None``: 0.5 for the global algorithms, 0 for the local ones.
    box_map
        ``"spans"`` (softmax of span log-weights around the averaging knots), ``"sorted"``, or
        ``"auto"``: spans for the global algorithms (they sample the box), sorted for the local
        ones (they move each knot from the averaging start).
    span_range
        ``"spans"`` map: the largest factor (> 1) between a span's weight at the two faces of
        the box.
    initial_step
        nlopt's initial step in the unit box ``(0, 1]``.
    perturbation
        Standard deviation of the restart perturbation in the unit box (> 0).
    k_grid
        Number of coarse grid values of K (``variable_count`` only, >= 2).
    """

    encodings = ("continuous",)

    def __init__(self, algorithm: str = "LN_BOBYQA", local_algorithm: str = "LN_BOBYQA",
                 restarts: int = 0, min_gap: float = 1e-4, data_gap: float | None = None,
                 box_map: str = "auto", span_range: float = 4.0, initial_step: float = 0.1,
                 perturbation: float = 0.05, k_grid: int = 5) -> None:
        self.algorithm = _check_name("algorithm", algorithm, ALGORITHMS)
        self.local_algorithm = _check_name("local_algorithm", local_algorithm, LOCAL_ALGORITHMS)
        self.restarts = check_param("restarts", restarts, low=0, integer=True)
        self.min_gap = check_param("min_gap", min_gap, low=0, high=0.5, low_open=True)
        self.data_gap = None if data_gap is None else check_param("data_gap", data_gap, low=0)
        self.box_map = _check_name("box_map", box_map, ("auto", "spans", "sorted"))
        self.span_range = check_param("span_range", span_range, low=1, low_open=True)
        self.initial_step = check_param("initial_step", initial_step, low=0, high=1,
                                        low_open=True)
        self.perturbation = check_param("perturbation", perturbation, low=0, low_open=True)
        self.k_grid = check_param("k_grid", k_grid, low=2, integer=True)

    def setup(self, problem: FreeKnots, rng: np.random.Generator) -> None:
        if not all(hasattr(problem, a) for a in ("params", "degree", "n_knots", "pad")):
            # duck-typed, so wrappers of a FreeKnots (counting, logging) work as well
            raise ValueError(f"optimizer 'nlopt' needs a FreeKnots problem (continuous knot "
                             f"positions); got {problem.name!r}")
        if (problem.n_knots + 1) * self.min_gap >= 1:
            raise ValueError(f"min_gap={self.min_gap} leaves no room for {problem.n_knots} knots; "
                             f"it must be < 1 / {problem.n_knots + 1}")
        super().setup(problem, rng)
        self._worst_finite = -np.inf

    @property
    def map(self) -> str:
        """The box map in use (``box_map``, with ``"auto"`` resolved for the algorithm)."""
        if self.box_map != "auto":
            return self.box_map
        return "sorted" if self.algorithm in LOCAL_ALGORITHMS else "spans"

    def gap(self, n_knots: int) -> float:
        """The smallest knot span for ``n_knots`` knots: ``min_gap`` of the range, or
        ``data_gap`` times the widest spacing of the data parameters if larger (so every span
        holds a data point), at most half the room ``n_knots`` knots leave."""
        u = self.problem.params
        length = float(u[-1] - u[0])
        data_gap = self.data_gap if self.data_gap is not None else (
            0.0 if self.algorithm in LOCAL_ALGORITHMS else 0.5)
        gap = max(self.min_gap * length, data_gap * float(np.diff(u).max()))
        return min(gap, 0.5 * length / (n_knots + 1))

    def _frame(self, n_knots: int) -> tuple[float, float, float]:
        """Start ``a``, the gap and the free length for ``n_knots`` knots."""
        a, b = float(self.problem.params[0]), float(self.problem.params[-1])
        gap = self.gap(n_knots)
        return a, gap, (b - a) - (n_knots + 1) * gap

    def _prior(self, n_knots: int) -> np.ndarray:
        """Log-shares of the free length of the averaging knots' spans (``"spans"`` map)."""
        cache = self.__dict__.setdefault("_priors", {})
        if n_knots not in cache:
            a, gap, free = self._frame(n_knots)
            u = self.problem.params
            ext = np.concatenate(([a], averaging_knots(u, n_knots, self.problem.degree),
                                  [float(u[-1])]))
            share = np.maximum(np.diff(ext) - gap, 1e-3 * free / (n_knots + 1))
            cache[n_knots] = np.log(share / share.sum())
        return cache[n_knots]

    def knots(self, y: np.ndarray) -> np.ndarray:
        """Knot positions of the unit-box vector ``y`` (sorted, spans >= the gap)."""
        y = np.asarray(y, dtype=np.float64)
        a, gap, free = self._frame(y.size)
        if self.map == "sorted":
            return a + gap * np.arange(1, y.size + 1) + free * np.sort(y)
        logw = self._prior(y.size).copy()
        logw[:-1] += np.log(self.span_range) * (y - 0.5)
        share = np.exp(logw - logw.max())
        spans = gap + free * share / share.sum()
        return a + np.cumsum(spans)[:-1]

    def unit(self, knots: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`knots` for sorted knots (clipped to the unit box)."""
        knots = np.asarray(knots, dtype=np.float64)
        a, gap, free = self._frame(knots.size)
        if self.map == "sorted":
            offsets = gap * np.arange(1, knots.size + 1)
            return np.clip((knots - a - offsets) / free, 0.0, 1.0)
        ext = np.concatenate(([a], knots, [float(self.problem.params[-1])]))
        share = np.log(np.maximum(np.diff(ext) - gap, 1e-12 * free))
        prior = self._prior(knots.size)
        relative = (share[:-1] - share[-1]) - (prior[:-1] - prior[-1])
        return np.clip(0.5 + relative / np.log(self.span_range), 0.0, 1.0)

    def run(self, evaluator: Evaluator) -> None:
        try:
            if self.problem.variable_count:
                self._search_count(evaluator)
            else:
                self._optimize(evaluator, self.problem.n_knots, evaluator.remaining,
                               self.restarts + 1)
        except BudgetExhausted:
            pass

    def _search_count(self, evaluator: Evaluator) -> None:
        n = self.problem.n_knots
        grid = np.unique(np.round(np.linspace(1, n, min(n, self.k_grid))).astype(int))
        widest = int(np.diff(grid).max()) if grid.size > 1 else 1
        n_trials = grid.size + 2 * int(np.ceil(np.log2(widest + 1)))
        trial_budget = max(1, evaluator.remaining // (2 * n_trials))
        results: dict[int, tuple[float, np.ndarray]] = {}
        pending = [int(k) for k in grid]
        while pending:
            for k in pending:
                results[k] = self._optimize(evaluator, k, trial_budget, 1)
            tried = sorted(results)
            best = min(tried, key=lambda k: results[k][0])
            i = tried.index(best)
            lower, upper = tried[max(i - 1, 0)], tried[min(i + 1, len(tried) - 1)]
            pending = sorted({(lower + best) // 2, (best + upper + 1) // 2} - set(results))
        best = min(results, key=lambda k: results[k][0])
        self._optimize(evaluator, best, evaluator.remaining, self.restarts + 1,
                       results[best][1])

    def _optimize(self, evaluator: Evaluator, n_knots: int, budget: int, starts: int,
                  start: np.ndarray | None = None) -> tuple[float, np.ndarray]:
        """Runs on ``n_knots`` knots within ``budget`` evaluations; the best value and point.

        Nothing raises through nlopt (GN_CRS2_LM keeps calling after an exception, with a Python
        error pending): the objective records the exception, force-stops nlopt and answers
        further calls at once; afterwards nlopt's own stop exceptions are passed over and the
        objective's exception (``BudgetExhausted``, or any error of the problem, a
        ``RuntimeError`` included) is raised again.
        """
        if start is None:
            start = self.unit(averaging_knots(self.problem.params, n_knots, self.problem.degree))
        best, caught, current = [np.inf, start.copy()], [], []
        pad = self.problem.pad if self.problem.variable_count else (lambda x: x)
        cache: dict[bytes, float] = {}  # nlopt may re-send a point; do not pay for it twice

        def objective(y: np.ndarray, grad: np.ndarray) -> float:
            if caught:
                return self._penalty()
            key = y.tobytes()
            try:
                if key not in cache:
                    cache[key] = float(evaluator(pad(self.knots(y))[None, :])[0])
            except Exception as exc:  # handed back after nlopt returns
                caught.append(exc)
                current[0].force_stop()
                return self._penalty()
            f = cache[key]
            if f < best[0]:
                best[0], best[1] = f, y.copy()
            if not np.isfinite(f):
                return self._penalty()
            self._worst_finite = max(self._worst_finite, f)
            return f

        first, idle, run = evaluator.n_evaluations, 0, 0
        while idle < 3 and (left := budget - (evaluator.n_evaluations - first)) > 0:
            x0 = start if run == 0 else np.clip(
                best[1] + self.rng.normal(0.0, self.perturbation, n_knots), 0.0, 1.0)
            before = evaluator.n_evaluations
            current[:] = [self._build(n_knots, objective, max(1, left // max(starts - run, 1)))]
            caught.clear()
            try:
                if run == 0:  # the start itself first (BOBYQA may shift it off a bound)
                    objective(start, np.empty(0))
                if not caught:
                    current[0].optimize(x0)
            except NLOPT_STOPS:
                pass  # the best point seen is kept by the objective and the evaluator
            if caught:
                raise caught[0]
            idle = idle + 1 if evaluator.n_evaluations == before else 0
            run += 1
        return best[0], best[1]

    def _penalty(self) -> float:
        """Finite stand-in for +inf: worse than every finite value seen so far."""
        worst = self._worst_finite
        return worst + abs(worst) + 1.0 if np.isfinite(worst) else 1e12

    def _build(self, n_knots: int, objective, maxeval: int) -> nlopt.opt:
        nlopt.srand(int(self.rng.integers(2**31)))  # nlopt's RNG, for the GN_* / MLSL draws
        opt = nlopt.opt(getattr(nlopt, self.algorithm), n_knots)
        opt.set_min_objective(objective)
        opt.set_lower_bounds(np.zeros(n_knots))
        opt.set_upper_bounds(np.ones(n_knots))
        opt.set_initial_step(self.initial_step)
        opt.set_maxeval(int(maxeval))
        if self.algorithm == "G_MLSL_LDS":
            local = nlopt.opt(getattr(nlopt, self.local_algorithm), n_knots)
            local.set_xtol_rel(1e-4)
            local.set_initial_step(self.initial_step)
            opt.set_local_optimizer(local)
        return opt
