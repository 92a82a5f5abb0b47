"""Compiled parts of variable projection (loaded on first use: importing the optimizers does not
import numba): the design matrix of an open curve, and the derivatives of its B-splines with
respect to each interior knot, applied to the control points and to the residual.

The B-spline values come from the kernel's :func:`~metaknot.bspline._kernel.basis_at`; the
derivative with respect to a knot is the closed form of
:mod:`metaknot.algorithms.variable_projection`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from metaknot.bspline._kernel import basis_at


@njit(cache=True)
def design_open(u, t, p, n, basis, spans):
    """The dense ``(N, n)`` design matrix of the clamped knot vector ``t`` at the increasing
    parameters ``u`` into ``basis`` (zeroed here), and each parameter's knot span."""
    values = np.empty(p + 1)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    basis[:] = 0.0
    span = p
    for x in range(u.size):
        while span < n - 1 and u[x] >= t[span + 1]:
            span += 1
        spans[x] = span
        basis_at(t, span, u[x], p, values, left, right)
        for r in range(p + 1):
            basis[x, span - p + r] = values[r]


@njit(cache=True)
def _over(value, width):
    return value / width if width > 0.0 else 0.0


@njit(cache=True)
def knot_derivatives(u, t, p, n, spans, basis, coef, residual, positions, variables, moved,
                     pulled):
    """The derivatives with respect to variable ``k``, which moves the (simple) knots
    ``t[positions[e]]`` with ``variables[e] == k`` (one knot of an open curve; a closed curve's
    breakpoint and its periodic copies): ``moved[x, :, k]``, the derivative of the curve with
    control points ``coef`` at ``u[x]`` (``D_k C``), and ``pulled[i, :, k]``, the derivative's
    basis column ``i`` against the residual (``D_k^T r``). Both are zeroed here."""
    moved[:] = 0.0
    pulled[:] = 0.0
    d = coef.shape[1]
    refined = np.empty(t.size + 1)
    fine = np.empty(p + 1)
    left = np.empty(p + 1)
    right = np.empty(p + 1)
    for e in range(positions.size):
        j, k = positions[e], variables[e]
        refined[:j] = t[:j]
        refined[j] = t[j]
        refined[j + 1:] = t[j:]
        for x in range(u.size):
            span = spans[x]
            lo = max(span - p, j - p - 1, 0)
            hi = min(span, j, n - 1)
            if lo > hi:
                continue
            fine_span = span + 1 if j <= span else span
            basis_at(refined, fine_span, u[x], p, fine, left, right)
            offset = fine_span - p  # fine[r] is refined B-spline offset + r
            for i in range(lo, hi + 1):
                sign = -1.0 if i == j else (1.0 if i + p + 1 == j else 0.0)
                value = sign * _over(basis[x, i], t[i + p + 1] - t[i])
                r = i + 1 - offset
                if 0 <= r <= p:
                    value += _over(fine[r], refined[i + p + 2] - refined[i + 1])
                r = i - offset
                if 0 <= r <= p:
                    value -= _over(fine[r], refined[i + p + 1] - refined[i])
                for c in range(d):
                    moved[x, c, k] += value * coef[i, c]
                    pulled[i, c, k] += value * residual[x, c]
