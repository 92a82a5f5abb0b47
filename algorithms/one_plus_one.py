"""The (1+1) evolutionary algorithm (``one_plus_one``): the reference a population method must
beat at equal budget.

One parent; each step mutates it into ``offspring`` children (one: the classical (1+1) EA; more:
the (1+λ) EA, evaluated as one batch) and the best child replaces the parent if it is no worse
(equal values are accepted, so the search drifts across plateaus). On a 0/1 mask every bit flips
independently with probability ``rate`` (default ``1/n``, the standard rate); a child that would
equal its parent is drawn again (the number of flips is conditioned on being at least one), so no
evaluation is spent on a copy. On ordered indices (``KnotIndices``) every knot moves with
probability ``rate`` by a step of ``±1..max_step`` along the data (at least one knot moves),
and the set is repaired as the GA does.

With one child per step, the children of the next steps are asked for ahead, as many as were
rejected in a row (at most :attr:`OnePlusOneEA.lookahead`): the mutations do not depend on the
parent's fate, so each step's draws are made in the same order as one step per call. The
evaluator counts them up to the first child taken (:meth:`~metaknot.Optimizer.acceptance`);
the children scored after it are dropped unseen and accounted as fits. The run is that of one
step per call (same candidates, values and trace), at a fraction of the calls.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.problem import Problem
from metaknot.registry import register

__all__ = ["OnePlusOneEA", "distinct_positions", "flip_at_least_one", "step_at_least_one"]


_SIGNS = np.array((-1, 1))


def distinct_positions(n: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """``count`` distinct positions of ``range(n)`` in random order: the values and the draws
    of ``rng.choice(n, size=count, replace=False)``, at a third of its cost for one or two
    positions (numpy's Floyd sampling and its shuffle, draw by draw; ``choice`` otherwise)."""
    if count > 2 or n > 10_000:
        return rng.choice(n, size=count, replace=False)
    integers, found = rng.integers, []
    for j in range(n - count, n):  # Floyd: a position drawn before gives way to j
        drawn = int(integers(j + 1))
        found.append(j if drawn in found else drawn)
    if count == 2 and int(integers(2)) == 0:  # the shuffle's one swap
        found.reverse()
    return np.array(found, dtype=np.int64)


def _at_least_one(n_var: int, rate: float, rows: int, rng: np.random.Generator) -> np.ndarray:
    """Boolean ``(rows, n_var)``: each entry True with probability ``rate``, conditioned on at
    least one True per row (a binomial count conditioned >= 1, at distinct random places)."""
    hit = np.zeros((rows, n_var), dtype=bool)
    for row in hit:
        count = 0
        while count == 0:
            count = int(rng.binomial(n_var, rate))
        row[distinct_positions(n_var, count, rng)] = True
    return hit


def flip_at_least_one(x: np.ndarray, rate: float, rows: int,
                      rng: np.random.Generator) -> np.ndarray:
    """``rows`` children of the 0/1 vector ``x``: bit flips with probability ``rate`` each, at
    least one per child."""
    return np.asarray(x)[None, :] ^ _at_least_one(x.size, rate, rows, rng)


def _flip_draw(n_var: int, rate: float, rng: np.random.Generator) -> int | np.ndarray:
    """The positions one child of :func:`flip_at_least_one` flips, with its draws (those of
    ``_at_least_one`` for one row)."""
    count = 0
    while count == 0:
        count = int(rng.binomial(n_var, rate))
    if count == 1:  # Floyd's sampling of one position is one draw
        return int(rng.integers(n_var))
    return distinct_positions(n_var, count, rng)


def _flip_draws(n_var: int, rate: float, steps: int, rng: np.random.Generator
                ) -> list[int | np.ndarray]:
    """:func:`_flip_draw` of ``steps`` consecutive steps, the same draws in the same order:
    compiled, but for the steps with more than two flips (and masks over 10,000 bits), which
    ``Generator.choice`` draws."""
    if n_var > 10_000:
        return [_flip_draw(n_var, rate, rng) for _ in range(steps)]
    from ._mutation_kernels import flip_draws

    out: list[int | np.ndarray] = []
    counts = np.empty(steps, dtype=np.int64)
    positions = np.empty((steps, 2), dtype=np.int64)
    while len(out) < steps:
        left = steps - len(out)
        done = flip_draws(rng, n_var, rate, counts[:left], positions[:left])
        out += [int(positions[i, 0]) if counts[i] == 1 else positions[i].copy()
                for i in range(done)]
        if done < left:  # a step of more flips: its count is drawn, numpy draws the places
            out.append(rng.choice(n_var, size=int(counts[done]), replace=False))
    return out


def _step_draws(n_var: int, rate: float, max_step: int, steps: int, rng: np.random.Generator
                ) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`_step_draw` of ``steps`` consecutive one-child steps, the same draws in the same
    order: compiled, but for the steps that move more than two genes (and sets of over 10,000
    genes), whose places ``Generator.choice`` draws."""
    if n_var > 10_000:
        return [_step_draw(n_var, rate, 1, max_step, rng) for _ in range(steps)]
    from ._mutation_kernels import step_draws

    out: list[tuple[np.ndarray, np.ndarray]] = []
    counts = np.empty(steps, dtype=np.int64)
    positions = np.empty((steps, 2), dtype=np.int64)
    sizes = np.empty((steps, n_var), dtype=np.int64)
    signs = np.empty((steps, n_var), dtype=np.int64)
    while len(out) < steps:
        left = steps - len(out)
        done = step_draws(rng, n_var, rate, max_step, counts[:left], positions[:left],
                          sizes[:left], signs[:left])
        hit = np.zeros((done, n_var), dtype=bool)
        for i in range(done):
            hit[i, positions[i, : counts[i]]] = True
        step = sizes[:done] * _SIGNS[signs[:done]]
        out += [(hit[i : i + 1], step[i : i + 1]) for i in range(done)]
        if done < left:  # a step of more moves: its count is drawn, numpy draws the rest
            row = np.zeros((1, n_var), dtype=bool)
            row[0, rng.choice(n_var, size=int(counts[done]), replace=False)] = True
            out.append((row, _steps(row.shape, max_step, rng)))
    return out


def step_at_least_one(x: np.ndarray, rate: float, rows: int, max_step: int,
                      rng: np.random.Generator) -> np.ndarray:
    """``rows`` children of the integer vector ``x``: each gene moves with probability
    ``rate`` by ``±1..max_step`` (uniform), at least one per child (not repaired)."""
    hit, step = _step_draw(x.size, rate, rows, max_step, rng)
    return np.where(hit, np.asarray(x)[None, :] + step, x[None, :])


def _step_draw(n_var: int, rate: float, rows: int, max_step: int, rng: np.random.Generator
               ) -> tuple[np.ndarray, np.ndarray]:
    """Which genes ``rows`` children of :func:`step_at_least_one` move and by how much, with
    its draws: boolean and integer arrays of shape ``(rows, n_var)``."""
    hit = _at_least_one(n_var, rate, rows, rng)
    return hit, _steps(hit.shape, max_step, rng)


def _steps(shape: tuple[int, int], max_step: int, rng: np.random.Generator) -> np.ndarray:
    """A step of ``±1..max_step`` (uniform) for every gene, drawn as step sizes then signs."""
    size = rng.integers(1, max_step + 1, size=shape)
    # the signs as Generator.choice((-1, 1), size) draws them, without its conversions
    return size * _SIGNS[rng.integers(0, 2, size=shape, dtype=np.int64)]


@register("one_plus_one")
class OnePlusOneEA(Optimizer):
    """(1+1) EA, or (1+λ) EA with ``offspring > 1``, on masks and ordered indices.

    Parameters
    ----------
    rate
        Per-variable mutation probability in (0, 1]; ``None`` means ``1 / n_var``.
    offspring
        Children per step, evaluated together (1: the classical (1+1) EA).
    max_step
        Largest move of an index along the data (index encodings).
    """

    encodings = ("binary", "integer")

    def __init__(self, rate: float | None = None, offspring: int = 1, max_step: int = 1) -> None:
        self.rate = None if rate is None else check_param("rate", rate, low=0, high=1,
                                                          low_open=True)
        self.offspring = check_param("offspring", offspring, low=1, integer=True)
        self.max_step = check_param("max_step", max_step, low=1, integer=True)

    #: Steps of the (1+1) EA asked for ahead, at most: as many as were rejected in a row since
    #: the parent last changed. They are children of the current parent, scored in one call
    #: and counted up to the first one taken (:meth:`acceptance`), so the run is the same as
    #: with one step per call: same draws, children, values and trace.
    lookahead = 64

    def setup(self, problem: Problem, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        n_var = problem.encoding.n_var
        self._rate = 1.0 / n_var if self.rate is None else self.rate
        self.parent: np.ndarray | None = None
        self.parent_f = np.inf
        self._draws: list = []  # the next steps' mutations, drawn in order, kept until used
        self._asked = 0  # children in the last batch asked ahead
        self._rejected = 0  # children rejected since the parent last changed

    def ask(self) -> np.ndarray:
        """The first parent (a sample of the problem), then ``offspring`` children; with one
        child per step, the children of the next steps (see :attr:`lookahead`)."""
        if self.parent is None:
            return self.problem.sample(self.rng, 1)
        encoding = self.problem.encoding
        binary = encoding.kind == "binary"
        if self.offspring > 1:
            if binary:
                return flip_at_least_one(self.parent, self._rate, self.offspring, self.rng)
            children = step_at_least_one(self.parent, self._rate, self.offspring,
                                         self.max_step, self.rng)
            return encoding.repair(children)
        ahead = min(self.lookahead, max(1, self._rejected), self.problem.remaining)
        if len(self._draws) < ahead:  # the next steps' draws, a lookahead at a time
            more, n_var = max(ahead - len(self._draws), self.lookahead), self.parent.size
            self._draws += _flip_draws(n_var, self._rate, more, self.rng) if binary else \
                _step_draws(n_var, self._rate, self.max_step, more, self.rng)
        draws = self._draws[:ahead]
        self._asked = ahead
        if binary:
            children = np.repeat(self.parent[None, :], ahead, axis=0)
            for row, flips in zip(children, draws, strict=True):
                row[flips] ^= True
            return children
        hit = np.vstack([h for h, _ in draws])
        step = np.vstack([s for _, s in draws])
        return encoding.repair(np.where(hit, self.parent[None, :] + step, self.parent[None, :]))

    def acceptance(self) -> np.ndarray | None:
        """With steps asked ahead: the parent's value for each (a child no worse is taken)."""
        if self.parent is None or self.offspring > 1 or self._asked < 2:
            return None
        return np.full(self._asked, self.parent_f)

    def move_origin(self) -> np.ndarray | None:
        """The parent: children differ from it by a few flips or steps (delta evaluation)."""
        return self.parent

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        """Keep the best child if it is no worse than the parent."""
        if self.parent is not None and self.offspring == 1:
            del self._draws[: len(F)]  # the steps these children took
        best = int(np.argmin(F))
        if self.parent is None or F[best] <= self.parent_f:
            self.parent = np.array(X[best], copy=True)
            self.parent_f = float(F[best])
            self._rejected = 0
        else:
            self._rejected += len(F)
