"""Compiled draws of the (1+1) EA's mutations (loaded on first use: importing the optimizers
does not import numba).

numba's ``numpy.random.Generator`` methods draw from the generator's own bit generator with
numpy's algorithms, so these are numpy's draws, value for value, and leave the generator where
numpy's calls would (``tests/test_local_methods.py`` compares them).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
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


@njit(cache=True)
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
def flip_draws(rng: np.random.Generator, n_var: int, rate: float, steps: int
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
def step_draws(rng: np.random.Generator, n_var: int, rate: float, max_step: int, steps: int
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The draws of ``steps`` consecutive one-child steps of ``step_at_least_one``: the
    places as :func:`flip_draws` gives them, each followed by every gene's step size in
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
def flip_children(parent: np.ndarray, starts: np.ndarray, places: np.ndarray, first: int,
                  count: int) -> np.ndarray:
    """``count`` children (int64) of the 0/1 vector ``parent``, one per step drawn by
    :func:`flip_draws`: child ``r`` flips the bits ``places[starts[first + r]:starts[first + r +
    1]]`` (``starts``: where each step's places begin, and their end)."""
    out = np.empty((count, parent.size), dtype=np.int64)
    for r in range(count):
        out[r] = parent
        for j in range(starts[first + r], starts[first + r + 1]):
            out[r, places[j]] = 1 - out[r, places[j]]
    return out
