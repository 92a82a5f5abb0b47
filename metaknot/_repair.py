"""Compiled repair of integer sets (used by :meth:`metaknot.Encoding.repair`)."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def distinct_nearest_rows(X: np.ndarray, rows: np.ndarray, lo: int, hi: int) -> None:
    """In place, for each row index in ``rows``: the row's sorted values, in order, each moved to
    the nearest value of ``lo..hi`` not taken by an earlier one (ties: the lower), then sorted.
    """
    used = np.zeros(hi - lo + 1, dtype=np.bool_)
    for r in rows:
        row = X[r]
        used[:] = False
        for j in range(row.size):
            v = row[j]
            step = 0
            while True:
                c = v - step
                if lo <= c <= hi and not used[c - lo]:
                    break
                c = v + step
                if lo <= c <= hi and not used[c - lo]:
                    break
                step += 1
            used[c - lo] = True
            row[j] = c
        row.sort()
