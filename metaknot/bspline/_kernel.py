"""Compiled least-squares B-spline kernel (numba).

Each candidate is fitted by Givens QR on the banded collocation matrix, row by row, as FITPACK's
``fpcurf`` does: O(N p^2) work and O(n p) memory per candidate, numerically stable (no normal
equations). A batch of candidates is spread over threads with ``prange``; each thread reuses its
workspaces from one candidate to the next. Small batches are fitted on the calling thread
(:func:`evaluate_batch_serial`, :func:`evaluate_masks_serial`,
:func:`evaluate_positions_serial`): the same per-candidate code, so the same results, without
waking the thread pool.

Reason codes (see :class:`metaknot.bspline.Infeasibility`):
0 feasible, 1 more control points than data points, 2 knot outside the open parameter range or
not finite, 3 coincident interior knots (a knot repeated more often than the candidate's
``max_mult`` allows, or unsorted), 4 Schoenberg-Whitney conditions violated, 5 numerically
singular.

*Multiple knots.* ``max_mult`` (1 to the degree ``p``) is the multiplicity an interior knot may
have: 1 for the encodings whose knots are distinct, up to ``p`` where a problem allows multiple
knots (continuity C^(p - m) at a knot of multiplicity m). The basis recurrence takes a zero-length
span's reciprocal as 0 (de Boor's convention) and the span search skips such spans. The
generated row loop's Schoenberg-Whitney test takes distinct knots (a multiple knot can pass it
wrongly, never fail it wrongly), so a candidate that repeats a knot is tested again by
:func:`schoenberg_whitney`, which counts the multiplicity of a knot a data point sits on; the
row loop of distinct knots stays as it was, at its speed.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ._rows import EMPTY, back, bound, deviation, fma, rows

FEASIBLE = 0
TOO_MANY_CONTROL_POINTS = 1
KNOT_OUT_OF_RANGE = 2
COINCIDENT_KNOTS = 3
SCHOENBERG_WHITNEY = 4
SINGULAR = 5

# A diagonal entry of R below this fraction of the largest one counts as singular.
RCOND = 1e-12
# A least-squares system whose (infinity-norm) condition number exceeds this is reported as
# numerically singular: its control points (and the curve between data points) would be noise.
COND_LIMIT = 1e11
# A closed curve's system is singular when a pivot of its factor is at most this fraction of
# the largest one (:func:`solve_closed_into`; the closed move evaluator's certificate keeps it).
PIVOT_RATIO = 1e-11


@njit(cache=True)
def _build_knots(u, interior, p, t, max_mult):
    """Fill the clamped knot vector ``t``; return a reason code for malformed interior knots.

    One pass without branches on the knots (out of range, NaN included, takes precedence over
    unsorted or coincident); a knot may repeat up to ``max_mult`` times (the runs counted by
    :func:`repeated_beyond`, the rule of every check of multiple knots).
    """
    k = interior.size
    u0 = u[0]
    um = u[u.size - 1]
    for i in range(p + 1):
        t[i] = u0
        t[k + p + 1 + i] = um
    outside = False
    unsorted = False
    prev = u0
    repeats = max_mult > 1  # equal neighbours allowed: their runs are counted after the loop
    for i in range(k):
        x = interior[i]
        t[p + 1 + i] = x
        outside |= not ((x > u0) & (x < um))  # also catches NaN
        unsorted |= (x < prev) | ((x == prev) & (not repeats))
        prev = x
    if outside:
        return KNOT_OUT_OF_RANGE
    if unsorted or (repeats and repeated_beyond(interior, max_mult)):
        return COINCIDENT_KNOTS
    return FEASIBLE


@njit(cache=True, inline='always', error_model='numpy')
def empty_state(st, columns, width):
    """Mark ``columns`` columns of the flat factor ``st`` as reached by no row."""
    for c in range(columns):
        st[c * width] = EMPTY
        for k in range(1, width):
            st[c * width + k] = 0.0


@njit(cache=True, error_model="numpy")
def reciprocals(t, p, iv, lo_start, lo_stop):
    """``iv[(j - 1) * t.size + lo] = 1 / (t[lo + j] - t[lo])`` (0 where not positive) for
    ``j = 1..p`` and ``lo_start <= lo < lo_stop``: the denominators of the basis recurrence,
    computed once per knot vector (all of them: ``0, t.size``), the table of every generated
    row loop. Stored by ``j`` so that the inner loop over ``lo`` is a vector division."""
    size = t.size
    for j in range(1, p + 1):  # unsigned indices: no wraparound test, a vector loop
        row = np.uint64((j - 1) * size)
        stop = max(min(lo_stop, size - j), 0)  # never negative: it would wrap around
        for lo in range(np.uint64(max(lo_start, 0)), np.uint64(stop)):
            gap = t[lo + np.uint64(j)] - t[lo]
            iv[row + lo] = 1.0 / gap if gap > 0.0 else 0.0


@njit(cache=True)
def _solve_into(u, q, t, p, n, coef, basis, spans, iv, st, max_mult=1):
    """Least-squares control points into ``coef`` (n, d); return (reason code, SSE).

    Square-root-free Givens rotations (Gentleman 1973), row by row as in FITPACK's ``fpcurf``:
    the triangular factor is ``R = diag(sqrt(1 / dinv)) @ rb`` with unit-diagonal ``rb``; a data
    row enters with weight ``w = 1 / big_w``. Tracking ``big_w`` and ``dinv`` (reciprocals)
    keeps every division off the chain of dependent operations, so rotations pipeline. The sum of
    squared residuals is what the rotations leave of the data rows, so no second pass is needed
    for it. The row loop itself is generated per degree and dimension (``_rows.py``) and checks
    the Schoenberg-Whitney conditions on the way. ``iv`` (at least ``t.size * p``) and ``st``
    (at least ``n * (1 + p + d)``) are workspaces: ``st`` holds, per column of the factor,
    ``dinv``, the ``p`` off-diagonal entries of ``rb`` and the ``d`` right-hand sides. If
    ``basis`` is not empty, basis values and spans of every data point are stored for
    ``_rows.deviation`` (the maximum deviation).
    """
    d = q.shape[1]
    width = 1 + p + d
    reciprocals(t, p, iv, 0, t.size)
    empty_state(st, n, width)
    sse, matched = rows(u, q, t, iv, p, n, st, basis, spans)
    if matched and max_mult > 1 and _repeats(t, p, n):  # the row loop's test takes distinct
        matched = schoenberg_whitney(u, t, p, n)  # knots: a multiple one can pass it wrongly
    if not matched:
        return SCHOENBERG_WHITNEY, np.inf
    # 1 / dinv is the squared diagonal of R: compare its smallest entry with its largest
    smallest_dinv, largest_dinv, row_max, v_max = bound(st, p, width, n)
    if not (smallest_dinv > 0.0 and smallest_dinv >= RCOND * RCOND * largest_dinv):
        return SINGULAR, np.inf
    if not (_bound_from(smallest_dinv, largest_dinv, row_max, v_max) <= COND_LIMIT
            or _condition_estimate(st, width, p, n) <= COND_LIMIT):
        return SINGULAR, np.inf
    back(st, p, n, coef)
    return FEASIBLE, sse


@njit(cache=True)
def _bound_from(smallest_dinv, largest_dinv, row_max, v_max):
    """Cheap upper bound of the infinity-norm condition number of ``R`` from the results of
    ``_rows.bound`` (one banded pass, generated per degree, without division).

    ``|R^-1| <= M^-1`` elementwise, with ``M`` the comparison matrix of ``R`` (unit diagonal,
    minus the absolute off-diagonal entries of ``rb``), so ``||R^-1||_inf`` is at most the
    largest entry of ``M^-1 e`` (``v_max``) times the largest ``1 / R_ii``; usually within a
    small factor of the true value for B-spline systems.
    """
    # (largest R_ii) * (largest 1 / R_ii) = sqrt(largest dinv / smallest dinv)
    return math.sqrt(largest_dinv / smallest_dinv) * row_max * v_max


@njit(cache=True)
def _condition_estimate(st, width, p, n):
    """Estimate the infinity-norm condition number of ``R = diag(sqrt(1 / dinv)) @ rb``.

    ``dinv[i]`` is ``st[i * width]``, ``rb[i, a]`` is ``st[i * width + a]``.

    ``||R||_inf`` exactly, ``||R^-1||_inf = ||R^-T||_1`` by Hager's estimator (Higham 1988, as
    in LAPACK's ``xLACON``): a few rounds of two banded triangular solves, O(n p) each. The
    estimate is a lower bound, almost always within a factor 3.
    """
    sq = np.empty(n)  # 1 / R_ii
    norm_r = 0.0
    for i in range(n):
        sq[i] = math.sqrt(st[i * width])
        row = 1.0
        for a in range(1, min(p, n - 1 - i) + 1):
            row += abs(st[i * width + a])
        norm_r = max(norm_r, row / sq[i])
    x = np.full(n, 1.0 / n)
    y = np.empty(n)
    z = np.empty(n)
    est = 0.0
    for it in range(5):
        total = 0.0
        for i in range(n):  # y = R^-T x
            acc = x[i]
            for a in range(min(p, i), 0, -1):
                acc -= st[(i - a) * width + a] * y[i - a]
            y[i] = acc
        for i in range(n):
            y[i] *= sq[i]
            total += abs(y[i])
        if it > 0 and total <= est:
            break
        est = total
        best = 0
        z_best = -1.0
        zx = 0.0
        for i in range(n - 1, -1, -1):  # z = R^-1 sign(y)
            acc = sq[i] if y[i] >= 0.0 else -sq[i]
            for a in range(min(p, n - 1 - i), 0, -1):
                acc -= st[i * width + a] * z[i + a]
            z[i] = acc
            zx += acc * x[i]
            if abs(acc) > z_best:
                best = i
                z_best = abs(acc)
        if it > 0 and z_best <= zx:
            break
        x[:] = 0.0
        x[best] = 1.0
    return norm_r * est


@njit(cache=True, inline='always')
def fit_workspaces(n, p, d):
    """The workspaces of a fit of ``n`` control points (:func:`_solve_into`, and the first two
    of :func:`closed_workspaces`): the knots' reciprocal differences and the banded factor."""
    return np.empty((n + p + 1) * p), np.empty(n * (1 + p + d))


@njit(cache=True)
def _fit_ws(u, q, interior, p, t, coef, basis, spans, iv, st, max_mult):
    """Fit one candidate into preallocated ``t`` and ``coef`` with the workspaces ``iv`` and
    ``st`` of :func:`fit_workspaces`; return (reason code, SSE)."""
    n = interior.size + p + 1
    if n > u.size:
        return TOO_MANY_CONTROL_POINTS, np.inf
    reason = _build_knots(u, interior, p, t, max_mult)
    if reason != FEASIBLE:
        return reason, np.inf
    return _solve_into(u, q, t, p, n, coef, basis, spans, iv, st, max_mult)


@njit(cache=True)
def _repeats(t, p, n):
    """Whether the clamped knot vector ``t`` (``n`` B-splines) repeats an interior knot."""
    for i in range(p + 2, n):
        if t[i] == t[i - 1]:
            return True
    return False


@njit(cache=True)
def schoenberg_whitney(u, t, p, n):
    """The Schoenberg-Whitney conditions for the clamped knot vector ``t`` (interior knots of
    any multiplicity up to ``p``) and the increasing parameters ``u``: each of the ``n``
    B-splines gets a data point of its own where it is nonzero.

    The greedy matching of the generated row loop (points in order, each to the first
    unmatched B-spline nonzero there), with the B-splines nonzero at a point on a knot of
    multiplicity ``m`` counted right: ``span - p .. span - m`` (those starting at the point are
    zero there, unless ``m`` is ``p + 1``, the clamped start)."""
    matched = 0
    span = p
    last = n - 1
    for j in range(u.size):
        x = u[j]
        while span < last and t[span + 1] <= x:
            span += 1
        first = span - p
        if matched < first:
            return False
        hi = span
        if x == t[span]:
            hi = span - 1
            while hi > first and t[hi] == x:
                hi -= 1
        if matched <= hi:
            matched += 1
    return matched == n


@njit(cache=True)
def fit_one(u, q, interior, p, max_mult):
    """Fit one candidate (a knot repeated at most ``max_mult`` times): return (reason, knot
    vector, control points)."""
    n = interior.size + p + 1
    t = np.empty(n + p + 1)
    coef = np.zeros((n, q.shape[1]))
    iv, st = fit_workspaces(n, p, q.shape[1])
    reason, _ = _fit_ws(u, q, interior, p, t, coef, np.empty((0, p + 1)),
                        np.empty(0, dtype=np.int64), iv, st, max_mult)
    return reason, t, coef


@njit(cache=True)
def _largest_fit(offsets, n_points, p):
    """Control points of the largest candidate of a flattened batch (capped at ``n_points``
    + p + 1: larger candidates are refused before they touch a workspace)."""
    k_max = 0
    for b in range(offsets.size - 1):
        k_max = max(k_max, offsets[b + 1] - offsets[b])
    return min(k_max, n_points) + p + 1


@njit(cache=True)
def _score_workspaces(n_points, d, p, n_max, want_max_dev):
    """The workspaces of :func:`_score` for candidates of at most ``n_max`` control points, open
    or closed: the fit's (:func:`closed_workspaces`, whose first two an open fit takes), the
    rows' basis values and spans (empty unless ``want_max_dev``), the breakpoints, the knot
    vector and the control points."""
    rows = n_points if want_max_dev else 0
    return (closed_workspaces(n_max, p, d), np.empty((rows, p + 1)),
            np.empty(rows, dtype=np.int64), np.empty(n_max), np.empty(n_max + 2 * p + 1),
            np.empty((n_max, d)))


@njit(cache=True)
def _score(u, q, p, closed, interior, b, ws, sse, max_dev, n_ctrl, reason, max_mult):
    """Fit candidate ``b``, its interior knots each repeated at most ``max_mult`` times, with
    the workspaces ``ws`` of :func:`_score_workspaces`; its results go to entry ``b`` of the
    output arrays. Open: sorted interior knots of a clamped spline. Closed: breakpoints 0 and
    ``interior`` in any order (sorted here), ``m = interior.size + 1`` periodic control
    points; refused before a fit (and before a workspace is touched): a knot outside (0, 1)
    (:func:`closed_verdict`), then coincident knots, then fewer than ``p`` breakpoints
    (SINGULAR) or more than there are points."""
    fit_ws, basis, spans, breaks, t_ws, coef_ws = ws
    if not closed:
        n = interior.size + p + 1
        n_ctrl[b] = n
        coef = coef_ws[:n]  # a candidate of more than u.size is refused before it is touched
        code, sse[b] = _fit_ws(u, q, interior, p, t_ws[: n + p + 1], coef, basis, spans,
                               fit_ws[0], fit_ws[1], max_mult)
        reason[b] = code
        if max_dev.size > 0:
            max_dev[b] = deviation(q, p, coef, basis, spans) if code == FEASIBLE \
                else np.inf
        return
    m = interior.size + 1
    n_ctrl[b] = m
    code, in_order = closed_verdict(interior, max_mult)
    if code == FEASIBLE and (m < p or m > u.size):
        code = SINGULAR if m < p else TOO_MANY_CONTROL_POINTS
    if code != FEASIBLE:
        sse[b], reason[b] = np.inf, code
        if max_dev.size > 0:
            max_dev[b] = np.inf
        return
    breaks[0] = 0.0
    breaks[1:m] = interior if in_order else np.sort(interior)
    t = t_ws[: m + 2 * p + 1]
    extended_knots(breaks[:m], p, t)
    coef = coef_ws[:m]
    code, value = solve_closed_into(u, q, t, p, coef, basis, spans, fit_ws, PIVOT_RATIO)
    if code == FEASIBLE and not np.isfinite(value):  # spans too short to compute with
        code, value = SINGULAR, np.inf
    sse[b], reason[b] = value, code
    if max_dev.size > 0:
        max_dev[b] = deviation_from_basis(q, p, m, coef, basis, spans) \
            if code == FEASIBLE else np.inf


@njit(cache=True)
def _score_range(u, q, p, closed, max_mult, knots, offsets, lo, hi, n_max, sse, max_dev, n_ctrl,
                 reason):
    """Score the candidates ``lo .. hi - 1`` of a flattened batch (:func:`evaluate_batch`) with
    one set of workspaces, sized for ``n_max`` control points."""
    ws = _score_workspaces(u.size, q.shape[1], p, n_max, max_dev.size > 0)
    for b in range(lo, hi):
        _score(u, q, p, closed, knots[offsets[b] : offsets[b + 1]], b, ws, sse, max_dev, n_ctrl,
               reason, max_mult)


@njit(cache=True, parallel=True)
def evaluate_batch(u, q, p, closed, max_mult, knots, offsets, sse, max_dev, n_ctrl, reason,
                   n_chunks):
    """Score every candidate ``b`` with interior knots ``knots[offsets[b]:offsets[b+1]]``
    (sorted; of a closed curve, in any order: :func:`_score` sorts them), each knot
    repeated at most ``max_mult`` times, in ``n_chunks`` parts for the threads.

    ``max_dev`` may be empty: the maximum deviation (a second pass over the data) is then
    skipped.
    """
    n_cand = offsets.size - 1
    n_max = _largest_fit(offsets, u.size, p)
    n_chunks = min(n_cand, max(n_chunks, 1))
    for c in prange(n_chunks):  # one workspace per chunk, sized for the largest candidate
        _score_range(u, q, p, closed, max_mult, knots, offsets, c * n_cand // n_chunks,
                     (c + 1) * n_cand // n_chunks, n_max, sse, max_dev, n_ctrl, reason)


@njit(cache=True)
def evaluate_batch_serial(u, q, p, closed, max_mult, knots, offsets, sse, max_dev, n_ctrl,
                          reason):
    """:func:`evaluate_batch` on the calling thread (small batches: no thread pool to wake)."""
    _score_range(u, q, p, closed, max_mult, knots, offsets, 0, offsets.size - 1,
                 _largest_fit(offsets, u.size, p), sse, max_dev, n_ctrl, reason)


@njit(cache=True)
def evaluate_masks_serial(u, q, p, closed, masks, sse, max_dev, n_ctrl, reason):
    """:func:`evaluate_batch` of a batch of masks over the candidate knots ``u[1:]`` (nonzero:
    a knot there; ``(B, N - 2)`` on an open curve, ``(B, N - 1)`` on a closed one) on the
    calling thread, each mask's knots gathered in one workspace."""
    n_cand, n_var = masks.shape
    k_max = 0
    for b in range(n_cand):
        count = 0
        for i in range(n_var):
            count += masks[b, i] != 0
        k_max = max(k_max, count)
    ws = _score_workspaces(u.size, q.shape[1], p, min(k_max, u.size) + p + 1,
                           max_dev.size > 0)
    interior = np.empty(k_max)
    for b in range(n_cand):
        end = n_var  # branch-free gathering, as in masks_to_knots
        while end > 0 and masks[b, end - 1] == 0:
            end -= 1
        k = 0
        for i in range(end):
            interior[k] = u[i + 1]
            k += masks[b, i] != 0
        _score(u, q, p, closed, interior[:k], b, ws, sse, max_dev, n_ctrl, reason, 1)


@njit(cache=True)
def evaluate_positions_serial(u, q, p, closed, max_mult, positions, nan_is_absent, sse, max_dev,
                              n_ctrl, reason):
    """:func:`evaluate_batch` of a ``(B, K)`` batch of knot positions on the calling thread,
    each row sorted in one workspace (NaN last, as numpy sorts; dropped if ``nan_is_absent``,
    else reported by the knot checks)."""
    n_cand, k = positions.shape
    ws = _score_workspaces(u.size, q.shape[1], p, min(k, u.size) + p + 1, max_dev.size > 0)
    interior = np.empty(k)
    for b in range(n_cand):
        interior[:] = positions[b]
        interior.sort()
        count = k
        if nan_is_absent:
            while count > 0 and np.isnan(interior[count - 1]):
                count -= 1
        _score(u, q, p, closed, interior[:count], b, ws, sse, max_dev, n_ctrl, reason,
               max_mult)


@njit(cache=True, parallel=True)
def masks_to_knots(u, masks):
    """Interior knots and row offsets of a (B, N-2) boolean mask batch.

    Branch-free (a random mask makes every branch on its entries a coin toss): every entry up to
    a row's last selected one is stored at the row's next free position, which advances only
    past selected ones, so unselected entries are overwritten and no store leaves the row.
    """
    n_cand, n_var = masks.shape
    counts = np.zeros(n_cand, dtype=np.int64)
    for b in prange(n_cand):
        c = 0
        for i in range(n_var):
            c += masks[b, i]
        counts[b] = c
    offsets = np.zeros(n_cand + 1, dtype=np.int64)
    for b in range(n_cand):
        offsets[b + 1] = offsets[b] + counts[b]
    knots = np.empty(offsets[n_cand])
    for b in prange(n_cand):
        end = n_var
        while end > 0 and not masks[b, end - 1]:
            end -= 1
        pos = offsets[b]
        for i in range(end):
            knots[pos] = u[i + 1]
            pos += masks[b, i]
    return knots, offsets


# -------------------------------------------------------------------------------------------
# Closed curves: the same factorisation with wrap-around columns


@njit(cache=True)
def basis_at(t, span, x, p, out, left, right):
    """The ``p + 1`` nonzero B-splines at ``x`` in knot span ``span`` of ``t`` (NURBS Book
    A2.2, with its divisions): for the few rows that the generated loops do not take."""
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


@njit(cache=True, inline='always')
def givens(st, o, hc, big_w):
    """The square-root-free Givens rotation of a row's entry ``hc`` (reciprocal weight
    ``big_w``) into the column of the flat factor ``st`` at ``o`` (its reciprocal weight
    ``dinv``, updated): returns ``(cb, sb, bw)``, the rotation and the row's new reciprocal
    weight; :func:`rotate_entries` applies it to the entries. The rule of the generated loops
    (:mod:`._codegen`), for the rows they do not take."""
    di = st[o]
    hd = hc * di
    bw = fma(hc, hd, big_w)
    inv = 1.0 / bw
    cb = big_w * inv
    sb = hd * inv
    st[o] = di * cb
    return cb, sb, bw


@njit(cache=True, inline='always')
def rotate_entries(st, o, row, r, count, hc, cb, sb):
    """Apply a rotation of :func:`givens` to ``count`` entries: the factor's ``st[o:]`` and the
    row's ``row[r:]``."""
    for a in range(count):
        ra = st[o + a]
        st[o + a] = fma(cb, ra, sb * row[r + a])
        row[r + a] = fma(-hc, ra, row[r + a])


@njit(cache=True)
def rotate_dense(st, far, width, p, d, ncol, row, values, first, band_stop, big_w):
    """Rotate one row into a factor of ``ncol`` columns whose last ``p`` are wrap-around
    columns, by the square-root-free Givens rotations of the generated row loop (the one
    rotation rule of open and closed fits and of delta evaluation).

    The factor is the flat ``st`` (``width = 1 + p + d`` entries per column: reciprocal weight,
    the unit triangular row's entries in the next ``p`` columns, the right-hand sides;
    ``dinv = EMPTY`` for a column no row has reached) and ``far[col, k]``, the entry of row
    ``col`` in wrap-around column ``ncol - p + k`` beyond its band (``ncol - p + k > col + p``);
    an open factor has no wrap-around entries. ``row[:ncol]`` holds the row's entries (the first
    nonzero at ``first``), ``values[:d]`` its right-hand side, ``big_w`` its reciprocal weight.
    Columns ``first .. band_stop - 1`` are rotated, then the wrap-around columns: rows given in
    the order of their first column fill in no band column beyond their first ``p + 1``
    (``band_stop = first + p + 1``); any other row needs ``band_stop = ncol``. Leaves the
    rotated entries of ``row`` zero and returns the squared residual left of the row (none if
    an empty column takes it).
    """
    wrap0 = ncol - p
    col = first
    while col < ncol:
        if col >= band_stop and col < wrap0:
            col = wrap0
            continue
        hc = row[col]
        if hc == 0.0:  # a rotation by a zero entry changes nothing
            col += 1
            continue
        o = col * width
        di = st[o]
        if di == EMPTY:  # an empty column takes the row, scaled: nothing of it is left
            inv = 1.0 / hc
            taken = big_w * inv * inv
            if not taken < EMPTY:  # an entry too small to reach the column (its weight
                row[col] = 0.0     # would overflow): dropped, the row goes on
                col += 1
                continue
            st[o] = taken
            for a in range(1, min(p, ncol - 1 - col) + 1):
                st[o + a] = row[col + a] * inv
                row[col + a] = 0.0
            for k in range(max(0, col + 2 * p + 1 - ncol), p):
                far[col, k] = row[wrap0 + k] * inv
                row[wrap0 + k] = 0.0
            for c in range(d):
                st[o + p + 1 + c] = values[c] * inv
            row[col] = 0.0
            return 0.0
        cb, sb, big_w = givens(st, o, hc, big_w)
        rotate_entries(st, o + 1, row, col + 1, min(p, ncol - 1 - col), hc, cb, sb)
        beyond = max(0, col + 2 * p + 1 - ncol)  # the wrap-around columns beyond the band
        rotate_entries(far[col], beyond, row, wrap0 + beyond, p - beyond, hc, cb, sb)
        rotate_entries(st, o + p + 1, values, 0, d, hc, cb, sb)
        row[col] = 0.0
        col += 1
    left_over = 0.0
    for c in range(d):
        left_over += values[c] * values[c]
    return left_over / big_w


@njit(cache=True)
def back_substitute(st, far, width, p, d, ncol, x):
    """Solve the unit triangular factor of :func:`rotate_dense` (``ncol`` columns, the last
    ``p`` wrap-around) for ``x[:ncol]``."""
    wrap0 = ncol - p
    for i in range(ncol - 1, -1, -1):
        o = i * width
        for c in range(d):
            v = st[o + p + 1 + c]
            for a in range(1, min(p, ncol - 1 - i) + 1):
                v -= st[o + a] * x[i + a, c]
            for k in range(max(0, i + 2 * p + 1 - ncol), p):
                v -= far[i, k] * x[wrap0 + k, c]
            x[i, c] = v


@njit(cache=True)
def closed_workspaces(m, p, d):
    """The workspaces of :func:`solve_closed_into` for ``m`` control points: the
    reciprocals, the factor, its wrap-around entries, a dense row, the solution, and those of
    :func:`_seam_into`: the basis values of a seam row with their knot differences, the
    seam's banded factor with the reciprocals of its knots, its dense factor and that
    factor's wrap-around entries."""
    iv, st = fit_workspaces(m, p, d)
    seam = (np.empty((3, p + 1)), np.empty(2 * p * (1 + p + d)), np.empty(p * (3 * p + 1)),
            np.empty(2 * p * (1 + p + d)), np.empty((2 * p, p)))
    return iv, st, np.empty((m, p)), np.empty(m + d), np.empty((m, d)), seam


@njit(cache=True)
def _seam_into(u, q, t, p, m, seam, st, far, row, seam_ws, basis, spans):
    """Rotate the seam rows ``0 .. seam - 1`` (the spans before breakpoint ``p``) into the
    factor ``st``, ``far`` of :func:`solve_closed_into`; return what is left of them. A seam
    row touches the first ``p`` unknowns and the last ``p`` only. When those are ``2p``
    distinct ones (``m >= 2p``), the rows are first rotated among themselves into a dense
    factor of those ``2p`` columns (``dense``, ``dense_far``; rows of :func:`rotate_dense`
    with ``ncol = 2p``), whose at most ``2p`` rows are then rotated, weighted, through the
    whole factor: the fill-in of the band runs at most ``p`` times, not once per seam row.
    More than ``2p`` seam rows go to that dense factor through a banded one: taken last ``p``
    unknowns first, a row in span ``j`` touches the columns ``j .. j + p`` of the ``2p``, so
    the generated row loop (on the unshifted knots ``t[:3p + 1]``) rotates them into
    ``band``, whose at most ``2p`` rows then go to the dense factor. Stores the rows' basis
    values and natural spans if ``basis`` is not empty. ``seam_ws`` are the last workspaces
    of :func:`closed_workspaces`."""
    seam_basis, band, band_iv, dense, dense_far = seam_ws
    d = q.shape[1]
    width = 1 + p + d
    keep = basis.shape[0] > 0
    values = row[m : m + d]  # the row's right-hand side lives behind its entries
    local = m >= 2 * p
    ncol = 2 * p if local else m
    if local:
        empty_state(dense, ncol, width)
        dense_far[:] = 0.0
    target, target_far = (dense, dense_far) if local else (st, far)  # of the rows one by one
    sse = 0.0
    if local and seam > ncol:  # through the banded factor
        empty_state(band, ncol, width)
        knots = t[: 3 * p + 1]
        reciprocals(knots, p, band_iv, 0, knots.size)
        sse, _ = rows(u[:seam], q[:seam], knots, band_iv, p, ncol, band,
                      basis[:seam] if keep else basis, spans[:seam] if keep else spans)
        if keep:
            spans[:seam] -= p  # natural spans
        for a in range(ncol):  # band column a is dense column p + a (a < p) or a - p
            big_w = band[a * width]
            if big_w == EMPTY:
                continue
            row[:ncol] = 0.0
            _factor_row(band, dense_far[:0], a, p, d, ncol, p, -p, row, values)
            sse += rotate_dense(dense, dense_far, width, p, d, ncol, row, values,
                                0 if a < p else a - p, ncol, big_w)
    else:
        h, left, right = seam_basis[0], seam_basis[1], seam_basis[2]
        j = 0
        for i in range(seam):
            xi = u[i]
            while j < p - 1 and xi >= t[p + j + 1]:
                j += 1
            basis_at(t, p + j, xi, p, h, left, right)
            if keep:
                spans[i] = j
                for k in range(p + 1):
                    basis[i, k] = h[k]
            row[:ncol] = 0.0
            for k in range(p + 1):  # extended function j + k is unknown (j + k - p) mod m
                e = j + k
                row[e - p if e >= p else ncol - p + e] += h[k]
            for c in range(d):
                values[c] = q[i, c]
            sse += rotate_dense(target, target_far, width, p, d, ncol, row, values, 0, ncol,
                                1.0)
    if not local:
        return sse
    for a in range(ncol):  # dense column a is unknown a or m - 2p + a
        big_w = dense[a * width]
        if big_w == EMPTY:
            continue
        row[:m] = 0.0
        _factor_row(dense, dense_far, a, p, d, ncol, 0, m - 2 * p, row, values)
        sse += rotate_dense(st, far, width, p, d, m, row, values, a if a < p else m - 2 * p + a,
                            m, big_w)
    return sse


@njit(cache=True, inline='always')
def _factor_row(src, src_far, a, p, d, ncol, low, high, row, values):
    """Row ``a`` of the unit triangular factor ``src`` of :func:`rotate_dense` (``ncol``
    columns; its wrap-around entries ``src_far``, none if empty) into the dense ``row`` and
    its right-hand side ``values``, column ``c`` of ``src`` at ``c + low`` if ``c < p``, else
    at ``c + high``: how :func:`_seam_into` moves a factor's rows into another."""
    width = 1 + p + d
    o = a * width
    row[a + (low if a < p else high)] = 1.0
    for b in range(1, min(p, ncol - 1 - a) + 1):
        c = a + b
        row[c + (low if c < p else high)] = src[o + b]
    for k in range(max(0, a + 2 * p + 1 - ncol), p if src_far.shape[0] > 0 else 0):
        row[ncol - p + k + high] = src_far[a, k]
    for c in range(d):
        values[c] = src[o + p + 1 + c]


@njit(cache=True)
def solve_closed_into(u, q, t, p, coef, basis, spans, ws, pivot_ratio):
    """Least-squares periodic spline on the extended knot vector ``t`` (``m + 2p + 1`` knots,
    ``t[p:p + m + 1]`` the breakpoints from 0 to 1); the ``m`` coefficients go to ``coef`` in
    their natural order. Returns (reason code, SSE).

    The same factorisation as :func:`_solve_into`, with wrap-around columns. Unknown ``k`` of
    the factor is coefficient ``(k + p) mod m``; a data row in natural span ``j >= p`` then
    touches the unknowns ``j - p .. j``, a band as on an open curve, and is rotated in by the
    generated row loop (called with ``t[p:]``). The rows of the spans ``j < p`` also touch the
    last ``p`` unknowns (the wrap around the seam); they are rotated in afterwards, one at a
    time, with the same square-root-free rotations: a row of the factor keeps its band, and the
    entries it gains in the last ``p`` columns beyond its band in ``far``. An open curve is the
    case without such rows.

    A column whose pivot ``1 / sqrt(dinv)`` is at most ``pivot_ratio`` times the largest makes
    the system singular. If ``basis`` is not empty, every row's basis values and natural span
    are kept there. ``ws`` are the workspaces of :func:`closed_workspaces` for at least ``m``.
    """
    n, d = q.shape
    m = t.size - 2 * p - 1
    if m > n:
        return TOO_MANY_CONTROL_POINTS, np.inf
    iv, st, far, row, x, seam_ws = ws
    width = 1 + p + d
    shifted = t[p:]
    reciprocals(shifted, p, iv, 0, shifted.size)
    empty_state(st, m, width)
    far[:m] = 0.0
    seam = 0  # rows in the spans before breakpoint p
    while seam < n and u[seam] < t[2 * p]:
        seam += 1
    keep = basis.shape[0] > 0
    sse, _ = rows(u[seam:], q[seam:], shifted, iv, p, m, st,
                  basis[seam:] if keep else basis, spans[seam:] if keep else spans)
    sse += _seam_into(u, q, t, p, m, seam, st, far, row, seam_ws, basis, spans)
    smallest_dinv, largest_dinv, _, _ = bound(st, p, width, m)
    if not (smallest_dinv > 0.0 and smallest_dinv > pivot_ratio * pivot_ratio * largest_dinv):
        return SINGULAR, np.inf
    back_substitute(st, far, width, p, d, m, x)
    for ci in range(m):
        for c in range(d):
            coef[ci, c] = x[ci - p if ci >= p else m - p + ci, c]
    return FEASIBLE, sse


@njit(cache=True)
def extended_knots(breaks: np.ndarray, p: int, t: np.ndarray) -> None:
    """Fill ``t`` (``m + 2p + 1`` entries) with the extended knot vector of the ``m``
    breakpoints ``breaks`` (0 first): p periodic copies on each side."""
    m = breaks.size
    for k in range(p):
        t[k] = breaks[m - p + k] - 1.0
    t[p : p + m] = breaks
    for k in range(p + 1):
        t[p + m + k] = (breaks[k] if k < m else breaks[k - m] + 1.0) + 1.0


@njit(cache=True)
def deviation_from_basis(q: np.ndarray, p: int, m: int, coef: np.ndarray, basis: np.ndarray,
                         spans: np.ndarray) -> float:
    """Largest distance of a data point to the periodic spline with coefficients ``coef``
    (``m`` of them), from the basis values and spans :func:`fit_closed` kept."""
    worst = 0.0
    for i in range(q.shape[0]):
        worst = max(worst, periodic_distance2(q, i, basis[i], spans[i], coef, m, p))
    return np.sqrt(worst)


@njit(cache=True, inline='always')
def periodic_distance2(q, i, h, first, coef, m, p):
    """Squared distance of point ``q[i]`` to a periodic spline of ``m`` coefficients ``coef``
    at a parameter whose basis values ``h`` start at coefficient ``first`` (mod ``m``)."""
    dist2 = 0.0
    for c in range(q.shape[1]):
        s = 0.0
        for k in range(p + 1):
            ci = first + k
            if ci >= m:
                ci -= m
            s += h[k] * coef[ci, c]
        diff = q[i, c] - s
        dist2 += diff * diff
    return dist2


@njit(cache=True)
def fit_closed(u: np.ndarray, q: np.ndarray, t: np.ndarray, p: int, coef: np.ndarray,
               basis: np.ndarray, spans: np.ndarray) -> tuple:
    """Least-squares periodic fit on the extended knot vector ``t`` (``m + 2p + 1`` knots):
    the ``m`` coefficients into ``coef[:m]``; returns (reason, sse), as
    :func:`solve_closed_into`. Unless the workspaces
    ``basis`` (``(N, p + 1)``) and ``spans`` (``(N,)``) are empty, keeps every row's basis
    values and natural span there (for :func:`deviation_from_basis`). With the workspaces
    of :func:`closed_workspaces` built per call (the closed move evaluator's full fits)."""
    m = t.size - 2 * p - 1
    return solve_closed_into(u, q, t, p, coef, basis, spans,
                             closed_workspaces(m, p, q.shape[1]), PIVOT_RATIO)


@njit(cache=True)
def closed_verdict(interior, max_mult):
    """The reason to refuse the breakpoints 0 and ``interior`` (in any order) of a closed
    candidate: KNOT_OUT_OF_RANGE for a knot not in (0, 1) (NaN included) before
    COINCIDENT_KNOTS for one repeated more than ``max_mult`` times, else FEASIBLE; and whether
    ``interior`` is sorted."""
    in_order = True
    for i in range(interior.size):
        x = interior[i]
        if not (x > 0.0 and x < 1.0):
            return KNOT_OUT_OF_RANGE, in_order
        if i > 0 and x < interior[i - 1]:
            in_order = False
    repeated = repeated_beyond(interior, max_mult) if in_order else \
        repeated_beyond(np.sort(interior), max_mult)
    return (COINCIDENT_KNOTS if repeated else FEASIBLE), in_order


@njit(cache=True)
def repeated_beyond(knots, max_mult):
    """Whether a value of the sorted ``knots`` repeats more than ``max_mult`` times (the rule
    of every check of multiple knots)."""
    run = 1
    for i in range(1, knots.size):
        run = run + 1 if knots[i] == knots[i - 1] else 1
        if run > max_mult:
            return True
    return False
