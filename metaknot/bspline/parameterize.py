"""Data validation and parameterization of point sequences."""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from ..validate import is_integer

__all__ = ["PARAMETERIZATIONS", "as_points", "check_coordinates", "check_degree",
           "closed_parameterize", "parameterize"]

PARAMETERIZATIONS = ("uniform", "chord", "centripetal")
#: The step between neighbours is the chord length to this power, per parameterization.
EXPONENTS = dict(zip(PARAMETERIZATIONS, (0.0, 1.0, 0.5), strict=True))
MIN_DEGREE, MAX_DEGREE = 1, 5
#: Largest coordinate magnitude accepted: squared distances summed over many points stay finite.
MAX_COORDINATE = 1e100

ParameterizationName = Literal["uniform", "chord", "centripetal"]


def check_degree(degree: int) -> int:
    """Return ``degree`` as an ``int`` after checking it lies in 1..5.

    Raises
    ------
    ValueError
        If the degree is not an integer between 1 and 5.
    """
    if not is_integer(degree):
        raise ValueError(f"degree must be an integer between 1 and 5, got {degree!r}")
    if not MIN_DEGREE <= int(degree) <= MAX_DEGREE:
        raise ValueError(f"degree must be between {MIN_DEGREE} and {MAX_DEGREE}, got {degree}")
    return int(degree)


def check_coordinates(values: np.ndarray, name: str = "points") -> None:
    """Check that every value is finite and at most ``MAX_COORDINATE`` in magnitude: the check
    of coordinates and explicit parameter values (:func:`as_points`, :func:`parameterize`,
    :func:`metaknot.fit`).

    Raises
    ------
    ValueError
        Naming ``name`` and the first row (index along the first axis) at fault.
    """
    bad = ~np.isfinite(values)
    if bad.any():
        row = int(np.argwhere(bad)[0, 0])
        raise ValueError(f"{name} contains NaN or infinite values (first at row {row})")
    big = np.abs(values) > MAX_COORDINATE
    if big.any():
        row = int(np.argwhere(big)[0, 0])
        raise ValueError(f"{name} has values of magnitude above {MAX_COORDINATE:g} (first at "
                         f"row {row}); rescale the data (squared errors would overflow)")


def as_points(points: ArrayLike, *, degree: int = 3, name: str = "points",
              closed: bool = False) -> np.ndarray:
    """Validate data points and return them as a float64 array of shape ``(N, d)``.

    A 1-D array is read as ``N`` scalar values (``d = 1``).

    Raises
    ------
    ValueError
        If the array is not 1-D or 2-D, has no coordinates, holds NaN or infinite values or
        magnitudes above ``1e100``, or has fewer than ``degree + 2`` points (too few to place a
        single interior knot; a ``closed`` outline needs 3).
    """
    try:
        arr = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array: {exc}") from None
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ValueError(f"{name} must have shape (N, d); got an array with shape {arr.shape}")
    if arr.shape[1] < 1:
        raise ValueError(f"{name} must have at least one coordinate; got shape {arr.shape}")
    check_coordinates(arr, name)
    if not closed:
        check_point_count(arr.shape[0], check_degree(degree), name)
    elif arr.shape[0] < 3:
        raise ValueError(f"a closed curve needs at least 3 points; got {arr.shape[0]}")
    return np.ascontiguousarray(arr)


def check_point_count(n_points: int, degree: int, name: str = "points") -> None:
    """Refuse fewer than ``degree + 2`` points, too few to place a single interior knot: the
    one rule (and message) of every entry point.

    Raises
    ------
    ValueError
        ``"<name>: a degree-p fit needs at least p + 2 points; got N"``.
    """
    need = degree + 2
    if n_points < need:
        raise ValueError(f"{name}: a degree-{degree} fit needs at least {need} points; "
                         f"got {n_points}")


def parameterize(
    points: ArrayLike,
    method: ParameterizationName | ArrayLike = "centripetal",
    *,
    degree: int = 3,
) -> np.ndarray:
    """Assign a parameter value to every data point.

    Parameters
    ----------
    points
        Data points, shape ``(N, d)`` (or ``(N,)`` for scalar data).
    method
        ``"uniform"`` (equal steps), ``"chord"`` (steps proportional to the distance between
        consecutive points) or ``"centripetal"`` (steps proportional to its square root), each
        normalised to ``[0, 1]``. Alternatively an array of ``N`` strictly increasing finite
        values, used as given (function data ``y = f(x)``: pass ``x``, as with FITPACK's
        ``curfit``).
    degree
        Spline degree the parameters are meant for; only used to check the number of points.

    Returns
    -------
    numpy.ndarray
        Strictly increasing parameter values, shape ``(N,)``.

    Raises
    ------
    ValueError
        On malformed points, an unknown method, explicit values of the wrong length or not
        strictly increasing, or consecutive duplicate points under ``"chord"`` or
        ``"centripetal"`` (a zero chord length would give two points the same parameter).
    """
    return _parameters(as_points(points, degree=degree), method)


def _parameters(pts: np.ndarray, method: ParameterizationName | ArrayLike) -> np.ndarray:
    """:func:`parameterize` of points :func:`as_points` has checked."""
    n = pts.shape[0]
    if not isinstance(method, str):
        try:
            values = np.asarray(method, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"explicit parameter values must be numeric: {exc}") from None
        if values.shape != (n,):
            raise ValueError(
                f"explicit parameter values must have shape ({n},) to match the points; "
                f"got {values.shape}"
            )
        check_coordinates(values, "explicit parameter values")
        steps = np.diff(values)
        if (steps <= 0).any():
            i = int(np.argmax(steps <= 0))
            raise ValueError(
                f"explicit parameter values must be strictly increasing; "
                f"values[{i}] = {values[i]!r} >= values[{i + 1}] = {values[i + 1]!r}"
            )
        return np.ascontiguousarray(values)
    if method not in PARAMETERIZATIONS:
        raise ValueError(
            f"unknown parameterization {method!r}; choose one of {', '.join(PARAMETERIZATIONS)} "
            "or pass an array of parameter values"
        )
    if method == "uniform":
        return np.linspace(0.0, 1.0, n)
    # scale to unit size first: the parameters are scale-invariant and nothing can overflow
    chords = np.linalg.norm(np.diff(pts / np.abs(pts).max(initial=1e-300), axis=0), axis=1)
    zero = chords <= 0.0
    if zero.any():
        i = int(np.argmax(zero))
        raise ValueError(
            f"points {i} and {i + 1} coincide (zero chord length); remove consecutive "
            f"duplicate points or use the 'uniform' parameterization"
        )
    steps = np.sqrt(chords) if method == "centripetal" else chords
    u = np.concatenate(([0.0], np.cumsum(steps)))
    u /= u[-1]
    u[-1] = 1.0
    if (np.diff(u) <= 0).any():  # steps below rounding relative to the total length
        raise ValueError(
            f"{method} parameterization is degenerate: some consecutive points are too close "
            "relative to the curve length to get distinct parameter values"
        )
    return u


def closed_parameterize(points: ArrayLike, method: str = "centripetal") -> np.ndarray:
    """Parameter values in [0, 1) of a closed outline (the closing chord included): the step
    from each point to the next is its chord length to the power 0 (``"uniform"``), 1
    (``"chord"``) or 1/2 (``"centripetal"``).

    Raises
    ------
    ValueError
        For an unknown method, fewer than 3 points, consecutive repeated points (the closing
        pair included) or points too close to get distinct parameters.
    """
    if method not in EXPONENTS:
        raise ValueError(f"parameterization must be one of {', '.join(EXPONENTS)}; "
                         f"got {method!r}")
    q = np.asarray(points, dtype=np.float64)
    q = q[:, None] if q.ndim == 1 else q
    if q.shape[0] < 3:
        raise ValueError(f"a closed curve needs at least 3 points; got {q.shape[0]}")
    chords = np.linalg.norm(np.diff(np.vstack((q, q[:1])), axis=0), axis=1)
    if (chords == 0).any():
        i = int(np.argmax(chords == 0))
        raise ValueError(f"point {(i + 1) % len(q)} repeats point {i}; a closed outline "
                         "lists each point once (do not repeat the first at the end)")
    steps = chords ** EXPONENTS[method]
    u = np.concatenate(([0.0], np.cumsum(steps[:-1]))) / steps.sum()
    if (np.diff(u) <= 0).any() or u[-1] >= 1.0:  # steps below rounding against the total
        raise ValueError(f"{method} parameterization is degenerate: some consecutive points "
                         "are too close relative to the outline's length to get distinct "
                         "parameter values")
    return u
