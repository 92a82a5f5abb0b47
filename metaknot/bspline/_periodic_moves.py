"""Compiled delta evaluation of local knot moves on closed curves (numba); see
:mod:`metaknot.bspline.moves`.

Notation: the incumbent is a periodic spline with ``m`` breakpoints ``b_0 = 0 < b_1 < ... <
b_{m-1} < 1`` and the extended knot vector ``t`` of :func:`._kernel.extended_knots`; data row ``r``
lies in natural span ``spans[r]`` (``b_j <= u[r] < b_{j+1}``) and touches the natural columns
``spans[r] .. spans[r] + p`` (mod ``m``).

*Frames.* A frame cuts the circle at a breakpoint ``s`` and orders everything from there: frame
span ``k`` is the natural span ``(s + k) mod m``; the frame columns are the *wrap columns*
(natural ``s .. s + p - 1``, touched by the first and the last spans of the frame) and the ``nb
= m - p`` *band columns* (natural ``s + p ..`` in order, band position ``pos``). A row of frame
span ``k`` touches the band positions ``k - p .. k`` and, near the cut, wrap columns: the
closed fit orders its unknowns as the frame ``s = 0`` does.

*Forward state* ``K`` of a frame: the rows of frame spans ``< K`` rotated into a factor (band
rows ``band[pos, 0..p]`` for columns ``pos .. pos + p``, their wrap entries ``wrap[pos, :]``,
the wrap block's ``p x p`` triangle and the right-hand sides). Band rows below ``K - p`` are
final (no later row touches their pivot column); the state keeps the ``p`` active band rows,
the wrap triangle, the residual so far and the active columns' sums. *Backward state* ``K``:
the same for the rows of spans ``>= K``, rotated from the frame's end with the band positions
mirrored (``nb - 1 - pos``); its active rows are again band positions ``K - p .. K - 1``.

A move changes the breakpoints between two unchanged ones; rows of frame spans ``< KL`` keep
their basis values and columns, those of spans ``>= KR`` keep theirs with their band positions
shifted by the change in the number of breakpoints. If ``p <= KL`` and ``KR <= nb`` (the change
lies at least about ``2p`` spans from the cut) the candidate's SSE is exactly

    forward residual at KL + backward residual at KR
    + residual of [forward active rows and triangle; window rows; backward active rows and
      triangle]

the last a small least-squares problem over band positions ``KL - p .. KR' - 1`` and the wrap
columns (the window rows touch no wrap column). Every incumbent carries two frames or more,
cut at evenly spaced breakpoints (:func:`metaknot.bspline.moves._cuts`), so every change of one
or two neighbouring knots lies inside one of them.

*Certificate.* The closed fit (:func:`._kernel.solve_closed_into`) reports a system singular
when a pivot of its factor is at most ``PIVOT_RATIO`` times the largest. Every pivot lies
between ``sigma_min(B)`` and the largest column norm of ``B`` (at most the square root of
the largest column sum: entries in [0, 1]); ``[left final rows; right final rows; merged
factor]`` is a block upper triangular square factor of the candidate's normal matrix, so
bounding the inverse of each block bounds
``1 / sigma_min``. A candidate is reported feasible on the delta path only when that bound
keeps every pivot above ``PIVOT_RATIO / CERTIFY`` times the largest; the full fit decides the
rest.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ._kernel import (
    COINCIDENT_KNOTS,
    FEASIBLE,
    KNOT_OUT_OF_RANGE,
    PIVOT_RATIO,
    SINGULAR,
    TOO_MANY_CONTROL_POINTS,
    basis_at,
    deviation_from_basis,
    extended_knots,
    fit_closed,
)
from ._moves import CERTIFY, PATH_CHECKS, PATH_DELTA, PATH_FULL, check_offsets


@njit(cache=True, inline='always')
def givens_norm(a: float, b: float) -> float:
    """``sqrt(a^2 + b^2)``: by the square root where the squares neither underflow nor
    overflow, else by ``hypot`` (a tiny entry squared to zero would make a rotation singular
    or inexact)."""
    big = max(abs(a), abs(b))
    if 1e-150 < big < 1e150:
        return math.sqrt(a * a + b * b)
    return math.hypot(a, b)


@njit(cache=True)
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


# _candidate's verdict on knots given out of order (and sorted there) but feasible so far.
UNSORTED = -1


@njit(cache=True)
def rotate_in(band, wrap, rhs, nbx, p, d, row, row_rhs, first):
    """Rotate a row into the factor (``band[nbx, p + 1]``, ``wrap[nbx + p, p]`` whose last
    ``p`` rows are the wrap triangle, ``rhs[nbx + p, d]``) by standard Givens rotations
    (``rotate_row``): ``row[:nbx]`` are its band entries (nonzero from ``first`` for at most
    ``p + 1`` columns), ``row[nbx:]`` its wrap entries. Leaves ``row`` zero; returns the squared
    residual the rotations leave of the row."""
    rotate_row(band, wrap, rhs, nbx, p, d, row, row_rhs, first, True, None)
    residual = 0.0
    for c in range(d):
        residual += row_rhs[c] * row_rhs[c]
    return residual


@njit(cache=True)
def inverse_bound(band, wrap, nbx, p, with_wrap, v, w):
    """Upper bound of ``||R^-1||_2`` for the triangular factor's first ``nbx`` band columns
    and (``with_wrap``) its wrap block: ``|R^-1| <= M^-1`` elementwise for the comparison
    matrix ``M``, whose inverse's infinity and 1-norms are the largest entries of ``M^-1 e`` and
    ``M^-T e``, and ``||A||_2 <= sqrt(||A||_1 ||A||_inf)``. ``inf`` for a zero pivot; ``v`` and
    ``w`` are workspaces of ``nbx + p`` entries."""
    size = nbx + (p if with_wrap else 0)
    v_max = 0.0
    for i in range(size - 1, -1, -1):  # v = M^-1 e
        acc = 1.0
        if i >= nbx:
            r = i - nbx
            for k in range(r + 1, p):
                acc += abs(wrap[i, k]) * v[nbx + k]
            pivot = abs(wrap[i, r])
        else:
            for k in range(1, p + 1):
                if i + k < nbx:
                    acc += abs(band[i, k]) * v[i + k]
            if with_wrap:
                for k in range(p):
                    acc += abs(wrap[i, k]) * v[nbx + k]
            pivot = abs(band[i, 0])
        if pivot == 0.0:
            return np.inf
        v[i] = acc / pivot
        v_max = max(v_max, v[i])
    w_max = 0.0
    for j in range(size):  # w = M^-T e
        acc = 1.0
        if j < nbx:
            for k in range(1, p + 1):
                if j - k >= 0:
                    acc += abs(band[j - k, k]) * w[j - k]
            pivot = abs(band[j, 0])
        else:
            r = j - nbx
            for i in range(nbx):
                acc += abs(wrap[i, r]) * w[i]
            for k in range(r):
                acc += abs(wrap[nbx + k, r]) * w[nbx + k]
            pivot = abs(wrap[j, r])
        w[j] = acc / pivot
        w_max = max(w_max, w[j])
    return math.sqrt(v_max * w_max)


@njit(cache=True)
def _scatter(h, k, m, p, nb, mirror, row):
    """Put a row's basis values ``h`` (frame span ``k``) into the dense row ``row`` (band
    positions, mirrored if ``mirror``, then the wrap columns); return its first band entry."""
    first = nb
    for i in range(p + 1):
        fc = k + i
        if fc >= m:
            fc -= m
        if fc < p:
            row[nb + fc] += h[i]
        else:
            pos = fc - p
            if mirror:
                pos = nb - 1 - pos
            row[pos] += h[i]
            first = min(first, pos)
    return first


@njit(cache=True)
def _save(band, wrap, rhs, nb, p, d, rows_from, sse, colsum, S_band, S_wrap, S_rhs, S_col,
          S_sse, K):
    """Save state ``K``: band rows ``rows_from .. rows_from + p - 1`` (zero rows outside the
    band), the wrap triangle, the residual and the rows' column sums."""
    for a in range(p):
        pos = rows_from + a
        inside = 0 <= pos < nb
        for k in range(p + 1):
            S_band[K, a, k] = band[pos, k] if inside else 0.0
        for k in range(p):
            S_wrap[K, a, k] = wrap[pos, k] if inside else 0.0
            S_wrap[K, p + a, k] = wrap[nb + a, k]
        for c in range(d):
            S_rhs[K, a, c] = rhs[pos, c] if inside else 0.0
            S_rhs[K, p + a, c] = rhs[nb + a, c]
        S_col[K, a] = colsum[pos] if inside else 0.0
    S_sse[K] = sse


@njit(cache=True)
def sweep(q, basis, p, m, s, mirror, row_start, band, wrap, rhs, S_band, S_wrap, S_rhs, S_col,
          S_sse):
    """One sweep of a frame cut at ``s``: forward (frame spans ``0 .. m - 1``, state ``K``
    saved before span ``K``) or mirrored (spans ``m - 1 .. 0``, state ``K`` saved after span
    ``K``, its active rows the mirrored positions ``nb - K .. nb - K + p - 1``). Leaves the
    final factor in ``band``, ``wrap`` and ``rhs`` (zeroed first)."""
    d = q.shape[1]
    nb = m - p
    band[:] = 0.0
    wrap[:] = 0.0
    rhs[:] = 0.0
    row = np.zeros(nb + p)
    row_rhs = np.empty(d)
    colsum = np.zeros(max(nb, 1))  # by (mirrored) band position
    sse = 0.0
    for step in range(m + 1):
        K = step if not mirror else m - step
        if mirror:
            _save(band, wrap, rhs, nb, p, d, nb - K, sse, colsum, S_band, S_wrap, S_rhs, S_col,
                  S_sse, K)
        else:
            _save(band, wrap, rhs, nb, p, d, K - p, sse, colsum, S_band, S_wrap, S_rhs, S_col,
                  S_sse, K)
        if step == m:
            break
        k = K if not mirror else K - 1
        j = s + k
        if j >= m:
            j -= m
        r0, r1 = row_start[j], row_start[j + 1]
        for i in range(r1 - r0):
            r = r0 + i if not mirror else r1 - 1 - i
            first = _scatter(basis[r], k, m, p, nb, mirror, row)
            for pos in range(first, min(first + p + 1, nb)):
                colsum[pos] += row[pos]
            for c in range(d):
                row_rhs[c] = q[r, c]
            sse += rotate_in(band, wrap, rhs, nb, p, d, row, row_rhs, first)


@njit(cache=True)
def bind(u, q, t, p, cuts):
    """Everything delta evaluation caches for the incumbent with extended knot vector ``t`` (a
    feasible fit): spans and basis values of the rows, ``row_start`` (first row of each
    natural span), the column sums, and per frame (cut at breakpoint ``cuts[f]``) the forward
    and mirrored states and final factors and the bounds of their band blocks' inverses."""
    n, d = q.shape
    m = t.size - 2 * p - 1
    nb = m - p
    spans = np.empty(n, dtype=np.int64)
    basis = np.empty((n, p + 1))
    row_start = np.empty(m + 1, dtype=np.int64)
    column_sums = np.zeros(m)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    j = 0
    row_start[0] = 0
    for r in range(n):
        x = u[r]
        while j < m - 1 and x >= t[p + j + 1]:
            j += 1
            row_start[j] = r
        spans[r] = j
        basis_at(t, p + j, x, p, basis[r], left, right)
        for i in range(p + 1):
            column_sums[(j + i) % m] += basis[r, i]
    while j < m - 1:  # spans without rows (not in a feasible fit, but kept consistent)
        j += 1
        row_start[j] = n
    row_start[m] = n
    frames = cuts.size
    S_band = np.zeros((frames, 2, m + 1, p, p + 1))
    S_wrap = np.zeros((frames, 2, m + 1, 2 * p, p))
    S_rhs = np.zeros((frames, 2, m + 1, 2 * p, d))
    S_col = np.zeros((frames, 2, m + 1, p))
    S_sse = np.zeros((frames, 2, m + 1))
    final_band = np.zeros((frames, 2, max(nb, 1), p + 1))
    final_wrap = np.zeros((frames, 2, nb + p, p))
    final_rhs = np.zeros((frames, 2, nb + p, d))
    inverse = np.zeros((frames, 2))
    v = np.empty(nb + p)
    w = np.empty(nb + p)
    for f in range(frames):
        for side in range(2):
            sweep(q, basis, p, m, cuts[f], side == 1, row_start, final_band[f, side],
                  final_wrap[f, side], final_rhs[f, side], S_band[f, side], S_wrap[f, side],
                  S_rhs[f, side], S_col[f, side], S_sse[f, side])
            inverse[f, side] = inverse_bound(final_band[f, side], final_wrap[f, side], nb, p,
                                             False, v, w)
    return (spans, basis, row_start, column_sums, S_band, S_wrap, S_rhs, S_col, S_sse,
            final_band, final_wrap, final_rhs, inverse)


@njit(cache=True)
def _candidate(interior, start, stop, inserted, breaks):
    """Fill ``breaks`` with 0 and the incumbent's interior knots whose ``start:stop`` are
    replaced by ``inserted``; return the reason the batch evaluator would give for malformed
    knots (out of range before coincident), only the inserted knots being checked. Knots out
    of order are sorted, as the batch evaluator sorts them (``UNSORTED``: no longer a local
    change, the full fit decides)."""
    k = interior.size
    breaks[0] = 0.0
    for i in range(start):
        breaks[1 + i] = interior[i]
    for i in range(inserted.size):
        breaks[1 + start + i] = inserted[i]
    tail = 1 + start + inserted.size
    for i in range(stop, k):
        breaks[tail + i - stop] = interior[i]
    for i in range(inserted.size):
        x = inserted[i]
        if not (x > 0.0 and x < 1.0):  # also catches NaN
            return KNOT_OUT_OF_RANGE
    for i in range(max(start + 1, 2), min(tail + 1, breaks.size)):
        if breaks[i] < breaks[i - 1]:  # out of order: the batch evaluator sorts the knots
            breaks[1:] = np.sort(breaks[1:])
            for j in range(2, breaks.size):
                if breaks[j] <= breaks[j - 1]:
                    return COINCIDENT_KNOTS
            return UNSORTED
        if breaks[i] == breaks[i - 1]:
            return COINCIDENT_KNOTS
    return FEASIBLE


@njit(cache=True)
def _changed_block(interior, knots, lo, hi):
    """The incumbent's interior knots ``start:stop`` that candidate ``knots[lo:hi]`` replaces
    (by its knots ``lo + start : hi - (k - stop)``): the common head and tail removed."""
    k = interior.size
    k2 = hi - lo
    e = 0
    while e < k and e < k2 and interior[e] == knots[lo + e]:
        e += 1
    f = 0
    while f < k - e and f < k2 - e and interior[k - 1 - f] == knots[hi - 1 - f]:
        f += 1
    return e, k - f, lo + e, hi - f


@njit(cache=True)
def evaluate_moves(u, q, p, interior, spans, basis, row_start, cuts, S_band,
                   S_wrap, S_rhs, S_col, S_sse, final_band, final_wrap, final_rhs, inverse,
                   gram_norm, base_sse, base_max_dev, knots, offsets, starts, stops,
                   max_window_rows, want_max_dev, sse_out, max_dev_out, n_ctrl_out, reason_out,
                   path_out):
    """Score candidates (interior knots ``knots[offsets[b]:offsets[b + 1]]``, or with
    ``starts`` not empty the incumbent's interior knots ``starts[b]:stops[b]`` replaced by
    them) by merging a frame's cached states; the full fit decides where no frame holds the
    change, the change spans more than ``max_window_rows`` rows, or the certificate fails.
    Outputs per candidate: SSE, maximum deviation (when ``want_max_dev``), control points,
    reason code and the path that decided it."""
    n, d = q.shape
    m = interior.size + 1
    nb = m - p
    n_cand = offsets.size - 1
    check_offsets(offsets, knots.size)
    m_max = n + 1
    # a candidate's breakpoints are gathered before its count is checked against the data:
    # room for the largest (the incumbent's and all its inserted knots at most)
    widest = 0
    for b in range(n_cand):
        widest = max(widest, offsets[b + 1] - offsets[b])
    breaks = np.empty(max(m_max, m + widest))
    t2 = np.empty(m_max + 2 * p + 1)
    coef = np.zeros((m_max, d))
    rows_max = m_max + p
    mb = np.zeros((rows_max, p + 1))  # the merged factor
    mw = np.zeros((rows_max + p, p))
    mr = np.zeros((rows_max + p, d))
    mcol = np.zeros(rows_max)
    row = np.zeros(rows_max + p)
    row_rhs = np.empty(d)
    v = np.empty(rows_max + p)
    w = np.empty(rows_max + p)
    x_band = np.zeros((m_max, d))
    x_wrap = np.zeros((p, d))
    full_basis = np.empty((n if want_max_dev else 0, p + 1))  # the full fit's rows
    full_spans = np.empty(n if want_max_dev else 0, dtype=np.int64)
    window_basis = np.empty((n, p + 1))
    window_span = np.empty(n, dtype=np.int64)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    replacing = starts.size > 0
    for b in range(n_cand):
        lo, hi = offsets[b], offsets[b + 1]
        if replacing:
            start, stop, ins_lo, ins_hi = starts[b], stops[b], lo, hi
        else:
            start, stop, ins_lo, ins_hi = _changed_block(interior, knots, lo, hi)
        inserted = knots[ins_lo:ins_hi]
        m2 = m - (stop - start) + inserted.size
        delta = m2 - m
        n_ctrl_out[b] = m2
        sse_out[b] = np.inf
        if want_max_dev:
            max_dev_out[b] = np.inf
        path_out[b] = PATH_CHECKS
        br = breaks[:m2]
        code = _candidate(interior, start, stop, inserted, br)
        local = code == FEASIBLE
        if code == UNSORTED:
            code = FEASIBLE
        if code == FEASIBLE and m2 < p:
            code = SINGULAR
        if code == FEASIBLE and m2 > n:
            code = TOO_MANY_CONTROL_POINTS
        if code != FEASIBLE:
            reason_out[b] = code
            continue
        tb = t2[: m2 + 2 * p + 1]
        extended_knots(br, p, tb)
        if local and start == stop and inserted.size == 0:  # the incumbent itself
            reason_out[b] = FEASIBLE
            sse_out[b] = base_sse
            path_out[b] = PATH_DELTA
            if want_max_dev:
                max_dev_out[b] = base_max_dev
            continue
        # the frame that holds the change: breakpoints start (natural) and stop + 1 are the
        # last and first unchanged ones; rows of frame spans < KL and >= KR keep their basis
        frame = -1
        KL = KR = s2 = 0
        for f in range(cuts.size if local else 0):
            s = cuts[f]
            A = start - s
            if A < 0:
                A += m
            B = A + (stop - start) + 1
            KL = A - p + 1
            KR = B + p - 1
            if KL >= p and KR <= nb:
                frame = f
                s2 = s if s <= start else s + delta
                break
        rows_lo = row_start[(cuts[frame] + KL) % m] if frame >= 0 else 0
        rows_hi = row_start[(cuts[frame] + KR) % m] if frame >= 0 else 0
        window_rows = rows_hi - rows_lo
        if window_rows < 0:
            window_rows += n
        if frame >= 0 and window_rows <= max_window_rows:
            KR2 = KR + delta
            nbm = KR2 - KL + p  # merged band columns: positions KL - p .. KR2 - 1
            base = KL - p
            for i in range(nbm):
                for k in range(p + 1):
                    mb[i, k] = 0.0
                for k in range(p):
                    mw[i, k] = 0.0
                for c in range(d):
                    mr[i, c] = 0.0
                mcol[i] = 0.0
            for a in range(p):  # the forward state: active rows and the wrap triangle
                for k in range(p + 1):
                    mb[a, k] = S_band[frame, 0, KL, a, k]
                for k in range(p):
                    mw[a, k] = S_wrap[frame, 0, KL, a, k]
                    mw[nbm + a, k] = S_wrap[frame, 0, KL, p + a, k]
                for c in range(d):
                    mr[a, c] = S_rhs[frame, 0, KL, a, c]
                    mr[nbm + a, c] = S_rhs[frame, 0, KL, p + a, c]
                mcol[a] += S_col[frame, 0, KL, a]
                # the backward state's rows are the mirrored positions nb - KR + a, forward
                # position KR - 1 - a
                mcol[nbm - 1 - a] += S_col[frame, 1, KR, a]
            # the window: the rows between the unchanged spans, under the candidate's knots
            res = 0.0
            j2 = s2 + KL
            if j2 >= m2:
                j2 -= m2
            r = rows_lo
            for _ in range(window_rows):
                if r == n:
                    r = 0
                    j2 = 0
                x = u[r]
                while j2 < m2 - 1 and x >= tb[p + j2 + 1]:
                    j2 += 1
                hj = window_basis[r]
                basis_at(tb, p + j2, x, p, hj, left, right)
                k = j2 - s2
                if k < 0:
                    k += m2
                window_span[r] = k
                first = k - KL  # merged index of band position k - p
                for i in range(p + 1):
                    row[first + i] += hj[i]
                    mcol[first + i] += hj[i]
                for c in range(d):
                    row_rhs[c] = q[r, c]
                res += rotate_in(mb, mw, mr, nbm, p, d, row, row_rhs, first)
                r += 1
            # the backward state's active rows (mirrored entries: position P - k for entry k)
            for a in range(p):
                P = KR2 - 1 - a - base  # merged index
                first = nbm
                for k in range(p + 1):
                    value = S_band[frame, 1, KR, a, k]
                    if value != 0.0:
                        row[P - k] = value
                        first = min(first, P - k)
                for k in range(p):
                    row[nbm + k] = S_wrap[frame, 1, KR, a, k]
                for c in range(d):
                    row_rhs[c] = S_rhs[frame, 1, KR, a, c]
                res += rotate_in(mb, mw, mr, nbm, p, d, row, row_rhs, first)
            for a in range(p):  # and its wrap triangle
                for k in range(p):
                    row[nbm + k] = S_wrap[frame, 1, KR, p + a, k]
                for c in range(d):
                    row_rhs[c] = S_rhs[frame, 1, KR, p + a, c]
                res += rotate_in(mb, mw, mr, nbm, p, d, row, row_rhs, nbm)
            # the certificate (see the module notes)
            inv_m = inverse_bound(mb, mw, nbm, p, True, v, w)
            inv_s = inv_m + (inverse[frame, 0] + inverse[frame, 1]) * (1.0 + gram_norm * inv_m)
            largest_sum = gram_norm * gram_norm
            for i in range(nbm):
                largest_sum = max(largest_sum, mcol[i])
            if inv_s * math.sqrt(largest_sum) * PIVOT_RATIO <= CERTIFY:
                reason_out[b] = FEASIBLE
                sse_out[b] = S_sse[frame, 0, KL] + S_sse[frame, 1, KR] + res
                path_out[b] = PATH_DELTA
                if want_max_dev:
                    max_dev_out[b] = _merged_max_deviation(
                        u, q, p, spans, basis, window_basis, window_span, row_start, cuts[frame],
                        m, m2, KL, KR, rows_lo, window_rows, mb, mw, mr, nbm,
                        final_band[frame], final_wrap[frame], final_rhs[frame], x_band, x_wrap,
                        coef)
                continue
        # the full fit decides
        path_out[b] = PATH_FULL
        c2 = coef[:m2]
        code, value = fit_closed(u, q, tb, p, c2, full_basis, full_spans)
        reason_out[b] = code
        sse_out[b] = value
        if want_max_dev and code == FEASIBLE:
            max_dev_out[b] = deviation_from_basis(q, p, m2, c2, full_basis, full_spans)


@njit(cache=True)
def _merged_max_deviation(u, q, p, spans, basis, window_basis, window_span, row_start, s, m,
                          m2, KL, KR, rows_lo, window_rows, mb, mw, mr, nbm, fb, fw, fr,
                          x_band, x_wrap, coef):
    """Largest distance of a data point to a merged candidate: its coefficients solved from
    the merged block outwards (the wrap triangle, the merged band rows, the incumbent's final
    forward rows leftwards and its final mirrored rows rightwards), then every row's value from
    its basis (the window's for rows in the window, the incumbent's elsewhere)."""
    n, d = q.shape
    nb = m - p
    delta = m2 - m
    base = KL - p
    for k in range(p - 1, -1, -1):  # the wrap triangle
        r = nbm + k
        for c in range(d):
            acc = mr[r, c]
            for kk in range(k + 1, p):
                acc -= mw[r, kk] * x_wrap[kk, c]
            x_wrap[k, c] = acc / mw[r, k]
    for i in range(nbm - 1, -1, -1):  # the merged band rows
        for c in range(d):
            acc = mr[i, c]
            for k in range(1, p + 1):
                if i + k < nbm:
                    acc -= mb[i, k] * x_band[base + i + k, c]
            for k in range(p):
                acc -= mw[i, k] * x_wrap[k, c]
            x_band[base + i, c] = acc / mb[i, 0]
    for pos in range(base - 1, -1, -1):  # the final forward rows
        for c in range(d):
            acc = fr[0, pos, c]
            for k in range(1, p + 1):
                acc -= fb[0, pos, k] * x_band[pos + k, c]
            for k in range(p):
                acc -= fw[0, pos, k] * x_wrap[k, c]
            x_band[pos, c] = acc / fb[0, pos, 0]
    for P in range(KR, nb):  # the final mirrored rows (mirrored position nb - 1 - P)
        mp = nb - 1 - P
        for c in range(d):
            acc = fr[1, mp, c]
            for k in range(1, p + 1):
                if mp + k < nb:
                    acc -= fb[1, mp, k] * x_band[P - k + delta, c]
            for k in range(p):
                acc -= fw[1, mp, k] * x_wrap[k, c]
            x_band[P + delta, c] = acc / fb[1, mp, 0]
    for fc in range(m2):  # frame columns: the wrap columns, then the band
        for c in range(d):
            coef[fc, c] = x_wrap[fc, c] if fc < p else x_band[fc - p, c]
    worst = 0.0
    for r in range(n):
        in_window = r - rows_lo
        if in_window < 0:
            in_window += n
        if in_window < window_rows:
            k = window_span[r]
            h = window_basis[r]
        else:
            k = spans[r] - s
            if k < 0:
                k += m
            if k >= KR:
                k += delta
            h = basis[r]
        dist2 = 0.0
        for c in range(d):
            acc = 0.0
            for i in range(p + 1):
                fc = k + i
                if fc >= m2:
                    fc -= m2
                acc += h[i] * coef[fc, c]
            diff = q[r, c] - acc
            dist2 += diff * diff
        worst = max(worst, dist2)
    return math.sqrt(worst)
