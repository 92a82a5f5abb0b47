"""Row loops of the periodic least-squares kernel, by degree and dimension.
GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._periodic_codegen``; see that module and
``_periodic_kernel.fit_one``.
"""

import math

from numba import njit


@njit(cache=True, inline="always")
def givens_norm(a, b):
    """``sqrt(a^2 + b^2)`` (as ``_periodic_kernel.givens_norm``)."""
    big = max(abs(a), abs(b))
    if 1e-150 < big < 1e150:
        return math.sqrt(a * a + b * b)
    return math.hypot(a, b)


@njit(cache=True)
def rows_p3_d2(u, q, t, iv, m, band, tail, has_tail, rhs, basis, spans, keep):
    """Rotate every data row into the factor (degree 3, dimension 2); the SSE."""
    nb = m - 3
    size = t.size
    sse = 0.0
    j = 0
    for i in range(u.size):
        x = u[i]
        while j < m - 1 and x >= t[4 + j]:
            j += 1
        span = 3 + j
        v0 = 1.0
        l1 = x - t[span]
        r1 = t[span + 1] - x
        saved = 0.0
        at = span
        temp = v0 * iv[at]
        v0 = saved + r1 * temp
        saved = l1 * temp
        v1 = saved
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        saved = 0.0
        at = 1 * size + span - 1
        temp = v0 * iv[at]
        v0 = saved + r1 * temp
        saved = l2 * temp
        temp = v1 * iv[at + 1]
        v1 = saved + r2 * temp
        saved = l1 * temp
        v2 = saved
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        saved = 0.0
        at = 2 * size + span - 2
        temp = v0 * iv[at]
        v0 = saved + r1 * temp
        saved = l3 * temp
        temp = v1 * iv[at + 1]
        v1 = saved + r2 * temp
        saved = l2 * temp
        temp = v2 * iv[at + 2]
        v2 = saved + r3 * temp
        saved = l1 * temp
        v3 = saved
        if keep:
            spans[i] = j
            basis[i, 0] = v0
            basis[i, 1] = v1
            basis[i, 2] = v2
            basis[i, 3] = v3
        w0 = w1 = w2 = w3 = t0 = t1 = t2 = 0.0
        row_tail = False
        first = j - 3 if j >= 3 else 0
        ci = j
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v0
            elif s == 1:
                w1 += v0
            elif s == 2:
                w2 += v0
            else:
                w3 += v0
        else:
            row_tail = True
            if ci == 0:
                t0 += v0
            elif ci == 1:
                t1 += v0
            else:
                t2 += v0
        ci = j + 1
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v1
            elif s == 1:
                w1 += v1
            elif s == 2:
                w2 += v1
            else:
                w3 += v1
        else:
            row_tail = True
            if ci == 0:
                t0 += v1
            elif ci == 1:
                t1 += v1
            else:
                t2 += v1
        ci = j + 2
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v2
            elif s == 1:
                w1 += v2
            elif s == 2:
                w2 += v2
            else:
                w3 += v2
        else:
            row_tail = True
            if ci == 0:
                t0 += v2
            elif ci == 1:
                t1 += v2
            else:
                t2 += v2
        ci = j + 3
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v3
            elif s == 1:
                w1 += v3
            elif s == 2:
                w2 += v3
            else:
                w3 += v3
        else:
            row_tail = True
            if ci == 0:
                t0 += v3
            elif ci == 1:
                t1 += v3
            else:
                t2 += v3
        y0 = q[i, 0]
        y1 = q[i, 1]
        for s in range(4):
            col = first + s
            if col >= nb:
                break
            w = w0
            if w != 0.0:
                r0 = band[col, 0]
                h = givens_norm(r0, w)
                inv = 1.0 / h
                cs, sn = r0 * inv, w * inv
                band[col, 0] = h
                if col + 1 < nb:
                    a = band[col, 1]
                    band[col, 1] = cs * a + sn * w1
                    w1 = -sn * a + cs * w1
                if col + 2 < nb:
                    a = band[col, 2]
                    band[col, 2] = cs * a + sn * w2
                    w2 = -sn * a + cs * w2
                if col + 3 < nb:
                    a = band[col, 3]
                    band[col, 3] = cs * a + sn * w3
                    w3 = -sn * a + cs * w3
                if row_tail or has_tail[col]:
                    a = tail[col, 0]
                    tail[col, 0] = cs * a + sn * t0
                    t0 = -sn * a + cs * t0
                    a = tail[col, 1]
                    tail[col, 1] = cs * a + sn * t1
                    t1 = -sn * a + cs * t1
                    a = tail[col, 2]
                    tail[col, 2] = cs * a + sn * t2
                    t2 = -sn * a + cs * t2
                    has_tail[col] = True
                    row_tail = True
                a = rhs[col, 0]
                rhs[col, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[col, 1]
                rhs[col, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
            w0, w1, w2, w3 = w1, w2, w3, 0.0
        if row_tail:
            if t0 != 0.0:
                r = nb
                r0 = tail[r, 0]
                h = givens_norm(r0, t0)
                inv = 1.0 / h
                cs, sn = r0 * inv, t0 * inv
                tail[r, 0] = h
                a = tail[r, 1]
                tail[r, 1] = cs * a + sn * t1
                t1 = -sn * a + cs * t1
                a = tail[r, 2]
                tail[r, 2] = cs * a + sn * t2
                t2 = -sn * a + cs * t2
                a = rhs[r, 0]
                rhs[r, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[r, 1]
                rhs[r, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
            if t1 != 0.0:
                r = nb + 1
                r0 = tail[r, 1]
                h = givens_norm(r0, t1)
                inv = 1.0 / h
                cs, sn = r0 * inv, t1 * inv
                tail[r, 1] = h
                a = tail[r, 2]
                tail[r, 2] = cs * a + sn * t2
                t2 = -sn * a + cs * t2
                a = rhs[r, 0]
                rhs[r, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[r, 1]
                rhs[r, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
            if t2 != 0.0:
                r = nb + 2
                r0 = tail[r, 2]
                h = givens_norm(r0, t2)
                inv = 1.0 / h
                cs, sn = r0 * inv, t2 * inv
                tail[r, 2] = h
                a = rhs[r, 0]
                rhs[r, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[r, 1]
                rhs[r, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
        sse += y0 * y0
        sse += y1 * y1
    return sse


@njit(cache=True)
def rows_p3_d3(u, q, t, iv, m, band, tail, has_tail, rhs, basis, spans, keep):
    """Rotate every data row into the factor (degree 3, dimension 3); the SSE."""
    nb = m - 3
    size = t.size
    sse = 0.0
    j = 0
    for i in range(u.size):
        x = u[i]
        while j < m - 1 and x >= t[4 + j]:
            j += 1
        span = 3 + j
        v0 = 1.0
        l1 = x - t[span]
        r1 = t[span + 1] - x
        saved = 0.0
        at = span
        temp = v0 * iv[at]
        v0 = saved + r1 * temp
        saved = l1 * temp
        v1 = saved
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        saved = 0.0
        at = 1 * size + span - 1
        temp = v0 * iv[at]
        v0 = saved + r1 * temp
        saved = l2 * temp
        temp = v1 * iv[at + 1]
        v1 = saved + r2 * temp
        saved = l1 * temp
        v2 = saved
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        saved = 0.0
        at = 2 * size + span - 2
        temp = v0 * iv[at]
        v0 = saved + r1 * temp
        saved = l3 * temp
        temp = v1 * iv[at + 1]
        v1 = saved + r2 * temp
        saved = l2 * temp
        temp = v2 * iv[at + 2]
        v2 = saved + r3 * temp
        saved = l1 * temp
        v3 = saved
        if keep:
            spans[i] = j
            basis[i, 0] = v0
            basis[i, 1] = v1
            basis[i, 2] = v2
            basis[i, 3] = v3
        w0 = w1 = w2 = w3 = t0 = t1 = t2 = 0.0
        row_tail = False
        first = j - 3 if j >= 3 else 0
        ci = j
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v0
            elif s == 1:
                w1 += v0
            elif s == 2:
                w2 += v0
            else:
                w3 += v0
        else:
            row_tail = True
            if ci == 0:
                t0 += v0
            elif ci == 1:
                t1 += v0
            else:
                t2 += v0
        ci = j + 1
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v1
            elif s == 1:
                w1 += v1
            elif s == 2:
                w2 += v1
            else:
                w3 += v1
        else:
            row_tail = True
            if ci == 0:
                t0 += v1
            elif ci == 1:
                t1 += v1
            else:
                t2 += v1
        ci = j + 2
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v2
            elif s == 1:
                w1 += v2
            elif s == 2:
                w2 += v2
            else:
                w3 += v2
        else:
            row_tail = True
            if ci == 0:
                t0 += v2
            elif ci == 1:
                t1 += v2
            else:
                t2 += v2
        ci = j + 3
        if ci >= m:
            ci -= m
        if ci >= 3:
            s = ci - 3 - first
            if s == 0:
                w0 += v3
            elif s == 1:
                w1 += v3
            elif s == 2:
                w2 += v3
            else:
                w3 += v3
        else:
            row_tail = True
            if ci == 0:
                t0 += v3
            elif ci == 1:
                t1 += v3
            else:
                t2 += v3
        y0 = q[i, 0]
        y1 = q[i, 1]
        y2 = q[i, 2]
        for s in range(4):
            col = first + s
            if col >= nb:
                break
            w = w0
            if w != 0.0:
                r0 = band[col, 0]
                h = givens_norm(r0, w)
                inv = 1.0 / h
                cs, sn = r0 * inv, w * inv
                band[col, 0] = h
                if col + 1 < nb:
                    a = band[col, 1]
                    band[col, 1] = cs * a + sn * w1
                    w1 = -sn * a + cs * w1
                if col + 2 < nb:
                    a = band[col, 2]
                    band[col, 2] = cs * a + sn * w2
                    w2 = -sn * a + cs * w2
                if col + 3 < nb:
                    a = band[col, 3]
                    band[col, 3] = cs * a + sn * w3
                    w3 = -sn * a + cs * w3
                if row_tail or has_tail[col]:
                    a = tail[col, 0]
                    tail[col, 0] = cs * a + sn * t0
                    t0 = -sn * a + cs * t0
                    a = tail[col, 1]
                    tail[col, 1] = cs * a + sn * t1
                    t1 = -sn * a + cs * t1
                    a = tail[col, 2]
                    tail[col, 2] = cs * a + sn * t2
                    t2 = -sn * a + cs * t2
                    has_tail[col] = True
                    row_tail = True
                a = rhs[col, 0]
                rhs[col, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[col, 1]
                rhs[col, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
                a = rhs[col, 2]
                rhs[col, 2] = cs * a + sn * y2
                y2 = -sn * a + cs * y2
            w0, w1, w2, w3 = w1, w2, w3, 0.0
        if row_tail:
            if t0 != 0.0:
                r = nb
                r0 = tail[r, 0]
                h = givens_norm(r0, t0)
                inv = 1.0 / h
                cs, sn = r0 * inv, t0 * inv
                tail[r, 0] = h
                a = tail[r, 1]
                tail[r, 1] = cs * a + sn * t1
                t1 = -sn * a + cs * t1
                a = tail[r, 2]
                tail[r, 2] = cs * a + sn * t2
                t2 = -sn * a + cs * t2
                a = rhs[r, 0]
                rhs[r, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[r, 1]
                rhs[r, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
                a = rhs[r, 2]
                rhs[r, 2] = cs * a + sn * y2
                y2 = -sn * a + cs * y2
            if t1 != 0.0:
                r = nb + 1
                r0 = tail[r, 1]
                h = givens_norm(r0, t1)
                inv = 1.0 / h
                cs, sn = r0 * inv, t1 * inv
                tail[r, 1] = h
                a = tail[r, 2]
                tail[r, 2] = cs * a + sn * t2
                t2 = -sn * a + cs * t2
                a = rhs[r, 0]
                rhs[r, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[r, 1]
                rhs[r, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
                a = rhs[r, 2]
                rhs[r, 2] = cs * a + sn * y2
                y2 = -sn * a + cs * y2
            if t2 != 0.0:
                r = nb + 2
                r0 = tail[r, 2]
                h = givens_norm(r0, t2)
                inv = 1.0 / h
                cs, sn = r0 * inv, t2 * inv
                tail[r, 2] = h
                a = rhs[r, 0]
                rhs[r, 0] = cs * a + sn * y0
                y0 = -sn * a + cs * y0
                a = rhs[r, 1]
                rhs[r, 1] = cs * a + sn * y1
                y1 = -sn * a + cs * y1
                a = rhs[r, 2]
                rhs[r, 2] = cs * a + sn * y2
                y2 = -sn * a + cs * y2
        sse += y0 * y0
        sse += y1 * y1
        sse += y2 * y2
    return sse


@njit(cache=True)
def rows(u, q, t, iv, p, m, band, tail, has_tail, rhs, basis, spans, keep):
    """Dispatch on the degree and dimension: the SSE, or -1.0 (no loop generated for
    them: the caller runs its generic one)."""
    d = q.shape[1]
    if p == 3 and d == 2:
        return rows_p3_d2(u, q, t, iv, m, band, tail, has_tail, rhs, basis,
                            spans, keep)
    elif p == 3 and d == 3:
        return rows_p3_d3(u, q, t, iv, m, band, tail, has_tail, rhs, basis,
                            spans, keep)
    return -1.0
