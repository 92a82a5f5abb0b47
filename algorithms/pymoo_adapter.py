"""pymoo's algorithms on every knot problem (``pymoo``, or by name as ``pymoo:GA``,
``pymoo:DE``, ``pymoo:BRKGA``, and the multi-objective ``pymoo:NSGA2`` for the objective
``pareto``). pymoo is an optional dependency (``pip install metaknot[adapters]``).

pymoo searches a genotype that is decoded into the problem's candidate:

* ``GA`` and ``NSGA2`` on a 0/1 mask: the mask itself (two-point crossover, bit flips; ``GA``
  samples bits with probability 1/2, ``NSGA2`` draws each individual's density uniformly from
  (0, 1), so its first population already spans the control-point range of a front);
* ``GA`` and ``NSGA2`` on index sets: integers in the index range (SBX and polynomial mutation
  with rounding), repaired to sorted distinct sets (the GA's rule); on masks of multiplicities
  the same operators, the first population sampled as 0/1 masks are;
* otherwise (``DE``, ``BRKGA``, and ``GA`` on free knots): random keys in ``[0, 1]^n``: a bit is
  set where its key exceeds 1/2 (on a mask of multiplicities, a copy more of the knot at 3/4,
  7/8, ... up to the largest multiplicity), an index is
  ``lower + floor(key (upper - lower + 1))`` (then repaired), and free knots come from the
  unit box of a
  :class:`~metaknot.algorithms.knot_map.KnotMap` (span weights centred on the averaging knots).

pymoo runs through its ask/tell interface with metaknot's evaluator (each population is one
batch, counted against the framework's budget; pymoo's own evaluation counter is fed with the
values, nothing is evaluated twice), seeded from the run's generator. A population cut short by
the budget is not told. When pymoo ends the search itself (its mating makes no new candidate:
with duplicates eliminated, a small search space runs out of them), the run ends there, before
the budget.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import is_mask
from metaknot.registry import register
from metaknot.task import ProblemView

from ._adapters import (
    FinitePenalty,
    check_choice,
    free_knots,
    optional_import,
    refuse_variable_count,
)
from .baselines import knots_to_candidate
from .knot_map import KnotMap

__all__ = ["PymooOptimizer"]

ALGORITHMS = ("GA", "DE", "BRKGA", "NSGA2")


@register("pymoo")
class PymooOptimizer(Optimizer):
    """A pymoo algorithm by name.

    Parameters
    ----------
    variant
        ``"GA"``, ``"DE"``, ``"BRKGA"`` (one objective) or ``"NSGA2"`` (NSGA-II: a front of
        control points against error under the objective ``pareto``; on one objective it is a
        GA with crowding).
    population
        Population size (``BRKGA``: elites + offspring + mutants, split 20/70/10 %).
    initial
        ``"random"``, or ``"averaging"`` (``GA`` and ``NSGA2`` on 0/1 masks): half the first
        population are the averaging knots (NURBS Book) at knot counts spread evenly over the
        range, the rest random, so the search starts from the classical front.
    """

    encodings = ("binary", "integer", "continuous")
    variant_parameter = "variant"

    def __init__(self, variant: str = "GA", population: int = 50,
                 initial: str = "random") -> None:
        self.variant = check_choice("variant", variant, ALGORITHMS)
        self.multi_objective = variant == "NSGA2"
        if initial not in ("random", "averaging"):
            raise ValueError(f"initial must be 'random' or 'averaging'; got {initial!r}")
        if initial == "averaging" and variant not in ("GA", "NSGA2"):
            raise ValueError(f"initial='averaging' applies to GA and NSGA2; got {variant!r}")
        self.initial = initial
        self.population = check_param("population", population, low=4, integer=True)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        optional_import("pymoo", "pymoo")
        refuse_variable_count(problem, "pymoo")
        super().setup(problem, rng)
        from pymoo.core.problem import Problem as PymooProblem

        encoding = problem.encoding
        n = encoding.n_var
        own = self.variant in ("GA", "NSGA2") and encoding.kind in ("binary", "integer")
        self.genotype = encoding.kind if own else "keys"  # GA, NSGA2: masks and sets as such
        if self.genotype == "integer":
            lower, upper = encoding.lower.astype(float), encoding.upper.astype(float)
        else:
            lower, upper = np.zeros(n), np.ones(n)
        vtype = {"binary": bool, "integer": int, "keys": float}[self.genotype]
        self.box = KnotMap.of(free_knots(problem, "pymoo")) if encoding.kind == "continuous" \
            else None
        self.n_obj = getattr(problem, "n_objectives", 1)
        self.pymoo_problem = PymooProblem(n_var=n, n_obj=self.n_obj, xl=lower, xu=upper,
                                          vtype=vtype)
        self.method = self._algorithm()
        self.method.setup(self.pymoo_problem, termination=("n_eval", 10**12),
                          seed=int(rng.integers(2**31)))
        self._pop = None
        self._ended = False
        self.penalty = FinitePenalty()

    def _algorithm(self):
        from pymoo.algorithms.moo.nsga2 import NSGA2
        from pymoo.algorithms.soo.nonconvex.brkga import BRKGA
        from pymoo.algorithms.soo.nonconvex.de import DE
        from pymoo.algorithms.soo.nonconvex.ga import GA
        from pymoo.operators.crossover.pntx import TwoPointCrossover
        from pymoo.operators.crossover.sbx import SBX
        from pymoo.operators.mutation.bitflip import BitflipMutation
        from pymoo.operators.mutation.pm import PM
        from pymoo.operators.repair.rounding import RoundingRepair
        from pymoo.operators.sampling.rnd import BinaryRandomSampling, IntegerRandomSampling

        size = self.population
        if self.variant == "DE":
            return DE(pop_size=size)
        if self.variant == "BRKGA":
            elites, mutants = max(1, size // 5), max(1, size // 10)
            return BRKGA(n_elites=elites, n_offsprings=size - elites - mutants,
                         n_mutants=mutants)
        method = NSGA2 if self.variant == "NSGA2" else GA
        if self.genotype == "binary":
            sampling = _spread_sampling() if method is NSGA2 else BinaryRandomSampling()
            if self.initial == "averaging":
                sampling = self._averaging_start(sampling)
            return method(pop_size=size, sampling=sampling, crossover=TwoPointCrossover(),
                          mutation=BitflipMutation(), eliminate_duplicates=True)
        if self.genotype == "integer":
            # a mask of multiplicities starts from 0/1 masks (as a 0/1 mask does): uniform
            # multiplicities put a multiple knot at most points, every candidate infeasible
            sampling = IntegerRandomSampling() if not is_mask(self.problem) else \
                _as_integers(_spread_sampling() if method is NSGA2 else BinaryRandomSampling())
            return method(pop_size=size, sampling=sampling,
                          crossover=SBX(vtype=float, repair=RoundingRepair()),
                          mutation=PM(vtype=float, repair=RoundingRepair()),
                          eliminate_duplicates=True)
        return method(pop_size=size)

    def _averaging_start(self, sampling):
        """A first population of averaging-knot masks (half) and ``sampling``'s (the rest)."""
        problem = self.problem
        if problem.encoding.kind != "binary":
            raise ValueError("initial='averaging' needs a 0/1 mask problem (mask)")
        top = problem.data.n_points - problem.degree - 1
        counts = np.unique(np.linspace(1, top, self.population // 2).round().astype(int))
        masks = [knots_to_candidate(problem, problem.start_knots(k)) for k in counts]
        seed = int(self.rng.integers(2**31))
        rest = sampling.do(self.pymoo_problem, self.population - len(masks),
                           random_state=np.random.default_rng(seed)).get("X")
        return np.vstack([np.array(masks, dtype=bool), np.asarray(rest, dtype=bool)])

    def decode(self, G: np.ndarray) -> np.ndarray:
        """Candidates of the problem from pymoo genotypes (see the module notes)."""
        encoding = self.problem.encoding
        G = np.asarray(G, dtype=np.float64)
        if self.genotype == "binary":
            return G.astype(np.int64)
        if self.genotype == "integer":
            X = np.rint(G).astype(np.int64)
            return encoding.repair(X) if encoding.distinct_sorted else X
        if encoding.kind == "binary":
            return (G > 0.5).astype(np.int64)
        if is_mask(self.problem):  # a knot where the key exceeds 1/2, a copy more for each
            with np.errstate(divide="ignore"):  # halving of the distance to 1 (key 1: -log 0)
                copies = np.floor(-np.log2(np.maximum(1.0 - G, 0.0)))
            return np.where(G > 0.5, np.minimum(copies, encoding.upper), 0).astype(np.int64)
        if encoding.kind == "integer":
            lo, hi = encoding.lower, encoding.upper
            X = np.minimum(lo + np.floor(G * (hi - lo + 1)).astype(np.int64), hi)
            return encoding.repair(X) if encoding.distinct_sorted else X
        box = self.box
        assert box is not None  # continuous candidates: the map made in setup
        return np.array([box.knots(g) for g in G])

    def finished(self) -> bool:
        """True once pymoo has ended the search: its mating made no new candidate (with
        duplicates eliminated, a small search space runs out of them)."""
        return self._ended

    def ask(self) -> np.ndarray:
        self._pop = self.method.ask()
        if self._pop is None:  # pymoo terminated itself: nothing new is left to evaluate
            self._ended = True
            return np.empty((0, self.problem.encoding.n_var), dtype=np.int64)
        return self.decode(self._pop.get("X"))

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        from pymoo.problems.static import StaticProblem

        F = np.asarray(F, dtype=np.float64)
        if self._pop is None or len(F) < len(self._pop):
            return  # the budget cut the population short: the run ends here
        values = self.penalty(F).reshape(len(F), self.n_obj)
        self.method.evaluator.eval(StaticProblem(self.pymoo_problem, F=values), self._pop)
        self.method.tell(infills=self._pop)
        self._pop = None


def _as_integers(sampling):
    """pymoo ``sampling`` with its samples as integers (0/1 masks for an integer genotype)."""
    from pymoo.core.sampling import Sampling

    class IntegerSampling(Sampling):
        def _do(self, problem, n_samples, *args, **kwargs):
            return np.asarray(sampling._do(problem, n_samples, *args, **kwargs), dtype=np.int64)

    return IntegerSampling()


def _spread_sampling():
    """pymoo sampling of 0/1 masks whose densities are uniform in (0, 1), one per individual."""
    from pymoo.core.sampling import Sampling

    class SpreadBinarySampling(Sampling):
        def _do(self, problem, n_samples, *args, random_state=None, **kwargs):
            density = random_state.random((n_samples, 1))
            return random_state.random((n_samples, problem.n_var)) < density

    return SpreadBinarySampling()
