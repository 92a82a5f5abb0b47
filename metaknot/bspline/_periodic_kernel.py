"""Compiled least squares for periodic B-splines (closed outlines), a batch at a time.

The m unknowns are ordered c_p .. c_{m-1}, c_0 .. c_{p-1}: every data row then has its p + 1
nonzeros in a band of the first m - p columns plus some of the last p columns (the wrap around
the seam). Givens rotations row by row keep R as a band (p + 1 wide) plus a dense block of the
last p columns and a p x p triangle at the end: O(N p^2) per candidate, like the open kernel.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from . import _periodic_rows
from ._kernel import (
    COINCIDENT_KNOTS,
    FEASIBLE,
    KNOT_OUT_OF_RANGE,
    SINGULAR,
    TOO_MANY_CONTROL_POINTS,
    reciprocals_into,
)

# A pivot of the factor at most this fraction of the largest one makes the system singular.
PIVOT_RATIO = 1e-11


@numba.njit(cache=True)
def _basis(t: np.ndarray, span: int, x: float, p: int, out: np.ndarray,
           left: np.ndarray, right: np.ndarray) -> None:
    """The p + 1 nonzero B-splines at x in knot span ``span`` (NURBS Book A2.2)."""
    out[0] = 1.0
    for j in range(1, p + 1):
        left[j] = x - t[span + 1 - j]
        right[j] = t[span + j] - x
        saved = 0.0
        for r in range(j):
            temp = out[r] / (right[r + 1] + left[j - r])
            out[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        out[j] = saved


@numba.njit(cache=True)
def _basis_table(t: np.ndarray, span: int, x: float, p: int, iv: np.ndarray, out: np.ndarray,
                 left: np.ndarray, right: np.ndarray) -> None:
    """:func:`_basis` with the reciprocal knot differences looked up in ``iv``
    (:func:`~metaknot.bspline._kernel.reciprocals_into` of ``t``) instead of divided."""
    size = t.size
    out[0] = 1.0
    for j in range(1, p + 1):
        left[j] = x - t[span + 1 - j]
        right[j] = t[span + j] - x
        saved = 0.0
        row = (j - 1) * size + span + 1 - j
        for r in range(j):
            temp = out[r] * iv[row + r]
            out[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        out[j] = saved


@numba.njit(cache=True, inline="always")
def givens_norm(a: float, b: float) -> float:
    """``sqrt(a^2 + b^2)``: by the square root where the squares neither underflow nor
    overflow, else by ``hypot`` (a tiny entry squared to zero would make a rotation singular
    or inexact)."""
    big = max(abs(a), abs(b))
    if 1e-150 < big < 1e150:
        return math.sqrt(a * a + b * b)
    return math.hypot(a, b)


@numba.njit(cache=True)
def extended_knots(breaks: np.ndarray, p: int, t: np.ndarray) -> None:
    """Fill ``t`` (``m + 2p + 1`` entries) with the extended knot vector of the ``m``
    breakpoints ``breaks`` (0 first): p periodic copies on each side."""
    m = breaks.size
    for k in range(p):
        t[k] = breaks[m - p + k] - 1.0
    t[p : p + m] = breaks
    for k in range(p + 1):
        t[p + m + k] = (breaks[k] if k < m else breaks[k - m] + 1.0) + 1.0


@numba.njit(cache=True)
def rotate_row(band: np.ndarray, tail: np.ndarray, rhs: np.ndarray, nb: int, p: int, d: int,
               row: np.ndarray, row_rhs: np.ndarray, first: int, row_tail: bool,
               has_tail: np.ndarray | None) -> None:
    """Rotate a data row into the factor by Givens rotations: ``band[nb, p + 1]``,
    ``tail[nb + p, p]`` (the last ``p`` rows: the triangle of the wrap-around columns) and
    ``rhs[nb + p, d]``. ``row[:nb]`` holds the row's band entries (nonzero from ``first`` for
    at most ``p + 1`` columns: the data are sorted, so what the rotations fill in stays there),
    ``row[nb:]`` its wrap-around entries (``row_tail``: some are nonzero), ``row_rhs`` its
    point. Band columns first, left to right, then the wrap-around triangle. ``has_tail[r]``
    says row r of R has a nonzero wrap-around entry (zeros rotated into zeros stay zero, and
    are skipped; ``None``: not kept, every row rotated in full). Leaves ``row`` zero and the
    row's residual in ``row_rhs``."""
    for col in range(first, min(first + p + 1, nb)):
        w = row[col]
        if w == 0.0:
            continue
        r0 = band[col, 0]
        h = givens_norm(r0, w)
        inv = 1.0 / h
        cs, sn = r0 * inv, w * inv
        band[col, 0] = h
        row[col] = 0.0
        for k in range(1, p + 1):
            if col + k < nb:
                a, b = band[col, k], row[col + k]
                band[col, k] = cs * a + sn * b
                row[col + k] = -sn * a + cs * b
        if has_tail is not None:  # both tails zero stay zero: skipped
            row_tail = row_tail or has_tail[col]
            has_tail[col] = row_tail
        if row_tail:
            for k in range(p):
                a, b = tail[col, k], row[nb + k]
                tail[col, k] = cs * a + sn * b
                row[nb + k] = -sn * a + cs * b
        for c in range(d):
            a, b = rhs[col, c], row_rhs[c]
            rhs[col, c] = cs * a + sn * b
            row_rhs[c] = -sn * a + cs * b
    for k in range(p if row_tail else 0):
        w = row[nb + k]
        if w == 0.0:
            continue
        r = nb + k
        r0 = tail[r, k]
        h = givens_norm(r0, w)
        inv = 1.0 / h
        cs, sn = r0 * inv, w * inv
        tail[r, k] = h
        row[nb + k] = 0.0
        for kk in range(k + 1, p):
            a, b = tail[r, kk], row[nb + kk]
            tail[r, kk] = cs * a + sn * b
            row[nb + kk] = -sn * a + cs * b
        for c in range(d):
            a, b = rhs[r, c], row_rhs[c]
            rhs[r, c] = cs * a + sn * b
            row_rhs[c] = -sn * a + cs * b


@numba.njit(cache=True)
def fit_one(u: np.ndarray, q: np.ndarray, t: np.ndarray, p: int, coef: np.ndarray,
            basis: np.ndarray, spans: np.ndarray, generated: bool = True) -> tuple:
    """Least-squares periodic fit on the extended knot vector ``t`` (``m + 2p + 1`` knots).
    Writes the m distinct coefficients into ``coef[:m]`` and returns (sse, reason); unless
    the workspaces ``basis`` (``(N, p + 1)``) and ``spans`` (``(N,)``) are empty, keeps every
    row's basis values and span there (for :func:`deviation_from_basis`). ``generated``: the
    row loop generated for the degree and dimension, where there is one (``_periodic_rows``:
    the same rotations, so the same result, as the loop here, which runs otherwise)."""
    n, d = q.shape
    m = t.size - 2 * p - 1
    if m > n:
        return np.inf, TOO_MANY_CONTROL_POINTS
    keep = basis.shape[0] > 0
    nb = m - p  # band columns
    band = np.zeros((max(nb, 1), p + 1))  # band[r, k]: column r + k (if < nb)
    tail = np.zeros((m, p))  # tail[r, k]: column nb + k, for every row r of R
    has_tail = np.zeros(m, dtype=np.bool_)  # row r of R has a nonzero tail entry
    rhs = np.zeros((m, d))
    row = np.zeros(m)
    row_rhs = np.zeros(d)
    values = np.empty(p + 1)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    iv = np.empty(p * t.size)
    reciprocals_into(t, p, iv)
    sse = _periodic_rows.rows(u, q, t, iv, p, m, band, tail, has_tail, rhs, basis, spans,
                              keep) if generated else -1.0
    generic = sse < 0.0
    if generic:
        sse = 0.0
    j = 0
    for i in range(n if generic else 0):
        x = u[i]
        while j < m - 1 and x >= t[p + j + 1]:
            j += 1
        _basis_table(t, p + j, x, p, iv, values, left, right)
        if keep:
            spans[i] = j
            for k in range(p + 1):
                basis[i, k] = values[k]
        first = nb  # smallest band column touched
        row_tail = False  # the row has a nonzero tail entry
        for k in range(p + 1):
            ci = j + k
            if ci >= m:
                ci -= m
            col = ci - p if ci >= p else nb + ci
            row[col] += values[k]
            if col < first:
                first = col
            row_tail |= col >= nb
        for c in range(d):
            row_rhs[c] = q[i, c]
        rotate_row(band, tail, rhs, nb, p, d, row, row_rhs, first, row_tail, has_tail)
        for c in range(d):
            sse += row_rhs[c] * row_rhs[c]
    # conditioning: a pivot far below the largest one means a rank-deficient system
    largest = 0.0
    for r in range(nb):
        largest = max(largest, abs(band[r, 0]))
    for k in range(p):
        largest = max(largest, abs(tail[nb + k, k]))
    for r in range(nb):
        if abs(band[r, 0]) <= PIVOT_RATIO * largest:
            return np.inf, SINGULAR
    for k in range(p):
        if abs(tail[nb + k, k]) <= PIVOT_RATIO * largest:
            return np.inf, SINGULAR
    # back substitution: the triangle, then the band rows
    x_tail = np.zeros((p, d))
    for k in range(p - 1, -1, -1):
        r = nb + k
        for c in range(d):
            s = rhs[r, c]
            for kk in range(k + 1, p):
                s -= tail[r, kk] * x_tail[kk, c]
            x_tail[k, c] = s / tail[r, k]
    x_band = np.zeros((max(nb, 1), d))
    for r in range(nb - 1, -1, -1):
        for c in range(d):
            s = rhs[r, c]
            for k in range(1, p + 1):
                if r + k < nb:
                    s -= band[r, k] * x_band[r + k, c]
            for k in range(p):
                s -= tail[r, k] * x_tail[k, c]
            x_band[r, c] = s / band[r, 0]
    for ci in range(m):  # back to the natural order c_0 .. c_{m-1}
        for c in range(d):
            coef[ci, c] = x_band[ci - p, c] if ci >= p else x_tail[ci, c]
    return sse, FEASIBLE


@numba.njit(cache=True)
def deviation_from_basis(q: np.ndarray, p: int, m: int, coef: np.ndarray, basis: np.ndarray,
                         spans: np.ndarray) -> float:
    """Largest distance of a data point to the periodic spline with coefficients ``coef``
    (``m`` of them), from the basis values and spans :func:`fit_one` kept."""
    n, d = q.shape
    worst = 0.0
    for i in range(n):
        j = spans[i]
        dist2 = 0.0
        for c in range(d):
            s = 0.0
            for k in range(p + 1):
                ci = j + k
                if ci >= m:
                    ci -= m
                s += basis[i, k] * coef[ci, c]
            dist2 += (q[i, c] - s) ** 2
        worst = max(worst, dist2)
    return np.sqrt(worst)


@numba.njit(cache=True)
def rows_to_knots(pos: np.ndarray, nan_is_absent: bool) -> tuple:
    """Rows of knot positions, each sorted (NaN last), flattened for :func:`evaluate_batch`:
    the knots, the row offsets and each row's reason to be refused (0 for none). NaN means no
    knot when ``nan_is_absent`` and is out of range otherwise; a knot outside (0, 1) is passed on
    as 0.5 (its row still fits) and refuses its row as KNOT_OUT_OF_RANGE, which takes precedence
    over COINCIDENT_KNOTS (a knot not above the one before it)."""
    n_rows, width = pos.shape
    offsets = np.zeros(n_rows + 1, dtype=np.int64)
    for b in range(n_rows):
        count = 0
        for k in range(width):
            if not (nan_is_absent and np.isnan(pos[b, k])):
                count += 1
        offsets[b + 1] = offsets[b] + count
    knots = np.empty(offsets[n_rows])
    refused = np.zeros(n_rows, dtype=np.int8)
    for b in range(n_rows):
        at = offsets[b]
        out_of_range = coincident = False
        previous = 0.0
        for k in range(width):
            x = pos[b, k]
            if nan_is_absent and np.isnan(x):
                continue
            if at > offsets[b] and x - previous <= 0.0:  # False for NaN, as numpy's
                coincident = True
            previous = x
            inside = 0.0 < x < 1.0
            knots[at] = x if inside else 0.5
            out_of_range |= not inside
            at += 1
        if out_of_range:
            refused[b] = KNOT_OUT_OF_RANGE
        elif coincident:
            refused[b] = COINCIDENT_KNOTS
    return knots, offsets, refused


@numba.njit(cache=True, parallel=True)
def evaluate_batch(u: np.ndarray, q: np.ndarray, p: int, knots: np.ndarray,
                   offsets: np.ndarray, want_max: bool, sse: np.ndarray,
                   max_dev: np.ndarray, n_control: np.ndarray, reason: np.ndarray,
                   generated: bool = True) -> None:
    """Fit every candidate: ``knots[offsets[b]:offsets[b+1]]`` are candidate b's interior
    knots in (0, 1), sorted and distinct (``generated``: as :func:`fit_one`)."""
    d = q.shape[1]
    for b in numba.prange(offsets.size - 1):
        interior = knots[offsets[b] : offsets[b + 1]]
        m = interior.size + 1
        n_control[b] = m
        if m < p:
            sse[b], reason[b] = np.inf, SINGULAR
            if want_max:
                max_dev[b] = np.inf
            continue
        breaks = np.empty(m)
        breaks[0] = 0.0
        breaks[1:] = interior
        t = np.empty(m + 2 * p + 1)
        extended_knots(breaks, p, t)
        coef = np.zeros((m, d))
        rows = u.size if want_max else 0
        basis = np.empty((rows, p + 1))
        spans = np.empty(rows, dtype=np.int64)
        value, code = fit_one(u, q, t, p, coef, basis, spans, generated)
        sse[b], reason[b] = value, code
        if want_max:
            max_dev[b] = deviation_from_basis(q, p, m, coef, basis, spans) \
                if code == FEASIBLE else np.inf
