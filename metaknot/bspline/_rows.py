"""Row loops of the least-squares kernel, one per degree. GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._codegen``; see that module and ``_kernel._solve``.
"""

import numpy as np
from numba import njit


@njit(cache=True)
def rows_p1(u, q, t, iv, n, rb, dinv, z, basis, spans):
    """Rotate every data row into the factor (degree 1); return the residual SSE."""
    m, d = q.shape
    store = basis.shape[0] > 0
    rhs = np.empty(d)
    span = 1
    sse = 0.0
    for j in range(m):
        x = u[j]
        while span < n - 1 and t[span + 1] <= x:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        tmp = iv[span * 1 + 0]
        h0 = r1 * tmp
        s1_0 = l1 * tmp
        h1 = s1_0
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
        for k in range(d):
            rhs[k] = q[j, k]
        first = span - 1
        big_w = 1.0
        absorbed = False
        if not absorbed and h0 != 0.0:
            col = first + 0
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h0
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h1 * ix
                absorbed = True
            else:
                bw = big_w + h0 * h0 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h0 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h0 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h1
                h1 = h1 - h0 * ra
                big_w = bw
        if not absorbed and h1 != 0.0:
            col = first + 1
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h1
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                absorbed = True
            else:
                bw = big_w + h1 * h1 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h1 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h1 * zk
                big_w = bw
        if not absorbed:
            # what the rotations leave of the row, with its weight, is its residual
            left_over = 0.0
            for k in range(d):
                left_over += rhs[k] * rhs[k]
            sse += left_over / big_w
    return sse


@njit(cache=True)
def rows_p2(u, q, t, iv, n, rb, dinv, z, basis, spans):
    """Rotate every data row into the factor (degree 2); return the residual SSE."""
    m, d = q.shape
    store = basis.shape[0] > 0
    rhs = np.empty(d)
    span = 2
    sse = 0.0
    for j in range(m):
        x = u[j]
        while span < n - 1 and t[span + 1] <= x:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        tmp = iv[span * 2 + 0]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[(span - 1) * 2 + 1]
        h0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span * 2 + 1]
        h1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        h2 = s2_1
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
        for k in range(d):
            rhs[k] = q[j, k]
        first = span - 2
        big_w = 1.0
        absorbed = False
        if not absorbed and h0 != 0.0:
            col = first + 0
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h0
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h1 * ix
                rb[col, 2] = h2 * ix
                absorbed = True
            else:
                bw = big_w + h0 * h0 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h0 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h0 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h1
                h1 = h1 - h0 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h2
                h2 = h2 - h0 * ra
                big_w = bw
        if not absorbed and h1 != 0.0:
            col = first + 1
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h1
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h2 * ix
                absorbed = True
            else:
                bw = big_w + h1 * h1 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h1 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h1 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h2
                h2 = h2 - h1 * ra
                big_w = bw
        if not absorbed and h2 != 0.0:
            col = first + 2
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h2
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                absorbed = True
            else:
                bw = big_w + h2 * h2 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h2 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h2 * zk
                big_w = bw
        if not absorbed:
            # what the rotations leave of the row, with its weight, is its residual
            left_over = 0.0
            for k in range(d):
                left_over += rhs[k] * rhs[k]
            sse += left_over / big_w
    return sse


@njit(cache=True)
def rows_p3(u, q, t, iv, n, rb, dinv, z, basis, spans):
    """Rotate every data row into the factor (degree 3); return the residual SSE."""
    m, d = q.shape
    store = basis.shape[0] > 0
    rhs = np.empty(d)
    span = 3
    sse = 0.0
    for j in range(m):
        x = u[j]
        while span < n - 1 and t[span + 1] <= x:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        tmp = iv[span * 3 + 0]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[(span - 1) * 3 + 1]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span * 3 + 1]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[(span - 2) * 3 + 2]
        h0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[(span - 1) * 3 + 2]
        h1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span * 3 + 2]
        h2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        h3 = s3_2
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
        for k in range(d):
            rhs[k] = q[j, k]
        first = span - 3
        big_w = 1.0
        absorbed = False
        if not absorbed and h0 != 0.0:
            col = first + 0
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h0
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h1 * ix
                rb[col, 2] = h2 * ix
                rb[col, 3] = h3 * ix
                absorbed = True
            else:
                bw = big_w + h0 * h0 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h0 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h0 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h1
                h1 = h1 - h0 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h2
                h2 = h2 - h0 * ra
                ra = rb[col, 3]
                rb[col, 3] = cb * ra + sb * h3
                h3 = h3 - h0 * ra
                big_w = bw
        if not absorbed and h1 != 0.0:
            col = first + 1
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h1
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h2 * ix
                rb[col, 2] = h3 * ix
                absorbed = True
            else:
                bw = big_w + h1 * h1 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h1 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h1 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h2
                h2 = h2 - h1 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h3
                h3 = h3 - h1 * ra
                big_w = bw
        if not absorbed and h2 != 0.0:
            col = first + 2
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h2
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h3 * ix
                absorbed = True
            else:
                bw = big_w + h2 * h2 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h2 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h2 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h3
                h3 = h3 - h2 * ra
                big_w = bw
        if not absorbed and h3 != 0.0:
            col = first + 3
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h3
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                absorbed = True
            else:
                bw = big_w + h3 * h3 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h3 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h3 * zk
                big_w = bw
        if not absorbed:
            # what the rotations leave of the row, with its weight, is its residual
            left_over = 0.0
            for k in range(d):
                left_over += rhs[k] * rhs[k]
            sse += left_over / big_w
    return sse


@njit(cache=True)
def rows_p4(u, q, t, iv, n, rb, dinv, z, basis, spans):
    """Rotate every data row into the factor (degree 4); return the residual SSE."""
    m, d = q.shape
    store = basis.shape[0] > 0
    rhs = np.empty(d)
    span = 4
    sse = 0.0
    for j in range(m):
        x = u[j]
        while span < n - 1 and t[span + 1] <= x:
            span += 1
        l1 = x - t[span]
        r1 = t[span + 1] - x
        l2 = x - t[span - 1]
        r2 = t[span + 2] - x
        l3 = x - t[span - 2]
        r3 = t[span + 3] - x
        l4 = x - t[span - 3]
        r4 = t[span + 4] - x
        tmp = iv[span * 4 + 0]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[(span - 1) * 4 + 1]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span * 4 + 1]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[(span - 2) * 4 + 2]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[(span - 1) * 4 + 2]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span * 4 + 2]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[(span - 3) * 4 + 3]
        h0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[(span - 2) * 4 + 3]
        h1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[(span - 1) * 4 + 3]
        h2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span * 4 + 3]
        h3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        h4 = s4_3
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
        for k in range(d):
            rhs[k] = q[j, k]
        first = span - 4
        big_w = 1.0
        absorbed = False
        if not absorbed and h0 != 0.0:
            col = first + 0
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h0
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h1 * ix
                rb[col, 2] = h2 * ix
                rb[col, 3] = h3 * ix
                rb[col, 4] = h4 * ix
                absorbed = True
            else:
                bw = big_w + h0 * h0 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h0 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h0 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h1
                h1 = h1 - h0 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h2
                h2 = h2 - h0 * ra
                ra = rb[col, 3]
                rb[col, 3] = cb * ra + sb * h3
                h3 = h3 - h0 * ra
                ra = rb[col, 4]
                rb[col, 4] = cb * ra + sb * h4
                h4 = h4 - h0 * ra
                big_w = bw
        if not absorbed and h1 != 0.0:
            col = first + 1
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h1
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h2 * ix
                rb[col, 2] = h3 * ix
                rb[col, 3] = h4 * ix
                absorbed = True
            else:
                bw = big_w + h1 * h1 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h1 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h1 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h2
                h2 = h2 - h1 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h3
                h3 = h3 - h1 * ra
                ra = rb[col, 3]
                rb[col, 3] = cb * ra + sb * h4
                h4 = h4 - h1 * ra
                big_w = bw
        if not absorbed and h2 != 0.0:
            col = first + 2
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h2
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h3 * ix
                rb[col, 2] = h4 * ix
                absorbed = True
            else:
                bw = big_w + h2 * h2 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h2 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h2 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h3
                h3 = h3 - h2 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h4
                h4 = h4 - h2 * ra
                big_w = bw
        if not absorbed and h3 != 0.0:
            col = first + 3
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h3
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h4 * ix
                absorbed = True
            else:
                bw = big_w + h3 * h3 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h3 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h3 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h4
                h4 = h4 - h3 * ra
                big_w = bw
        if not absorbed and h4 != 0.0:
            col = first + 4
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h4
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                absorbed = True
            else:
                bw = big_w + h4 * h4 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h4 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h4 * zk
                big_w = bw
        if not absorbed:
            # what the rotations leave of the row, with its weight, is its residual
            left_over = 0.0
            for k in range(d):
                left_over += rhs[k] * rhs[k]
            sse += left_over / big_w
    return sse


@njit(cache=True)
def rows_p5(u, q, t, iv, n, rb, dinv, z, basis, spans):
    """Rotate every data row into the factor (degree 5); return the residual SSE."""
    m, d = q.shape
    store = basis.shape[0] > 0
    rhs = np.empty(d)
    span = 5
    sse = 0.0
    for j in range(m):
        x = u[j]
        while span < n - 1 and t[span + 1] <= x:
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
        tmp = iv[span * 5 + 0]
        b1_0 = r1 * tmp
        s1_0 = l1 * tmp
        b1_1 = s1_0
        tmp = b1_0 * iv[(span - 1) * 5 + 1]
        b2_0 = r1 * tmp
        s2_0 = l2 * tmp
        tmp = b1_1 * iv[span * 5 + 1]
        b2_1 = s2_0 + r2 * tmp
        s2_1 = l1 * tmp
        b2_2 = s2_1
        tmp = b2_0 * iv[(span - 2) * 5 + 2]
        b3_0 = r1 * tmp
        s3_0 = l3 * tmp
        tmp = b2_1 * iv[(span - 1) * 5 + 2]
        b3_1 = s3_0 + r2 * tmp
        s3_1 = l2 * tmp
        tmp = b2_2 * iv[span * 5 + 2]
        b3_2 = s3_1 + r3 * tmp
        s3_2 = l1 * tmp
        b3_3 = s3_2
        tmp = b3_0 * iv[(span - 3) * 5 + 3]
        b4_0 = r1 * tmp
        s4_0 = l4 * tmp
        tmp = b3_1 * iv[(span - 2) * 5 + 3]
        b4_1 = s4_0 + r2 * tmp
        s4_1 = l3 * tmp
        tmp = b3_2 * iv[(span - 1) * 5 + 3]
        b4_2 = s4_1 + r3 * tmp
        s4_2 = l2 * tmp
        tmp = b3_3 * iv[span * 5 + 3]
        b4_3 = s4_2 + r4 * tmp
        s4_3 = l1 * tmp
        b4_4 = s4_3
        tmp = b4_0 * iv[(span - 4) * 5 + 4]
        h0 = r1 * tmp
        s5_0 = l5 * tmp
        tmp = b4_1 * iv[(span - 3) * 5 + 4]
        h1 = s5_0 + r2 * tmp
        s5_1 = l4 * tmp
        tmp = b4_2 * iv[(span - 2) * 5 + 4]
        h2 = s5_1 + r3 * tmp
        s5_2 = l3 * tmp
        tmp = b4_3 * iv[(span - 1) * 5 + 4]
        h3 = s5_2 + r4 * tmp
        s5_3 = l2 * tmp
        tmp = b4_4 * iv[span * 5 + 4]
        h4 = s5_3 + r5 * tmp
        s5_4 = l1 * tmp
        h5 = s5_4
        if store:
            spans[j] = span
            basis[j, 0] = h0
            basis[j, 1] = h1
            basis[j, 2] = h2
            basis[j, 3] = h3
            basis[j, 4] = h4
            basis[j, 5] = h5
        for k in range(d):
            rhs[k] = q[j, k]
        first = span - 5
        big_w = 1.0
        absorbed = False
        if not absorbed and h0 != 0.0:
            col = first + 0
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h0
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h1 * ix
                rb[col, 2] = h2 * ix
                rb[col, 3] = h3 * ix
                rb[col, 4] = h4 * ix
                rb[col, 5] = h5 * ix
                absorbed = True
            else:
                bw = big_w + h0 * h0 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h0 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h0 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h1
                h1 = h1 - h0 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h2
                h2 = h2 - h0 * ra
                ra = rb[col, 3]
                rb[col, 3] = cb * ra + sb * h3
                h3 = h3 - h0 * ra
                ra = rb[col, 4]
                rb[col, 4] = cb * ra + sb * h4
                h4 = h4 - h0 * ra
                ra = rb[col, 5]
                rb[col, 5] = cb * ra + sb * h5
                h5 = h5 - h0 * ra
                big_w = bw
        if not absorbed and h1 != 0.0:
            col = first + 1
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h1
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h2 * ix
                rb[col, 2] = h3 * ix
                rb[col, 3] = h4 * ix
                rb[col, 4] = h5 * ix
                absorbed = True
            else:
                bw = big_w + h1 * h1 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h1 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h1 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h2
                h2 = h2 - h1 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h3
                h3 = h3 - h1 * ra
                ra = rb[col, 3]
                rb[col, 3] = cb * ra + sb * h4
                h4 = h4 - h1 * ra
                ra = rb[col, 4]
                rb[col, 4] = cb * ra + sb * h5
                h5 = h5 - h1 * ra
                big_w = bw
        if not absorbed and h2 != 0.0:
            col = first + 2
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h2
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h3 * ix
                rb[col, 2] = h4 * ix
                rb[col, 3] = h5 * ix
                absorbed = True
            else:
                bw = big_w + h2 * h2 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h2 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h2 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h3
                h3 = h3 - h2 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h4
                h4 = h4 - h2 * ra
                ra = rb[col, 3]
                rb[col, 3] = cb * ra + sb * h5
                h5 = h5 - h2 * ra
                big_w = bw
        if not absorbed and h3 != 0.0:
            col = first + 3
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h3
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h4 * ix
                rb[col, 2] = h5 * ix
                absorbed = True
            else:
                bw = big_w + h3 * h3 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h3 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h3 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h4
                h4 = h4 - h3 * ra
                ra = rb[col, 2]
                rb[col, 2] = cb * ra + sb * h5
                h5 = h5 - h3 * ra
                big_w = bw
        if not absorbed and h4 != 0.0:
            col = first + 4
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h4
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                rb[col, 1] = h5 * ix
                absorbed = True
            else:
                bw = big_w + h4 * h4 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h4 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h4 * zk
                ra = rb[col, 1]
                rb[col, 1] = cb * ra + sb * h5
                h5 = h5 - h4 * ra
                big_w = bw
        if not absorbed and h5 != 0.0:
            col = first + 5
            di = dinv[col]
            if di == np.inf:
                ix = 1.0 / h5
                dinv[col] = big_w * ix * ix
                for k in range(d):
                    z[col, k] = rhs[k] * ix
                absorbed = True
            else:
                bw = big_w + h5 * h5 * di
                inv = 1.0 / bw
                cb = big_w * inv
                sb = h5 * di * inv
                dinv[col] = di * cb
                for k in range(d):
                    zk = z[col, k]
                    yk = rhs[k]
                    z[col, k] = cb * zk + sb * yk
                    rhs[k] = yk - h5 * zk
                big_w = bw
        if not absorbed:
            # what the rotations leave of the row, with its weight, is its residual
            left_over = 0.0
            for k in range(d):
                left_over += rhs[k] * rhs[k]
            sse += left_over / big_w
    return sse


@njit(cache=True)
def rows(u, q, t, iv, p, n, rb, dinv, z, basis, spans):
    """Dispatch on the degree."""
    if p == 1:
        return rows_p1(u, q, t, iv, n, rb, dinv, z, basis, spans)
    elif p == 2:
        return rows_p2(u, q, t, iv, n, rb, dinv, z, basis, spans)
    elif p == 3:
        return rows_p3(u, q, t, iv, n, rb, dinv, z, basis, spans)
    elif p == 4:
        return rows_p4(u, q, t, iv, n, rb, dinv, z, basis, spans)
    elif p == 5:
        return rows_p5(u, q, t, iv, n, rb, dinv, z, basis, spans)
    return np.nan
