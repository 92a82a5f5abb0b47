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
from numba import njit

from metaknot.optimizer import Optimizer, check_param
from metaknot.registry import register
from metaknot.task import ProblemView

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
                ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_flip_draw` of ``steps`` consecutive steps, the same draws in the same order, in
    compiled code (but for masks over 10,000 bits, whose places ``Generator.choice`` may draw
    by another algorithm): how many bits each step flips, and which (all steps' in one flat
    array)."""
    if n_var > 10_000:
        draws = [np.atleast_1d(_flip_draw(n_var, rate, rng)) for _ in range(steps)]
        return np.array([d.size for d in draws]), np.concatenate(draws)
    return _flip_places(rng, n_var, rate, steps)


def _step_draws(n_var: int, rate: float, max_step: int, steps: int, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_step_draw` of ``steps`` consecutive one-child steps, the same draws in the same
    order, in compiled code (but for sets of over 10,000 genes): how many genes each step moves
    and which (flat, as :func:`_flip_draws`), every gene's step size and sign draw (0 for -1)
    per step."""
    if n_var > 10_000:
        places, sizes, signs = [], [], []
        for _ in range(steps):  # _step_draw's draws of one row, in its order
            places.append(np.atleast_1d(_flip_draw(n_var, rate, rng)))
            sizes.append(rng.integers(1, max_step + 1, size=n_var))
            signs.append(rng.integers(0, 2, size=n_var, dtype=np.int64))
        return (np.array([row.size for row in places]), np.concatenate(places), np.array(sizes),
                np.array(signs))
    return _step_places(rng, n_var, rate, max_step, steps)


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

    #: Steps whose flips are drawn at a time, at least, on a 0/1 mask: a call of the compiled
    #: draws costs about what 50 steps' draws do. The steps are taken in the order drawn, so
    #: drawing ahead changes no child (index encodings, whose steps draw a size and sign for
    #: every gene, draw :attr:`lookahead` steps at a time).
    draw_steps = 1024

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        super().setup(problem, rng)
        self._encoding = problem.encoding
        self._binary = self._encoding.kind == "binary"
        n_var = self._encoding.n_var
        self._rate = 1.0 / n_var if self.rate is None else self.rate
        self.parent: np.ndarray | None = None
        self.parent_f = np.inf
        # the next steps' mutations, drawn in order and taken in order from step _next on:
        # how many genes each step changes, where its places begin in _places (and end),
        # and on index encodings every gene's step size and sign draw per step
        self._counts = np.empty(0, np.int64)
        self._starts = np.zeros(1, np.int64)
        self._places = np.empty(0, np.int64)
        self._per_gene: tuple[np.ndarray, ...] = ()
        self._next = 0
        self._asked = 0  # children in the last batch asked ahead
        self._rejected = 0  # children rejected since the parent last changed

    def ask(self) -> np.ndarray:
        """The first parent (a sample of the problem), then ``offspring`` children; with one
        child per step, the children of the next steps (see :attr:`lookahead`)."""
        if self.parent is None:
            return self.problem.sample(self.rng, 1)
        if self.offspring > 1:
            if self._binary:
                return flip_at_least_one(self.parent, self._rate, self.offspring, self.rng)
            children = step_at_least_one(self.parent, self._rate, self.offspring,
                                         self.max_step, self.rng)
            return self._encoding.repair(children)
        # as many as were rejected in a row (the evaluator cuts a batch at the budget)
        ahead = min(self.lookahead, max(1, self._rejected))
        if self._counts.size - self._next < ahead:
            self._draw(ahead)
        first = self._next
        self._asked = ahead
        if self._binary:
            return _flip_children(self.parent, self._starts, self._places, first, ahead)
        places = self._places[self._starts[first] : self._starts[first + ahead]]
        rows = np.repeat(np.arange(ahead), self._counts[first : first + ahead])
        parent = self.parent[None, :]
        hit = np.zeros((ahead, parent.size), dtype=bool)
        hit[rows, places] = True
        sizes, signs = (a[first : first + ahead] for a in self._per_gene)
        return self._encoding.repair(np.where(hit, parent + sizes * _SIGNS[signs], parent))

    def _draw(self, ahead: int) -> None:
        """Draw the next steps' mutations, enough for ``ahead`` steps from :attr:`_next` on
        (:attr:`draw_steps` or :attr:`lookahead` at least), after those not yet taken."""
        n_var, first = self._encoding.n_var, self._next
        more = max(ahead - (self._counts.size - first),
                   self.draw_steps if self._binary else self.lookahead)
        counts, places, *per_gene = _flip_draws(n_var, self._rate, more, self.rng) \
            if self._binary else _step_draws(n_var, self._rate, self.max_step, more, self.rng)
        self._counts = np.concatenate((self._counts[first:], counts))
        self._places = np.concatenate((self._places[self._starts[first]:], places))
        self._starts = np.concatenate(([0], np.cumsum(self._counts)))
        self._per_gene = tuple(np.concatenate((kept[first:], new)) for kept, new in
                               zip(self._per_gene, per_gene, strict=True)) \
            if self._per_gene else tuple(per_gene)
        self._next = 0

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
            self._next += len(F)  # steps taken
        best = int(F.argmin())
        if self.parent is None or F[best] <= self.parent_f:
            self.parent = np.array(X[best], copy=True)
            self.parent_f = float(F[best])
            self._rejected = 0
        else:
            self._rejected += len(F)


# The compiled draws of the mutations. numba's ``numpy.random.Generator`` methods draw from the
# generator's own bit generator with numpy's algorithms, so these are numpy's draws, value for
# value, and leave the generator where numpy's calls would (``tests/test_local_methods.py``
# compares them).


@njit(cache=True, inline="always")
def _floyd(rng: np.random.Generator, n: int, count: int, out: np.ndarray,
           taken: np.ndarray) -> None:
    """``count`` distinct places of ``range(n)`` into ``out``, drawn as
    ``rng.choice(n, size=count, replace=False)`` draws them for ``n <= 10,000``: Floyd's
    sampling (a place drawn before gives way to ``j``), then the shuffle of the places.
    ``taken`` (``n`` booleans, all False) is left all False."""
    for k in range(count):
        j = n - count + k
        drawn = rng.integers(0, j + 1) if j > 0 else 0  # numpy draws nothing for range 0..0
        if taken[drawn]:
            drawn = j
        taken[drawn] = True
        out[k] = drawn
    for k in range(count):
        taken[out[k]] = False
    for i in range(count - 1, 0, -1):
        swap = rng.integers(0, i + 1)
        out[i], out[swap] = out[swap], out[i]


@njit(cache=True, inline="always")
def _counted_places(rng: np.random.Generator, n_var: int, rate: float, steps: int,
                    counts: np.ndarray, places: np.ndarray, taken: np.ndarray,
                    i: int, used: int) -> np.ndarray:
    """Step ``i``'s draws of ``_at_least_one``: a binomial count conditioned on >= 1
    (``counts[i]``), then its places (:func:`_floyd`) at ``places[used:]`` (grown if
    needed): returns ``places``."""
    count = 0
    while count == 0:
        count = rng.binomial(n_var, rate)
    counts[i] = count
    if used + count > places.size:
        grown = np.empty(max(2 * places.size, used + count + 2 * (steps - i)), np.int64)
        grown[:used] = places[:used]
        places = grown
    _floyd(rng, n_var, count, places[used : used + count], taken)
    return places


@njit(cache=True)
def _flip_places(rng: np.random.Generator, n_var: int, rate: float, steps: int
                 ) -> tuple[np.ndarray, np.ndarray]:
    """The draws of ``steps`` consecutive one-child steps of ``flip_at_least_one``: how many
    bits each flips and which (step after step in one flat array)."""
    counts = np.empty(steps, np.int64)
    places = np.empty(2 * steps + 8, np.int64)
    taken = np.zeros(n_var, np.bool_)
    used = 0
    for i in range(steps):
        places = _counted_places(rng, n_var, rate, steps, counts, places, taken, i, used)
        used += counts[i]
    return counts, places[:used]


@njit(cache=True)
def _step_places(rng: np.random.Generator, n_var: int, rate: float, max_step: int, steps: int
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The draws of ``steps`` consecutive one-child steps of ``step_at_least_one``: the
    places as :func:`_flip_places` gives them, each followed by every gene's step size in
    ``1..max_step`` (``sizes[i]``) and sign draw (``signs[i]``: 0 for -1)."""
    counts = np.empty(steps, np.int64)
    places = np.empty(2 * steps + 8, np.int64)
    sizes = np.empty((steps, n_var), np.int64)
    signs = np.empty((steps, n_var), np.int64)
    taken = np.zeros(n_var, np.bool_)
    used = 0
    for i in range(steps):
        places = _counted_places(rng, n_var, rate, steps, counts, places, taken, i, used)
        used += counts[i]
        sizes[i] = rng.integers(1, max_step + 1, size=n_var)
        signs[i] = rng.integers(0, 2, size=n_var)
    return counts, places[:used], sizes, signs


@njit(cache=True)
def _flip_children(parent: np.ndarray, starts: np.ndarray, places: np.ndarray, first: int,
                   count: int) -> np.ndarray:
    """``count`` children (int64) of the 0/1 vector ``parent``, one per step drawn by
    :func:`_flip_places`: child ``r`` flips the bits ``places[starts[first + r]:starts[first + r +
    1]]`` (``starts``: where each step's places begin, and their end)."""
    out = np.empty((count, parent.size), dtype=np.int64)
    for r in range(count):
        out[r] = parent
        for j in range(starts[first + r], starts[first + r + 1]):
            out[r, places[j]] = 1 - out[r, places[j]]
    return out
