"""The three knot-placement problems over one point set.

=================  ==================  =============================================
problem            candidate           knots
=================  ==================  =============================================
``KnotSelection``  0/1 mask, N - 2     data parameters of the selected interior points
``KnotIndices``    K data indices      data parameters at those indices (a set)
``FreeKnots``      K real positions    the positions themselves (a set)
=================  ==================  =============================================

The end points are always knots (clamped spline). All three evaluate a whole batch in compiled
code and score it with an objective chosen by name (see :mod:`metaknot.problems.objectives`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, replace
from typing import Any, Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike

from metaknot.bspline import BatchFit, CurveFit
from metaknot.bspline._moves import mask_replacements
from metaknot.bspline.curve import Curve, make_curve
from metaknot.bspline.knots import check_multiplicity, stack_positions
from metaknot.bspline.moves import PATH_DELTA, MoveEvaluator
from metaknot.problem import Encoding, Problem
from metaknot.registry import register
from metaknot.task import ProblemView
from metaknot.validate import check_flag, is_integer, is_real

from .curves import PointSet, get_curve
from .objectives import DataInfo, Objective, _metrics_kernel, get_objective

_NO_VALUES = np.empty(0)

__all__ = ["FreeKnotSpace", "FreeKnots", "KnotIndices", "KnotProblem", "KnotSelection",
           "KnotSolution", "KnotSpace", "is_mask"]


@runtime_checkable
class KnotSpace(ProblemView, Protocol):
    """What an optimizer may rely on of a knot problem, seen directly or through its
    :class:`~metaknot.Task`: besides what it sees of any problem (a
    :class:`~metaknot.task.ProblemView`), the data parameters and points, the degree, whether
    the curve is closed, the open interval interior knots lie in, and the highest data index a
    knot may sit at, the objective and what it knows of the data (``info``), and the start
    knots of a count. ``isinstance(problem, KnotSpace)`` is
    the one test of "a knot problem" (duck-typed: wrappers of one pass too)."""

    # read-only settings (properties: a task's are)
    @property
    def data(self) -> PointSet: ...

    @property
    def params(self) -> np.ndarray: ...

    @property
    def points(self) -> np.ndarray: ...

    @property
    def degree(self) -> int: ...

    @property
    def closed(self) -> bool: ...

    @property
    def objective(self) -> Objective: ...

    @property
    def info(self) -> DataInfo: ...

    @property
    def knot_bounds(self) -> tuple[float, float]: ...

    @property
    def last_candidate_point(self) -> int: ...

    def start_knots(self, count: int) -> np.ndarray: ...


@runtime_checkable
class FreeKnotSpace(KnotSpace, Protocol):
    """A knot problem over continuous knot positions (:class:`FreeKnots`): ``n_knots``
    positions, NaN-padded to fewer with ``variable_count`` (:meth:`FreeKnots.pad`)."""

    @property
    def n_knots(self) -> int: ...

    @property
    def variable_count(self) -> bool: ...

    @property
    def merge_spacing(self) -> float | None: ...

    def pad(self, positions: ArrayLike) -> np.ndarray: ...


def is_mask(problem: ProblemView) -> bool:
    """Whether ``problem``'s candidates are masks over the candidate data points
    (:class:`KnotSelection`): 0/1, or a multiplicity ``0..max_multiplicity`` per point. Its
    entries may be 0, where an index set's (:class:`KnotIndices`) start at 1 and free knots
    are continuous."""
    encoding = problem.encoding
    return encoding.kind == "binary" or (encoding.kind == "integer"
                                         and int(encoding.lower.min()) == 0)


@dataclass(frozen=True, eq=False)
class KnotSolution:
    """A decoded candidate: its fitted spline and objective value.

    Attributes
    ----------
    x
        The candidate.
    objective_value
        Its objective value (the problem's ``objective`` names the objective); for the
        two-objective ``pareto``, its two scaled values.
    fit
        The fitted spline and its metrics.
    """

    x: np.ndarray
    objective_value: float | np.ndarray
    fit: CurveFit

    @property
    def metrics(self) -> dict[str, float]:
        """The fit's metrics (control points, SSE, RMSE, Euclidean distance, max deviation)."""
        return self.fit.metrics


class FitMetrics(Mapping[str, np.ndarray]):
    """The metrics of a batch of fits a run's trace records: ``rmse``, ``n_control_points``
    and, when the fits have it, ``max_deviation`` per candidate, NaN for an infeasible one.

    Computed when one is first read (all at once): a run's trace reads them only at its
    improvements and checkpoints, a small share of its batches.
    """

    __slots__ = ("_fit", "_n_points", "_names", "_values")

    def __init__(self, fit: BatchFit, n_points: int) -> None:
        self._fit = fit
        self._n_points = n_points
        self._names = _METRIC_NAMES[fit.max_deviation is not None]
        self._values: dict[str, np.ndarray] | None = None

    def __getitem__(self, name: str) -> np.ndarray:
        values = self._values
        if values is None:
            values = self._values = self._compute()
        return values[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)

    def __repr__(self) -> str:
        return f"FitMetrics({dict(self)!r})"

    def _compute(self) -> dict[str, np.ndarray]:
        fit = self._fit
        size, deviation = fit.sse.size, fit.max_deviation
        values = {name: np.empty(size) for name in self._names}
        _metrics_kernel(
            fit.sse, fit.sse if deviation is None else deviation, fit.n_control_points,
            fit.reason, self._n_points, values["rmse"], values["n_control_points"],
            values.get("max_deviation", _NO_VALUES))
        return values


#: The metrics of a batch, without and with the maximum deviation.
_METRIC_NAMES = {False: ("rmse", "n_control_points"),
                 True: ("rmse", "n_control_points", "max_deviation")}


def _as_point_set(points: PointSet | str | ArrayLike) -> PointSet:
    if isinstance(points, PointSet):
        return points
    if isinstance(points, str):
        return get_curve(points)
    return PointSet(np.asarray(points, dtype=np.float64))


class KnotProblem(Problem):
    """Common machinery: data, parameterization, degree, objective.

    Candidates made from one incumbent by local moves are scored by exact delta evaluation
    (:meth:`evaluate_near`, :mod:`metaknot.bspline.moves`) on open and closed curves; set
    ``delta_evaluation`` to False to fit every candidate in full (the values are the same).

    Parameters
    ----------
    points
        A :class:`PointSet`, the name of a seed curve, or an ``(N, d)`` array.
    degree
        Spline degree, 1..5 (default 3, cubic).
    parameterization
        ``"uniform"``, ``"chord"`` or ``"centripetal"`` (the seed's choice, default); ignored when
        the point set carries explicit parameter values.
    objective
        ``"paper"``, ``"bic"``, ``"error_bounded"`` or an :class:`Objective` instance.
    objective_options
        Keyword options of the objective (for example ``{"tolerance": 1e-3}``).
    closed
        A closed outline: a periodic spline, its parameters over [0, 1) with the closing
        chord, point 0 always at a breakpoint; the other points (1..N-1) are the candidate
        knots. A last point that repeats the first (as the seed's epitrochoid and Vivaldi
        curves do) is dropped.
    """

    public_attributes = Problem.public_attributes | {
        "data", "points", "params", "degree", "closed", "parameterization", "objective",
        "info", "knot_bounds", "last_candidate_point", "start_knots", "max_multiplicity"}
    metric_names = ("n_control_points", "sse", "rmse", "euclidean_distance", "max_deviation")
    #: How often an interior knot of a candidate may repeat (1: distinct knots; a problem
    #: that makes multiple knots sets it up to the degree).
    max_multiplicity = 1

    def __init__(self, points: PointSet | str | ArrayLike = "epitrochoid", *, degree: int = 3,
                 parameterization: str = "centripetal", objective: str | Objective = "paper",
                 objective_options: dict[str, Any] | None = None, closed: bool = False) -> None:
        self.data = _as_point_set(points)
        #: the curve model: open (a clamped spline) or closed (a periodic one)
        self.curve = make_curve(self.data.points, degree=degree,
                                parameterization=parameterization, closed=closed,
                                params=self.data.params)
        if self.curve.n_points < self.data.n_points:  # a closed outline's repeated first point
            self.data = replace(self.data, points=self.curve.points)
        self.degree = self.curve.degree
        self.closed = self.curve.closed
        self.params = self.curve.params
        self.parameterization = "explicit" if self.data.params is not None else parameterization
        self.objective = get_objective(objective, **(objective_options or {}))
        self.info = DataInfo(self.data.n_points, self.data.dim, self.data.scale, self.degree,
                             self.curve.extra_control_points)
        self.delta_evaluation = True
        self._moves: MoveEvaluator | None = None
        self._moves_key: bytes | None = None

    @property
    def points(self) -> np.ndarray:
        return self.data.points

    @property
    def n_objectives(self) -> int:
        """2 for the objective ``pareto`` (control points and error), else 1."""
        return self.objective.n_objectives

    def _fit_batch(self, X: np.ndarray) -> BatchFit:
        raise NotImplementedError

    def _interior_knots(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def evaluate_details(self, X: ArrayLike) -> tuple[np.ndarray, BatchFit]:
        """Objective values plus the per-candidate fit statistics."""
        fit = self._fit_batch(self.encoding.check(X))
        return self._values(fit), fit

    def evaluate(self, X: np.ndarray) -> np.ndarray:
        return self.evaluate_details(X)[0]

    def evaluate_with_metrics(self, X: np.ndarray) -> tuple[np.ndarray, Mapping[str, np.ndarray]]:
        """Objective values plus ``rmse``, ``n_control_points`` (and ``max_deviation`` when the
        objective computes it) per candidate; NaN for infeasible candidates. ``X`` is a batch
        checked by the encoding, as the evaluator passes it.

        A subclass that overrides :meth:`evaluate` is respected: its values are returned,
        without metrics.
        """
        if type(self).evaluate is not KnotProblem.evaluate:
            return self.evaluate(X), {}
        fit = self._fit_batch(X)  # checked by the evaluator
        return self._values(fit), self._metrics(fit)

    def evaluate_near(self, X: np.ndarray, near: np.ndarray
                      ) -> tuple[np.ndarray, Mapping[str, np.ndarray], int | np.ndarray]:
        """:meth:`evaluate_with_metrics` for candidates made from ``near`` by local moves.

        The candidates are scored by a :class:`MoveEvaluator` (on closed curves its periodic
        counterpart) bound to ``near`` (kept between calls, moved when ``near`` changes): the
        same values as a full evaluation, each candidate decided by delta evaluation where it
        can be. Returns the values, the metrics and which candidates the delta path decided
        (a boolean per candidate; for a single candidate, 1 or 0).
        """
        near = np.asarray(near)
        if near.ndim != 1:  # the compiled move evaluation takes one 1-D candidate
            if near.ndim != 2 or near.shape[0] != 1:
                raise ValueError(f"near must be one candidate, shape ({self.encoding.n_var},); "
                                 f"got {near.shape}")
            near = near[0]
        moves = self._move_evaluator(near) if self.delta_evaluation \
            and type(self).evaluate is KnotProblem.evaluate else None
        if moves is None:
            return (*self.evaluate_with_metrics(X), 0)
        fit, path = self._evaluate_moves(moves, X, near)  # X checked by the evaluator
        delta = int(path[0] == PATH_DELTA) if path.size == 1 else path == PATH_DELTA
        return self._values(fit), self._metrics(fit), delta

    def _move_evaluator(self, near: np.ndarray) -> MoveEvaluator | None:
        """The move evaluator bound to ``near`` (None if ``near`` cannot be fitted)."""
        near = np.asarray(near)
        key = near.dtype.str.encode() + near.tobytes()
        if key != self._moves_key:
            self._moves_key = key
            near = self.encoding.check(near)[0]
            # None for an infeasible incumbent: candidates are then fitted in full
            self._moves = self.curve.move_evaluator(self._interior_knots(near), self._moves,
                                                    max_multiplicity=self.max_multiplicity)
        return self._moves

    def _stack(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Candidates (checked by the encoding) as flattened interior knots and row offsets."""
        raise NotImplementedError

    def _evaluate_moves(self, moves: MoveEvaluator, X: np.ndarray, near: np.ndarray
                        ) -> tuple[BatchFit, np.ndarray]:
        """Score the candidates ``X`` made from ``near`` with the move evaluator bound to it."""
        return moves.evaluate(*self._stack(X), max_deviation=self.objective.needs_max_deviation)

    def _values(self, fit: BatchFit) -> np.ndarray:
        """The objective's values of the fitted candidates."""
        return self.objective(fit, self.info)

    def _metrics(self, fit: BatchFit) -> FitMetrics:
        """``rmse``, ``n_control_points`` (and ``max_deviation`` when computed) per candidate;
        NaN for an infeasible one (computed when first read)."""
        return FitMetrics(fit, self.info.n_points)

    def decode(self, x: ArrayLike) -> KnotSolution:
        """Fit the spline for candidate ``x``.

        Raises
        ------
        ValueError
            If the candidate's knots cannot be fitted (the message names the reason).
        """
        X = self.encoding.check(x)
        if X.shape[0] != 1:
            raise ValueError(f"decode takes one candidate, shape ({self.encoding.n_var},); got "
                             f"{X.shape}")
        row: np.ndarray = X[0]
        value = self._values(self._fit_batch(X))[0]  # X checked above
        value = float(value) if np.ndim(value) == 0 else value
        # its knots (1-D, from the checked candidate) and the multiplicity (checked when the
        # problem was made) are fitted without a second check, as _fit_batch fits them
        return KnotSolution(x=row, objective_value=value,
                            fit=self.curve._fit(self._interior_knots(row), self.max_multiplicity))

    def describe(self) -> dict[str, Any]:
        """Problem name, encoding and every setting: the data (name, fingerprint, size, noise),
        degree, parameterization, the objective's name and options (``objective.<option>``)."""
        return {**super().describe(), **self.data.describe(), "degree": self.degree,
                "parameterization": self.parameterization, "closed": self.closed,
                **self.objective.describe()}

    @property
    def knot_bounds(self) -> tuple[float, float]:
        """The open interval interior knots lie in: ``(u_0, u_{N-1})`` (open), ``(0, 1)``
        (closed)."""
        return self.curve.knot_bounds

    @property
    def last_candidate_point(self) -> int:
        """The highest data index a knot can sit at: N - 2 (open), N - 1 (closed)."""
        return self.curve.max_index

    def start_knots(self, count: int) -> np.ndarray:
        """``count`` interior knots to start a search from
        (:meth:`~metaknot.bspline.curve.Curve.start_knots`: the averaging knots, or on a
        closed outline beyond their range evenly spread breakpoints)."""
        return self.curve.start_knots(count)


@register("mask")
class KnotSelection(KnotProblem):
    """The seed paper's encoding: a 0/1 mask over the interior data points (``N - 2`` bits).

    ``density`` is the probability that a random candidate selects a point (the seed: 0.5).

    With ``max_multiplicity`` above 1 (up to the degree) a candidate gives each interior data
    point a multiplicity, ``0..max_multiplicity`` (an integer encoding): a knot repeated that
    many times, so that a search can place kinks and corners (a knot of multiplicity m leaves
    the spline C^(p - m) there). A random candidate still selects each point with probability
    ``density``, once. Local moves are then fitted in full.
    """

    public_attributes = KnotProblem.public_attributes | {"density"}

    def __init__(self, points: PointSet | str | ArrayLike = "epitrochoid", *,
                 density: float = 0.5, max_multiplicity: int = 1, **kwargs: Any) -> None:
        super().__init__(points, **kwargs)
        if not 0.0 <= density <= 1.0:
            raise ValueError(f"density must lie in [0, 1]; got {density}")
        self.density = float(density)
        self.max_multiplicity = check_multiplicity(max_multiplicity, self.degree)
        n_var = self.last_candidate_point
        self.encoding = Encoding.binary(n_var) if self.max_multiplicity == 1 else \
            Encoding.integer(n_var, 0, self.max_multiplicity)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        return (rng.random((n, self.encoding.n_var)) < self.density).astype(np.int64)

    def _fit_batch(self, X: np.ndarray) -> BatchFit:
        if self.max_multiplicity == 1:  # masks checked by the encoding
            return self.curve._evaluate_masks(X, self.objective.needs_max_deviation)
        counts = np.asarray(X, dtype=np.int64)  # checked by the encoding: 0..max_multiplicity
        knots = np.repeat(np.tile(self.curve.candidate_params, len(counts)), counts.ravel())
        offsets = np.concatenate(([0], np.cumsum(counts.sum(axis=1))))
        return self.curve.evaluate_knots(knots, offsets,
                                         max_deviation=self.objective.needs_max_deviation,
                                         max_multiplicity=self.max_multiplicity)

    def _interior_knots(self, x: np.ndarray) -> np.ndarray:
        return np.repeat(self.curve.candidate_params, np.asarray(x).astype(np.int64))

    def _evaluate_moves(self, moves: MoveEvaluator, X: np.ndarray, near: np.ndarray
                        ) -> tuple[BatchFit, np.ndarray]:
        """Masks as replacements of ``near``'s knots between the first and last flipped bit:
        no whole knot vectors to compare."""
        starts, stops, inserted, offsets = mask_replacements(
            self.params, np.asarray(near, dtype=np.int64), X)
        return moves._evaluate(inserted, offsets, self.objective.needs_max_deviation, starts,
                               stops)

    def describe(self) -> dict[str, Any]:
        multiple = {} if self.max_multiplicity == 1 else \
            {"max_multiplicity": self.max_multiplicity}
        return {**super().describe(), "density": self.density, **multiple}


def _check_n_knots(n_knots: int, curve: Curve) -> int:
    upper = curve.max_interior_knots
    if not is_integer(n_knots) or not 1 <= n_knots <= upper:
        raise ValueError(
            f"n_knots must be an integer in 1..{upper} ({curve.max_interior_knots_rule}) for "
            f"{curve.n_points} points "
            f"of degree {curve.degree}; got {n_knots!r}"
        )
    return int(n_knots)


@register("indices")
class KnotIndices(KnotProblem):
    """``n_knots`` interior knots at data points, given as indices in ``1..N-2``.

    Alternatives are ordered along the curve. A candidate is a set: it is sorted before fitting,
    and a repeated index (coincident knots) makes it infeasible.

    With ``max_multiplicity`` above 1 (up to the degree) an index may repeat that many times: a
    knot of that multiplicity at the data point (a kink, or a corner at the degree). A
    candidate is then a sorted multiset (the encoding's ``distinct_sorted`` is off: sampling
    and repair no longer keep the values apart), ``n_knots`` counting every copy; local moves
    are fitted in full.
    """

    public_attributes = KnotProblem.public_attributes | {"n_knots"}

    def __init__(self, points: PointSet | str | ArrayLike = "epitrochoid", *,
                 n_knots: int = 20, max_multiplicity: int = 1, **kwargs: Any) -> None:
        super().__init__(points, **kwargs)
        self.n_knots = _check_n_knots(n_knots, self.curve)
        self.max_multiplicity = check_multiplicity(max_multiplicity, self.degree)
        self.encoding = Encoding.integer(self.n_knots, 1, self.last_candidate_point,
                                         distinct_sorted=self.max_multiplicity == 1)

    def _fit_batch(self, X: np.ndarray) -> BatchFit:
        if self.max_multiplicity > 1:
            return self.curve.evaluate_knots(*self._stack(X),
                                             max_deviation=self.objective.needs_max_deviation,
                                             max_multiplicity=self.max_multiplicity)
        return self.curve.evaluate_indices(X, max_deviation=self.objective.needs_max_deviation)

    def _interior_knots(self, x: np.ndarray) -> np.ndarray:
        return np.sort(self.params[np.asarray(x, dtype=np.int64)])

    def _stack(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # the encoding has checked X (whole numbers in 1..last_candidate_point): what
        # stack_indices gives, without checking again
        idx = np.sort(X, axis=1)
        return self.params[idx].ravel(), np.arange(0, idx.size + 1, idx.shape[1])

    def describe(self) -> dict[str, Any]:
        multiple = {} if self.max_multiplicity == 1 else \
            {"max_multiplicity": self.max_multiplicity}
        return {**super().describe(), "n_knots": self.n_knots, **multiple}


@register("free")
class FreeKnots(KnotProblem):
    """``n_knots`` interior knots anywhere in the open parameter range (for nlopt and friends).

    A candidate is sorted before fitting; coincident knots, knots on or outside the range ends,
    and knot spans that leave a basis function without data are infeasible.

    With ``variable_count=True``, ``n_knots`` is the largest number of knots and a NaN entry
    means "no knot": a search over the number of knots (as the objectives ``paper``, ``bic`` and
    ``error_bounded`` need) pads its candidates with NaN.

    With ``merge_spacing`` set (a spacing >= 0 in parameter units), knots closer than that to
    the first knot of their group are merged into one knot of higher multiplicity, at the
    group's mean, up to the degree (a knot of multiplicity m leaves the spline C^(p - m)
    there: a corner at m = p, a double knot of Kang et al.'s spline at m = 2); a group of more
    than ``degree`` knots is infeasible. The candidate keeps its ``n_knots`` entries and its
    control points count each copy. ``0`` merges only equal knots; ``None`` (default):
    coincident knots are infeasible.
    """

    public_attributes = KnotProblem.public_attributes | {"n_knots", "variable_count", "pad",
                                                         "merge_spacing"}

    def __init__(self, points: PointSet | str | ArrayLike = "epitrochoid", *,
                 n_knots: int = 20, variable_count: bool = False,
                 merge_spacing: float | None = None, **kwargs: Any) -> None:
        super().__init__(points, **kwargs)
        self.n_knots = _check_n_knots(n_knots, self.curve)
        self.variable_count = check_flag("variable_count", variable_count)
        if merge_spacing is not None and not (is_real(merge_spacing)
                                              and 0 <= merge_spacing < np.inf):
            raise ValueError(f"merge_spacing must be a number >= 0 or None; got "
                             f"{merge_spacing!r}")
        self.merge_spacing = None if merge_spacing is None else float(merge_spacing)
        if self.merge_spacing is not None:
            self.max_multiplicity = self.degree
        self.encoding = Encoding.continuous(self.n_knots, *self.curve.knot_bounds,
                                            distinct_sorted=True)

    def _fit_batch(self, X: np.ndarray) -> BatchFit:
        # NaN: no knot with variable_count, else out of range
        return self.curve.evaluate_positions(self._merged(X),
                                             max_deviation=self.objective.needs_max_deviation,
                                             nan_is_absent=self.variable_count,
                                             max_multiplicity=self.max_multiplicity)

    def _merged(self, X: np.ndarray) -> np.ndarray:
        """Candidates as they are fitted: with ``merge_spacing``, sorted and merged."""
        if self.merge_spacing is None:
            return X
        return merge_close_knots(np.sort(np.asarray(X, dtype=np.float64), axis=-1),
                                 self.merge_spacing)

    def _interior_knots(self, x: np.ndarray) -> np.ndarray:
        x = np.sort(self._merged(x))
        return x[~np.isnan(x)] if self.variable_count else x

    def _stack(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return stack_positions(self._merged(X), nan_is_absent=self.variable_count)

    def pad(self, positions: ArrayLike) -> np.ndarray:
        """A candidate from fewer than ``n_knots`` positions (NaN-padded; ``variable_count``)."""
        positions = np.sort(np.asarray(positions, dtype=np.float64).ravel())
        if positions.size > self.n_knots:
            raise ValueError(f"at most {self.n_knots} knots; got {positions.size}")
        if positions.size < self.n_knots and not self.variable_count:
            raise ValueError(f"exactly {self.n_knots} knots needed (variable_count is off); "
                             f"got {positions.size}")
        return np.concatenate((positions, np.full(self.n_knots - positions.size, np.nan)))

    def describe(self) -> dict[str, Any]:
        merge = {} if self.merge_spacing is None else {"merge_spacing": self.merge_spacing}
        return {**super().describe(), "n_knots": self.n_knots,
                "variable_count": self.variable_count, **merge}


def merge_close_knots(rows: np.ndarray, spacing: float) -> np.ndarray:
    """Sorted knot rows (NaN last) with each group of knots closer than ``spacing`` to the
    group's first knot replaced by copies of the group's mean: one knot of multiplicity the
    group's size (:class:`FreeKnots` with ``merge_spacing``). A 1-D row gives a 1-D row."""
    rows = np.asarray(rows, dtype=np.float64)
    batch = np.atleast_2d(rows)
    n_rows, width = batch.shape
    if width == 0:
        return rows.copy()
    group = np.zeros((n_rows, width), dtype=np.int64)  # group number of each knot in its row
    first = batch[:, 0].copy()  # the first knot of the current group
    for k in range(1, width):
        starts = ~(batch[:, k] - first < spacing)  # NaN starts a group of its own
        first = np.where(starts, batch[:, k], first)
        group[:, k] = group[:, k - 1] + starts
    flat = (np.arange(n_rows)[:, None] * width + group).ravel()
    sums = np.bincount(flat, weights=batch.ravel(), minlength=n_rows * width)
    counts = np.bincount(flat, minlength=n_rows * width)
    with np.errstate(invalid="ignore"):
        merged = (sums / np.maximum(counts, 1))[flat].reshape(batch.shape)
    return merged.reshape(rows.shape)
