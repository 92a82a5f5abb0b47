"""Any optimizer of nevergrad's registry on every knot problem (``nevergrad``, or by name as
``nevergrad:<variant>``, e.g. ``nevergrad:NGOpt``, ``nevergrad:DiscreteOnePlusOne``,
``nevergrad:CMA``). nevergrad is an optional dependency (``pip install metaknot[adapters]``).

The candidate is a nevergrad ``Array``: 0/1 with integer casting for masks (0 up to the largest
multiplicity for masks of multiplicities, started at 0.5 as a 0/1 mask is), integers in the
index range for ``KnotIndices`` (repaired to sorted distinct sets before evaluation, the GA's
rule), and the unit box of a :class:`~metaknot.algorithms.knot_map.KnotMap` for free knots (span
weights centred on the averaging knots). ``batch_size`` candidates are asked at a time
(nevergrad's ``num_workers``) and evaluated as one batch; the framework's budget is nevergrad's
budget, and nevergrad's random state is seeded from the run's generator.
"""

from __future__ import annotations

import numpy as np

from metaknot.optimizer import Optimizer, check_param
from metaknot.problems import is_mask
from metaknot.registry import register
from metaknot.task import ProblemView

from ._adapters import FinitePenalty, free_knots, optional_import, refuse_variable_count
from .knot_map import KnotMap

__all__ = ["NevergradOptimizer"]


def _patch_metamodel() -> None:
    """Compatibility with numpy 2: nevergrad's surrogate step (used by NGOpt and MetaModel)
    converts a 1-element array to float, which numpy 2.4 refuses with a TypeError; raised
    through ``tell`` it leaves a worker thread behind and the process never exits. Turned into
    nevergrad's own ``MetaModelFailure``, NGOpt falls back to its base optimizer, as it does for
    any other surrogate failure."""
    from nevergrad.optimization import metamodel, optimizerlib

    if getattr(optimizerlib.learn_on_k_best, "metaknot_patched", False):
        return
    learn = metamodel.learn_on_k_best

    def learn_on_k_best(*args, **kwargs):
        try:
            return learn(*args, **kwargs)
        except TypeError as exc:
            raise metamodel.MetaModelFailure(f"surrogate failed: {exc}") from exc

    setattr(learn_on_k_best, "metaknot_patched", True)  # noqa: B010 (not typed on a function)
    optimizerlib.learn_on_k_best = learn_on_k_best


@register("nevergrad")
class NevergradOptimizer(Optimizer):
    """A nevergrad optimizer by registry name.

    Parameters
    ----------
    variant
        Name in ``nevergrad.optimizers.registry`` (``NGOpt``: nevergrad's own choice).
    batch_size
        Candidates asked and evaluated together (nevergrad's ``num_workers``).
    """

    encodings = ("binary", "integer", "continuous")
    #: ``nevergrad:<name>`` in the registry sets this parameter.
    variant_parameter = "variant"

    def __init__(self, variant: str = "NGOpt", batch_size: int = 16) -> None:
        if not isinstance(variant, str) or not variant:
            raise ValueError(f"variant must be a nevergrad registry name; got {variant!r}")
        self.variant = variant
        self.batch_size = check_param("batch_size", batch_size, low=1, integer=True)

    def setup(self, problem: ProblemView, rng: np.random.Generator) -> None:
        ng = optional_import("nevergrad", "nevergrad")
        _patch_metamodel()
        if self.variant not in ng.optimizers.registry:
            import difflib

            close = difflib.get_close_matches(self.variant, list(ng.optimizers.registry), 3)
            raise ValueError(f"nevergrad has no optimizer {self.variant!r}"
                             + (f"; did you mean {', '.join(close)}?" if close else ""))
        refuse_variable_count(problem, "nevergrad")
        super().setup(problem, rng)
        encoding = problem.encoding
        n = encoding.n_var
        self.box = None
        if encoding.kind == "continuous":
            self.box = KnotMap.of(free_knots(problem, "nevergrad"))
            parametrization = ng.p.Array(shape=(n,), lower=0.0, upper=1.0)
        else:
            # a mask of multiplicities starts where a 0/1 mask does (0.5: between no knot and
            # a simple one), not at the box's centre (a multiple knot at every point: too
            # many control points, every candidate near it infeasible)
            lower, upper = float(encoding.lower.min()), float(encoding.upper.max())
            start = 0.5 if is_mask(problem) else (lower + upper) / 2.0  # nevergrad's default
            parametrization = ng.p.Array(init=np.full(n, start), lower=lower, upper=upper)
            parametrization.set_integer_casting()
        parametrization.random_state.seed(int(rng.integers(2**31)))
        budget = getattr(problem, "budget", None)
        self.ng = ng.optimizers.registry[self.variant](
            parametrization=parametrization, budget=budget, num_workers=self.batch_size)
        self._asked: list = []
        self.penalty = FinitePenalty()

    def ask(self) -> np.ndarray:
        self._asked = [self.ng.ask() for _ in range(self.batch_size)]
        values = np.array([np.asarray(c.value, dtype=np.float64) for c in self._asked])
        encoding = self.problem.encoding
        if self.box is not None:
            return np.array([self.box.knots(y) for y in values])
        X = np.rint(values).astype(np.int64)
        return encoding.repair(X) if encoding.distinct_sorted else X

    def tell(self, X: np.ndarray, F: np.ndarray) -> None:
        for candidate, value in zip(self._asked, self.penalty(F), strict=False):
            self.ng.tell(candidate, float(value))
        self._asked = []
