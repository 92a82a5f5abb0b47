"""Compiled helpers of :class:`metaknot.Encoding`: the bounds check of ``check`` and the repair of
integer sets of ``repair``."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def within(X: np.ndarray, low: int, high: int) -> bool:
    """True if every entry of ``X`` lies in ``low..high``: one pass without a branch, which the
    compiler vectorises (candidates are nearly always valid: stopping at the first one outside
    saves nothing)."""
    flat = X.ravel()
    outside = 0
    for i in range(flat.size):
        outside |= (flat[i] < low) | (flat[i] > high)
    return outside == 0


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


@njit(cache=True)
def repair_sets(X: np.ndarray, lower: np.ndarray, upper: np.ndarray, lo: int,
                hi: int) -> np.ndarray:
    """:meth:`Encoding.repair` of integer sets in one pass: each row of ``X`` (int64)
    clipped to ``lower..upper`` per column, sorted, and, if a value repeats, made distinct by
    :func:`distinct_nearest_rows`. Returns a new array."""
    out = np.empty_like(X)
    rows = np.empty(X.shape[0], dtype=np.int64)
    n_rows = 0
    for r in range(X.shape[0]):
        row = out[r]
        for j in range(X.shape[1]):
            row[j] = min(max(X[r, j], lower[j]), upper[j])
        row.sort()
        for j in range(1, row.size):
            if row[j] == row[j - 1]:
                rows[n_rows] = r
                n_rows += 1
                break
    if n_rows:
        distinct_nearest_rows(out, rows[:n_rows], lo, hi)
    return out
