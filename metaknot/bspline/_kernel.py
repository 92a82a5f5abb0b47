"""Compiled least-squares B-spline kernel (numba).

Each candidate is fitted by Givens QR on the banded collocation matrix, row by row, as FITPACK's
``fpcurf`` does: O(N p^2) work and O(n p) memory per candidate, numerically stable (no normal
equations). A batch of candidates is spread over threads with ``prange``.

Reason codes (see :class:`metaknot.bspline.Infeasibility`):
0 feasible, 1 more control points than data points, 2 knot outside the open parameter range or
not finite, 3 coincident interior knots, 4 Schoenberg-Whitney conditions violated, 5 numerically
singular.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

FEASIBLE = 0
TOO_MANY_CONTROL_POINTS = 1
KNOT_OUT_OF_RANGE = 2
COINCIDENT_KNOTS = 3
SCHOENBERG_WHITNEY = 4
SINGULAR = 5

# A diagonal entry of R below this fraction of the largest one counts as singular.
RCOND = 1e-12
# A least-squares system whose estimated 1-norm condition number exceeds this is reported as
# numerically singular: its control points (and the curve between data points) would be noise.
COND_LIMIT = 1e11


@njit(cache=True)
def _build_knots(u, interior, p, t):
    """Fill the clamped knot vector ``t``; return a reason code for malformed interior knots."""
    k = interior.size
    u0 = u[0]
    um = u[u.size - 1]
    for i in range(p + 1):
        t[i] = u0
        t[k + p + 1 + i] = um
    prev = u0
    for i in range(k):
        x = interior[i]
        if not (x > u0 and x < um):  # also catches NaN
            return KNOT_OUT_OF_RANGE
        t[p + 1 + i] = x
    for i in range(k):
        x = interior[i]
        if x <= prev:
            return COINCIDENT_KNOTS
        prev = x
    return FEASIBLE


@njit(cache=True)
def _schoenberg_whitney(u, t, p, n):
    """True if data sites can be matched to the n basis functions (full column rank)."""
    m = u.size
    j = 0
    for i in range(n):
        lo = t[i]
        hi = t[i + p + 1]
        while j < m and not (u[j] > lo or (i == 0 and u[j] >= lo)):
            j += 1
        if j == m:
            return False
        if not (u[j] < hi or (i == n - 1 and u[j] <= hi)):
            return False
        j += 1
    return True


@njit(cache=True)
def _basis(t, p, span, x, out, left, right):
    """Non-zero basis functions N[span-p..span](x) (NURBS Book A2.2)."""
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


@njit(cache=True)
def _solve(u, q, t, p, n, coef, basis, spans):
    """Least-squares control points into ``coef`` (n, d); return (reason code, SSE).

    Square-root-free Givens rotations (Gentleman 1973): the triangular factor is
    ``R = diag(sqrt(1 / dinv)) @ rb`` with unit-diagonal ``rb``; a data row enters with weight
    ``w = 1 / big_w``. Tracking ``big_w`` and ``dinv`` (reciprocals) keeps every division off the
    chain of dependent operations, so rotations pipeline. The sum of squared residuals is what
    the rotations leave of the data rows (as in FITPACK), so no second pass is needed for it.
    Basis values and spans of every data point are stored in ``basis`` / ``spans`` for
    :func:`_max_deviation`.
    """
    m, d = q.shape
    rb = np.zeros((n, p + 1))
    dinv = np.full(n, np.inf)
    z = np.zeros((n, d))
    h = np.empty(p + 1)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    rhs = np.empty(d)
    span = p
    sse = 0.0
    for j in range(m):
        x = u[j]
        while span < n - 1 and t[span + 1] <= x:
            span += 1
        _basis(t, p, span, x, h, left, right)
        spans[j] = span
        for i in range(p + 1):
            basis[j, i] = h[i]
        for k in range(d):
            rhs[k] = q[j, k]
        first = span - p
        big_w = 1.0
        absorbed = False
        for i in range(p + 1):
            xi = h[i]
            if xi == 0.0:
                continue
            col = first + i
            di_inv = dinv[col]
            if di_inv == np.inf:
                # first row reaching this column: it becomes the column's row of the factor
                inv_x = 1.0 / xi
                dinv[col] = big_w * inv_x * inv_x
                for k in range(d):
                    z[col, k] = rhs[k] * inv_x
                for a in range(i + 1, p + 1):
                    rb[col, a - i] = h[a] * inv_x
                absorbed = True  # weight is now zero: the row is used up
                break
            big_w_new = big_w + xi * xi * di_inv
            inv_new = 1.0 / big_w_new
            cb = big_w * inv_new
            sb = xi * di_inv * inv_new
            dinv[col] = di_inv * cb
            for k in range(d):
                yk = rhs[k]
                zk = z[col, k]
                rhs[k] = yk - xi * zk
                z[col, k] = cb * zk + sb * yk
            for a in range(i + 1, p + 1):
                xa = h[a]
                ra = rb[col, a - i]
                h[a] = xa - xi * ra
                rb[col, a - i] = cb * ra + sb * xa
            big_w = big_w_new
        if not absorbed:
            # what is left of the row, with its weight, is its share of the residual
            left_over = 0.0
            for k in range(d):
                left_over += rhs[k] * rhs[k]
            sse += left_over / big_w
    # 1 / dinv is the squared diagonal of R: compare its smallest entry with its largest
    largest_dinv = 0.0
    smallest_dinv = np.inf
    for i in range(n):
        largest_dinv = max(largest_dinv, dinv[i])
        smallest_dinv = min(smallest_dinv, dinv[i])
    if not (smallest_dinv > 0.0 and smallest_dinv >= RCOND * RCOND * largest_dinv):
        return SINGULAR, np.inf
    if not _condition_estimate(rb, dinv, p, n) <= COND_LIMIT:
        return SINGULAR, np.inf
    for i in range(n - 1, -1, -1):
        for k in range(d):
            acc = z[i, k]
            for a in range(1, min(p, n - 1 - i) + 1):
                acc -= rb[i, a] * coef[i + a, k]
            coef[i, k] = acc
    return FEASIBLE, sse


@njit(cache=True)
def _condition_estimate(rb, dinv, p, n):
    """Estimate the 1-norm condition number of ``R = diag(sqrt(1 / dinv)) @ rb``.

    ``||R||_1`` exactly, ``||R^-1||_1`` by Hager's estimator (Higham 1988, as in LAPACK's
    ``xLACON``): a few banded triangular solves, O(n p) each. The estimate is a lower bound,
    almost always within a factor 3.
    """
    sd = np.empty(n)
    for i in range(n):
        sd[i] = 1.0 / math.sqrt(dinv[i])
    norm_r = 0.0
    for j in range(n):
        col = sd[j]
        for a in range(1, min(p, j) + 1):
            col += sd[j - a] * abs(rb[j - a, a])
        norm_r = max(norm_r, col)
    x = np.full(n, 1.0 / n)
    y = np.empty(n)
    w = np.empty(n)
    est = 0.0
    for it in range(5):
        total = 0.0
        for i in range(n - 1, -1, -1):  # y = R^-1 x
            acc = x[i] / sd[i]
            for a in range(1, min(p, n - 1 - i) + 1):
                acc -= rb[i, a] * y[i + a]
            y[i] = acc
            total += abs(acc)
        if it > 0 and total <= est:
            break
        est = total
        for i in range(n):  # w = R^-T sign(y), scaled back below
            acc = 1.0 if y[i] >= 0.0 else -1.0
            for a in range(1, min(p, i) + 1):
                acc -= rb[i - a, a] * w[i - a]
            w[i] = acc
        best = 0
        zx = 0.0
        for i in range(n):
            w[i] /= sd[i]
            zx += w[i] * x[i]
            if abs(w[i]) > abs(w[best]):
                best = i
        if it > 0 and abs(w[best]) <= zx:
            break
        x[:] = 0.0
        x[best] = 1.0
    return norm_r * est


@njit(cache=True)
def _max_deviation(q, p, coef, basis, spans):
    """Largest distance of a data point to its fitted point, from the stored bases."""
    m, d = q.shape
    worst = 0.0
    for j in range(m):
        first = spans[j] - p
        dist2 = 0.0
        for k in range(d):
            acc = 0.0
            for i in range(p + 1):
                acc += basis[j, i] * coef[first + i, k]
            diff = q[j, k] - acc
            dist2 += diff * diff
        worst = max(worst, dist2)
    return math.sqrt(worst)


@njit(cache=True)
def _fit_into(u, q, interior, p, t, coef, basis, spans):
    """Fit one candidate into preallocated ``t`` and ``coef``; return (reason code, SSE)."""
    n = interior.size + p + 1
    if n > u.size:
        return TOO_MANY_CONTROL_POINTS, np.inf
    reason = _build_knots(u, interior, p, t)
    if reason != FEASIBLE:
        return reason, np.inf
    if not _schoenberg_whitney(u, t, p, n):
        return SCHOENBERG_WHITNEY, np.inf
    return _solve(u, q, t, p, n, coef, basis, spans)


@njit(cache=True)
def fit_one(u, q, interior, p):
    """Fit one candidate: return (reason, knot vector, control points)."""
    n = interior.size + p + 1
    t = np.empty(n + p + 1)
    coef = np.zeros((n, q.shape[1]))
    basis = np.empty((u.size, p + 1))
    spans = np.empty(u.size, dtype=np.int64)
    reason, _ = _fit_into(u, q, interior, p, t, coef, basis, spans)
    return reason, t, coef


@njit(cache=True, parallel=True)
def evaluate_batch(u, q, p, knots, offsets, sse, max_dev, n_ctrl, reason, n_chunks):
    """Score every candidate ``b`` with interior knots ``knots[offsets[b]:offsets[b+1]]``.

    ``max_dev`` may be empty: the maximum deviation (a second pass over the data) is then
    skipped.
    """
    want_max_dev = max_dev.size > 0
    n_cand = offsets.size - 1
    k_max = 0
    for b in range(n_cand):
        k_max = max(k_max, offsets[b + 1] - offsets[b])
    n_max = min(k_max, u.size) + p + 1
    n_chunks = min(n_cand, max(n_chunks, 1))
    for c in prange(n_chunks):
        # one workspace per chunk, sized for the largest candidate
        t_ws = np.empty(n_max + p + 1)
        coef_ws = np.empty((n_max, q.shape[1]))
        basis = np.empty((u.size, p + 1))
        spans = np.empty(u.size, dtype=np.int64)
        for b in range(c * n_cand // n_chunks, (c + 1) * n_cand // n_chunks):
            interior = knots[offsets[b] : offsets[b + 1]]
            n = interior.size + p + 1
            n_ctrl[b] = n
            t = t_ws[: n + p + 1]
            coef = coef_ws[:n]
            code = TOO_MANY_CONTROL_POINTS
            sse[b] = np.inf
            if n <= u.size:
                code, sse[b] = _fit_into(u, q, interior, p, t, coef, basis, spans)
            reason[b] = code
            if want_max_dev:
                max_dev[b] = _max_deviation(q, p, coef, basis, spans) if code == FEASIBLE \
                    else np.inf


@njit(cache=True)
def masks_to_knots(u, masks):
    """Interior knots and row offsets of a (B, N-2) boolean mask batch."""
    n_cand, n_var = masks.shape
    offsets = np.zeros(n_cand + 1, dtype=np.int64)
    for b in range(n_cand):
        count = 0
        for i in range(n_var):
            if masks[b, i]:
                count += 1
        offsets[b + 1] = offsets[b] + count
    knots = np.empty(offsets[n_cand])
    for b in range(n_cand):
        pos = offsets[b]
        for i in range(n_var):
            if masks[b, i]:
                knots[pos] = u[i + 1]
                pos += 1
    return knots, offsets
