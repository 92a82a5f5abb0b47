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
def _places(rng: np.random.Generator, n_var: int, rate: float, counts: np.ndarray,
            positions: np.ndarray, i: int) -> bool:
    """Step ``i``'s draws of ``_at_least_one``: a binomial count conditioned on >= 1
    (``counts[i]``) and, for one or two places, the places by Floyd's sampling and its
    shuffle's swap, as ``distinct_positions`` draws them (``positions[i, :count]``). False for
    more places (numpy's ``Generator.choice`` draws those)."""
    count = 0
    while count == 0:
        count = rng.binomial(n_var, rate)
    counts[i] = count
    if count > 2:
        return False
    if count == 1:
        positions[i, 0] = rng.integers(0, n_var)
        return True
    first = rng.integers(0, n_var - 1)
    drawn = rng.integers(0, n_var)
    second = n_var - 1 if drawn == first else drawn
    if rng.integers(0, 2) == 0:
        first, second = second, first
    positions[i, 0] = first
    positions[i, 1] = second
    return True


@njit(cache=True)
def flip_draws(rng: np.random.Generator, n_var: int, rate: float, counts: np.ndarray,
               positions: np.ndarray) -> int:
    """The draws of consecutive one-child steps of ``flip_at_least_one`` (see
    :func:`_places`). Stops after the count of a step with more than two flips and returns how
    many steps it drew in full."""
    for i in range(counts.size):
        if not _places(rng, n_var, rate, counts, positions, i):
            return i
    return counts.size


@njit(cache=True)
def step_draws(rng: np.random.Generator, n_var: int, rate: float, max_step: int,
               counts: np.ndarray, positions: np.ndarray, sizes: np.ndarray,
               signs: np.ndarray) -> int:
    """The draws of consecutive one-child steps of ``step_at_least_one``: the places (see
    :func:`_places`), then every gene's step size in ``1..max_step`` (``sizes[i]``) and sign
    draw (``signs[i]``: 0 for -1). Stops after the count of a step with more than two moves
    and returns how many steps it drew in full."""
    for i in range(counts.size):
        if not _places(rng, n_var, rate, counts, positions, i):
            return i
        sizes[i] = rng.integers(1, max_step + 1, size=n_var)
        signs[i] = rng.integers(0, 2, size=n_var)
    return counts.size
