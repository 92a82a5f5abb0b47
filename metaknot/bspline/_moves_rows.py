"""Row loops of delta evaluation, by degree and dimension. GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._moves_codegen``; see that module and ``_moves``.
"""

from numba import njit

# An empty column of the factor: its reciprocal weight (see _moves_codegen).
EMPTY = 1e150
# Fused multiply-adds only: no reassociation, no approximate reciprocals.
FASTMATH = {"contract"}


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p1_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 1,
    dimension 1), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        tmp = iv[span]
        h0 = r1 * tmp
        s1_0 = l1 * tmp
        h1 = s1_0
        first = span - 1 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + 0) * 3
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        zk = st[o + 2]
        st[o + 2] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        big_w = bw
        o = (first + 1) * 3
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 2]
        st[o + 2] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p1_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 1, dimension
    1), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    steps = bounds.size - 1
    sse = 0.0
    span = 1
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 3 : (b + 1) * 3]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            tmp = iv[span]
            h0 = r1 * tmp
            s1_0 = l1 * tmp
            h1 = s1_0
            first = span - 1
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            y0 = q[j, 0]
            big_w = 1.0
            o = (first + 0) * 3
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            zk = st[o + 2]
            st[o + 2] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            big_w = bw
            o = (first + 1) * 3
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 2]
            st[o + 2] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            big_w = bw
            sse += (y0 * y0) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p1_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 1,
    dimension 2), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        tmp = iv[span]
        h0 = r1 * tmp
        s1_0 = l1 * tmp
        h1 = s1_0
        first = span - 1 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + 0) * 4
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        zk = st[o + 2]
        st[o + 2] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        big_w = bw
        o = (first + 1) * 4
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 2]
        st[o + 2] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p1_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 1, dimension
    2), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    steps = bounds.size - 1
    sse = 0.0
    span = 1
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 4 : (b + 1) * 4]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            tmp = iv[span]
            h0 = r1 * tmp
            s1_0 = l1 * tmp
            h1 = s1_0
            first = span - 1
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            y0 = q[j, 0]
            y1 = q[j, 1]
            big_w = 1.0
            o = (first + 0) * 4
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            zk = st[o + 2]
            st[o + 2] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            big_w = bw
            o = (first + 1) * 4
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 2]
            st[o + 2] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p1_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 1,
    dimension 3), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        tmp = iv[span]
        h0 = r1 * tmp
        s1_0 = l1 * tmp
        h1 = s1_0
        first = span - 1 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
        y0 = q[j, 0]
        y1 = q[j, 1]
        y2 = q[j, 2]
        big_w = 1.0
        o = (first + 0) * 5
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        zk = st[o + 2]
        st[o + 2] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y2
        y2 = y2 - h0 * zk
        big_w = bw
        o = (first + 1) * 5
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 2]
        st[o + 2] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y2
        y2 = y2 - h1 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p1_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 1, dimension
    3), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    steps = bounds.size - 1
    sse = 0.0
    span = 1
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 5 : (b + 1) * 5]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            tmp = iv[span]
            h0 = r1 * tmp
            s1_0 = l1 * tmp
            h1 = s1_0
            first = span - 1
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            y0 = q[j, 0]
            y1 = q[j, 1]
            y2 = q[j, 2]
            big_w = 1.0
            o = (first + 0) * 5
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            zk = st[o + 2]
            st[o + 2] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y2
            y2 = y2 - h0 * zk
            big_w = bw
            o = (first + 1) * 5
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 2]
            st[o + 2] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y2
            y2 = y2 - h1 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p2_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 2,
    dimension 1), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        h0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        h1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        h2 = s2_1
        first = span - 2 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + 0) * 4
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        big_w = bw
        o = (first + 1) * 4
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        big_w = bw
        o = (first + 2) * 4
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p2_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 2, dimension
    1), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 2
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 4 : (b + 2) * 4]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            h0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            h1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            h2 = s2_1
            first = span - 2
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            y0 = q[j, 0]
            big_w = 1.0
            o = (first + 0) * 4
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            big_w = bw
            o = (first + 1) * 4
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            big_w = bw
            o = (first + 2) * 4
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            big_w = bw
            sse += (y0 * y0) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p2_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 2,
    dimension 2), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        h0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        h1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        h2 = s2_1
        first = span - 2 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + 0) * 5
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        big_w = bw
        o = (first + 1) * 5
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        big_w = bw
        o = (first + 2) * 5
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p2_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 2, dimension
    2), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 2
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 5 : (b + 2) * 5]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            h0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            h1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            h2 = s2_1
            first = span - 2
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            y0 = q[j, 0]
            y1 = q[j, 1]
            big_w = 1.0
            o = (first + 0) * 5
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            big_w = bw
            o = (first + 1) * 5
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            big_w = bw
            o = (first + 2) * 5
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p2_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 2,
    dimension 3), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        h0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        h1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        h2 = s2_1
        first = span - 2 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
        y0 = q[j, 0]
        y1 = q[j, 1]
        y2 = q[j, 2]
        big_w = 1.0
        o = (first + 0) * 6
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y2
        y2 = y2 - h0 * zk
        big_w = bw
        o = (first + 1) * 6
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y2
        y2 = y2 - h1 * zk
        big_w = bw
        o = (first + 2) * 6
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 3]
        st[o + 3] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y2
        y2 = y2 - h2 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p2_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 2, dimension
    3), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 2
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 6 : (b + 2) * 6]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            h0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            h1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            h2 = s2_1
            first = span - 2
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            y0 = q[j, 0]
            y1 = q[j, 1]
            y2 = q[j, 2]
            big_w = 1.0
            o = (first + 0) * 6
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y2
            y2 = y2 - h0 * zk
            big_w = bw
            o = (first + 1) * 6
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y2
            y2 = y2 - h1 * zk
            big_w = bw
            o = (first + 2) * 6
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 3]
            st[o + 3] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y2
            y2 = y2 - h2 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p3_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 3,
    dimension 1), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        h0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        h1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        h2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        h3 = s3_2
        first = span - 3 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + 0) * 5
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        big_w = bw
        o = (first + 1) * 5
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        big_w = bw
        o = (first + 2) * 5
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        big_w = bw
        o = (first + 3) * 5
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p3_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 3, dimension
    1), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 3
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 5 : (b + 3) * 5]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            h0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            h1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            h2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            h3 = s3_2
            first = span - 3
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            y0 = q[j, 0]
            big_w = 1.0
            o = (first + 0) * 5
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            big_w = bw
            o = (first + 1) * 5
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            big_w = bw
            o = (first + 2) * 5
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            big_w = bw
            o = (first + 3) * 5
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            big_w = bw
            sse += (y0 * y0) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p3_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 3,
    dimension 2), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        h0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        h1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        h2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        h3 = s3_2
        first = span - 3 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
        y0 = q[j, 0]
        y1 = q[j, 1]
        big_w = 1.0
        o = (first + 0) * 6
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        big_w = bw
        o = (first + 1) * 6
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        big_w = bw
        o = (first + 2) * 6
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        big_w = bw
        o = (first + 3) * 6
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h3 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p3_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 3, dimension
    2), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 3
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 6 : (b + 3) * 6]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            h0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            h1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            h2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            h3 = s3_2
            first = span - 3
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            y0 = q[j, 0]
            y1 = q[j, 1]
            big_w = 1.0
            o = (first + 0) * 6
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            big_w = bw
            o = (first + 1) * 6
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            big_w = bw
            o = (first + 2) * 6
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            big_w = bw
            o = (first + 3) * 6
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h3 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p3_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 3,
    dimension 3), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        h0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        h1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        h2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        h3 = s3_2
        first = span - 3 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
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
        o = (first + 0) * 7
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y2
        y2 = y2 - h0 * zk
        big_w = bw
        o = (first + 1) * 7
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y2
        y2 = y2 - h1 * zk
        big_w = bw
        o = (first + 2) * 7
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y2
        y2 = y2 - h2 * zk
        big_w = bw
        o = (first + 3) * 7
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 4]
        st[o + 4] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y1
        y1 = y1 - h3 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y2
        y2 = y2 - h3 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p3_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 3, dimension
    3), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 3
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 7 : (b + 3) * 7]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            h0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            h1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            h2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            h3 = s3_2
            first = span - 3
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            y0 = q[j, 0]
            y1 = q[j, 1]
            y2 = q[j, 2]
            big_w = 1.0
            o = (first + 0) * 7
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y2
            y2 = y2 - h0 * zk
            big_w = bw
            o = (first + 1) * 7
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y2
            y2 = y2 - h1 * zk
            big_w = bw
            o = (first + 2) * 7
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y2
            y2 = y2 - h2 * zk
            big_w = bw
            o = (first + 3) * 7
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 4]
            st[o + 4] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y1
            y1 = y1 - h3 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y2
            y2 = y2 - h3 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p4_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 4,
    dimension 1), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        l4 = x - t[span - 3]
        r4 = t[span + 4] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - 3 + o4]
        h0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - 2 + o4]
        h1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - 1 + o4]
        h2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        h3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        h4 = s4_3
        first = span - 4 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        colsum[first + 4] += h4
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
        y0 = q[j, 0]
        big_w = 1.0
        o = (first + 0) * 6
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h4
        h4 = h4 - h0 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        big_w = bw
        o = (first + 1) * 6
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h4
        h4 = h4 - h1 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        big_w = bw
        o = (first + 2) * 6
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h4
        h4 = h4 - h2 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        big_w = bw
        o = (first + 3) * 6
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h4
        h4 = h4 - h3 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        big_w = bw
        o = (first + 4) * 6
        di = st[o]
        hd = h4 * di
        bw = big_w + h4 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h4 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p4_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 4, dimension
    1), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 4
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 6 : (b + 4) * 6]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        Scol[s, 3] = colsum[b + 3]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            l4 = x - t[span - 3]
            r4 = t[span + 4] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            b3_0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            b3_1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            b3_2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            b3_3 = s3_2
            tmp = b3_0 * iv[span - 3 + o4]
            h0 = r1 * tmp
            s4_0 = l4 * tmp
            tmp = b3_1 * iv[span - 2 + o4]
            h1 = s4_0 + r2 * tmp
            s4_1 = l3 * tmp
            tmp = b3_2 * iv[span - 1 + o4]
            h2 = s4_1 + r3 * tmp
            s4_2 = l2 * tmp
            tmp = b3_3 * iv[span + o4]
            h3 = s4_2 + r4 * tmp
            s4_3 = l1 * tmp
            h4 = s4_3
            first = span - 4
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            colsum[first + 4] += h4
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
            y0 = q[j, 0]
            big_w = 1.0
            o = (first + 0) * 6
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h4
            h4 = h4 - h0 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            big_w = bw
            o = (first + 1) * 6
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h4
            h4 = h4 - h1 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            big_w = bw
            o = (first + 2) * 6
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h4
            h4 = h4 - h2 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            big_w = bw
            o = (first + 3) * 6
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h4
            h4 = h4 - h3 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            big_w = bw
            o = (first + 4) * 6
            di = st[o]
            hd = h4 * di
            bw = big_w + h4 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h4 * zk
            big_w = bw
            sse += (y0 * y0) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p4_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 4,
    dimension 2), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        l4 = x - t[span - 3]
        r4 = t[span + 4] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - 3 + o4]
        h0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - 2 + o4]
        h1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - 1 + o4]
        h2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        h3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        h4 = s4_3
        first = span - 4 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        colsum[first + 4] += h4
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
        o = (first + 0) * 7
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h4
        h4 = h4 - h0 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        big_w = bw
        o = (first + 1) * 7
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h4
        h4 = h4 - h1 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        big_w = bw
        o = (first + 2) * 7
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h4
        h4 = h4 - h2 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        big_w = bw
        o = (first + 3) * 7
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h4
        h4 = h4 - h3 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h3 * zk
        big_w = bw
        o = (first + 4) * 7
        di = st[o]
        hd = h4 * di
        bw = big_w + h4 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h4 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h4 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p4_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 4, dimension
    2), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 4
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 7 : (b + 4) * 7]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        Scol[s, 3] = colsum[b + 3]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            l4 = x - t[span - 3]
            r4 = t[span + 4] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            b3_0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            b3_1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            b3_2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            b3_3 = s3_2
            tmp = b3_0 * iv[span - 3 + o4]
            h0 = r1 * tmp
            s4_0 = l4 * tmp
            tmp = b3_1 * iv[span - 2 + o4]
            h1 = s4_0 + r2 * tmp
            s4_1 = l3 * tmp
            tmp = b3_2 * iv[span - 1 + o4]
            h2 = s4_1 + r3 * tmp
            s4_2 = l2 * tmp
            tmp = b3_3 * iv[span + o4]
            h3 = s4_2 + r4 * tmp
            s4_3 = l1 * tmp
            h4 = s4_3
            first = span - 4
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            colsum[first + 4] += h4
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
            y0 = q[j, 0]
            y1 = q[j, 1]
            big_w = 1.0
            o = (first + 0) * 7
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h4
            h4 = h4 - h0 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            big_w = bw
            o = (first + 1) * 7
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h4
            h4 = h4 - h1 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            big_w = bw
            o = (first + 2) * 7
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h4
            h4 = h4 - h2 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            big_w = bw
            o = (first + 3) * 7
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h4
            h4 = h4 - h3 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h3 * zk
            big_w = bw
            o = (first + 4) * 7
            di = st[o]
            hd = h4 * di
            bw = big_w + h4 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h4 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h4 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p4_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 4,
    dimension 3), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        l4 = x - t[span - 3]
        r4 = t[span + 4] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - 3 + o4]
        h0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - 2 + o4]
        h1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - 1 + o4]
        h2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        h3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        h4 = s4_3
        first = span - 4 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        colsum[first + 4] += h4
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
        o = (first + 0) * 8
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h4
        h4 = h4 - h0 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y2
        y2 = y2 - h0 * zk
        big_w = bw
        o = (first + 1) * 8
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h4
        h4 = h4 - h1 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y2
        y2 = y2 - h1 * zk
        big_w = bw
        o = (first + 2) * 8
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h4
        h4 = h4 - h2 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y2
        y2 = y2 - h2 * zk
        big_w = bw
        o = (first + 3) * 8
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h4
        h4 = h4 - h3 * ra
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h3 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y2
        y2 = y2 - h3 * zk
        big_w = bw
        o = (first + 4) * 8
        di = st[o]
        hd = h4 * di
        bw = big_w + h4 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 5]
        st[o + 5] = cb * zk + sb * y0
        y0 = y0 - h4 * zk
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y1
        y1 = y1 - h4 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y2
        y2 = y2 - h4 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p4_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 4, dimension
    3), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 4
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 8 : (b + 4) * 8]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        Scol[s, 3] = colsum[b + 3]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            l4 = x - t[span - 3]
            r4 = t[span + 4] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            b3_0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            b3_1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            b3_2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            b3_3 = s3_2
            tmp = b3_0 * iv[span - 3 + o4]
            h0 = r1 * tmp
            s4_0 = l4 * tmp
            tmp = b3_1 * iv[span - 2 + o4]
            h1 = s4_0 + r2 * tmp
            s4_1 = l3 * tmp
            tmp = b3_2 * iv[span - 1 + o4]
            h2 = s4_1 + r3 * tmp
            s4_2 = l2 * tmp
            tmp = b3_3 * iv[span + o4]
            h3 = s4_2 + r4 * tmp
            s4_3 = l1 * tmp
            h4 = s4_3
            first = span - 4
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            colsum[first + 4] += h4
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
            o = (first + 0) * 8
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h4
            h4 = h4 - h0 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y2
            y2 = y2 - h0 * zk
            big_w = bw
            o = (first + 1) * 8
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h4
            h4 = h4 - h1 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y2
            y2 = y2 - h1 * zk
            big_w = bw
            o = (first + 2) * 8
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h4
            h4 = h4 - h2 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y2
            y2 = y2 - h2 * zk
            big_w = bw
            o = (first + 3) * 8
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h4
            h4 = h4 - h3 * ra
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h3 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y2
            y2 = y2 - h3 * zk
            big_w = bw
            o = (first + 4) * 8
            di = st[o]
            hd = h4 * di
            bw = big_w + h4 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 5]
            st[o + 5] = cb * zk + sb * y0
            y0 = y0 - h4 * zk
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y1
            y1 = y1 - h4 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y2
            y2 = y2 - h4 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p5_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 5,
    dimension 1), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    o5 = 4 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        l4 = x - t[span - 3]
        r4 = t[span + 4] - x
        l5 = x - t[span - 4]
        r5 = t[span + 5] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - 3 + o4]
        b4_0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - 2 + o4]
        b4_1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - 1 + o4]
        b4_2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        b4_3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        b4_4 = s4_3
        tmp = b4_0 * iv[span - 4 + o5]
        h0 = r1 * tmp
        s5_0 = l5 * tmp
        tmp = b4_1 * iv[span - 3 + o5]
        h1 = s5_0 + r2 * tmp
        s5_1 = l4 * tmp
        tmp = b4_2 * iv[span - 2 + o5]
        h2 = s5_1 + r3 * tmp
        s5_2 = l3 * tmp
        tmp = b4_3 * iv[span - 1 + o5]
        h3 = s5_2 + r4 * tmp
        s5_3 = l2 * tmp
        tmp = b4_4 * iv[span + o5]
        h4 = s5_3 + r5 * tmp
        s5_4 = l1 * tmp
        h5 = s5_4
        first = span - 5 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        colsum[first + 4] += h4
        colsum[first + 5] += h5
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
        o = (first + 0) * 7
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h4
        h4 = h4 - h0 * ra
        ra = st[o + 5]
        st[o + 5] = cb * ra + sb * h5
        h5 = h5 - h0 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        big_w = bw
        o = (first + 1) * 7
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h4
        h4 = h4 - h1 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h5
        h5 = h5 - h1 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        big_w = bw
        o = (first + 2) * 7
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h4
        h4 = h4 - h2 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h5
        h5 = h5 - h2 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        big_w = bw
        o = (first + 3) * 7
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h4
        h4 = h4 - h3 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h5
        h5 = h5 - h3 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        big_w = bw
        o = (first + 4) * 7
        di = st[o]
        hd = h4 * di
        bw = big_w + h4 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h5
        h5 = h5 - h4 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h4 * zk
        big_w = bw
        o = (first + 5) * 7
        di = st[o]
        hd = h5 * di
        bw = big_w + h5 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h5 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p5_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 5, dimension
    1), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    o5 = 4 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 5
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 7 : (b + 5) * 7]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        Scol[s, 3] = colsum[b + 3]
        Scol[s, 4] = colsum[b + 4]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            l4 = x - t[span - 3]
            r4 = t[span + 4] - x
            l5 = x - t[span - 4]
            r5 = t[span + 5] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            b3_0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            b3_1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            b3_2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            b3_3 = s3_2
            tmp = b3_0 * iv[span - 3 + o4]
            b4_0 = r1 * tmp
            s4_0 = l4 * tmp
            tmp = b3_1 * iv[span - 2 + o4]
            b4_1 = s4_0 + r2 * tmp
            s4_1 = l3 * tmp
            tmp = b3_2 * iv[span - 1 + o4]
            b4_2 = s4_1 + r3 * tmp
            s4_2 = l2 * tmp
            tmp = b3_3 * iv[span + o4]
            b4_3 = s4_2 + r4 * tmp
            s4_3 = l1 * tmp
            b4_4 = s4_3
            tmp = b4_0 * iv[span - 4 + o5]
            h0 = r1 * tmp
            s5_0 = l5 * tmp
            tmp = b4_1 * iv[span - 3 + o5]
            h1 = s5_0 + r2 * tmp
            s5_1 = l4 * tmp
            tmp = b4_2 * iv[span - 2 + o5]
            h2 = s5_1 + r3 * tmp
            s5_2 = l3 * tmp
            tmp = b4_3 * iv[span - 1 + o5]
            h3 = s5_2 + r4 * tmp
            s5_3 = l2 * tmp
            tmp = b4_4 * iv[span + o5]
            h4 = s5_3 + r5 * tmp
            s5_4 = l1 * tmp
            h5 = s5_4
            first = span - 5
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            colsum[first + 4] += h4
            colsum[first + 5] += h5
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
            basis[j, 5] = h5
            y0 = q[j, 0]
            big_w = 1.0
            o = (first + 0) * 7
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h4
            h4 = h4 - h0 * ra
            ra = st[o + 5]
            st[o + 5] = cb * ra + sb * h5
            h5 = h5 - h0 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            big_w = bw
            o = (first + 1) * 7
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h4
            h4 = h4 - h1 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h5
            h5 = h5 - h1 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            big_w = bw
            o = (first + 2) * 7
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h4
            h4 = h4 - h2 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h5
            h5 = h5 - h2 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            big_w = bw
            o = (first + 3) * 7
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h4
            h4 = h4 - h3 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h5
            h5 = h5 - h3 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            big_w = bw
            o = (first + 4) * 7
            di = st[o]
            hd = h4 * di
            bw = big_w + h4 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h5
            h5 = h5 - h4 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h4 * zk
            big_w = bw
            o = (first + 5) * 7
            di = st[o]
            hd = h5 * di
            bw = big_w + h5 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h5 * zk
            big_w = bw
            sse += (y0 * y0) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p5_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 5,
    dimension 2), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    o5 = 4 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        l4 = x - t[span - 3]
        r4 = t[span + 4] - x
        l5 = x - t[span - 4]
        r5 = t[span + 5] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - 3 + o4]
        b4_0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - 2 + o4]
        b4_1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - 1 + o4]
        b4_2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        b4_3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        b4_4 = s4_3
        tmp = b4_0 * iv[span - 4 + o5]
        h0 = r1 * tmp
        s5_0 = l5 * tmp
        tmp = b4_1 * iv[span - 3 + o5]
        h1 = s5_0 + r2 * tmp
        s5_1 = l4 * tmp
        tmp = b4_2 * iv[span - 2 + o5]
        h2 = s5_1 + r3 * tmp
        s5_2 = l3 * tmp
        tmp = b4_3 * iv[span - 1 + o5]
        h3 = s5_2 + r4 * tmp
        s5_3 = l2 * tmp
        tmp = b4_4 * iv[span + o5]
        h4 = s5_3 + r5 * tmp
        s5_4 = l1 * tmp
        h5 = s5_4
        first = span - 5 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        colsum[first + 4] += h4
        colsum[first + 5] += h5
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
        o = (first + 0) * 8
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h4
        h4 = h4 - h0 * ra
        ra = st[o + 5]
        st[o + 5] = cb * ra + sb * h5
        h5 = h5 - h0 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        big_w = bw
        o = (first + 1) * 8
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h4
        h4 = h4 - h1 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h5
        h5 = h5 - h1 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        big_w = bw
        o = (first + 2) * 8
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h4
        h4 = h4 - h2 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h5
        h5 = h5 - h2 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        big_w = bw
        o = (first + 3) * 8
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h4
        h4 = h4 - h3 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h5
        h5 = h5 - h3 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h3 * zk
        big_w = bw
        o = (first + 4) * 8
        di = st[o]
        hd = h4 * di
        bw = big_w + h4 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h5
        h5 = h5 - h4 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h4 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h4 * zk
        big_w = bw
        o = (first + 5) * 8
        di = st[o]
        hd = h5 * di
        bw = big_w + h5 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h5 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h5 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p5_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 5, dimension
    2), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    o5 = 4 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 5
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 8 : (b + 5) * 8]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        Scol[s, 3] = colsum[b + 3]
        Scol[s, 4] = colsum[b + 4]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            l4 = x - t[span - 3]
            r4 = t[span + 4] - x
            l5 = x - t[span - 4]
            r5 = t[span + 5] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            b3_0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            b3_1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            b3_2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            b3_3 = s3_2
            tmp = b3_0 * iv[span - 3 + o4]
            b4_0 = r1 * tmp
            s4_0 = l4 * tmp
            tmp = b3_1 * iv[span - 2 + o4]
            b4_1 = s4_0 + r2 * tmp
            s4_1 = l3 * tmp
            tmp = b3_2 * iv[span - 1 + o4]
            b4_2 = s4_1 + r3 * tmp
            s4_2 = l2 * tmp
            tmp = b3_3 * iv[span + o4]
            b4_3 = s4_2 + r4 * tmp
            s4_3 = l1 * tmp
            b4_4 = s4_3
            tmp = b4_0 * iv[span - 4 + o5]
            h0 = r1 * tmp
            s5_0 = l5 * tmp
            tmp = b4_1 * iv[span - 3 + o5]
            h1 = s5_0 + r2 * tmp
            s5_1 = l4 * tmp
            tmp = b4_2 * iv[span - 2 + o5]
            h2 = s5_1 + r3 * tmp
            s5_2 = l3 * tmp
            tmp = b4_3 * iv[span - 1 + o5]
            h3 = s5_2 + r4 * tmp
            s5_3 = l2 * tmp
            tmp = b4_4 * iv[span + o5]
            h4 = s5_3 + r5 * tmp
            s5_4 = l1 * tmp
            h5 = s5_4
            first = span - 5
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            colsum[first + 4] += h4
            colsum[first + 5] += h5
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
            o = (first + 0) * 8
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h4
            h4 = h4 - h0 * ra
            ra = st[o + 5]
            st[o + 5] = cb * ra + sb * h5
            h5 = h5 - h0 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            big_w = bw
            o = (first + 1) * 8
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h4
            h4 = h4 - h1 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h5
            h5 = h5 - h1 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            big_w = bw
            o = (first + 2) * 8
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h4
            h4 = h4 - h2 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h5
            h5 = h5 - h2 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            big_w = bw
            o = (first + 3) * 8
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h4
            h4 = h4 - h3 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h5
            h5 = h5 - h3 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h3 * zk
            big_w = bw
            o = (first + 4) * 8
            di = st[o]
            hd = h4 * di
            bw = big_w + h4 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h5
            h5 = h5 - h4 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h4 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h4 * zk
            big_w = bw
            o = (first + 5) * 8
            di = st[o]
            hd = h5 * di
            bw = big_w + h5 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h5 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h5 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1) / big_w


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def window_p5_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,
                    spans):
    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree 5,
    dimension 3), whose first column is the knot vector's column ``col0``; the
    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to
    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and
    the spans by row. Returns the rows' residual SSE and the last span.
    """
    store = basis.shape[0] > 0
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    o5 = 4 * t.size
    sse = 0.0
    for j in range(j0, j1):
        x = u[j]
        while t[span + 1] <= x and span < last:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        l4 = x - t[span - 3]
        r4 = t[span + 4] - x
        l5 = x - t[span - 4]
        r5 = t[span + 5] - x
        tmp = iv[span]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[span - 1 + o2]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span + o2]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[span - 2 + o3]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[span - 1 + o3]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span + o3]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[span - 3 + o4]
        b4_0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[span - 2 + o4]
        b4_1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[span - 1 + o4]
        b4_2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span + o4]
        b4_3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        b4_4 = s4_3
        tmp = b4_0 * iv[span - 4 + o5]
        h0 = r1 * tmp
        s5_0 = l5 * tmp
        tmp = b4_1 * iv[span - 3 + o5]
        h1 = s5_0 + r2 * tmp
        s5_1 = l4 * tmp
        tmp = b4_2 * iv[span - 2 + o5]
        h2 = s5_1 + r3 * tmp
        s5_2 = l3 * tmp
        tmp = b4_3 * iv[span - 1 + o5]
        h3 = s5_2 + r4 * tmp
        s5_3 = l2 * tmp
        tmp = b4_4 * iv[span + o5]
        h4 = s5_3 + r5 * tmp
        s5_4 = l1 * tmp
        h5 = s5_4
        first = span - 5 - col0
        colsum[first + 0] += h0
        colsum[first + 1] += h1
        colsum[first + 2] += h2
        colsum[first + 3] += h3
        colsum[first + 4] += h4
        colsum[first + 5] += h5
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
        o = (first + 0) * 9
        di = st[o]
        hd = h0 * di
        bw = big_w + h0 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h1
        h1 = h1 - h0 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h2
        h2 = h2 - h0 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h3
        h3 = h3 - h0 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h4
        h4 = h4 - h0 * ra
        ra = st[o + 5]
        st[o + 5] = cb * ra + sb * h5
        h5 = h5 - h0 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h0 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h0 * zk
        zk = st[o + 8]
        st[o + 8] = cb * zk + sb * y2
        y2 = y2 - h0 * zk
        big_w = bw
        o = (first + 1) * 9
        di = st[o]
        hd = h1 * di
        bw = big_w + h1 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h2
        h2 = h2 - h1 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h3
        h3 = h3 - h1 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h4
        h4 = h4 - h1 * ra
        ra = st[o + 4]
        st[o + 4] = cb * ra + sb * h5
        h5 = h5 - h1 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h1 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h1 * zk
        zk = st[o + 8]
        st[o + 8] = cb * zk + sb * y2
        y2 = y2 - h1 * zk
        big_w = bw
        o = (first + 2) * 9
        di = st[o]
        hd = h2 * di
        bw = big_w + h2 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h3
        h3 = h3 - h2 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h4
        h4 = h4 - h2 * ra
        ra = st[o + 3]
        st[o + 3] = cb * ra + sb * h5
        h5 = h5 - h2 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h2 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h2 * zk
        zk = st[o + 8]
        st[o + 8] = cb * zk + sb * y2
        y2 = y2 - h2 * zk
        big_w = bw
        o = (first + 3) * 9
        di = st[o]
        hd = h3 * di
        bw = big_w + h3 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h4
        h4 = h4 - h3 * ra
        ra = st[o + 2]
        st[o + 2] = cb * ra + sb * h5
        h5 = h5 - h3 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h3 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h3 * zk
        zk = st[o + 8]
        st[o + 8] = cb * zk + sb * y2
        y2 = y2 - h3 * zk
        big_w = bw
        o = (first + 4) * 9
        di = st[o]
        hd = h4 * di
        bw = big_w + h4 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        ra = st[o + 1]
        st[o + 1] = cb * ra + sb * h5
        h5 = h5 - h4 * ra
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h4 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h4 * zk
        zk = st[o + 8]
        st[o + 8] = cb * zk + sb * y2
        y2 = y2 - h4 * zk
        big_w = bw
        o = (first + 5) * 9
        di = st[o]
        hd = h5 * di
        bw = big_w + h5 * hd
        inv = 1.0 / bw
        cb = big_w * inv
        sb = hd * inv
        st[o] = di * cb
        zk = st[o + 6]
        st[o + 6] = cb * zk + sb * y0
        y0 = y0 - h5 * zk
        zk = st[o + 7]
        st[o + 7] = cb * zk + sb * y1
        y1 = y1 - h5 * zk
        zk = st[o + 8]
        st[o + 8] = cb * zk + sb * y2
        y2 = y2 - h5 * zk
        big_w = bw
        # what the rotations leave of the row, with its weight, is its residual
        sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w
    return sse, span


@njit(cache=True, fastmath=FASTMATH, error_model='numpy')
def sweep_p5_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,
                   basis, spans):
    """Rotate every data row into the flat factor ``st`` (degree 5, dimension
    3), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save
    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual
    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved
    after the last step. Stores every row's basis values and span.
    """
    o2 = 1 * t.size
    o3 = 2 * t.size
    o4 = 3 * t.size
    o5 = 4 * t.size
    steps = bounds.size - 1
    sse = 0.0
    span = 5
    for s in range(steps + 1):
        b = blocks[s]
        S[s, :] = st[b * 9 : (b + 5) * 9]
        Ssse[s] = sse
        Scol[s, 0] = colsum[b + 0]
        Scol[s, 1] = colsum[b + 1]
        Scol[s, 2] = colsum[b + 2]
        Scol[s, 3] = colsum[b + 3]
        Scol[s, 4] = colsum[b + 4]
        if s == steps:
            break
        for j in range(bounds[s], bounds[s + 1]):
            x = u[j]
            while t[span + 1] <= x and span < last:
                span += 1
            l1 = x - t[span]
            r1 = t[span + 1] - x
            l2 = x - t[span - 1]
            r2 = t[span + 2] - x
            l3 = x - t[span - 2]
            r3 = t[span + 3] - x
            l4 = x - t[span - 3]
            r4 = t[span + 4] - x
            l5 = x - t[span - 4]
            r5 = t[span + 5] - x
            tmp = iv[span]
            b1_0 = r1 * tmp
            s1_0 = l1 * tmp
            b1_1 = s1_0
            tmp = b1_0 * iv[span - 1 + o2]
            b2_0 = r1 * tmp
            s2_0 = l2 * tmp
            tmp = b1_1 * iv[span + o2]
            b2_1 = s2_0 + r2 * tmp
            s2_1 = l1 * tmp
            b2_2 = s2_1
            tmp = b2_0 * iv[span - 2 + o3]
            b3_0 = r1 * tmp
            s3_0 = l3 * tmp
            tmp = b2_1 * iv[span - 1 + o3]
            b3_1 = s3_0 + r2 * tmp
            s3_1 = l2 * tmp
            tmp = b2_2 * iv[span + o3]
            b3_2 = s3_1 + r3 * tmp
            s3_2 = l1 * tmp
            b3_3 = s3_2
            tmp = b3_0 * iv[span - 3 + o4]
            b4_0 = r1 * tmp
            s4_0 = l4 * tmp
            tmp = b3_1 * iv[span - 2 + o4]
            b4_1 = s4_0 + r2 * tmp
            s4_1 = l3 * tmp
            tmp = b3_2 * iv[span - 1 + o4]
            b4_2 = s4_1 + r3 * tmp
            s4_2 = l2 * tmp
            tmp = b3_3 * iv[span + o4]
            b4_3 = s4_2 + r4 * tmp
            s4_3 = l1 * tmp
            b4_4 = s4_3
            tmp = b4_0 * iv[span - 4 + o5]
            h0 = r1 * tmp
            s5_0 = l5 * tmp
            tmp = b4_1 * iv[span - 3 + o5]
            h1 = s5_0 + r2 * tmp
            s5_1 = l4 * tmp
            tmp = b4_2 * iv[span - 2 + o5]
            h2 = s5_1 + r3 * tmp
            s5_2 = l3 * tmp
            tmp = b4_3 * iv[span - 1 + o5]
            h3 = s5_2 + r4 * tmp
            s5_3 = l2 * tmp
            tmp = b4_4 * iv[span + o5]
            h4 = s5_3 + r5 * tmp
            s5_4 = l1 * tmp
            h5 = s5_4
            first = span - 5
            colsum[first + 0] += h0
            colsum[first + 1] += h1
            colsum[first + 2] += h2
            colsum[first + 3] += h3
            colsum[first + 4] += h4
            colsum[first + 5] += h5
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
            o = (first + 0) * 9
            di = st[o]
            hd = h0 * di
            bw = big_w + h0 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h1
            h1 = h1 - h0 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h2
            h2 = h2 - h0 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h3
            h3 = h3 - h0 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h4
            h4 = h4 - h0 * ra
            ra = st[o + 5]
            st[o + 5] = cb * ra + sb * h5
            h5 = h5 - h0 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h0 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h0 * zk
            zk = st[o + 8]
            st[o + 8] = cb * zk + sb * y2
            y2 = y2 - h0 * zk
            big_w = bw
            o = (first + 1) * 9
            di = st[o]
            hd = h1 * di
            bw = big_w + h1 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h2
            h2 = h2 - h1 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h3
            h3 = h3 - h1 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h4
            h4 = h4 - h1 * ra
            ra = st[o + 4]
            st[o + 4] = cb * ra + sb * h5
            h5 = h5 - h1 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h1 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h1 * zk
            zk = st[o + 8]
            st[o + 8] = cb * zk + sb * y2
            y2 = y2 - h1 * zk
            big_w = bw
            o = (first + 2) * 9
            di = st[o]
            hd = h2 * di
            bw = big_w + h2 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h3
            h3 = h3 - h2 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h4
            h4 = h4 - h2 * ra
            ra = st[o + 3]
            st[o + 3] = cb * ra + sb * h5
            h5 = h5 - h2 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h2 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h2 * zk
            zk = st[o + 8]
            st[o + 8] = cb * zk + sb * y2
            y2 = y2 - h2 * zk
            big_w = bw
            o = (first + 3) * 9
            di = st[o]
            hd = h3 * di
            bw = big_w + h3 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h4
            h4 = h4 - h3 * ra
            ra = st[o + 2]
            st[o + 2] = cb * ra + sb * h5
            h5 = h5 - h3 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h3 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h3 * zk
            zk = st[o + 8]
            st[o + 8] = cb * zk + sb * y2
            y2 = y2 - h3 * zk
            big_w = bw
            o = (first + 4) * 9
            di = st[o]
            hd = h4 * di
            bw = big_w + h4 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            ra = st[o + 1]
            st[o + 1] = cb * ra + sb * h5
            h5 = h5 - h4 * ra
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h4 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h4 * zk
            zk = st[o + 8]
            st[o + 8] = cb * zk + sb * y2
            y2 = y2 - h4 * zk
            big_w = bw
            o = (first + 5) * 9
            di = st[o]
            hd = h5 * di
            bw = big_w + h5 * hd
            inv = 1.0 / bw
            cb = big_w * inv
            sb = hd * inv
            st[o] = di * cb
            zk = st[o + 6]
            st[o + 6] = cb * zk + sb * y0
            y0 = y0 - h5 * zk
            zk = st[o + 7]
            st[o + 7] = cb * zk + sb * y1
            y1 = y1 - h5 * zk
            zk = st[o + 8]
            st[o + 8] = cb * zk + sb * y2
            y2 = y2 - h5 * zk
            big_w = bw
            sse += (y0 * y0 + y1 * y1 + y2 * y2) / big_w


@njit(cache=True)
def window(p, d, u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans):
    """``window_p{p}_d{d}`` for the given degree and dimension."""
    if p == 1 and d == 1:
        return window_p1_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 1 and d == 2:
        return window_p1_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 1 and d == 3:
        return window_p1_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 2 and d == 1:
        return window_p2_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 2 and d == 2:
        return window_p2_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 2 and d == 3:
        return window_p2_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 3 and d == 1:
        return window_p3_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 3 and d == 2:
        return window_p3_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 3 and d == 3:
        return window_p3_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 4 and d == 1:
        return window_p4_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 4 and d == 2:
        return window_p4_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 4 and d == 3:
        return window_p4_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 5 and d == 1:
        return window_p5_d1(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 5 and d == 2:
        return window_p5_d2(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    elif p == 5 and d == 3:
        return window_p5_d3(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans)
    raise ValueError('degree 1-5 and dimension 1-3 only')


@njit(cache=True)
def sweep(p, d, u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis, spans):
    """``sweep_p{p}_d{d}`` for the given degree and dimension."""
    if p == 1 and d == 1:
        return sweep_p1_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 1 and d == 2:
        return sweep_p1_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 1 and d == 3:
        return sweep_p1_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 2 and d == 1:
        return sweep_p2_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 2 and d == 2:
        return sweep_p2_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 2 and d == 3:
        return sweep_p2_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 3 and d == 1:
        return sweep_p3_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 3 and d == 2:
        return sweep_p3_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 3 and d == 3:
        return sweep_p3_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 4 and d == 1:
        return sweep_p4_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 4 and d == 2:
        return sweep_p4_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 4 and d == 3:
        return sweep_p4_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 5 and d == 1:
        return sweep_p5_d1(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 5 and d == 2:
        return sweep_p5_d2(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    elif p == 5 and d == 3:
        return sweep_p5_d3(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, basis,
                                spans)
    raise ValueError('degree 1-5 and dimension 1-3 only')
