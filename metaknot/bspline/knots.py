"""Knot vectors (clamped for open curves, periodic for closed ones) and the three knot
encodings (mask, data indices, positions) as flat batches."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..validate import is_integer
from . import _kernel
from .parameterize import check_degree

__all__ = [
    "as_positions",
    "averaging_knots",
    "check_indices",
    "check_masks",
    "check_multiplicity",
    "check_offsets",
    "clamped_knot_vector",
    "extra_control_points",
    "n_control_points",
    "periodic_knot_vector",
    "stack_indices",
    "stack_masks",
    "stack_positions",
    "stack_rows",
]


def extra_control_points(degree: int, closed: bool = False) -> int:
    """Control points beyond the interior knots: ``degree + 1`` on a clamped (open) spline, 1
    on a periodic one (its breakpoint 0)."""
    return 1 if closed else int(degree) + 1


def n_control_points(n_interior: int, degree: int) -> int:
    """Number of control points of a clamped spline: interior knots + degree + 1."""
    return int(n_interior) + extra_control_points(degree)


def _as_params(u: ArrayLike) -> np.ndarray:
    u = np.asarray(u, dtype=np.float64)
    if u.ndim != 1 or u.size < 2:
        raise ValueError(f"parameter values must be a 1-D array of length >= 2; got {u.shape}")
    return u


def check_multiplicity(max_multiplicity: Any, degree: int) -> int:
    """``max_multiplicity`` checked: how often an interior knot may repeat, 1 (distinct knots)
    to ``degree`` (a knot of multiplicity m leaves the spline C^(degree - m) there: a corner at
    m = degree)."""
    if not is_integer(max_multiplicity) or not 1 <= max_multiplicity <= degree:
        raise ValueError(f"max_multiplicity must be an integer from 1 to the degree "
                         f"({degree}); got {max_multiplicity!r}")
    return int(max_multiplicity)


def _multiplicity_error(max_multiplicity: int) -> str:
    return ("interior knots must be strictly increasing (coincident knots given)"
            if max_multiplicity == 1 else
            f"an interior knot repeats more than max_multiplicity={max_multiplicity} times")


def clamped_knot_vector(u: ArrayLike, interior: ArrayLike, degree: int = 3, *,
                        max_multiplicity: int = 1) -> np.ndarray:
    """Full clamped knot vector ``[u0]*(p+1) + interior + [um]*(p+1)``.

    Raises
    ------
    ValueError
        If an interior knot is not finite, lies outside the open interval ``(u0, um)``, or the
        interior knots decrease or repeat a knot more than ``max_multiplicity`` times (by
        default they must be strictly increasing).
    """
    p = check_degree(degree)
    max_multiplicity = check_multiplicity(max_multiplicity, p)
    u = _as_params(u)
    interior = np.asarray(interior, dtype=np.float64).ravel()
    if not np.isfinite(interior).all():
        raise ValueError("interior knots contain NaN or infinite values")
    if interior.size and (interior.min() <= u[0] or interior.max() >= u[-1]):
        raise ValueError(
            f"interior knots must lie strictly inside the parameter range ({u[0]}, {u[-1]})"
        )
    if (np.diff(interior) < 0).any() or _kernel.repeated_beyond(interior, max_multiplicity):
        raise ValueError(_multiplicity_error(max_multiplicity))
    return np.concatenate((np.full(p + 1, u[0]), interior, np.full(p + 1, u[-1])))


def periodic_knot_vector(interior: ArrayLike, degree: int = 3, *,
                         max_multiplicity: int = 1) -> np.ndarray:
    """The extended knot vector of a periodic spline on [0, 1) whose breakpoints are 0 and
    the sorted ``interior`` knots (all in (0, 1)): the ``m`` breakpoints and 1, with ``degree``
    periodic copies on each side (``m + 2 degree + 1`` knots, FITPACK's periodic layout).

    Raises
    ------
    ValueError
        If an interior knot is not finite, lies outside (0, 1) or repeats more than
        ``max_multiplicity`` times (by default: repeats another), or there are fewer than
        ``degree`` breakpoints.
    """
    p = check_degree(degree)
    return _periodic_knots(interior, p, check_multiplicity(max_multiplicity, p))


def _periodic_knots(interior: ArrayLike, p: int, max_multiplicity: int = 1) -> np.ndarray:
    """:func:`periodic_knot_vector` of a degree and a multiplicity already checked."""
    inner = np.sort(np.asarray(interior, dtype=np.float64).ravel())
    # the batch fit's verdict (NaN included), then named here
    if _kernel.closed_verdict(inner, max_multiplicity)[0] != _kernel.FEASIBLE:
        repeats = "distinct" if max_multiplicity == 1 else \
            f"each repeated at most max_multiplicity={max_multiplicity} times"
        raise ValueError(f"interior knots of a periodic spline must be finite, {repeats} and lie "
                         "in (0, 1)")
    breaks = np.concatenate(([0.0], inner))
    m = breaks.size
    if m < p:
        raise ValueError(f"a periodic spline of degree {p} needs at least {p - 1} interior "
                         f"knots; got {inner.size}")
    t = np.empty(m + 2 * p + 1)
    _kernel.extended_knots(breaks, p, t)
    return t


def averaging_knots(u: ArrayLike, n_interior: int, degree: int = 3) -> np.ndarray:
    """Interior knots by the averaging technique of the NURBS Book (eqs. 9.68-9.69).

    Spreads ``n_interior`` knots so that every knot span holds data parameters, which keeps the
    least-squares problem well posed.
    """
    p = check_degree(degree)
    u = _as_params(u)
    m = u.size - 1
    n = n_interior + p  # highest control-point index
    if n_interior < 0 or n > m:
        raise ValueError(f"n_interior must lie in 0..{m - p}; got {n_interior}")
    if n_interior == 0:
        return np.empty(0)
    d = (m + 1) / (n - p + 1)
    j = np.arange(1, n - p + 1)
    i = np.floor(j * d).astype(int)
    alpha = j * d - i
    return (1.0 - alpha) * u[i - 1] + alpha * u[i]


def _offsets(counts: np.ndarray) -> np.ndarray:
    offsets = np.zeros(counts.size + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return offsets


def stack_rows(rows: list[np.ndarray] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flatten rows of interior knots (of any lengths) to knots plus row offsets; a
    ``ValueError`` naming the first row that is not 1-D."""
    for b, row in enumerate(rows):
        if np.ndim(row) != 1:
            raise ValueError(f"knot set {b} must be a 1-D array of knots; got shape "
                             f"{np.shape(row)}")
    knots = np.concatenate(rows) if len(rows) else np.empty(0)
    return knots, _offsets(np.array([len(r) for r in rows], dtype=np.int64))


def check_masks(masks: ArrayLike, n_points: int, *, closed: bool = False,
                trust_integers: bool = False) -> np.ndarray:
    """A batch of 0/1 masks over the candidate data points, as booleans: ``(B, N-2)`` over the
    interior ones, ``(B, N-1)`` over those after the first on a ``closed`` outline. A
    ``ValueError`` for another shape or for values other than 0 and 1; with
    ``trust_integers``, integer masks are returned as they are (any nonzero entry is a knot:
    the problems' encodings have checked them)."""
    masks = np.asarray(masks)
    n_var = n_points - (1 if closed else 2)
    if masks.ndim != 2 or masks.shape[1] != n_var:
        raise ValueError(f"masks must have shape (B, N - {1 if closed else 2}) = (B, {n_var}); "
                         f"got {masks.shape}")
    if masks.dtype != bool and not (trust_integers and masks.dtype.kind in "iu"):
        if not np.isin(masks, (0, 1)).all():
            raise ValueError("masks must contain only 0 and 1")
        masks = masks.astype(bool)
    return masks


def stack_masks(u: ArrayLike, masks: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Flatten a ``(B, N-2)`` batch of 0/1 masks to interior knots plus row offsets.

    Raises
    ------
    ValueError
        Unless ``u`` is 1-D and ``masks`` has shape ``(B, N-2)`` and holds only 0 and 1 (the
        compiled gathering trusts both: a wider mask read past ``u``, other values sized the
        output wrongly).
    """
    u = _as_params(u)
    return _kernel.masks_to_knots(u, np.ascontiguousarray(check_masks(masks, u.size)))


def check_offsets(knots: ArrayLike, offsets: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Flattened candidates (candidate ``b``: ``knots[offsets[b]:offsets[b + 1]]``) as float64
    knots and int64 offsets, or a ``ValueError`` naming what does not match: the compiled
    evaluators trust the offsets to stay within the knots."""
    knots = np.asarray(knots, dtype=np.float64)
    if knots.ndim != 1:
        raise ValueError(f"knots must be a 1-D array; got shape {knots.shape}")
    offsets = np.asarray(offsets)
    if offsets.dtype.kind not in "iu" and offsets.size and (
            offsets.dtype.kind not in "f" or not np.array_equal(offsets, np.round(offsets))):
        raise ValueError(f"offsets must be integers; got {offsets.dtype} {offsets.tolist()!r:.80}")
    offsets = np.ascontiguousarray(offsets, dtype=np.int64)
    if offsets.ndim != 1 or offsets.size < 1 or offsets[0] != 0 or offsets[-1] != knots.size:
        raise ValueError("offsets must run from 0 to len(knots)")
    if (np.diff(offsets) < 0).any():
        raise ValueError("offsets must be non-decreasing")
    return knots, offsets


def check_indices(u: np.ndarray, indices: ArrayLike, *, closed: bool = False) -> np.ndarray:
    """A ``(B, K)`` batch of data indices as int64, each row sorted, or a ``ValueError``
    unless they are whole numbers in ``1..N-2`` (``1..N-1`` on a ``closed`` curve)."""
    idx = np.asarray(indices)
    if idx.ndim != 2:
        raise ValueError(f"indices must have shape (B, K); got {idx.shape}")
    if idx.size and not np.issubdtype(idx.dtype, np.integer):
        if not np.array_equal(idx, np.round(idx)):
            raise ValueError("indices must be integers")
        idx = idx.astype(np.int64)
    last = u.size - (1 if closed else 2)
    if idx.size and (idx.min() < 1 or idx.max() > last):
        raise ValueError(f"indices must lie in 1..{last} "
                         f"({'data points after the first' if closed else 'interior data points'})")
    return np.sort(idx.astype(np.int64, copy=False), axis=1)


def stack_indices(u: np.ndarray, indices: ArrayLike, *, closed: bool = False
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Flatten a ``(B, K)`` batch of data indices (each sorted per row) to knots plus offsets.

    Rows are sorted; repeated indices are kept and reported by the evaluator as coincident knots.
    Indices lie in ``1..N-2`` (the interior data points), or ``1..N-1`` on a ``closed`` curve.
    """
    idx = check_indices(u, indices, closed=closed)
    counts = np.full(idx.shape[0], idx.shape[1], dtype=np.int64)
    return np.ascontiguousarray(u[idx].ravel()), _offsets(counts)


def as_positions(positions: ArrayLike) -> np.ndarray:
    """Knot positions as a float64 array, or a ``ValueError`` for complex values (the cast would
    drop their imaginary parts with only a warning)."""
    if np.iscomplexobj(positions):
        raise ValueError("knot positions must be real numbers; got complex values")
    return np.asarray(positions, dtype=np.float64)


def stack_positions(positions: ArrayLike, *, nan_is_absent: bool = False
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Flatten a ``(B, K)`` batch of continuous knot positions (sorted per row) plus offsets.

    Values outside the parameter range and coincident positions are left for the evaluator to
    report as infeasible; so is NaN, unless ``nan_is_absent``: then a NaN entry means "no knot"
    (rows of different knot counts in one batch).
    """
    pos = as_positions(positions)
    if pos.ndim != 2:
        raise ValueError(f"positions must have shape (B, K); got {pos.shape}")
    pos = np.sort(pos, axis=1)  # NaN sorts last
    if nan_is_absent:
        present = ~np.isnan(pos)
        return np.ascontiguousarray(pos[present]), _offsets(present.sum(axis=1))
    counts = np.full(pos.shape[0], pos.shape[1], dtype=np.int64)
    return np.ascontiguousarray(pos.ravel()), _offsets(counts)
