"""Sparse knot selection (Kang et al. 2015): knots where an L1-penalised fit over a dense candidate
set keeps a jump of the p-th derivative.

H. Kang, F. Chen, Y. Li, J. Deng & Z. Yang, "Knot calculation for spline fitting via sparse
optimization", Computer-Aided Design 58 (2015) 179-188 (the suite's ``kang_spline`` is their
known-answer example). A spline of degree p is a polynomial between its knots, so its p-th
derivative is piecewise constant and jumps only at its knots: over a dense set of candidate
knots, the knots a fit needs are the candidates where that jump is nonzero. The fit minimises
``||B c - q||^2 + lambda sum_j |J_j c|`` (``B``: the basis at the data, ``J_j c``: the jump of
the p-th derivative at candidate j), whose L1 penalty leaves most jumps at zero; adjacent
nonzero jumps mark one knot between candidates, placed at their jump-weighted mean. The spline is
then refitted by least squares on the selected knots, and ``lambda`` is the largest (fewest
knots) whose refit is within the tolerance.

Choices the paper leaves open (or that differ):

* The candidates are the data parameters (a knot can then be found to the sampling resolution).
* The L1 problem is solved by iteratively reweighted least squares (``|z|`` replaced by
  ``z^2 / |z_k|`` at the previous iterate, up to ``rounds`` rounds (until the weights change by
  less than 1e-3 of the largest), sparse normal equations by
  ``scipy.sparse.linalg.spsolve``), with a group penalty on curves: the jump's Euclidean norm
  over the coordinates. A jump counts as nonzero above ``threshold`` times the largest (and
  above 1e-9 of the largest jump the data's range allows: rounding). A run of
  at most ``p + 1`` adjacent nonzero jumps is one knot between candidates; a longer run (small
  ``lambda``: a region that needs many knots) gives a knot at every other candidate (every
  one would leave more coefficients than data); knots that would leave a span without data
  are dropped. If the smallest ``lambda``'s selection is not within the tolerance, every jump
  above rounding there is taken, at every other candidate.
* ``lambda`` is searched by bisection on its logarithm (down to a width of 0.05, over 16
  decades around
  ``max |B^T (q - mean q)| / max_j sum |J_j|``), keeping the fewest knots seen within the
  tolerance; data that a polynomial (a closed outline: the fewest breakpoints) fits within
  the tolerance get no knot.
* Kang et al. refine each cluster's knot by a nonlinear fit; here it is the jump-weighted mean
  (their second stage is what ``bisection``'s least-squares refinement does).
* A closed outline: a periodic basis over [0, 1) (its extended knots folded onto one period);
  the jump at 0 is free (0 is always a breakpoint).
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import check_param
from metaknot.registry import register

from .literature import Target, ToleranceMethod, tolerance_method

__all__ = ["SparseL1", "jump_matrices", "sparse_l1"]


def jump_matrices(target: Target):
    """``(B, J, candidates)``: the basis at the data ``(N, n)`` and the jump of the p-th
    derivative at each candidate knot ``(M, n)`` (sparse), over the candidate knots (every
    interior data parameter)."""
    from scipy import sparse
    from scipy.interpolate import BSpline

    u, p = target.params, target.degree
    candidates = target.curve.candidate_params
    t, fold = target.curve.coefficient_map(candidates)
    n = t.size - p - 1
    basis = BSpline.design_matrix(u, t, p).tocsr() @ fold
    derivative = sparse.identity(n, format="csr")
    tk, k = t, p
    for _ in range(p):  # scipy's splder, as a matrix: c'_i = k (c_{i+1} - c_i) / dt_i
        rows = tk.size - k - 2
        dt = tk[k + 1 : k + 1 + rows] - tk[1 : 1 + rows]
        step = sparse.diags([-k / dt, k / dt], [0, 1], shape=(rows, rows + 1), format="csr")
        derivative = step @ derivative
        tk, k = tk[1:-1], k - 1
    # a degree-0 spline on tk: one value per span; the jumps between consecutive spans
    rows = derivative.shape[0]
    # scipy-stubs take a sequence of diagonals as scalars or nested sequences, not 1-D arrays
    diff = sparse.diags([-np.ones(rows - 1), np.ones(rows - 1)], [0, 1],  # type: ignore[call-overload]
                        shape=(rows - 1, rows), format="csr")
    # open: the spans of [u_0, u_N-1]; closed: of [0, 1), the jump at 0 left free
    jumps = diff @ derivative @ fold
    return basis.tocsr(), jumps.tocsr(), candidates


def select_knots(jump: np.ndarray, candidates: np.ndarray, threshold: float, floor: float,
                 longest: int) -> np.ndarray:
    """Knots from jump sizes: the candidates whose jump is above ``threshold`` times the
    largest (and above ``floor``); a run of at most ``longest`` adjacent ones gives one knot at
    their jump-weighted mean (a knot between candidates), a longer run a knot at every other
    candidate."""
    if jump.size == 0 or jump.max() <= floor:
        return np.empty(0)
    on = jump > max(threshold * jump.max(), floor)
    edges = np.diff(np.concatenate(([0], on.astype(np.int8), [0])))
    knots = []
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        if b - a <= longest:
            knots.append(np.average(candidates[a:b], weights=jump[a:b]))
        else:
            knots += candidates[a:b:2].tolist()
    return np.array(knots)


@tolerance_method("sparse_l1")
def sparse_l1(target: Target, threshold: float = 1e-3, rounds: int = 30) -> np.ndarray:
    """Kang et al.'s sparse knot selection (see the module docstring)."""
    from scipy.sparse.linalg import spsolve

    basis, jumps, candidates = jump_matrices(target)
    q = target.points
    gram = (basis.T @ basis).tocsc()
    rhs = basis.T @ q
    reach = float(np.abs(jumps).sum(axis=1).max())  # the largest jump of a unit spline
    centred = q - q.mean(axis=0)
    scale = float(np.abs(basis.T @ centred).max()) / max(reach, 1e-300)  # a lambda scale
    floor = 1e-9 * reach * float(np.abs(centred).max())  # smaller jumps are rounding
    ridge = 1e-12 * gram.diagonal().max()
    from scipy import sparse

    def knots_for(lam: float, share: float = threshold,
                  longest: int = target.degree + 1) -> np.ndarray:
        weights = np.ones(candidates.size)
        c = None
        for _ in range(rounds):
            system = gram + lam * (jumps.T @ sparse.diags(weights) @ jumps) \
                + ridge * sparse.identity(gram.shape[0])
            target.count(1)
            c = spsolve(system.tocsc(), rhs).reshape(gram.shape[0], -1)
            z = np.linalg.norm(jumps @ c, axis=1)
            eps = max(1e-6 * z.max(), floor)
            if np.abs(1.0 / (z + eps) - weights).max() <= 1e-3 * weights.max():
                break  # converged
            weights = 1.0 / (z + eps)
        return target.with_data_between(select_knots(
            np.linalg.norm(jumps @ c, axis=1), candidates, share, floor, longest))

    if target.within(start := target.curve.spread_knots(target.min_count)):
        return start  # a polynomial (or the fewest breakpoints) is within already
    lo, hi = np.log(scale) - 12 * np.log(10), np.log(scale) + 4 * np.log(10)
    best = knots_for(float(np.exp(lo)))
    if not target.within(best):  # every jump above rounding, at every other candidate
        best = knots_for(float(np.exp(lo)), share=0.0, longest=0)
        if not target.within(best):  # not even the densest selection: as found (the reason
            return target.with_min_count(best)  # is given), with a fit's fewest breakpoints
    within, beyond = lo, hi
    while beyond - within >= 0.05:
        mid = 0.5 * (within + beyond)
        knots = knots_for(float(np.exp(mid)))
        if target.within(knots):
            within = mid
            if knots.size < best.size:
                best = knots
        else:
            beyond = mid
    return best


@register("sparse_l1")
class SparseL1(ToleranceMethod):
    """Sparse knot selection (:func:`sparse_l1`) as an optimizer
    (:class:`~metaknot.algorithms.literature.ToleranceMethod`).

    Parameters
    ----------
    threshold
        A jump counts as nonzero above this fraction of the largest (in (0, 1)).
    rounds
        Reweighted least-squares rounds per ``lambda`` (>= 1).
    tolerance, metric, max_knots, batch_size
        As :class:`~metaknot.algorithms.literature.ToleranceMethod`.
    """

    method = staticmethod(sparse_l1)
    options = ("threshold", "rounds")

    def __init__(self, threshold: float = 1e-3, rounds: int = 30,
                 tolerance: float | None = None, metric: str = "max_deviation",
                 max_knots: int | None = None, batch_size: int = 1) -> None:
        super().__init__(tolerance, metric, max_knots, batch_size)
        self.threshold = check_param("threshold", threshold, low=0, high=1, low_open=True)
        self.rounds = check_param("rounds", rounds, low=1, integer=True)
