"""Dolphin Echolocation (Kaveh & Farhoudi 2013), the seed paper's optimizer.

Variable ``j`` has the ordered alternatives ``lower_j..upper_j`` (binary masks: ``{0, 1}``;
``KnotIndices``: data indices along the curve). Loop ``i``: evaluate the NL locations; add each
location's fitness to the accumulative fitness AF of its alternatives and their neighbours within
``re`` (linear weight, mirror reflection at the edges); add ``epsilon``; zero the loop-best's
alternatives; give those the probability ``PP(i)`` and the others ``(1 - PP(i)) AF / sum AF``;
sample every variable of the next NL locations independently. On a binary mask this reduces to
"each bit equals the loop-best's bit with probability PP(i)" (AF and ``re`` play no part).

Choices the paper leaves open:

* Fitness (maximised) from the objective (minimised): ``"inverse"`` is the seed's ``1/objective``;
  ``"rank"`` ranks the loop's feasible locations (worst 1 .. best n, ties averaged);
  ``"auto"`` takes inverse when the problem's objective has a natural zero
  (``objective.ratio_scale``: the seed's ``paper``), else rank — so on ``bic``, defined up to a
  constant, rescaling the data does not change the search. Infeasible locations get 0.
  Fitness is scaled so the loop-best has 1; as probabilities depend on fitness only relative to
  ``epsilon``, ``epsilon`` is in units of the loop-best's fitness (default 1e-3: below the
  lowest fitness of a loop).
* ``loops=None``: ``ceil(budget / population)`` loops, derived at ``setup`` from the task's
  budget, so PP reaches 1 at the last loop (whose sampled locations go unused, as in the
  paper). An explicit ``loops`` ends the run after that many loops, even with budget left.
  ``loops = 1`` gives ``PP(1) = pp1``.
* Index sets (``KnotIndices``) cannot hold an index twice: sampled locations pass through
  ``encoding.repair`` (sorted, repeats moved to the nearest free index), the one departure from
  the paper. Variable ``j`` is then the ``j``-th knot along the curve.
* Ties for the loop-best go to the first location; the evaluator keeps the best ever seen (also
  in ``best_x`` / ``best_f``).
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.registry import register
from metaknot.task import ProblemView

__all__ = ["DolphinEcholocation", "accumulative_fitness", "alternative_probabilities",
           "binary_probabilities", "fitness_values", "pp_schedule", "reflect",
           "sample_alternatives"]


def pp_schedule(loops: int, pp1: float, power: float) -> np.ndarray:
    """``PP(i)``, ``i = 1..loops`` (eq. 1): ``pp1 + (1-pp1) (i^power - 1) / (loops^power - 1)``."""
    if loops == 1:
        return np.array([float(pp1)])
    i = np.arange(1, loops + 1, dtype=np.float64)
    return pp1 + (1.0 - pp1) * (i**power - 1.0) / (float(loops) ** power - 1.0)


def reflect(index: np.ndarray, n_alternatives: np.ndarray | int) -> np.ndarray:
    """Mirror indices into ``0..n-1`` (``-m -> m``, ``n-1+m -> n-1-m``), folding repeatedly."""
    period = 2 * (np.asarray(n_alternatives) - 1)
    m = np.abs(index) % np.maximum(period, 1)
    return np.where(m > period // 2, period - m, m)


def accumulative_fitness(alternatives: np.ndarray, fitness: np.ndarray,
                         n_alternatives: np.ndarray | int, re: int, epsilon: float = 0.0,
                         best: np.ndarray | None = None) -> np.ndarray:
    """Step 4: AF of shape ``(max n_alternatives, NV)``.

    Parameters
    ----------
    alternatives
        ``(NL, NV)`` positions (0-based) of the locations' values among their alternatives.
    fitness
        ``(NL,)`` fitness of the locations (maximised).
    n_alternatives
        Number of alternatives per variable (scalar or ``(NV,)``); rows beyond it stay 0.
    re, epsilon
        Effective radius: alternative ``A + k``, ``|k| <= re``, gains ``(re - |k|) / re`` times
        the fitness; then ``epsilon`` is added to every alternative.
    best
        ``(NV,)`` alternatives of the loop-best location, whose AF is set to 0 (step 4c).
    """
    alternatives = np.asarray(alternatives, dtype=np.int64)
    n_var = alternatives.shape[1]
    n_alt = np.broadcast_to(np.asarray(n_alternatives, dtype=np.int64), (n_var,))
    k = np.arange(-re, re + 1)
    target = reflect(alternatives[:, :, None] + k, n_alt[:, None])           # (NL, NV, 2re+1)
    weight = np.asarray(fitness, dtype=np.float64)[:, None, None] * ((re - np.abs(k)) / re)
    rows = int(n_alt.max())
    flat = target * n_var + np.arange(n_var)[:, None]
    af: np.ndarray = np.bincount(flat.ravel(), np.broadcast_to(weight, target.shape).ravel(),
                     minlength=rows * n_var).reshape(rows, n_var)
    af += epsilon * (np.arange(rows)[:, None] < n_alt)
    if best is not None:
        af[np.asarray(best), np.arange(n_var)] = 0.0
    return af


def alternative_probabilities(af: np.ndarray, best: np.ndarray, pp: float) -> np.ndarray:
    """Steps 5-6: ``pp`` for the loop-best's alternative, ``(1 - pp) AF / sum AF`` for the rest
    (the loop-best's AF counted as 0). A variable with no other alternative keeps the best."""
    cols = np.arange(af.shape[1])
    others = np.array(af, dtype=np.float64)
    others[best, cols] = 0.0
    total = others.sum(axis=0)
    p = (1.0 - pp) * np.divide(others, total, out=np.zeros_like(others), where=total > 0)
    p[best, cols] = np.where(total > 0, pp, 1.0)
    return p


def binary_probabilities(best: np.ndarray, pp: float) -> np.ndarray:
    """Steps 4-6 for two alternatives per variable, shape ``(2, NV)``: ``pp`` for the loop-best's
    alternative, ``1 - pp`` for the other, whatever the fitness (epsilon > 0 leaves the other
    alternative all of the remaining AF). Equal, bit for bit, to
    :func:`alternative_probabilities` of any :func:`accumulative_fitness` with ``epsilon > 0``.
    """
    best = np.asarray(best)
    return np.stack((np.where(best == 0, pp, 1.0 - pp), np.where(best == 1, pp, 1.0 - pp)))


def sample_alternatives(probabilities: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Step 7: alternative of every variable of every new location, by inverting each column's
    cumulative probabilities at the uniform draws ``u`` (shape ``(NL, NV)``)."""
    cumulative = np.cumsum(probabilities, axis=0)
    picked = np.empty(u.shape, dtype=np.int64)
    for j in range(u.shape[1]):
        picked[:, j] = np.searchsorted(cumulative[:, j], u[:, j], side="right")
    return picked


def fitness_values(objective: np.ndarray, transform: str) -> np.ndarray:
    """Fitness of one loop (see the module notes): ``"inverse"`` (``min / value``) or
    ``"rank"``; the loop-best gets 1, infeasible locations 0."""
    objective = np.asarray(objective, dtype=np.float64)
    fit = np.zeros_like(objective)
    ok = np.isfinite(objective)
    if not ok.any():
        return fit
    if transform == "inverse":
        if not (objective[ok] > 0).all():
            raise ValueError("fitness='inverse' needs positive objective values; use 'rank'")
        fit[ok] = objective[ok].min() / objective[ok]
    else:
        from scipy.stats import rankdata  # loaded on first use: scipy.stats is slow to import

        fit[ok] = rankdata(-objective[ok]) / ok.sum()
    return fit


@register("dolphin")
class DolphinEcholocation(Optimizer):
    """Dolphin Echolocation on binary masks and ordered integer alternatives.

    On a 0/1 mask (the seed paper's encoding) the method reduces to "each new bit is the
    loop-best's bit with probability PP, else flipped": ``re``, ``epsilon`` and ``fitness``
    have no effect there (setting them warns). They act on ordered alternatives such as
    ``KnotIndices``, where neighbouring alternatives share accumulated fitness.

    Parameters
    ----------
    population
        NL, the number of locations per loop (>= 2).
    loops
        LoopsNumber; ``None`` derives it from the budget (``ceil(budget / population)``).
    pp1, power
        Convergence curve (eq. 1): first-loop probability in ``[0, 1]`` and its power (> 0).
    re
        Effective radius in alternatives (>= 1; the paper advises at most a quarter of them).
    epsilon
        Added to every AF entry (> 0), in units of the loop-best's fitness.
    fitness
        ``"auto"``, ``"inverse"`` or ``"rank"`` (module notes).
    """

    encodings = ("binary", "integer")

    def __init__(self, population: int = 50, loops: int | None = None, pp1: float = 0.1,
                 power: float = 1.0, re: int = 5, epsilon: float = 1e-3,
                 fitness: str = "auto") -> None:
        self.population = check_param("population", population, low=2, integer=True)
        self.loops = None if loops is None else check_param("loops", loops, low=1, integer=True)
        self.pp1 = check_param("pp1", pp1, low=0.0, high=1.0)
        self.power = check_param("power", power, low=0.0, low_open=True)
        self.re = check_param("re", re, low=1, integer=True)
        self.epsilon = check_param("epsilon", epsilon, low=0.0, low_open=True)
        if fitness not in ("auto", "inverse", "rank"):
            raise ValueError(f"fitness must be 'auto', 'inverse' or 'rank'; got {fitness!r}")
        self.fitness = fitness

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        self._lower = np.asarray(problem.encoding.lower).astype(np.int64)
        self._n_alt = np.asarray(problem.encoding.upper).astype(np.int64) - self._lower + 1
        self._binary = bool((self._n_alt == 2).all())
        if self.fitness == "auto":
            objective = getattr(problem, "objective", None)
            self._transform = "inverse" if getattr(objective, "ratio_scale", False) else "rank"
        else:
            self._transform = self.fitness
        if self._binary and (self.re, self.epsilon, self.fitness) != (5, 1e-3, "auto"):
            warnings.warn(
                "on a 0/1 mask (two alternatives per variable) Dolphin Echolocation copies each "
                "bit of the loop-best with probability PP and flips it otherwise: re, epsilon "
                "and fitness have no effect there; they act on index encodings (KnotIndices)",
                UserWarning, stacklevel=2)
        loops = self.loops
        if loops is None:
            budget = getattr(problem, "budget", None)
            if budget is None:
                raise ValueError("loops=None derives the number of loops from the budget; set "
                                 "the optimizer up on a Task (Evaluator(problem, budget).task) "
                                 "or give loops")
            loops = max(1, math.ceil(budget / self.population))
        self.n_loops = loops
        self.pp = pp_schedule(loops, self.pp1, self.power)
        self.loop = 0
        self.best_x: np.ndarray | None = None
        self.best_f = np.inf
        self.probabilities: np.ndarray | None = None
        self._locations = problem.sample(rng, self.population)

    def finished(self) -> bool:
        return self.loop >= self.n_loops

    def ask(self) -> np.ndarray:
        return self._locations.copy()

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        X, F = np.asarray(X, dtype=np.int64), np.asarray(F, dtype=np.float64)
        pp = float(self.pp[min(self.loop, self.n_loops - 1)])
        self.loop += 1
        best = int(np.argmin(F))
        if F[best] < self.best_f:
            self.best_x, self.best_f = X[best].copy(), float(F[best])
        alternatives = X - self._lower
        u = self.rng.random((self.population, X.shape[1]))
        if self._binary:  # the reduction of the module notes: AF and re play no part
            self.probabilities = binary_probabilities(alternatives[best], pp)
            picked = (u >= self.probabilities[0]).astype(np.int64)
        else:
            af = accumulative_fitness(alternatives, fitness_values(F, self._transform),
                                      self._n_alt, self.re, self.epsilon,
                                      best=alternatives[best])
            self.probabilities = alternative_probabilities(af, alternatives[best], pp)
            picked = sample_alternatives(self.probabilities, u)
        new = np.minimum(picked, self._n_alt - 1) + self._lower
        encoding = self.problem.encoding
        self._locations = encoding.repair(new) if encoding.distinct_sorted else new
