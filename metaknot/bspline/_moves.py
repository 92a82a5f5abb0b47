"""Compiled delta evaluation of local knot moves (numba); see :mod:`metaknot.bspline.moves`.

Notation: ``t`` is the incumbent's clamped knot vector with ``n`` basis functions (columns);
data row ``j`` lies in knot span ``spans[j]`` (``t[k] <= u[j] < t[k + 1]``, the last point in
span ``n - 1``) and touches columns ``spans[j] - p .. spans[j]``.

*Forward state* ``c`` (``p <= c <= n``): the data rows of spans ``< c`` rotated, in order, into
a banded triangular factor by Givens rotations. Columns below ``c - p`` are final (no row of a
later span touches them), so the state that matters to later rows is the ``p`` rows of the
factor for columns ``c - p .. c - 1`` (their entries lie in those columns too), their right-hand
sides and the squared residual so far. *Backward state* ``c``: the same for the rows of spans
``>= c``, rotated from the right end with the columns counted from the right; its active rows
are again columns ``c - p .. c - 1``.

A move changes the knots between two unchanged ends. The rows of spans ``< cL`` keep their
basis values and columns (counted from the left), those of spans ``>= cR`` keep theirs (counted
from the right). The candidate's SSE is then exactly::

    forward residual at cL + backward residual at cR
    + residual of [forward active rows; window rows (new basis); backward active rows]

the last a small banded least-squares problem over columns ``cL - p .. cR' - 1`` (``cR'`` is
``cR`` counted in the candidate's columns). The final rows of either factor are satisfied
exactly (their pivot column appears in no other row), so they add nothing.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._kernel import (
    COINCIDENT_KNOTS,
    COND_LIMIT,
    FEASIBLE,
    KNOT_OUT_OF_RANGE,
    SCHOENBERG_WHITNEY,
    TOO_MANY_CONTROL_POINTS,
    _fit_into,
    _max_deviation,
)

# How each candidate was decided (``path`` output).
PATH_DELTA = 0  # merged from the cached states
PATH_CHECKS = 1  # infeasible by the knot checks alone (no fit needed on either path)
PATH_FULL = 2  # fitted in full (too wide a change, an uncertain verdict, or max deviation)


# The delta path reports a candidate feasible only if an upper bound of the condition number
# the full kernel tests is below this fraction of its limit (room for rounding in the bound);
# other candidates are fitted in full, so the kernel's own tests decide them.
CERTIFY = 0.5


@njit(cache=True)
def basis_values(t, p, k, x, out, left, right):
    """The ``p + 1`` nonzero B-spline values at ``x`` in span ``k`` (NURBS Book A2.2)."""
    out[0] = 1.0
    for j in range(1, p + 1):
        left[j] = x - t[k + 1 - j]
        right[j] = t[k + j] - x
        saved = 0.0
        for r in range(j):
            temp = out[r] / (right[r + 1] + left[j - r])
            out[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        out[j] = saved


@njit(cache=True)
def rotate_row(rb, dinv, z, first, h, rhs, width, big_w):
    """Rotate the row ``h`` (columns ``first .. first + width - 1``) with right-hand side
    ``rhs`` and weight ``1 / big_w`` into the factor ``rb``, ``dinv``, ``z``.

    The factor is kept as the full kernel keeps it (square-root-free Givens, Gentleman 1973):
    row ``c`` stands for ``(rb[c] . coef - z[c])^2 / dinv[c]`` with a unit diagonal ``rb[c, 0]``
    and ``rb[c, b]`` the entry at column ``c + b``; ``dinv[c] = inf`` marks a row no data
    has reached yet, which takes the incoming row as it is. ``h`` and ``rhs`` are overwritten.
    Returns the weighted squared residual the row leaves (0 if it was absorbed).
    """
    d = rhs.size
    for a in range(width):
        hv = h[a]
        if hv == 0.0:
            continue
        col = first + a
        di = dinv[col]
        if di == np.inf:
            ix = 1.0 / hv
            dinv[col] = big_w * ix * ix
            for k in range(d):
                z[col, k] = rhs[k] * ix
            for b in range(a + 1, width):
                rb[col, b - a] = h[b] * ix
            return 0.0
        bw = big_w + hv * hv * di
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hv * di * inv
        dinv[col] = di * cb
        for k in range(d):
            zk = z[col, k]
            yk = rhs[k]
            z[col, k] = cb * zk + sb * yk
            rhs[k] = yk - hv * zk
        for b in range(a + 1, width):
            ra = rb[col, b - a]
            hb = h[b]
            rb[col, b - a] = cb * ra + sb * hb
            h[b] = hb - hv * ra
        big_w = bw
    res = 0.0
    for k in range(d):
        res += rhs[k] * rhs[k]
    return res / big_w


@njit(cache=True)
def inverse_norm_bound(rb, dinv, size, p):
    """Upper bound of the 2-norm of ``R^-1`` for the factor's first ``size`` rows
    (``R = diag(1 / sqrt(dinv)) rb``, ``inf`` if a row is missing).

    ``|rb^-1| <= M^-1`` elementwise for the comparison matrix ``M`` of the unit triangular
    ``rb``, so its infinity and 1-norms are at most the largest entries of ``M^-1 e`` and
    ``M^-T e``; ``||A||_2 <= sqrt(||A||_1 ||A||_inf)``, and the diagonal scaling adds at most
    ``max sqrt(dinv)``.
    """
    v = np.empty(size)
    w = np.empty(size)
    v_max = 0.0
    w_max = 0.0
    d_max = 0.0
    for i in range(size - 1, -1, -1):  # v = M^-1 e
        if dinv[i] == np.inf:
            return np.inf
        d_max = max(d_max, dinv[i])
        acc = 1.0
        for a in range(min(p, size - 1 - i), 0, -1):
            acc += abs(rb[i, a]) * v[i + a]
        v[i] = acc
        v_max = max(v_max, acc)
    for j in range(size):  # w = M^-T e
        acc = 1.0
        for a in range(min(p, j), 0, -1):
            acc += abs(rb[j - a, a]) * w[j - a]
        w[j] = acc
        w_max = max(w_max, acc)
    return math.sqrt(v_max * w_max * d_max)


@njit(cache=True)
def incumbent_rows(u, t, p, n, spans, basis, row_start, column_sums):
    """Spans and basis values of every data row under ``t``; ``row_start[c]`` is the first row
    of a span ``>= c`` (``c = 0 .. n``); ``column_sums`` of the collocation matrix."""
    m = u.size
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    span = p
    for j in range(m):
        x = u[j]
        while span < n - 1 and t[span + 1] <= x:
            span += 1
        spans[j] = span
        basis_values(t, p, span, x, basis[j], left, right)
        for i in range(p + 1):
            column_sums[span - p + i] += basis[j, i]
    j = 0
    for c in range(n + 1):
        while j < m and spans[j] < c:
            j += 1
        row_start[c] = j


@njit(cache=True)
def forward_states(q, p, n, spans, basis, Frb, Fdinv, Fz, Fsse, Fcol, rb, dinv, z):
    """Forward states ``c = p .. n``: row ``a`` of state ``c`` is the factor's row of column
    ``c - p + a`` (``Frb[c, a, b]``: entry at column ``c - p + a + b``; ``Fdinv``, ``Fz``).
    ``Fcol[c, a]`` is what those rows add to the column sum of column ``c - p + a``. The final
    factor is left in ``rb``, ``dinv``, ``z``."""
    m, d = q.shape
    colsum = np.zeros(n)
    rb[:, :] = 0.0
    dinv[:] = np.inf
    z[:, :] = 0.0
    h = np.empty(p + 1)
    rhs = np.empty(d)
    sse = 0.0
    j = 0
    for c in range(p, n + 1):
        for a in range(p):
            col = c - p + a
            for b in range(p):
                Frb[c, a, b] = rb[col, b] if b < p - a else 0.0
            Fdinv[c, a] = dinv[col]
            Fcol[c, a] = colsum[col]
            for k in range(d):
                Fz[c, a, k] = z[col, k]
        Fsse[c] = sse
        if c == n:
            break
        while j < m and spans[j] == c:
            for i in range(p + 1):
                h[i] = basis[j, i]
                colsum[c - p + i] += h[i]
            for k in range(d):
                rhs[k] = q[j, k]
            sse += rotate_row(rb, dinv, z, c - p, h, rhs, p + 1, 1.0)
            j += 1


@njit(cache=True)
def backward_states(q, p, n, spans, basis, Gh, Gbw, Gz, Gsse, Gcol, rb, dinv, z):
    """Backward states ``c = n .. p``, as rows to rotate into a forward factor: row ``a`` of
    state ``c`` is ``Gh[c, a, :]`` over columns ``c - p .. c - 1`` (counted from the left) with
    right-hand side ``Gz[c, a]`` and weight ``1 / Gbw[c, a]`` (``inf``: no row);
    ``Gcol[c, a]`` is what the rows add to the column sum of column ``c - p + a``. ``rb``,
    ``dinv``, ``z`` (columns counted from the right) are left with the final backward factor."""
    m, d = q.shape
    colsum = np.zeros(n)
    rb[:, :] = 0.0
    dinv[:] = np.inf
    z[:, :] = 0.0
    h = np.empty(p + 1)
    rhs = np.empty(d)
    sse = 0.0
    j = m - 1
    for c in range(n, p - 1, -1):
        for a in range(p):
            oc = c - 1 - a  # column counted from the left
            rc = n - 1 - oc  # the same column counted from the right
            for b in range(p):
                Gh[c, a, b] = 0.0
            Gh[c, a, oc - (c - p)] = 1.0
            for b in range(1, p + 1):  # entry at right-counted rc + b = left-counted oc - b
                col = oc - b - (c - p)
                if col >= 0:
                    Gh[c, a, col] = rb[rc, b]
            Gbw[c, a] = dinv[rc]
            Gcol[c, oc - (c - p)] = colsum[oc]
            for k in range(d):
                Gz[c, a, k] = z[rc, k]
        Gsse[c] = sse
        if c == p:
            break
        while j >= 0 and spans[j] == c - 1:
            for i in range(p + 1):
                h[i] = basis[j, p - i]
                colsum[c - 1 - i] += h[i]
            for k in range(d):
                rhs[k] = q[j, k]
            sse += rotate_row(rb, dinv, z, n - c, h, rhs, p + 1, 1.0)
            j -= 1


@njit(cache=True)
def sw_matching(u, t, p, n, match):
    """The greedy Schoenberg-Whitney matching of ``_kernel._schoenberg_whitney``: ``match[i]``
    is the data row given to basis function ``i`` (the first free row inside its support).
    Returns False (and stops) where a function finds none."""
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
        match[i] = j
        j += 1
    return True


@njit(cache=True)
def sw_local(u, t2, p, n2, match, first, tail, shift):
    """The Schoenberg-Whitney check of ``t2`` given the incumbent's matching ``match``.

    Functions below ``first`` have the incumbent's supports, so the greedy matching agrees
    there; it is resumed at ``first``. Functions from ``tail`` on have the supports of the
    incumbent's functions ``i - shift``: once the resumed matching gives one of them a row no
    later than the incumbent's, every later function is matched too (the greedy choice is
    monotone in the row it starts from), and the check stops early.
    """
    m = u.size
    j = match[first - 1] + 1 if first > 0 else 0
    for i in range(first, n2):
        lo = t2[i]
        hi = t2[i + p + 1]
        while j < m and not (u[j] > lo or (i == 0 and u[j] >= lo)):
            j += 1
        if j == m:
            return False
        if not (u[j] < hi or (i == n2 - 1 and u[j] <= hi)):
            return False
        if i >= tail and j <= match[i - shift]:
            return True
        j += 1
    return True


@njit(cache=True)
def _merged_coefficients(rbm, zm, size, rb_f, z_f, rb_b, z_b, n, p, c_left, c_right, delta,
                         coef):
    """Control points of a merged candidate (columns counted in the candidate): the merged
    block ``rbm``, ``zm`` (columns ``c_left - p ..``) first, then the incumbent's final forward
    rows leftwards and its final backward rows rightwards (unit triangular, square-root-free)."""
    d = zm.shape[1]
    base = c_left - p
    for i in range(size - 1, -1, -1):
        for k in range(d):
            acc = zm[i, k]
            for a in range(min(p, size - 1 - i), 0, -1):
                acc -= rbm[i, a] * coef[base + i + a, k]
            coef[base + i, k] = acc
    for col in range(base - 1, -1, -1):
        for k in range(d):
            acc = z_f[col, k]
            for a in range(p, 0, -1):
                acc -= rb_f[col, a] * coef[col + a, k]
            coef[col, k] = acc
    for oc in range(c_right, n):  # incumbent's column oc is the candidate's oc + delta
        rc = n - 1 - oc
        for k in range(d):
            acc = z_b[rc, k]
            for a in range(min(p, oc), 0, -1):
                acc -= rb_b[rc, a] * coef[oc - a + delta, k]
            coef[oc + delta, k] = acc


@njit(cache=True)
def _candidate_knots(u, t, interior, p, t2):
    """Fill ``t2`` with the candidate's clamped knot vector; return (reason, e, f): ``e`` the
    first index where it differs from the incumbent's ``t``, ``f`` the length of their common
    tail. Only the changed knots are checked (the others are the incumbent's): the reason is
    the full kernel's ``_build_knots`` verdict."""
    k = interior.size
    n1 = t.size
    n2 = k + 2 * p + 2
    u0 = u[0]
    um = u[u.size - 1]
    for i in range(p + 1):
        t2[i] = u0
        t2[n2 - 1 - i] = um
    t2[p + 1 : p + 1 + k] = interior
    e = 0
    limit = min(n1, n2)
    while e < limit and t[e] == t2[e]:
        e += 1
    f = 0
    while f < limit - e and t[n1 - 1 - f] == t2[n2 - 1 - f]:
        f += 1
    stop = n2 - f  # t2[e:stop] are the changed knots, all interior
    for i in range(e, stop):
        x = t2[i]
        if not (x > u0 and x < um):  # also catches NaN
            return KNOT_OUT_OF_RANGE, e, f
    for i in range(max(e, p + 2), min(stop + 1, n2 - p - 1)):
        if t2[i] <= t2[i - 1]:
            return COINCIDENT_KNOTS, e, f
    return FEASIBLE, e, f


@njit(cache=True)
def evaluate_moves(u, q, p, t, n, spans, row_start, match, Frb, Fdinv, Fz, Fsse, Gh, Gbw, Gz,
                   Gsse, Fcol, Gcol, col_before, col_from, base_sse, inverse_left, inverse_right,
                   gram_norm, rb_f, z_f, rb_b, z_b, basis, knots, offsets, max_window_rows,
                   want_max_dev, sse_out, max_dev_out, n_ctrl_out, reason_out, path_out):
    """Score candidates (interior knots ``knots[offsets[b]:offsets[b + 1]]``) by merging the
    incumbent's cached states; fall back to the full fit where the cheap path cannot decide.

    Outputs per candidate: SSE, maximum deviation (when ``want_max_dev``), control points,
    reason code and the path that decided it. The maximum deviation of a merged candidate
    comes from its control points, solved from the final rows of the incumbent's forward
    factor (``rb_f``, ``z_f``: columns left of the merged block), the merged block and the
    final rows of the backward factor (``rb_b``, ``z_b``: columns right of it), and the
    incumbent's basis values for the rows outside the window.
    """
    m, d = q.shape
    n_cand = offsets.size - 1
    k_max = 0
    for b in range(n_cand):
        k_max = max(k_max, offsets[b + 1] - offsets[b])
    n_max = max(k_max + p + 1, n + 1)
    t2 = np.empty(n_max + p + 1)
    coef = np.empty((n_max, d))
    basis_ws = np.empty((m if want_max_dev else 0, p + 1))
    spans_ws = np.empty(m if want_max_dev else 0, dtype=np.int64)
    rows_max = n_max + p
    rbm = np.zeros((rows_max, p + 1))
    dinvm = np.empty(rows_max)
    zm = np.zeros((rows_max, d))
    h = np.empty(p + 1)
    rhs = np.empty(d)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    colsum = np.empty(rows_max)
    window_basis = np.empty((m if want_max_dev else 0, p + 1))
    window_span = np.empty(m if want_max_dev else 0, dtype=np.int64)
    for b in range(n_cand):
        interior = knots[offsets[b]:offsets[b + 1]]
        n2 = interior.size + p + 1
        n_ctrl_out[b] = n2
        sse_out[b] = np.inf
        if want_max_dev:
            max_dev_out[b] = np.inf
        path_out[b] = PATH_CHECKS
        if n2 > m:
            reason_out[b] = TOO_MANY_CONTROL_POINTS
            continue
        tb = t2[: n2 + p + 1]
        code, e, f = _candidate_knots(u, t, interior, p, tb)
        if code != FEASIBLE:
            reason_out[b] = code
            continue
        delta = n2 - n
        # functions below e - p - 1 keep their supports, those from t.size - f + delta on
        # (counted in t2) keep the supports of the incumbent's functions shifted by delta
        if not sw_local(u, tb, p, n2, match, max(e - p - 1, 0), t.size - f + delta, delta):
            reason_out[b] = SCHOENBERG_WHITNEY
            continue
        c_left = max(e - p, p)
        c_right = min(t.size - f + p - 1, n)
        c_right2 = c_right + delta
        window_rows = row_start[c_right] - row_start[c_left]
        use_delta = window_rows <= max_window_rows
        if e == t.size and n2 == n:  # the incumbent itself
            if not want_max_dev:
                reason_out[b] = FEASIBLE
                sse_out[b] = base_sse
                path_out[b] = PATH_DELTA
                continue
            c_left = n - p  # merge the last spans again (their rows are unchanged)
            c_right = n
            c_right2 = n
            window_rows = row_start[c_right] - row_start[c_left]
        if use_delta:
            size = c_right2 - c_left + p
            for i in range(size):
                for k in range(p + 1):
                    rbm[i, k] = 0.0
                dinvm[i] = np.inf
            for i in range(size):
                colsum[i] = 0.0
            for a in range(p):
                colsum[a] += Fcol[c_left, a]
                colsum[size - p + a] += Gcol[c_right, a]
            for a in range(p):
                for k in range(p):
                    rbm[a, k] = Frb[c_left, a, k]
                dinvm[a] = Fdinv[c_left, a]
                for k in range(d):
                    zm[a, k] = Fz[c_left, a, k]
            res = 0.0
            span2 = c_left
            for j in range(row_start[c_left], row_start[c_right]):
                x = u[j]
                while span2 < n2 - 1 and tb[span2 + 1] <= x:
                    span2 += 1
                basis_values(tb, p, span2, x, h, left, right)
                if want_max_dev:
                    window_span[j] = span2
                    for k in range(p + 1):
                        window_basis[j, k] = h[k]
                for k in range(p + 1):
                    colsum[span2 - c_left + k] += h[k]
                for k in range(d):
                    rhs[k] = q[j, k]
                res += rotate_row(rbm, dinvm, zm, span2 - c_left, h, rhs, p + 1, 1.0)
            for a in range(p):
                big_w = Gbw[c_right, a]
                if big_w == np.inf:
                    continue
                for k in range(p):
                    h[k] = Gh[c_right, a, k]
                for k in range(d):
                    rhs[k] = Gz[c_right, a, k]
                res += rotate_row(rbm, dinvm, zm, size - p, h, rhs, p, big_w)
            # certify the full kernel's verdict (feasible) by bounding the condition number:
            # [left final rows; merged rows; right final rows] is a square factor S of the
            # candidate's normal matrix, block triangular around the merged block Rm, with the
            # left and right blocks parts of the incumbent's factors (see the module notes)
            inv_m = inverse_norm_bound(rbm, dinvm, size, p)
            inv_s = inv_m + inverse_left * (1.0 + gram_norm * inv_m) \
                + inverse_right * (1.0 + gram_norm * inv_m)
            # ||B'||_2^2 <= largest column sum (entries >= 0, rows summing to 1); the columns
            # outside the merged block keep the incumbent's sums
            largest_sum = max(col_before[c_left - p], col_from[c_right])
            for i in range(size):
                largest_sum = max(largest_sum, colsum[i])
            # the kernel's condition number is in the infinity norm, of the upper triangular R':
            # ||R'||_inf <= sqrt(p + 1) ||R'||_2 and ||R'^-1||_inf <= sqrt(n) ||R'^-1||_2
            kappa = math.sqrt((p + 1) * n2) * math.sqrt(largest_sum) * inv_s
            if kappa <= CERTIFY * COND_LIMIT:
                reason_out[b] = FEASIBLE
                sse_out[b] = Fsse[c_left] + Gsse[c_right] + res
                path_out[b] = PATH_DELTA
                if want_max_dev:
                    c = coef[:n2]
                    _merged_coefficients(rbm, zm, size, rb_f, z_f, rb_b, z_b, n, p, c_left,
                                         c_right, delta, c)
                    worst = 0.0
                    for j in range(m):
                        if j < row_start[c_left] or j >= row_start[c_right]:
                            first = spans[j] - p + (0 if j < row_start[c_left] else delta)
                            hj = basis[j]
                        else:
                            first = window_span[j] - p
                            hj = window_basis[j]
                        dist2 = 0.0
                        for k in range(d):
                            acc = 0.0
                            for i in range(p + 1):
                                acc += hj[i] * c[first + i, k]
                            diff = q[j, k] - acc
                            dist2 += diff * diff
                        worst = max(worst, dist2)
                    max_dev_out[b] = math.sqrt(worst)
                continue
        # the full fit decides
        path_out[b] = PATH_FULL
        code, value = _fit_into(u, q, interior, p, tb, coef[:n2], basis_ws, spans_ws)
        reason_out[b] = code
        sse_out[b] = value
        if want_max_dev and code == FEASIBLE:
            max_dev_out[b] = _max_deviation(q, p, coef[:n2], basis_ws, spans_ws)


@njit(cache=True)
def masks_to_knots_serial(u, masks):
    """``_kernel.masks_to_knots`` on one thread (no thread-pool start: for batches of a few)."""
    n_cand, n_var = masks.shape
    total = 0
    for b in range(n_cand):
        for i in range(n_var):
            total += masks[b, i]
    knots = np.empty(total)
    offsets = np.zeros(n_cand + 1, dtype=np.int64)
    pos = 0
    for b in range(n_cand):
        for i in range(n_var):
            if masks[b, i]:
                knots[pos] = u[i + 1]
                pos += 1
        offsets[b + 1] = pos
    return knots, offsets
