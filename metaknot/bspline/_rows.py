"""Row loops of the least-squares kernel, by degree, dimension. GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._codegen``; see that module and ``_kernel._solve_into``.
"""

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

# An empty column of the factor: its reciprocal weight (see _codegen).
EMPTY = 1e150


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (IEEE fused multiply-add), the same bits wherever inlined."""
    def codegen(context, builder, signature, args):
        return builder.fma(*args)
    return types.float64(types.float64, types.float64, types.float64), codegen


U0 = np.uint64(0)
U1 = np.uint64(1)
U2 = np.uint64(2)
U3 = np.uint64(3)
U4 = np.uint64(4)
U5 = np.uint64(5)
U6 = np.uint64(6)
U7 = np.uint64(7)
U8 = np.uint64(8)
U9 = np.uint64(9)


@njit(cache=True, error_model='numpy')
def rows_p1_d1(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 1, dimension 1).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    span = U1
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        tmp = iv[span]
        h0 = r1 * tmp
        s1_0 = l1 * tmp
        h1 = s1_0
        first = span - U1
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + U0) * U3
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        zk = st[o + U2]
        st[o + U2] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        big_w = bw
        o = (first + U1) * U3
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U2]
        st[o + U2] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p1_d2(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 1, dimension 2).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    span = U1
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        tmp = iv[span]
        h0 = r1 * tmp
        s1_0 = l1 * tmp
        h1 = s1_0
        first = span - U1
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + U0) * U4
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        zk = st[o + U2]
        st[o + U2] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        big_w = bw
        o = (first + U1) * U4
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U2]
        st[o + U2] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p1_d3(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 1, dimension 3).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    span = U1
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        tmp = iv[span]
        h0 = r1 * tmp
        s1_0 = l1 * tmp
        h1 = s1_0
        first = span - U1
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
        y0 = q[j, 0]
        y1 = q[j, 1]
        y2 = q[j, 2]
        big_w = 1.0
        o = (first + U0) * U5
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        zk = st[o + U2]
        st[o + U2] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y2)
        y2 = fma(-h0, zk, y2)
        big_w = bw
        o = (first + U1) * U5
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U2]
        st[o + U2] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y2)
        y2 = fma(-h1, zk, y2)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p2_d1(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 2, dimension 1).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    span = U2
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        h0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        h1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        h2 = s2_1
        first = span - U2
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + U0) * U4
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        big_w = bw
        o = (first + U1) * U4
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        big_w = bw
        o = (first + U2) * U4
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p2_d2(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 2, dimension 2).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    span = U2
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        h0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        h1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        h2 = s2_1
        first = span - U2
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + U0) * U5
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        big_w = bw
        o = (first + U1) * U5
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        big_w = bw
        o = (first + U2) * U5
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p2_d3(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 2, dimension 3).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    span = U2
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        h0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        h1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        h2 = s2_1
        first = span - U2
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
        y0 = q[j, 0]
        y1 = q[j, 1]
        y2 = q[j, 2]
        big_w = 1.0
        o = (first + U0) * U6
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y2)
        y2 = fma(-h0, zk, y2)
        big_w = bw
        o = (first + U1) * U6
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y2)
        y2 = fma(-h1, zk, y2)
        big_w = bw
        o = (first + U2) * U6
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U3]
        st[o + U3] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y2)
        y2 = fma(-h2, zk, y2)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p3_d1(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 3, dimension 1).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    span = U3
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        h0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        h1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        h2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        h3 = s3_2
        first = span - U3
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + U0) * U5
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        big_w = bw
        o = (first + U1) * U5
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        big_w = bw
        o = (first + U2) * U5
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        big_w = bw
        o = (first + U3) * U5
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p3_d2(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 3, dimension 2).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    span = U3
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        h0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        h1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        h2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        h3 = s3_2
        first = span - U3
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + U0) * U6
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        big_w = bw
        o = (first + U1) * U6
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        big_w = bw
        o = (first + U2) * U6
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        big_w = bw
        o = (first + U3) * U6
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h3, zk, y1)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p3_d3(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 3, dimension 3).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    span = U3
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        h0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        h1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        h2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        h3 = s3_2
        first = span - U3
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
        y0 = q[j, 0]
        y1 = q[j, 1]
        y2 = q[j, 2]
        big_w = 1.0
        o = (first + U0) * U7
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y2)
        y2 = fma(-h0, zk, y2)
        big_w = bw
        o = (first + U1) * U7
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y2)
        y2 = fma(-h1, zk, y2)
        big_w = bw
        o = (first + U2) * U7
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y2)
        y2 = fma(-h2, zk, y2)
        big_w = bw
        o = (first + U3) * U7
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U4]
        st[o + U4] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y1)
        y1 = fma(-h3, zk, y1)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y2)
        y2 = fma(-h3, zk, y2)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p4_d1(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 4, dimension 1).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    o4 = np.uint64(3 * t.size)
    span = U4
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        l4 = x - t[span - U3]
        r4 = t[span + U4] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        b3_1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - U3 + o4]
        h0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - U2 + o4]
        h1 = fma(r2, tmp, s4_0)
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - U1 + o4]
        h2 = fma(r3, tmp, s4_1)
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        h3 = fma(r4, tmp, s4_2)
        s4_3 = l1 * tmp
        h4 = s4_3
        first = span - U4
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + U0) * U6
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h4)
        h4 = fma(-h0, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        big_w = bw
        o = (first + U1) * U6
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h4)
        h4 = fma(-h1, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        big_w = bw
        o = (first + U2) * U6
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h4)
        h4 = fma(-h2, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        big_w = bw
        o = (first + U3) * U6
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h4)
        h4 = fma(-h3, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        big_w = bw
        o = (first + U4) * U6
        di = st[o]
        hd = h4 * di
        bw = fma(h4, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h4, zk, y0)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p4_d2(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 4, dimension 2).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    o4 = np.uint64(3 * t.size)
    span = U4
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        l4 = x - t[span - U3]
        r4 = t[span + U4] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        b3_1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - U3 + o4]
        h0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - U2 + o4]
        h1 = fma(r2, tmp, s4_0)
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - U1 + o4]
        h2 = fma(r3, tmp, s4_1)
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        h3 = fma(r4, tmp, s4_2)
        s4_3 = l1 * tmp
        h4 = s4_3
        first = span - U4
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + U0) * U7
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h4)
        h4 = fma(-h0, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        big_w = bw
        o = (first + U1) * U7
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h4)
        h4 = fma(-h1, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        big_w = bw
        o = (first + U2) * U7
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h4)
        h4 = fma(-h2, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        big_w = bw
        o = (first + U3) * U7
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h4)
        h4 = fma(-h3, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h3, zk, y1)
        big_w = bw
        o = (first + U4) * U7
        di = st[o]
        hd = h4 * di
        bw = fma(h4, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h4, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h4, zk, y1)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p4_d3(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 4, dimension 3).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    o4 = np.uint64(3 * t.size)
    span = U4
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        l4 = x - t[span - U3]
        r4 = t[span + U4] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        b3_1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - U3 + o4]
        h0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - U2 + o4]
        h1 = fma(r2, tmp, s4_0)
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - U1 + o4]
        h2 = fma(r3, tmp, s4_1)
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        h3 = fma(r4, tmp, s4_2)
        s4_3 = l1 * tmp
        h4 = s4_3
        first = span - U4
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
        y0 = q[j, 0]
        y1 = q[j, 1]
        y2 = q[j, 2]
        big_w = 1.0
        o = (first + U0) * U8
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h4)
        h4 = fma(-h0, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y2)
        y2 = fma(-h0, zk, y2)
        big_w = bw
        o = (first + U1) * U8
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h4)
        h4 = fma(-h1, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y2)
        y2 = fma(-h1, zk, y2)
        big_w = bw
        o = (first + U2) * U8
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h4)
        h4 = fma(-h2, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y2)
        y2 = fma(-h2, zk, y2)
        big_w = bw
        o = (first + U3) * U8
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h4)
        h4 = fma(-h3, ra, h4)
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h3, zk, y1)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y2)
        y2 = fma(-h3, zk, y2)
        big_w = bw
        o = (first + U4) * U8
        di = st[o]
        hd = h4 * di
        bw = fma(h4, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U5]
        st[o + U5] = fma(cb, zk, sb * y0)
        y0 = fma(-h4, zk, y0)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y1)
        y1 = fma(-h4, zk, y1)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y2)
        y2 = fma(-h4, zk, y2)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p5_d1(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 5, dimension 1).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    o4 = np.uint64(3 * t.size)
    o5 = np.uint64(4 * t.size)
    span = U5
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        l4 = x - t[span - U3]
        r4 = t[span + U4] - x
        l5 = x - t[span - U4]
        r5 = t[span + U5] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        b3_1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - U3 + o4]
        b4_0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - U2 + o4]
        b4_1 = fma(r2, tmp, s4_0)
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - U1 + o4]
        b4_2 = fma(r3, tmp, s4_1)
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        b4_3 = fma(r4, tmp, s4_2)
        s4_3 = l1 * tmp
        b4_4 = s4_3
        tmp = b4_0 * iv[span - U4 + o5]
        h0 = r1 * tmp
        s5_0 = l5 * tmp
        tmp = b4_1 * iv[span - U3 + o5]
        h1 = fma(r2, tmp, s5_0)
        s5_1 = l4 * tmp
        tmp = b4_2 * iv[span - U2 + o5]
        h2 = fma(r3, tmp, s5_1)
        s5_2 = l3 * tmp
        tmp = b4_3 * iv[span - U1 + o5]
        h3 = fma(r4, tmp, s5_2)
        s5_3 = l2 * tmp
        tmp = b4_4 * iv[span + o5]
        h4 = fma(r5, tmp, s5_3)
        s5_4 = l1 * tmp
        h5 = s5_4
        first = span - U5
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
            basis[j, 5] = h5
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + U0) * U7
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h4)
        h4 = fma(-h0, ra, h4)
        ra = st[o + U5]
        st[o + U5] = fma(cb, ra, sb * h5)
        h5 = fma(-h0, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        big_w = bw
        o = (first + U1) * U7
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h4)
        h4 = fma(-h1, ra, h4)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h5)
        h5 = fma(-h1, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        big_w = bw
        o = (first + U2) * U7
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h4)
        h4 = fma(-h2, ra, h4)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h5)
        h5 = fma(-h2, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        big_w = bw
        o = (first + U3) * U7
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h4)
        h4 = fma(-h3, ra, h4)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h5)
        h5 = fma(-h3, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        big_w = bw
        o = (first + U4) * U7
        di = st[o]
        hd = h4 * di
        bw = fma(h4, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h5)
        h5 = fma(-h4, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h4, zk, y0)
        big_w = bw
        o = (first + U5) * U7
        di = st[o]
        hd = h5 * di
        bw = fma(h5, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h5, zk, y0)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p5_d2(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 5, dimension 2).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    o4 = np.uint64(3 * t.size)
    o5 = np.uint64(4 * t.size)
    span = U5
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        l4 = x - t[span - U3]
        r4 = t[span + U4] - x
        l5 = x - t[span - U4]
        r5 = t[span + U5] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        b3_1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - U3 + o4]
        b4_0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - U2 + o4]
        b4_1 = fma(r2, tmp, s4_0)
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - U1 + o4]
        b4_2 = fma(r3, tmp, s4_1)
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        b4_3 = fma(r4, tmp, s4_2)
        s4_3 = l1 * tmp
        b4_4 = s4_3
        tmp = b4_0 * iv[span - U4 + o5]
        h0 = r1 * tmp
        s5_0 = l5 * tmp
        tmp = b4_1 * iv[span - U3 + o5]
        h1 = fma(r2, tmp, s5_0)
        s5_1 = l4 * tmp
        tmp = b4_2 * iv[span - U2 + o5]
        h2 = fma(r3, tmp, s5_1)
        s5_2 = l3 * tmp
        tmp = b4_3 * iv[span - U1 + o5]
        h3 = fma(r4, tmp, s5_2)
        s5_3 = l2 * tmp
        tmp = b4_4 * iv[span + o5]
        h4 = fma(r5, tmp, s5_3)
        s5_4 = l1 * tmp
        h5 = s5_4
        first = span - U5
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
            basis[j, 5] = h5
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + U0) * U8
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h4)
        h4 = fma(-h0, ra, h4)
        ra = st[o + U5]
        st[o + U5] = fma(cb, ra, sb * h5)
        h5 = fma(-h0, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        big_w = bw
        o = (first + U1) * U8
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h4)
        h4 = fma(-h1, ra, h4)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h5)
        h5 = fma(-h1, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        big_w = bw
        o = (first + U2) * U8
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h4)
        h4 = fma(-h2, ra, h4)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h5)
        h5 = fma(-h2, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        big_w = bw
        o = (first + U3) * U8
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h4)
        h4 = fma(-h3, ra, h4)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h5)
        h5 = fma(-h3, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h3, zk, y1)
        big_w = bw
        o = (first + U4) * U8
        di = st[o]
        hd = h4 * di
        bw = fma(h4, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h5)
        h5 = fma(-h4, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h4, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h4, zk, y1)
        big_w = bw
        o = (first + U5) * U8
        di = st[o]
        hd = h5 * di
        bw = fma(h5, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h5, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h5, zk, y1)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True, error_model='numpy')
def rows_p5_d3(u, q, t, iv, n, st, basis, spans):
    """Rotate every data row into the factor (degree 5, dimension 3).

    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.
    """
    m = q.shape[0]
    store = basis.shape[0] > 0
    last = np.uint64(n - 1)
    o2 = np.uint64(1 * t.size)
    o3 = np.uint64(2 * t.size)
    o4 = np.uint64(3 * t.size)
    o5 = np.uint64(4 * t.size)
    span = U5
    sse = 0.0
    # greedy matching: data points so far matched to basis functions 0..matched - 1
    matched = U0
    before_last = U0
    unmatched = False
    for j in range(m):
        x = u[j]
        step = (t[span + U1] <= x) & (span < last)
        span = span + U1 if step else span
        while t[span + U1] <= x and span < last:
            span += U1
        l1 = x - t[span]
        r1 = t[span + U1] - x
        l2 = x - t[span - U1]
        r2 = t[span + U2] - x
        l3 = x - t[span - U2]
        r3 = t[span + U3] - x
        l4 = x - t[span - U3]
        r4 = t[span + U4] - x
        l5 = x - t[span - U4]
        r5 = t[span + U5] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - U1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = fma(r2, tmp, s2_0)
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - U2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - U1 + o3]
        b3_1 = fma(r2, tmp, s3_0)
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = fma(r3, tmp, s3_1)
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - U3 + o4]
        b4_0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - U2 + o4]
        b4_1 = fma(r2, tmp, s4_0)
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - U1 + o4]
        b4_2 = fma(r3, tmp, s4_1)
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        b4_3 = fma(r4, tmp, s4_2)
        s4_3 = l1 * tmp
        b4_4 = s4_3
        tmp = b4_0 * iv[span - U4 + o5]
        h0 = r1 * tmp
        s5_0 = l5 * tmp
        tmp = b4_1 * iv[span - U3 + o5]
        h1 = fma(r2, tmp, s5_0)
        s5_1 = l4 * tmp
        tmp = b4_2 * iv[span - U2 + o5]
        h2 = fma(r3, tmp, s5_1)
        s5_2 = l3 * tmp
        tmp = b4_3 * iv[span - U1 + o5]
        h3 = fma(r4, tmp, s5_2)
        s5_3 = l2 * tmp
        tmp = b4_4 * iv[span + o5]
        h4 = fma(r5, tmp, s5_3)
        s5_4 = l1 * tmp
        h5 = s5_4
        first = span - U5
        # x lies inside the support of basis functions first..span, but not of span
        # itself at its left end (x == t[span]); the last point belongs to the last one
        before_last = matched
        unmatched |= matched < first
        hi = span - U1 if l1 == 0.0 else span
        matched = matched + U1 if matched <= hi else matched
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
            basis[j, 5] = h5
        y0 = q[j, 0]
        y1 = q[j, 1]
        y2 = q[j, 2]
        big_w = 1.0
        o = (first + U0) * U9
        di = st[o]
        hd = h0 * di
        bw = fma(h0, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h1)
        h1 = fma(-h0, ra, h1)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h2)
        h2 = fma(-h0, ra, h2)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h3)
        h3 = fma(-h0, ra, h3)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h4)
        h4 = fma(-h0, ra, h4)
        ra = st[o + U5]
        st[o + U5] = fma(cb, ra, sb * h5)
        h5 = fma(-h0, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h0, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h0, zk, y1)
        zk = st[o + U8]
        st[o + U8] = fma(cb, zk, sb * y2)
        y2 = fma(-h0, zk, y2)
        big_w = bw
        o = (first + U1) * U9
        di = st[o]
        hd = h1 * di
        bw = fma(h1, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h2)
        h2 = fma(-h1, ra, h2)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h3)
        h3 = fma(-h1, ra, h3)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h4)
        h4 = fma(-h1, ra, h4)
        ra = st[o + U4]
        st[o + U4] = fma(cb, ra, sb * h5)
        h5 = fma(-h1, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h1, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h1, zk, y1)
        zk = st[o + U8]
        st[o + U8] = fma(cb, zk, sb * y2)
        y2 = fma(-h1, zk, y2)
        big_w = bw
        o = (first + U2) * U9
        di = st[o]
        hd = h2 * di
        bw = fma(h2, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h3)
        h3 = fma(-h2, ra, h3)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h4)
        h4 = fma(-h2, ra, h4)
        ra = st[o + U3]
        st[o + U3] = fma(cb, ra, sb * h5)
        h5 = fma(-h2, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h2, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h2, zk, y1)
        zk = st[o + U8]
        st[o + U8] = fma(cb, zk, sb * y2)
        y2 = fma(-h2, zk, y2)
        big_w = bw
        o = (first + U3) * U9
        di = st[o]
        hd = h3 * di
        bw = fma(h3, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h4)
        h4 = fma(-h3, ra, h4)
        ra = st[o + U2]
        st[o + U2] = fma(cb, ra, sb * h5)
        h5 = fma(-h3, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h3, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h3, zk, y1)
        zk = st[o + U8]
        st[o + U8] = fma(cb, zk, sb * y2)
        y2 = fma(-h3, zk, y2)
        big_w = bw
        o = (first + U4) * U9
        di = st[o]
        hd = h4 * di
        bw = fma(h4, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + U1]
        st[o + U1] = fma(cb, ra, sb * h5)
        h5 = fma(-h4, ra, h5)
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h4, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h4, zk, y1)
        zk = st[o + U8]
        st[o + U8] = fma(cb, zk, sb * y2)
        y2 = fma(-h4, zk, y2)
        big_w = bw
        o = (first + U5) * U9
        di = st[o]
        hd = h5 * di
        bw = fma(h5, hd, big_w)
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + U6]
        st[o + U6] = fma(cb, zk, sb * y0)
        y0 = fma(-h5, zk, y0)
        zk = st[o + U7]
        st[o + U7] = fma(cb, zk, sb * y1)
        y1 = fma(-h5, zk, y1)
        zk = st[o + U8]
        st[o + U8] = fma(cb, zk, sb * y2)
        y2 = fma(-h5, zk, y2)
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    ok = not unmatched and matched == last + U1 and before_last >= last
    return sse, ok


@njit(cache=True)
def back_p1_d1(st, n, coef):
    """Control points from the factor (degree 1, dimension 1)."""
    c1_0 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U3
        r1 = st[o + U1]
        v0 = st[o + U2] - r1 * c1_0
        coef[i, 0] = v0
        c1_0 = v0


@njit(cache=True)
def back_p1_d2(st, n, coef):
    """Control points from the factor (degree 1, dimension 2)."""
    c1_0 = 0.0
    c1_1 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U4
        r1 = st[o + U1]
        v0 = st[o + U2] - r1 * c1_0
        coef[i, 0] = v0
        c1_0 = v0
        v1 = st[o + U3] - r1 * c1_1
        coef[i, 1] = v1
        c1_1 = v1


@njit(cache=True)
def back_p1_d3(st, n, coef):
    """Control points from the factor (degree 1, dimension 3)."""
    c1_0 = 0.0
    c1_1 = 0.0
    c1_2 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U5
        r1 = st[o + U1]
        v0 = st[o + U2] - r1 * c1_0
        coef[i, 0] = v0
        c1_0 = v0
        v1 = st[o + U3] - r1 * c1_1
        coef[i, 1] = v1
        c1_1 = v1
        v2 = st[o + U4] - r1 * c1_2
        coef[i, 2] = v2
        c1_2 = v2


@njit(cache=True)
def back_p2_d1(st, n, coef):
    """Control points from the factor (degree 2, dimension 1)."""
    c1_0 = 0.0
    c2_0 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U4
        r1 = st[o + U1]
        r2 = st[o + U2]
        v0 = st[o + U3] - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c2_0 = c1_0
        c1_0 = v0


@njit(cache=True)
def back_p2_d2(st, n, coef):
    """Control points from the factor (degree 2, dimension 2)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U5
        r1 = st[o + U1]
        r2 = st[o + U2]
        v0 = st[o + U3] - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U4] - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c2_1 = c1_1
        c1_1 = v1


@njit(cache=True)
def back_p2_d3(st, n, coef):
    """Control points from the factor (degree 2, dimension 3)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    c1_2 = 0.0
    c2_2 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U6
        r1 = st[o + U1]
        r2 = st[o + U2]
        v0 = st[o + U3] - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U4] - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c2_1 = c1_1
        c1_1 = v1
        v2 = st[o + U5] - r2 * c2_2 - r1 * c1_2
        coef[i, 2] = v2
        c2_2 = c1_2
        c1_2 = v2


@njit(cache=True)
def back_p3_d1(st, n, coef):
    """Control points from the factor (degree 3, dimension 1)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U5
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        v0 = st[o + U4] - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0


@njit(cache=True)
def back_p3_d2(st, n, coef):
    """Control points from the factor (degree 3, dimension 2)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    c3_1 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U6
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        v0 = st[o + U4] - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U5] - r3 * c3_1 - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c3_1 = c2_1
        c2_1 = c1_1
        c1_1 = v1


@njit(cache=True)
def back_p3_d3(st, n, coef):
    """Control points from the factor (degree 3, dimension 3)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    c3_1 = 0.0
    c1_2 = 0.0
    c2_2 = 0.0
    c3_2 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U7
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        v0 = st[o + U4] - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U5] - r3 * c3_1 - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c3_1 = c2_1
        c2_1 = c1_1
        c1_1 = v1
        v2 = st[o + U6] - r3 * c3_2 - r2 * c2_2 - r1 * c1_2
        coef[i, 2] = v2
        c3_2 = c2_2
        c2_2 = c1_2
        c1_2 = v2


@njit(cache=True)
def back_p4_d1(st, n, coef):
    """Control points from the factor (degree 4, dimension 1)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c4_0 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U6
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        r4 = st[o + U4]
        v0 = st[o + U5] - r4 * c4_0 - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c4_0 = c3_0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0


@njit(cache=True)
def back_p4_d2(st, n, coef):
    """Control points from the factor (degree 4, dimension 2)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c4_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    c3_1 = 0.0
    c4_1 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U7
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        r4 = st[o + U4]
        v0 = st[o + U5] - r4 * c4_0 - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c4_0 = c3_0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U6] - r4 * c4_1 - r3 * c3_1 - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c4_1 = c3_1
        c3_1 = c2_1
        c2_1 = c1_1
        c1_1 = v1


@njit(cache=True)
def back_p4_d3(st, n, coef):
    """Control points from the factor (degree 4, dimension 3)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c4_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    c3_1 = 0.0
    c4_1 = 0.0
    c1_2 = 0.0
    c2_2 = 0.0
    c3_2 = 0.0
    c4_2 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U8
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        r4 = st[o + U4]
        v0 = st[o + U5] - r4 * c4_0 - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c4_0 = c3_0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U6] - r4 * c4_1 - r3 * c3_1 - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c4_1 = c3_1
        c3_1 = c2_1
        c2_1 = c1_1
        c1_1 = v1
        v2 = st[o + U7] - r4 * c4_2 - r3 * c3_2 - r2 * c2_2 - r1 * c1_2
        coef[i, 2] = v2
        c4_2 = c3_2
        c3_2 = c2_2
        c2_2 = c1_2
        c1_2 = v2


@njit(cache=True)
def back_p5_d1(st, n, coef):
    """Control points from the factor (degree 5, dimension 1)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c4_0 = 0.0
    c5_0 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U7
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        r4 = st[o + U4]
        r5 = st[o + U5]
        v0 = st[o + U6] - r5 * c5_0 - r4 * c4_0 - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c5_0 = c4_0
        c4_0 = c3_0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0


@njit(cache=True)
def back_p5_d2(st, n, coef):
    """Control points from the factor (degree 5, dimension 2)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c4_0 = 0.0
    c5_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    c3_1 = 0.0
    c4_1 = 0.0
    c5_1 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U8
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        r4 = st[o + U4]
        r5 = st[o + U5]
        v0 = st[o + U6] - r5 * c5_0 - r4 * c4_0 - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c5_0 = c4_0
        c4_0 = c3_0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U7] - r5 * c5_1 - r4 * c4_1 - r3 * c3_1 - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c5_1 = c4_1
        c4_1 = c3_1
        c3_1 = c2_1
        c2_1 = c1_1
        c1_1 = v1


@njit(cache=True)
def back_p5_d3(st, n, coef):
    """Control points from the factor (degree 5, dimension 3)."""
    c1_0 = 0.0
    c2_0 = 0.0
    c3_0 = 0.0
    c4_0 = 0.0
    c5_0 = 0.0
    c1_1 = 0.0
    c2_1 = 0.0
    c3_1 = 0.0
    c4_1 = 0.0
    c5_1 = 0.0
    c1_2 = 0.0
    c2_2 = 0.0
    c3_2 = 0.0
    c4_2 = 0.0
    c5_2 = 0.0
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * U9
        r1 = st[o + U1]
        r2 = st[o + U2]
        r3 = st[o + U3]
        r4 = st[o + U4]
        r5 = st[o + U5]
        v0 = st[o + U6] - r5 * c5_0 - r4 * c4_0 - r3 * c3_0 - r2 * c2_0 - r1 * c1_0
        coef[i, 0] = v0
        c5_0 = c4_0
        c4_0 = c3_0
        c3_0 = c2_0
        c2_0 = c1_0
        c1_0 = v0
        v1 = st[o + U7] - r5 * c5_1 - r4 * c4_1 - r3 * c3_1 - r2 * c2_1 - r1 * c1_1
        coef[i, 1] = v1
        c5_1 = c4_1
        c4_1 = c3_1
        c3_1 = c2_1
        c2_1 = c1_1
        c1_1 = v1
        v2 = st[o + U8] - r5 * c5_2 - r4 * c4_2 - r3 * c3_2 - r2 * c2_2 - r1 * c1_2
        coef[i, 2] = v2
        c5_2 = c4_2
        c4_2 = c3_2
        c3_2 = c2_2
        c2_2 = c1_2
        c1_2 = v2


@njit(cache=True)
def deviation_p1_d1(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 1, dimension 1)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U1
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p1_d2(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 1, dimension 2)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U1
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p1_d3(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 1, dimension 3)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U1
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 2]
        acc += b1 * coef[first + U1, 2]
        diff = q[j, 2] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p2_d1(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 2, dimension 1)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U2
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p2_d2(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 2, dimension 2)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U2
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p2_d3(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 2, dimension 3)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U2
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 2]
        acc += b1 * coef[first + U1, 2]
        acc += b2 * coef[first + U2, 2]
        diff = q[j, 2] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p3_d1(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 3, dimension 1)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U3
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p3_d2(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 3, dimension 2)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U3
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        acc += b3 * coef[first + U3, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p3_d3(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 3, dimension 3)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U3
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        acc += b3 * coef[first + U3, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 2]
        acc += b1 * coef[first + U1, 2]
        acc += b2 * coef[first + U2, 2]
        acc += b3 * coef[first + U3, 2]
        diff = q[j, 2] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p4_d1(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 4, dimension 1)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U4
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        b4 = basis[j, 4]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        acc += b4 * coef[first + U4, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p4_d2(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 4, dimension 2)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U4
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        b4 = basis[j, 4]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        acc += b4 * coef[first + U4, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        acc += b3 * coef[first + U3, 1]
        acc += b4 * coef[first + U4, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p4_d3(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 4, dimension 3)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U4
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        b4 = basis[j, 4]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        acc += b4 * coef[first + U4, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        acc += b3 * coef[first + U3, 1]
        acc += b4 * coef[first + U4, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 2]
        acc += b1 * coef[first + U1, 2]
        acc += b2 * coef[first + U2, 2]
        acc += b3 * coef[first + U3, 2]
        acc += b4 * coef[first + U4, 2]
        diff = q[j, 2] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p5_d1(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 5, dimension 1)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U5
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        b4 = basis[j, 4]
        b5 = basis[j, 5]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        acc += b4 * coef[first + U4, 0]
        acc += b5 * coef[first + U5, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p5_d2(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 5, dimension 2)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U5
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        b4 = basis[j, 4]
        b5 = basis[j, 5]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        acc += b4 * coef[first + U4, 0]
        acc += b5 * coef[first + U5, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        acc += b3 * coef[first + U3, 1]
        acc += b4 * coef[first + U4, 1]
        acc += b5 * coef[first + U5, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def deviation_p5_d3(q, coef, basis, spans):
    """Largest distance of a data point to its fitted point (degree 5, dimension 3)."""
    worst = 0.0
    for j in range(q.shape[0]):
        first = np.uint64(spans[j]) - U5
        b0 = basis[j, 0]
        b1 = basis[j, 1]
        b2 = basis[j, 2]
        b3 = basis[j, 3]
        b4 = basis[j, 4]
        b5 = basis[j, 5]
        dist2 = 0.0
        acc = 0.0
        acc += b0 * coef[first + U0, 0]
        acc += b1 * coef[first + U1, 0]
        acc += b2 * coef[first + U2, 0]
        acc += b3 * coef[first + U3, 0]
        acc += b4 * coef[first + U4, 0]
        acc += b5 * coef[first + U5, 0]
        diff = q[j, 0] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 1]
        acc += b1 * coef[first + U1, 1]
        acc += b2 * coef[first + U2, 1]
        acc += b3 * coef[first + U3, 1]
        acc += b4 * coef[first + U4, 1]
        acc += b5 * coef[first + U5, 1]
        diff = q[j, 1] - acc
        dist2 += diff * diff
        acc = 0.0
        acc += b0 * coef[first + U0, 2]
        acc += b1 * coef[first + U1, 2]
        acc += b2 * coef[first + U2, 2]
        acc += b3 * coef[first + U3, 2]
        acc += b4 * coef[first + U4, 2]
        acc += b5 * coef[first + U5, 2]
        diff = q[j, 2] - acc
        dist2 += diff * diff
        worst = max(worst, dist2)
    return np.sqrt(worst)


@njit(cache=True)
def bound_p1(st, width, n):
    """Extremes of dinv, largest row sum of |rb| and of M^-1 e (degree 1)."""
    v1 = 0.0
    smallest = np.inf
    largest = 0.0
    v_max = 0.0
    row_max = 0.0
    w = np.uint64(width)
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * w
        di = st[o]
        smallest = min(smallest, di)
        largest = max(largest, di)
        acc = 1.0
        row = 1.0
        r = abs(st[o + U1])
        row += r
        acc += r * v1
        v1 = acc
        v_max = max(v_max, acc)
        row_max = max(row_max, row)
    return smallest, largest, row_max, v_max


@njit(cache=True)
def bound_p2(st, width, n):
    """Extremes of dinv, largest row sum of |rb| and of M^-1 e (degree 2)."""
    v1 = 0.0
    v2 = 0.0
    smallest = np.inf
    largest = 0.0
    v_max = 0.0
    row_max = 0.0
    w = np.uint64(width)
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * w
        di = st[o]
        smallest = min(smallest, di)
        largest = max(largest, di)
        acc = 1.0
        row = 1.0
        r = abs(st[o + U2])
        row += r
        acc += r * v2
        r = abs(st[o + U1])
        row += r
        acc += r * v1
        v2 = v1
        v1 = acc
        v_max = max(v_max, acc)
        row_max = max(row_max, row)
    return smallest, largest, row_max, v_max


@njit(cache=True)
def bound_p3(st, width, n):
    """Extremes of dinv, largest row sum of |rb| and of M^-1 e (degree 3)."""
    v1 = 0.0
    v2 = 0.0
    v3 = 0.0
    smallest = np.inf
    largest = 0.0
    v_max = 0.0
    row_max = 0.0
    w = np.uint64(width)
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * w
        di = st[o]
        smallest = min(smallest, di)
        largest = max(largest, di)
        acc = 1.0
        row = 1.0
        r = abs(st[o + U3])
        row += r
        acc += r * v3
        r = abs(st[o + U2])
        row += r
        acc += r * v2
        r = abs(st[o + U1])
        row += r
        acc += r * v1
        v3 = v2
        v2 = v1
        v1 = acc
        v_max = max(v_max, acc)
        row_max = max(row_max, row)
    return smallest, largest, row_max, v_max


@njit(cache=True)
def bound_p4(st, width, n):
    """Extremes of dinv, largest row sum of |rb| and of M^-1 e (degree 4)."""
    v1 = 0.0
    v2 = 0.0
    v3 = 0.0
    v4 = 0.0
    smallest = np.inf
    largest = 0.0
    v_max = 0.0
    row_max = 0.0
    w = np.uint64(width)
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * w
        di = st[o]
        smallest = min(smallest, di)
        largest = max(largest, di)
        acc = 1.0
        row = 1.0
        r = abs(st[o + U4])
        row += r
        acc += r * v4
        r = abs(st[o + U3])
        row += r
        acc += r * v3
        r = abs(st[o + U2])
        row += r
        acc += r * v2
        r = abs(st[o + U1])
        row += r
        acc += r * v1
        v4 = v3
        v3 = v2
        v2 = v1
        v1 = acc
        v_max = max(v_max, acc)
        row_max = max(row_max, row)
    return smallest, largest, row_max, v_max


@njit(cache=True)
def bound_p5(st, width, n):
    """Extremes of dinv, largest row sum of |rb| and of M^-1 e (degree 5)."""
    v1 = 0.0
    v2 = 0.0
    v3 = 0.0
    v4 = 0.0
    v5 = 0.0
    smallest = np.inf
    largest = 0.0
    v_max = 0.0
    row_max = 0.0
    w = np.uint64(width)
    for i in range(n - 1, -1, -1):
        o = np.uint64(i) * w
        di = st[o]
        smallest = min(smallest, di)
        largest = max(largest, di)
        acc = 1.0
        row = 1.0
        r = abs(st[o + U5])
        row += r
        acc += r * v5
        r = abs(st[o + U4])
        row += r
        acc += r * v4
        r = abs(st[o + U3])
        row += r
        acc += r * v3
        r = abs(st[o + U2])
        row += r
        acc += r * v2
        r = abs(st[o + U1])
        row += r
        acc += r * v1
        v5 = v4
        v4 = v3
        v3 = v2
        v2 = v1
        v1 = acc
        v_max = max(v_max, acc)
        row_max = max(row_max, row)
    return smallest, largest, row_max, v_max


@njit(cache=True)
def rows(u, q, t, iv, p, n, st, basis, spans):
    """Dispatch on the degree and dimension: (SSE, Schoenberg-Whitney holds)."""
    d = q.shape[1]
    if p == 1 and d == 1:
        return rows_p1_d1(u, q, t, iv, n, st, basis, spans)
    elif p == 1 and d == 2:
        return rows_p1_d2(u, q, t, iv, n, st, basis, spans)
    elif p == 1 and d == 3:
        return rows_p1_d3(u, q, t, iv, n, st, basis, spans)
    elif p == 2 and d == 1:
        return rows_p2_d1(u, q, t, iv, n, st, basis, spans)
    elif p == 2 and d == 2:
        return rows_p2_d2(u, q, t, iv, n, st, basis, spans)
    elif p == 2 and d == 3:
        return rows_p2_d3(u, q, t, iv, n, st, basis, spans)
    elif p == 3 and d == 1:
        return rows_p3_d1(u, q, t, iv, n, st, basis, spans)
    elif p == 3 and d == 2:
        return rows_p3_d2(u, q, t, iv, n, st, basis, spans)
    elif p == 3 and d == 3:
        return rows_p3_d3(u, q, t, iv, n, st, basis, spans)
    elif p == 4 and d == 1:
        return rows_p4_d1(u, q, t, iv, n, st, basis, spans)
    elif p == 4 and d == 2:
        return rows_p4_d2(u, q, t, iv, n, st, basis, spans)
    elif p == 4 and d == 3:
        return rows_p4_d3(u, q, t, iv, n, st, basis, spans)
    elif p == 5 and d == 1:
        return rows_p5_d1(u, q, t, iv, n, st, basis, spans)
    elif p == 5 and d == 2:
        return rows_p5_d2(u, q, t, iv, n, st, basis, spans)
    elif p == 5 and d == 3:
        return rows_p5_d3(u, q, t, iv, n, st, basis, spans)
    return np.nan, False


@njit(cache=True)
def back(st, p, n, coef):
    """Dispatch on the degree and dimension."""
    d = coef.shape[1]
    if p == 1 and d == 1:
        return back_p1_d1(st, n, coef)
    elif p == 1 and d == 2:
        return back_p1_d2(st, n, coef)
    elif p == 1 and d == 3:
        return back_p1_d3(st, n, coef)
    elif p == 2 and d == 1:
        return back_p2_d1(st, n, coef)
    elif p == 2 and d == 2:
        return back_p2_d2(st, n, coef)
    elif p == 2 and d == 3:
        return back_p2_d3(st, n, coef)
    elif p == 3 and d == 1:
        return back_p3_d1(st, n, coef)
    elif p == 3 and d == 2:
        return back_p3_d2(st, n, coef)
    elif p == 3 and d == 3:
        return back_p3_d3(st, n, coef)
    elif p == 4 and d == 1:
        return back_p4_d1(st, n, coef)
    elif p == 4 and d == 2:
        return back_p4_d2(st, n, coef)
    elif p == 4 and d == 3:
        return back_p4_d3(st, n, coef)
    elif p == 5 and d == 1:
        return back_p5_d1(st, n, coef)
    elif p == 5 and d == 2:
        return back_p5_d2(st, n, coef)
    elif p == 5 and d == 3:
        return back_p5_d3(st, n, coef)
    return None


@njit(cache=True)
def deviation(q, p, coef, basis, spans):
    """Dispatch on the degree and dimension."""
    d = q.shape[1]
    if p == 1 and d == 1:
        return deviation_p1_d1(q, coef, basis, spans)
    elif p == 1 and d == 2:
        return deviation_p1_d2(q, coef, basis, spans)
    elif p == 1 and d == 3:
        return deviation_p1_d3(q, coef, basis, spans)
    elif p == 2 and d == 1:
        return deviation_p2_d1(q, coef, basis, spans)
    elif p == 2 and d == 2:
        return deviation_p2_d2(q, coef, basis, spans)
    elif p == 2 and d == 3:
        return deviation_p2_d3(q, coef, basis, spans)
    elif p == 3 and d == 1:
        return deviation_p3_d1(q, coef, basis, spans)
    elif p == 3 and d == 2:
        return deviation_p3_d2(q, coef, basis, spans)
    elif p == 3 and d == 3:
        return deviation_p3_d3(q, coef, basis, spans)
    elif p == 4 and d == 1:
        return deviation_p4_d1(q, coef, basis, spans)
    elif p == 4 and d == 2:
        return deviation_p4_d2(q, coef, basis, spans)
    elif p == 4 and d == 3:
        return deviation_p4_d3(q, coef, basis, spans)
    elif p == 5 and d == 1:
        return deviation_p5_d1(q, coef, basis, spans)
    elif p == 5 and d == 2:
        return deviation_p5_d2(q, coef, basis, spans)
    elif p == 5 and d == 3:
        return deviation_p5_d3(q, coef, basis, spans)
    return np.nan


@njit(cache=True)
def bound(st, p, width, n):
    """Dispatch on the degree."""
    if p == 1:
        return bound_p1(st, width, n)
    elif p == 2:
        return bound_p2(st, width, n)
    elif p == 3:
        return bound_p3(st, width, n)
    elif p == 4:
        return bound_p4(st, width, n)
    elif p == 5:
        return bound_p5(st, width, n)
    return np.nan, np.nan, np.nan, np.nan
