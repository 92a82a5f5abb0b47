"""Free-knot baselines: the K interior knot positions of a ``FreeKnots`` problem optimised by nlopt.

Knots stay ordered and separated by construction. nlopt searches ``y`` in the unit box
``[0, 1]^K`` (finite bounds, as the GN_* algorithms need), mapped to knots by a
:class:`~metaknot.algorithms.knot_map.KnotMap`: every span at least a gap (``data_gap`` times
the widest data spacing, half of it by default for the global algorithms, which sample the
whole box: then almost every box point gives a feasible fit; or ``min_gap`` of the range), and
``box_map="auto"`` takes the ``"spans"`` map (span weights centred on the averaging knots) for
the global algorithms and the ``"sorted"`` map for the local ones, which move each knot from
the averaging start.

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

from collections.abc import Callable
from typing import Any

import nlopt
import numpy as np

from metaknot.budget import BudgetExhausted, Evaluator
from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import FreeKnotSpace
from metaknot.registry import register
from metaknot.task import ProblemView

from ._adapters import FinitePenalty, check_choice
from .knot_map import KnotMap

LOCAL_ALGORITHMS = ("LN_BOBYQA", "LN_SBPLX", "LN_COBYLA", "LN_NELDERMEAD")
#: Local algorithms with gradients: they minimise the fit's sum of squared errors, with its
#: exact gradient (:func:`~metaknot.algorithms.variable_projection.residual_jacobian`).
GRADIENT_ALGORITHMS = ("LD_LBFGS", "LD_MMA", "LD_SLSQP", "LD_TNEWTON_PRECOND_RESTART",
                       "LD_VAR2")
GLOBAL_ALGORITHMS = ("GN_CRS2_LM", "GN_ISRES", "G_MLSL_LDS")
ALGORITHMS = LOCAL_ALGORITHMS + GRADIENT_ALGORITHMS + GLOBAL_ALGORITHMS
#: Objectives that, at a fixed number of knots, grow with the sum of squared errors: what the
#: gradient algorithms minimise in their place.
SSE_MONOTONE_OBJECTIVES = ("rmse", "paper", "bic")
#: How nlopt runs end on these problems; the run goes on with the next start. RuntimeError is
#: nlopt's generic failure (``nlopt.runtime_error`` from nlopt 2.11 on, which the gradient
#: algorithms raise when a line search fails). An exception raised by the objective (the
#: problem, the budget) is never one of these: it is caught in the objective and raised again
#: after nlopt returns.
NLOPT_STOPS: tuple[type[BaseException], ...] = (
    nlopt.RoundoffLimited, nlopt.ForcedStop, RuntimeError,
    *((nlopt.runtime_error,) if hasattr(nlopt, "runtime_error") else ()))  # nlopt >= 2.11


def check_free_knots(name: str, problem: ProblemView, min_gap: float) -> None:
    """Refuse a problem that is not a FreeKnots (a :class:`FreeKnotSpace`: duck-typed, so
    wrappers of one, counting or logging, work as well) or has no room for its knots at gaps of
    ``min_gap``."""
    if not isinstance(problem, FreeKnotSpace):
        raise ValueError(f"optimizer {name!r} needs a FreeKnots problem (continuous knot "
                         f"positions); got {problem.name!r}")
    if (problem.n_knots + 1) * min_gap >= 1:
        raise ValueError(f"min_gap={min_gap} leaves no room for {problem.n_knots} knots; "
                         f"it must be < 1 / {problem.n_knots + 1}")


class NloptObjective:
    """``evaluate`` (the value of a unit-box point) as an nlopt objective: a point sent again is
    answered from a cache, a value that is not finite as ``penalty``'s stand-in. Nothing raises
    through nlopt (GN_CRS2_LM keeps calling after an exception): an exception of ``evaluate``
    force-stops nlopt, further calls are answered at once, and :meth:`optimize` raises it."""

    def __init__(self, evaluate: Callable[[np.ndarray], float], penalty: FinitePenalty,
                 gradient: Callable[[np.ndarray], np.ndarray] | None = None) -> None:
        self.evaluate, self.penalty, self.gradient = evaluate, penalty, gradient
        self.cache: dict[bytes, float] = {}
        self.caught: list[BaseException] = []
        self.opt: nlopt.opt | None = None  # the run to stop

    def __call__(self, y: np.ndarray, grad: np.ndarray) -> float:
        if self.caught:
            return self.penalty.value
        key = y.tobytes()
        try:
            if key not in self.cache:
                self.cache[key] = self.evaluate(y)
            if grad.size:  # asked for by the gradient algorithms only
                value = self.cache[key]
                grad[:] = self.gradient(y) if self.gradient is not None and np.isfinite(value) \
                    else 0.0
        except Exception as exc:  # handed back by optimize after nlopt returns
            self.caught.append(exc)
            assert self.opt is not None  # set by optimize, which nlopt calls this from
            self.opt.force_stop()
            return self.penalty.value
        return self.penalty.one(self.cache[key])

    def optimize(self, opt: nlopt.opt, y0: np.ndarray, first: bool = False) -> None:
        """``opt.optimize(y0)``, ``y0`` evaluated first with ``first``; nlopt's own stops
        (:data:`NLOPT_STOPS`) are passed over, the exception of ``evaluate`` raised again."""
        self.opt = opt
        try:
            if first:
                self(y0, np.empty(0))
            if not self.caught:
                opt.optimize(y0)
        except NLOPT_STOPS:
            pass  # the best point seen is kept by evaluate and the evaluator
        if self.caught:
            raise self.caught[0]


@register("nlopt")
class NloptKnots(Optimizer):
    """nlopt on free knot positions; local runs start from the averaging knots (NURBS Book).

    Parameters
    ----------
    variant
        One of :data:`ALGORITHMS`. The gradient algorithms (:data:`GRADIENT_ALGORITHMS`)
        minimise the fit's sum of squared errors with its exact gradient (every point they try
        is still evaluated, and counted, by the problem's objective, which must be one of
        :data:`SSE_MONOTONE_OBJECTIVES`); their own fits are declared (``external_fits``).
    local_variant
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

    #: ``nlopt:<variant>`` in the registry sets this parameter (``nlopt:LN_SBPLX``).
    variant_parameter = "variant"

    encodings = ("continuous",)
    problem: FreeKnotSpace  # setup refuses any other (check_free_knots)

    def __init__(self, variant: str = "LN_BOBYQA", local_variant: str = "LN_BOBYQA",
                 restarts: int = 0, min_gap: float = 1e-4, data_gap: float | None = None,
                 box_map: str = "auto", span_range: float = 4.0, initial_step: float = 0.1,
                 perturbation: float = 0.05, k_grid: int = 5) -> None:
        self.variant = check_choice("variant", variant, ALGORITHMS)
        self.local_variant = check_choice("local_variant", local_variant, LOCAL_ALGORITHMS)
        self.restarts = check_param("restarts", restarts, low=0, integer=True)
        self.min_gap = check_param("min_gap", min_gap, low=0, high=0.5, low_open=True)
        self.data_gap = None if data_gap is None else check_param("data_gap", data_gap, low=0)
        self.box_map = check_choice("box_map", box_map, ("auto", "spans", "sorted"))
        self.span_range = check_param("span_range", span_range, low=1, low_open=True)
        self.initial_step = check_param("initial_step", initial_step, low=0, high=1,
                                        low_open=True)
        self.perturbation = check_param("perturbation", perturbation, low=0, low_open=True)
        self.k_grid = check_param("k_grid", k_grid, low=2, integer=True)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        check_free_knots(self.name, problem, self.min_gap)
        objective = getattr(problem, "objective", None)
        if self.variant in GRADIENT_ALGORITHMS and \
                getattr(objective, "name", None) not in SSE_MONOTONE_OBJECTIVES:
            raise ValueError(f"nlopt's {self.variant} minimises the sum of squared errors, which "
                             f"orders candidates as the objectives "
                             f"{', '.join(SSE_MONOTONE_OBJECTIVES)} do; got objective "
                             f"{getattr(objective, 'name', objective)!r}")
        super().setup(problem, rng)
        self.penalty = FinitePenalty()
        self._box: KnotMap | None = None

    @property
    def local(self) -> bool:
        """True for the local algorithms (derivative-free or with gradients)."""
        return self.variant in LOCAL_ALGORITHMS + GRADIENT_ALGORITHMS

    @property
    def map(self) -> str:
        """The box map in use (``box_map``, with ``"auto"`` resolved for the algorithm)."""
        if self.box_map != "auto":
            return self.box_map
        return "sorted" if self.local else "spans"

    @property
    def box(self) -> KnotMap:
        """The box-to-knots map (see :mod:`metaknot.algorithms.knot_map`) for this problem."""
        box = getattr(self, "_box", None)
        if box is None:
            data_gap = self.data_gap if self.data_gap is not None else (
                0.0 if self.local else 0.5)
            box = self._box = KnotMap.of(self.problem, kind=self.map, min_gap=self.min_gap,
                                         data_gap=data_gap, span_range=self.span_range)
        return box

    def gap(self, n_knots: int) -> float:
        """The smallest knot span for ``n_knots`` knots (:meth:`KnotMap.gap`)."""
        return self.box.gap(n_knots)

    def knots(self, y: np.ndarray) -> np.ndarray:
        """Knot positions of the unit-box vector ``y`` (sorted, spans >= the gap)."""
        return self.box.knots(y)

    def unit(self, knots: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`knots` for sorted knots (clipped to the unit box)."""
        return self.box.unit(knots)

    def run(self, evaluator: Evaluator) -> None:
        from .variable_projection import one_blas_thread

        with one_blas_thread():  # the gradient's small matrices (see there)
            self._run(evaluator)

    def _run(self, evaluator: Evaluator) -> None:
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

        An exception of the evaluation (``BudgetExhausted``, any error of the problem) is raised
        after nlopt returns (:class:`NloptObjective`).
        """
        if start is None:
            start = self.unit(self.problem.start_knots(n_knots))
        best: list[Any] = [np.inf, start.copy()]  # the best value and its point
        pad = self.problem.pad if self.problem.variable_count else (lambda x: x)

        def evaluate(y: np.ndarray) -> float:
            f = float(evaluator(pad(self.knots(y))[None, :])[0])
            if f < best[0]:
                best[0], best[1] = f, y.copy()
            if self.variant in GRADIENT_ALGORITHMS and np.isfinite(f):
                return self._sse_and_gradient(y, with_gradient=False)[0]
            return f

        def gradient(y: np.ndarray) -> np.ndarray:
            return self._sse_and_gradient(y, with_gradient=True)[1]

        objective = NloptObjective(evaluate, self.penalty, gradient)
        first, idle, run = evaluator.n_evaluations, 0, 0
        while idle < 3 and (left := budget - (evaluator.n_evaluations - first)) > 0:
            x0 = start if run == 0 else np.clip(
                best[1] + self.rng.normal(0.0, self.perturbation, n_knots), 0.0, 1.0)
            before = evaluator.n_evaluations
            opt = self._build(n_knots, objective, max(1, left // max(starts - run, 1)))
            # the start itself first on the first run (BOBYQA may shift it off a bound)
            objective.optimize(opt, x0, first=run == 0)
            idle = idle + 1 if evaluator.n_evaluations == before else 0
            run += 1
        return best[0], best[1]

    def _sse_and_gradient(self, y: np.ndarray, with_gradient: bool
                          ) -> tuple[float, np.ndarray]:
        """The sum of squared errors at the unit-box point ``y`` and (``with_gradient``) its
        gradient with respect to ``y``, by the method's own fit (declared: one fit, a repeat
        of the evaluation's; the Jacobian charged to the budget as ``K + 1`` fits, one refined
        basis per knot and the fit). ``+inf`` for a fit that is rank deficient."""
        from .variable_projection import residual_jacobian

        problem = self.problem
        knots = self.knots(y)
        self.count_fits(1)
        if with_gradient:
            self.count_fits(knots.size + 1, charged=True)
        try:
            residual, jacobian, _ = residual_jacobian(
                problem.params, problem.points, problem.degree, knots, problem.knot_bounds,
                closed=bool(problem.closed), jacobian=with_gradient)
        except np.linalg.LinAlgError:
            return np.inf, np.zeros(y.size)
        gradient = np.zeros(y.size) if jacobian is None else \
            self.box.pull_back(y, 2.0 * (jacobian.T @ residual))
        return float(residual @ residual), gradient

    def _penalty(self) -> float:
        """Finite stand-in for +inf: worse than every finite value seen so far."""
        return self.penalty.value

    def _build(self, n_knots: int, objective: NloptObjective, maxeval: int) -> nlopt.opt:
        nlopt.srand(int(self.rng.integers(2**31)))  # nlopt's RNG, for the GN_* / MLSL draws
        opt = nlopt.opt(getattr(nlopt, self.variant), n_knots)
        opt.set_min_objective(objective)
        opt.set_lower_bounds(np.zeros(n_knots))
        opt.set_upper_bounds(np.ones(n_knots))
        opt.set_initial_step(self.initial_step)
        opt.set_maxeval(int(maxeval))
        if self.variant == "G_MLSL_LDS":
            local = nlopt.opt(getattr(nlopt, self.local_variant), n_knots)
            local.set_xtol_rel(1e-4)
            local.set_initial_step(self.initial_step)
            opt.set_local_optimizer(local)
        return opt
