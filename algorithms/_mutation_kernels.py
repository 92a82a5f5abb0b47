"""Compiled draws of the (1+1) EA's bit-flip mutation (loaded on first use: importing the
optimizers does not import numba).

numba's ``numpy.random.Generator`` methods draw from the generator's own bit generator with
numpy's algorithms, so these are numpy's draws, value for value, and leave the generator where
numpy's calls would (``tests/test_local_methods.py`` compares them).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def flip_draws(rng: np.random.Generator, n_var: int, rate: float, counts: np.ndarray,
               positions: np.ndarray) -> int:
    """The draws of consecutive one-child steps of ``flip_at_least_one``: per step a binomial
    count conditioned on >= 1 (``counts``) and, for one or two flips, their positions by
    Floyd's sampling and its shuffle's swap, as ``distinct_positions`` draws them
    (``positions[i, :count]``). Stops after the count of a step with more flips (numpy's
    ``Generator.choice`` draws those) and returns how many steps it drew in full."""
    for i in range(counts.size):
        count = 0
        while count == 0:
            count = rng.binomial(n_var, rate)
        counts[i] = count
        if count > 2:
            return i
        if count == 1:
            positions[i, 0] = rng.integers(0, n_var)
            continue
        first = rng.integers(0, n_var - 1)
        drawn = rng.integers(0, n_var)
        second = n_var - 1 if drawn == first else drawn
        if rng.integers(0, 2) == 0:
            first, second = second, first
        positions[i, 0] = first
        positions[i, 1] = second
    return counts.size
