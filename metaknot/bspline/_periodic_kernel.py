"""Periodic B-splines (closed outlines): the extended knot vector, the batch of fits, the
maximum deviation, and the rotations the closed move evaluator (:mod:`._periodic_moves`)
builds its factors with.

A fit is :func:`metaknot.bspline._kernel.solve_closed_into`: the open curves' factorisation
with wrap-around columns, its rows generated for every degree and dimension.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ._kernel import (
    COINCIDENT_KNOTS,
    FEASIBLE,
    KNOT_OUT_OF_RANGE,
    SINGULAR,
    closed_workspaces,
    solve_closed_into,
)

# A pivot of the factor at most this fraction of the largest one makes the system singular.
PIVOT_RATIO = 1e-11


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
            basis: np.ndarray, spans: np.ndarray) -> tuple:
    """Least-squares periodic fit on the extended knot vector ``t`` (``m + 2p + 1`` knots):
    the ``m`` coefficients into ``coef[:m]``; returns (sse, reason). Unless the workspaces
    ``basis`` (``(N, p + 1)``) and ``spans`` (``(N,)``) are empty, keeps every row's basis
    values and natural span there (for :func:`deviation_from_basis`)."""
    m = t.size - 2 * p - 1
    reason, sse = solve_closed_into(u, q, t, p, coef, basis, spans,
                                    closed_workspaces(m, p, q.shape[1]), PIVOT_RATIO)
    return sse, reason


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
                   n_chunks: int) -> None:
    """Fit every candidate: ``knots[offsets[b]:offsets[b+1]]`` are candidate b's interior
    knots in (0, 1), sorted and distinct; the batch is split into ``n_chunks`` parts for
    the threads."""
    n_cand = offsets.size - 1
    d = q.shape[1]
    m_max = 1
    for b in range(n_cand):
        m_max = max(m_max, offsets[b + 1] - offsets[b] + 1)
    n_chunks = min(n_cand, max(n_chunks, 1))
    for chunk in numba.prange(n_chunks):
        # one set of workspaces per chunk, sized for the largest candidate
        ws = closed_workspaces(m_max, p, d)
        rows = u.size if want_max else 0
        basis = np.empty((rows, p + 1))
        spans = np.empty(rows, dtype=np.int64)
        breaks = np.empty(m_max)
        t_ws = np.empty(m_max + 2 * p + 1)
        coef_ws = np.empty((m_max, d))
        for b in range(chunk * n_cand // n_chunks, (chunk + 1) * n_cand // n_chunks):
            interior = knots[offsets[b] : offsets[b + 1]]
            m = interior.size + 1
            n_control[b] = m
            if m < p:
                sse[b], reason[b] = np.inf, SINGULAR
                if want_max:
                    max_dev[b] = np.inf
                continue
            breaks[0] = 0.0
            breaks[1:m] = interior
            t = t_ws[: m + 2 * p + 1]
            extended_knots(breaks[:m], p, t)
            coef = coef_ws[:m]
            code, value = solve_closed_into(u, q, t, p, coef, basis, spans, ws, PIVOT_RATIO)
            sse[b], reason[b] = value, code
            if want_max:
                max_dev[b] = deviation_from_basis(q, p, m, coef, basis, spans) \
                    if code == FEASIBLE else np.inf
