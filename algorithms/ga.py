"""Genetic algorithm (``ga``): tournament selection, uniform or two-point crossover, bit-flip
or index mutation, elitism: the kind of GA the seed paper compares Dolphin Echolocation against.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.registry import register
from metaknot.task import ProblemView

__all__ = ["GeneticAlgorithm", "flip_mutation", "index_mutation", "tournament_selection",
           "two_point_crossover", "uniform_crossover"]

CROSSOVERS = ("uniform", "two_point")
INDEX_MUTATIONS = ("step", "reset")


def tournament_selection(F: np.ndarray, n: int, size: int, rng: np.random.Generator) -> np.ndarray:
    """Indices of the winners of ``n`` tournaments among ``size`` individuals drawn uniformly
    with replacement. Lowest objective wins; a tie (equal values, several ``+inf``) goes to the
    first tied contestant drawn, a uniformly random one of them, so plateaus and infeasible
    candidates never stall selection. NaN ranks last."""
    rank = np.unique(F, return_inverse=True)[1].reshape(-1)  # dense rank: equal values tie
    contestants = rng.integers(0, F.size, size=(n, size))
    return contestants[np.arange(n), np.argmin(rank[contestants], axis=1)]


def uniform_crossover(A: np.ndarray, B: np.ndarray, rate: float,
                      rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Two children per parent pair ``(A[i], B[i])``: with probability ``rate`` each gene comes
    from either parent with probability 1/2 (the second child gets the other one); otherwise
    the children are copies of the parents."""
    swap = (rng.random((A.shape[0], 1)) < rate) & (rng.random(A.shape) < 0.5)
    return np.where(swap, B, A), np.where(swap, A, B)


def two_point_crossover(A: np.ndarray, B: np.ndarray, rate: float,
                        rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Like :func:`uniform_crossover`, but the exchanged genes are one segment ``lo..hi-1``, two
    distinct cut points drawn uniformly from ``1..n-1`` (for ``n < 3`` genes: one cut at 1)."""
    m, n = A.shape
    crossed = rng.random((m, 1)) < rate
    if n >= 3:
        a = rng.integers(1, n, size=m)
        b = rng.integers(1, n - 1, size=m)
        b = b + (b >= a)  # uniform over 1..n-1 without a
        lo, hi = np.minimum(a, b), np.maximum(a, b)
    else:
        lo, hi = np.ones(m, dtype=np.int64), np.full(m, n)
    cols = np.arange(n)
    swap = crossed & (cols >= lo[:, None]) & (cols < hi[:, None])
    return np.where(swap, B, A), np.where(swap, A, B)


def flip_mutation(X: np.ndarray, rate: float, rng: np.random.Generator) -> np.ndarray:
    """Flip every bit of the 0/1 array ``X`` independently with probability ``rate``.

    Drawn as a binomial number of flips at uniformly random distinct positions (the same
    distribution as one Bernoulli draw per bit, at the cost of the flips only).
    """
    out = np.array(X, copy=True)
    n_flips = int(rng.binomial(out.size, rate))
    if n_flips:
        flat = out.reshape(-1)
        where = rng.choice(out.size, size=n_flips, replace=False)
        flat[where] ^= 1
    return out


def index_mutation(X: np.ndarray, rate: float, lower: np.ndarray, upper: np.ndarray,
                   rng: np.random.Generator, *, kind: str = "step",
                   max_step: int = 1) -> np.ndarray:
    """Move every gene of the integer array ``X`` independently with probability ``rate``.

    ``kind="step"``: by ``+-1..max_step`` (uniform), possibly past ``lower``/``upper`` (the
    caller repairs). ``kind="reset"``: to a uniformly random other value of ``lower..upper``.
    """
    hit = rng.random(X.shape) < rate
    if kind == "step":
        move = rng.integers(1, max_step + 1, size=X.shape) * rng.choice((-1, 1), size=X.shape)
        return np.where(hit, X + move, X)
    span = upper - lower + 1
    offset = 1 + np.floor(rng.random(X.shape) * (span - 1)).astype(np.int64)
    return np.where(hit, lower + (X - lower + offset) % span, X)


@register("ga")
class GeneticAlgorithm(Optimizer):
    """Generational GA with tournament selection and elitism.

    Each generation keeps the ``elite`` best individuals unchanged (not re-evaluated) and breeds
    ``population - elite`` offspring: parents by tournament, pairs crossed over with probability
    ``crossover_rate``, each gene mutated with probability ``mutation_rate``, and the children
    passed through ``problem.encoding.repair`` (sorted, distinct indices on ``KnotIndices``).
    Mutation flips a bit of a binary mask. On integer encodings (ordered alternatives, such as
    knot indices along the curve) ``index_mutation="step"`` (default) moves a gene by a uniform
    step of ``1..max_step`` either way, a local move along the curve; ``"reset"`` moves it to a
    uniformly random other alternative. A value pushed past a bound is clipped; one landing on
    another knot goes to the nearest free index (both by ``repair``). When the budget truncates
    a batch, the best parents fill the places of the children that were not evaluated.

    Parameters
    ----------
    population
        Individuals per generation (>= 2); the first batch is ``problem.sample``.
    tournament_size
        Contestants per tournament (>= 2); larger means stronger selection pressure.
    crossover
        ``"uniform"`` or ``"two_point"``.
    crossover_rate
        Probability in [0, 1] that a parent pair is crossed over rather than copied.
    mutation_rate
        Per-gene mutation probability in [0, 1]; ``None`` means ``1 / n_var``.
    elite
        Best individuals copied unchanged into the next generation (0 <= elite < population).
    index_mutation, max_step
        Integer encodings only: ``"step"`` (by ``+-1..max_step``) or ``"reset"``.
    """

    encodings = ("binary", "integer")

    def __init__(self, population: int = 50, tournament_size: int = 2,
                 crossover: str = "uniform", crossover_rate: float = 0.9,
                 mutation_rate: float | None = None, elite: int = 1,
                 index_mutation: str = "step", max_step: int = 3) -> None:
        self.population = check_param("population", population, low=2, integer=True)
        self.tournament_size = check_param("tournament_size", tournament_size, low=2,
                                           integer=True)
        if crossover not in CROSSOVERS:
            raise ValueError(f"crossover must be one of {CROSSOVERS}; got {crossover!r}")
        self.crossover = crossover
        self.crossover_rate = check_param("crossover_rate", crossover_rate, low=0, high=1)
        self.mutation_rate = None if mutation_rate is None else \
            check_param("mutation_rate", mutation_rate, low=0, high=1)
        self.elite = check_param("elite", elite, low=0, integer=True)
        if self.elite >= self.population:
            raise ValueError(f"elite must be < population ({self.population}); got {elite!r}")
        if index_mutation not in INDEX_MUTATIONS:
            raise ValueError(f"index_mutation must be one of {INDEX_MUTATIONS}; "
                             f"got {index_mutation!r}")
        self.index_mutation = index_mutation
        self.max_step = check_param("max_step", max_step, low=1, integer=True)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        n_var = problem.encoding.n_var
        self.rate = 1.0 / n_var if self.mutation_rate is None else self.mutation_rate
        self.pop_x = np.empty((0, n_var), dtype=np.int64)
        self.pop_f = np.empty(0)

    def ask(self) -> np.ndarray:
        """The initial population (or its missing part), later ``population - elite``
        offspring."""
        missing = self.population - self.pop_f.size
        if missing > 0:
            return self.problem.sample(self.rng, missing)
        return self.offspring(self.population - self.elite)

    def offspring(self, n: int) -> np.ndarray:
        """``n`` children of the current population: select, cross over, mutate, repair."""
        pairs = -(-n // 2)
        parents = tournament_selection(self.pop_f, 2 * pairs, self.tournament_size, self.rng)
        cross = uniform_crossover if self.crossover == "uniform" else two_point_crossover
        children = np.concatenate(cross(self.pop_x[parents[:pairs]], self.pop_x[parents[pairs:]],
                                        self.crossover_rate, self.rng))[:n]
        enc = self.problem.encoding
        if enc.kind == "binary":  # crossover and bit flips keep a 0/1 mask valid
            return flip_mutation(children, self.rate, self.rng)
        children = index_mutation(children, self.rate, enc.lower, enc.upper, self.rng,
                                  kind=self.index_mutation, max_step=self.max_step)
        return enc.repair(children)

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        """Store the initial population, or replace all but the best ``population - len(F)``
        individuals (the elite, plus the best parents when the batch was truncated)."""
        X, F = np.asarray(X, dtype=np.int64), np.asarray(F, dtype=np.float64)
        if X.shape[0] != F.size:
            raise ValueError(f"tell got {X.shape[0]} candidates but {F.size} values")
        if self.pop_f.size < self.population:
            self.pop_x = np.concatenate((self.pop_x, X))
            self.pop_f = np.concatenate((self.pop_f, F))
            return
        keep = np.argsort(self.pop_f, kind="stable")[: self.population - F.size]
        self.pop_x = np.concatenate((self.pop_x[keep], X))
        self.pop_f = np.concatenate((self.pop_f[keep], F))
