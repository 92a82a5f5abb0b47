"""The :class:`Problem` interface: an encoding plus a vectorised objective to minimise."""

from __future__ import annotations

import math
import threading
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Literal

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Encoding", "Problem"]

EncodingKind = Literal["binary", "integer", "continuous"]

_INT64 = np.dtype(np.int64)
_compiled = False  # whether the kernels below were replaced by numba's versions
_compiling = threading.Lock()


def _kernels() -> None:
    """Replace this module's kernels (the bounds check of :meth:`Encoding.check`, the repair of
    integer sets of :meth:`Encoding.repair`) by their numba versions, each compiled at its
    first call and cached on disk: when the first encoding of whole numbers is made, so that
    importing metaknot does not import numba. All at once, so that one calling another finds
    it compiled; once, also when threads make encodings at the same time."""
    global _compiled
    if _compiled:
        return
    from numba import njit

    with _compiling:
        if not _compiled:
            namespace = globals()
            for name in ("_within", "_distinct_nearest_rows", "_repair_sets"):
                namespace[name] = njit(cache=True)(namespace[name])
            _compiled = True


def _within(X: np.ndarray, low: int, high: int) -> bool:
    """True if every entry of ``X`` lies in ``low..high``: one pass without a branch, which the
    compiler vectorises (candidates are nearly always valid: stopping at the first one outside
    saves nothing)."""
    flat = X.ravel()
    outside = 0
    for i in range(flat.size):
        outside |= (flat[i] < low) | (flat[i] > high)
    return outside == 0


def _distinct_nearest_rows(X: np.ndarray, rows: np.ndarray, lo: int, hi: int) -> None:
    """In place, for each row index in ``rows``: the row's sorted values, in order, each moved to
    the nearest value of ``lo..hi`` not taken by an earlier one (ties: the lower), then sorted.
    """
    used = np.zeros(hi - lo + 1, dtype=np.bool_)
    for r in rows:
        row = X[r]
        used[:] = False
        for j in range(row.size):
            v = row[j]
            step = 0
            while True:
                c = v - step
                if lo <= c <= hi and not used[c - lo]:
                    break
                c = v + step
                if lo <= c <= hi and not used[c - lo]:
                    break
                step += 1
            used[c - lo] = True
            row[j] = c
        row.sort()


def _repair_sets(X: np.ndarray, lower: np.ndarray, upper: np.ndarray, lo: int,
                hi: int) -> np.ndarray:
    """:meth:`Encoding.repair` of integer sets in one pass: each row of ``X`` (int64)
    clipped to ``lower..upper`` per column, sorted, and, if a value repeats, made distinct by
    :func:`_distinct_nearest_rows`. Returns a new array."""
    out = np.empty_like(X)
    rows = np.empty(X.shape[0], dtype=np.int64)
    n_rows = 0
    for r in range(X.shape[0]):
        row = out[r]
        for j in range(X.shape[1]):
            row[j] = min(max(X[r, j], lower[j]), upper[j])
        row.sort()
        for j in range(1, row.size):
            if row[j] == row[j - 1]:
                rows[n_rows] = r
                n_rows += 1
                break
    if n_rows:
        _distinct_nearest_rows(out, rows[:n_rows], lo, hi)
    return out


@dataclass(frozen=True, eq=False)
class Encoding:
    """How a candidate solution is represented.

    Attributes
    ----------
    kind
        ``"binary"`` (0/1 vector), ``"integer"`` (ordered alternatives ``lower..upper``,
        inclusive) or ``"continuous"`` (real values in ``[lower, upper]``).
    n_var
        Length of a candidate vector.
    lower, upper
        Bounds per variable (for ``binary``: 0 and 1).
    distinct_sorted
        True if a candidate is a set: the problem sorts each candidate, and repeated values make it
        infeasible (knot indices, knot positions).
    """

    kind: EncodingKind
    n_var: int
    lower: np.ndarray
    upper: np.ndarray
    distinct_sorted: bool = False
    if TYPE_CHECKING:  # set by __post_init__; typed here only (no fields at run time)
        _low: Any = field(init=False)
        _high: Any = field(init=False)
        _uniform_bounds: bool = field(init=False)

    @classmethod
    def binary(cls, n_var: int) -> Encoding:
        return cls("binary", n_var, np.zeros(n_var), np.ones(n_var))

    @classmethod
    def integer(cls, n_var: int, lower: int, upper: int, *, distinct_sorted: bool = False):
        return cls(
            "integer", n_var, np.full(n_var, lower, dtype=np.int64),
            np.full(n_var, upper, dtype=np.int64), distinct_sorted,
        )

    @classmethod
    def continuous(cls, n_var: int, lower: float, upper: float, *, distinct_sorted: bool = False):
        return cls(
            "continuous", n_var, np.full(n_var, float(lower)), np.full(n_var, float(upper)),
            distinct_sorted,
        )

    def __setstate__(self, state: dict[str, Any]) -> None:
        """An encoding read back (pickle, copy) is made without ``__post_init__``: its
        kernels are compiled here too."""
        self.__dict__.update(state)
        if self.kind != "continuous":
            _kernels()

    def __post_init__(self) -> None:
        # scalar bounds for the common case of equal bounds on every variable (fast checks);
        # whole numbers for a binary or integer encoding, whose candidates are
        low = self.lower.min() if self.n_var else 0
        high = self.upper.max() if self.n_var else 0
        if self.kind != "continuous":
            low, high = math.ceil(low), math.floor(high)
            _kernels()  # the checks and repairs of whole numbers are compiled
        object.__setattr__(self, "_low", low)
        object.__setattr__(self, "_high", high)
        object.__setattr__(self, "_uniform_bounds", bool(
            self.n_var == 0 or ((self.lower == self.lower.min()).all()
                                and (self.upper == self.upper.max()).all())))

    @property
    def dtype(self) -> type:
        return np.float64 if self.kind == "continuous" else np.int64

    def check(self, X: ArrayLike) -> np.ndarray:
        """Return ``X`` as a 2-D array of this encoding, or raise a ``ValueError`` naming why."""
        X = np.asarray(X)
        if X.ndim != 2 or X.shape[1] != self.n_var:
            if X.ndim != 1 or X.size != self.n_var:
                raise ValueError(
                    f"candidates must have shape (B, {self.n_var}) for this {self.kind} "
                    f"encoding; got {X.shape}"
                )
            X = X[None, :]
        if X.dtype != _INT64 or self.kind == "continuous":  # int64 needs no conversion
            X = self._as_dtype(X)
        if self.kind != "continuous" and (
                not _within(X, self._low, self._high) or (
                    not self._uniform_bounds and X.size
                    and ((X < self.lower).any() or (X > self.upper).any()))):
            raise ValueError(
                f"{self.kind} candidates must lie in [{self.lower.min()}, "
                f"{self.upper.max()}]"
            )
        return X

    def _as_dtype(self, X: np.ndarray) -> np.ndarray:
        """``X`` as this encoding's dtype, or a ``ValueError`` unless it holds real numbers
        (whole numbers for a binary or integer encoding)."""
        if X.dtype == bool:
            X = X.astype(np.int64)
        if X.dtype.kind not in "iuf":  # real numbers (a cast would drop an imaginary part)
            raise ValueError("candidates must be real numbers; got complex values"
                             if X.dtype.kind == "c" else
                             f"candidates must be numeric; got dtype {X.dtype}")
        if self.kind == "continuous":
            return X.astype(np.float64, copy=False)
        if X.dtype.kind not in "iu" and (
                not np.isfinite(X).all() or not np.array_equal(X, np.round(X))):
            raise ValueError(f"{self.kind} candidates must hold whole numbers")
        return X.astype(np.int64, copy=False)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` uniformly random candidates (sets are drawn without repetition, sorted)."""
        if self.kind == "binary":
            return rng.integers(0, 2, size=(n, self.n_var))
        if self.kind == "integer":
            lo, hi = int(self.lower.min()), int(self.upper.max())
            if self.distinct_sorted:
                keys = rng.random((n, hi - lo + 1))
                return np.sort(np.argsort(keys, axis=1)[:, : self.n_var] + lo, axis=1)
            return rng.integers(self.lower, self.upper + 1, size=(n, self.n_var))
        X = rng.uniform(self.lower, self.upper, size=(n, self.n_var))
        return np.sort(X, axis=1) if self.distinct_sorted else X


    def repair(self, X: np.ndarray) -> np.ndarray:
        """Nearest valid candidates: values clipped to the bounds; for set encodings each row
        sorted, and (integer sets) every repeated value moved to the nearest unused one.

        Optimizers whose operators can leave the encoding (mutation past a bound, crossover of
        two index sets) call this on their offspring.
        """
        X = np.asarray(X)
        if X.ndim != 2 or X.shape[1] != self.n_var:  # the compiled repair trusts the width
            if X.ndim == 1 and X.size == self.n_var:
                return self.repair(X[None, :])[0]
            raise ValueError(
                f"candidates must have shape (B, {self.n_var}) for this {self.kind} encoding; "
                f"got {X.shape}"
            )
        if (self.kind == "integer" and self.distinct_sorted and X.ndim == 2
                and X.dtype == np.int64 and self.lower.dtype == np.int64
                and self.upper.dtype == np.int64):  # the same steps, compiled
            lo, hi = int(self._low), int(self._high)
            if self.n_var > hi - lo + 1:
                raise ValueError(f"cannot pick {self.n_var} distinct values from {lo}..{hi}")
            return _repair_sets(X, self.lower, self.upper, lo, hi)
        X = np.clip(X, self.lower, self.upper)
        if self.kind != "continuous":
            X = np.rint(X).astype(np.int64)
        if not self.distinct_sorted:
            return X
        X = np.sort(X, axis=1)
        if self.kind == "continuous":
            return X
        lo, hi = int(self.lower.min()), int(self.upper.max())
        if self.n_var > hi - lo + 1:
            raise ValueError(f"cannot pick {self.n_var} distinct values from {lo}..{hi}")
        rows = np.flatnonzero((np.diff(X, axis=1) == 0).any(axis=1))
        if rows.size:
            _distinct_nearest_rows(X, rows, lo, hi)
        return X


class Problem(ABC):
    """A minimisation problem over an :class:`Encoding`.

    Subclasses set :attr:`encoding` and implement :meth:`evaluate` (a whole batch at once) and
    :meth:`decode`. Objective values are finite for feasible candidates and ``+inf`` for
    infeasible ones; lower is better.
    """

    name: ClassVar[str] = "problem"
    encoding: Encoding
    if TYPE_CHECKING:  # read-only to users of a problem: a subclass may make it a property
        @property
        def n_objectives(self) -> int: ...
    else:
        #: Objectives per candidate: 1, or 2 for a front (see :mod:`metaknot.front`).
        n_objectives: int = 1
    #: Ideal and reference points of the hypervolume of a two-objective problem.
    hypervolume_box: tuple[tuple[float, float], tuple[float, float]] = ((0.0, 0.0), (1.0, 1.0))
    #: What an optimizer may read through its :class:`~metaknot.Task`, besides the encoding,
    #: ``sample`` and ``repair`` that every task offers: read-only settings, and methods that
    #: do not evaluate. Subclasses extend it with their own settings.
    public_attributes: ClassVar[frozenset[str]] = frozenset(
        {"name", "n_objectives", "hypervolume_box"})
    #: Metrics every run record of this problem has (NaN when the run found nothing feasible),
    #: as its solution's ``metrics`` gives them.
    metric_names: ClassVar[tuple[str, ...]] = ()

    @abstractmethod
    def evaluate(self, X: np.ndarray) -> np.ndarray:
        """Objective values of a batch ``X`` of shape ``(B, n_var)``; returns shape ``(B,)``
        (``(B, n_objectives)`` for a problem with several objectives)."""

    @abstractmethod
    def decode(self, x: np.ndarray) -> Any:
        """The solution a single candidate stands for (for knot problems: the fitted spline)."""

    def evaluate_with_metrics(self, X: np.ndarray
                              ) -> tuple[np.ndarray, Mapping[str, np.ndarray]]:
        """Objective values plus per-candidate metrics for the run's trace (for knot problems:
        ``rmse``, ``n_control_points`` and, when computed, ``max_deviation``). The default has
        no metrics; override to provide some without a second evaluation. The metrics are a
        mapping of names to arrays, any mapping: one that computes them when first read costs
        nothing in the batches whose metrics no callback reads.

        The evaluator calls this (and :meth:`evaluate_near`) with a batch it has checked by
        :meth:`Encoding.check`: shape ``(B, n_var)``, the encoding's dtype and bounds; a problem
        need not check it again. :meth:`evaluate`, which users call directly, checks."""
        return self.evaluate(X), {}

    def evaluate_near(self, X: np.ndarray, near: np.ndarray
                      ) -> tuple[np.ndarray, Mapping[str, np.ndarray], int | np.ndarray]:
        """:meth:`evaluate_with_metrics` for candidates made from ``near`` by local moves, plus
        which of them were decided by a cheaper path than a full evaluation: how many (an
        int), or a boolean per candidate (then an evaluator that drops the rows after an
        accepted one, :meth:`~metaknot.Optimizer.acceptance`, counts exactly the rows kept).

        The evaluator calls this when an optimizer names the origin of its batch
        (:meth:`~metaknot.Optimizer.move_origin`). The default evaluates in full (and returns
        0); a problem that can score local moves incrementally overrides it (the knot problems
        do, by exact delta evaluation). The values must be those of a full evaluation.
        """
        return (*self.evaluate_with_metrics(X), 0)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` random candidates; the default draws uniformly from the encoding."""
        return self.encoding.sample(rng, n)

    def describe(self) -> dict[str, Any]:
        """Flat description stored with every run (name, encoding, settings)."""
        return {"problem": self.name, "encoding": self.encoding.kind,
                "n_var": self.encoding.n_var}
