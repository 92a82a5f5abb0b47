"""The objectives' formulas and the run metrics, compiled: one pass over a batch of fits.

A batch of any size costs one call, so a sequential optimizer's batches of one candidate take
the same code as a population's, at the cost of a few scalar operations. The caller allocates
the outputs (an array numpy made is returned faster than one made in compiled code). Each
formula is written once, here; :mod:`metaknot.problems.objectives` and the knot problems call
it. An infeasible fit (``reason`` not 0) scores ``+inf`` and has NaN metrics.
"""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def paper(sse, n_control_points, reason, floor, values):
    """Control points x ``max(sqrt(SSE), floor)`` (:class:`~.objectives.Paper`)."""
    for b in range(sse.size):
        values[b] = n_control_points[b] * max(math.sqrt(sse[b]), floor) \
            if reason[b] == 0 else math.inf


@njit(cache=True)
def rmse(sse, reason, n_points, values):
    """Root-mean-square point distance (:class:`~.objectives.RMSE`)."""
    for b in range(sse.size):
        values[b] = math.sqrt(sse[b] / n_points) if reason[b] == 0 else math.inf


@njit(cache=True)
def error_bounded(sse, max_deviation, n_control_points, reason, n_points, tolerance,
                  by_max_deviation, values):
    """Control points plus error / tolerance within the tolerance, ``N + 2`` plus it beyond
    (:class:`~.objectives.ErrorBounded`); the error is the maximum deviation or, unless
    ``by_max_deviation``, the RMSE."""
    beyond = n_points + 2
    for b in range(sse.size):
        error = max_deviation[b] if by_max_deviation else math.sqrt(sse[b] / n_points)
        ratio = error / tolerance
        value = n_control_points[b] + ratio if ratio <= 1.0 else beyond + ratio
        values[b] = value if reason[b] == 0 else math.inf


@njit(cache=True)
def metrics(sse, max_deviation, n_control_points, reason, n_points, rmse_values,
            control_points, deviations):
    """RMSE, control points and maximum deviation (unless ``deviations`` is empty) per fit
    into the last three arrays, NaN for an infeasible fit."""
    with_max_deviation = deviations.size > 0
    for b in range(sse.size):
        feasible = reason[b] == 0
        rmse_values[b] = math.sqrt(sse[b] / n_points) if feasible else math.nan
        control_points[b] = n_control_points[b] if feasible else math.nan
        if with_max_deviation:
            deviations[b] = max_deviation[b] if feasible else math.nan
