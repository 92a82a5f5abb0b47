"""``minimize``: run an optimizer on a problem under a budget with one seeded generator."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np

from .budget import BudgetExhausted, Evaluator, Progress, fits_tallied
from .callbacks import Callback, ProgressBar, RunStart, TraceRecorder, as_callback
from .optimizer import Optimizer
from .problem import Problem
from .registry import get_optimizer, get_problem
from .result import RunResult
from .validate import check_flag, is_integer

__all__ = ["ProgressBar", "make_rng", "minimize"]


def _check_seed(seed: object) -> None:
    if seed is not None and not isinstance(seed, np.random.SeedSequence) and (
            not is_integer(seed) or seed < 0):
        raise ValueError(f"seed must be a non-negative integer, a numpy SeedSequence or None; "
                         f"got {seed!r}")


def make_rng(seed: int | np.random.SeedSequence | None) -> np.random.Generator:
    """The run's single random generator, built from a ``SeedSequence``."""
    _check_seed(seed)
    if isinstance(seed, np.random.SeedSequence):
        return np.random.default_rng(seed)
    return np.random.default_rng(np.random.SeedSequence(seed))


def minimize(
    problem: Problem | str,
    optimizer: Optimizer | str,
    *,
    budget: int,
    seed: int | np.random.SeedSequence | None = None,
    callbacks: Sequence[Callback | Callable[[Progress], bool | None]] | Callback
    | Callable[[Progress], bool | None] = (),
    progress: bool = False,
    problem_kwargs: dict[str, Any] | None = None,
    optimizer_kwargs: dict[str, Any] | None = None,
    checkpoints_per_decade: int = 10,
) -> RunResult:
    """Minimise ``problem`` with ``optimizer`` using at most ``budget`` evaluations.

    Parameters
    ----------
    problem, optimizer
        Instances, or registry names (built with ``problem_kwargs`` / ``optimizer_kwargs``).
        The optimizer is set up on the problem's :class:`~metaknot.Task` (it cannot evaluate).
    budget
        Hard cap on objective evaluations, enforced by the framework.
    seed
        Seed of the run's single ``numpy.random.Generator``: an int or a ``SeedSequence`` (its
        entropy and spawn key are recorded); the same seed gives the same result.
    callbacks
        :class:`~metaknot.callbacks.Callback` objects (start / batch / end) or plain callables
        called after every evaluated batch with a :class:`~metaknot.Progress`;
        returning ``True`` stops the run. A single one may be given as it is.
    progress
        Show a progress bar over the evaluations (hidden when the output is not a terminal).
    checkpoints_per_decade
        Density of the trace's log-spaced checkpoints.

    Returns
    -------
    RunResult
        Best solution, its decoded spline, the trace and the timings. The run is audited: if
        the model layer made more fits while the optimizer was set up and ran than the run
        accounts for (its evaluations, further fits made during the evaluator's calls,
        declared external fits), or the budget changed, the result has
        ``status="budget_violation"``, the reason in ``error`` and both counts
        (``audited_fits``, ``accounted_fits``).

    Raises
    ------
    Exception
        Whatever the optimizer or problem raised; if anything was evaluated, the exception's
        ``partial_result`` holds the best so far (status ``"failed"``).
    KeyboardInterrupt
        On Ctrl-C, also when it arrives inside compiled code (which hands it back as the
        cause of a ``SystemError``), with ``partial_result`` as above.
    """
    _check_seed(seed)
    check_flag("progress", progress)
    if isinstance(problem, str):
        problem = get_problem(problem, **(problem_kwargs or {}))
    if isinstance(optimizer, str):
        optimizer = get_optimizer(optimizer, **(optimizer_kwargs or {}))
    described = problem.describe()  # the problem as it is run, for the record
    recorder = TraceRecorder(checkpoints_per_decade)
    if isinstance(callbacks, Callback) or callable(callbacks):
        callbacks = (callbacks,)  # one callback, not in a sequence
    hooks = [*(as_callback(c) for c in callbacks), *([ProgressBar()] if progress else [])]
    evaluator = Evaluator(problem, budget, hooks, trace=recorder)
    for hook in (recorder, *hooks):
        hook.on_start(RunStart(problem, optimizer, evaluator.budget))
    clock = _Clock()
    audit = _Audit(evaluator)
    result = None
    try:
        with clock("setup_seconds"):
            optimizer.setup(evaluator.task, make_rng(seed))
        with clock("optimize_seconds"), contextlib.suppress(BudgetExhausted):
            optimizer.run(evaluator)
        audit.close()
        result = _record(problem, described, optimizer, seed, evaluator, recorder, clock,
                         audit)
    except Exception as exc:
        # keep what was computed: the best so far rides on the exception
        audit.close()
        if evaluator.n_evaluations:
            result = _record(problem, described, optimizer, seed, evaluator, recorder, clock,
                             audit, error=f"{type(exc).__name__}: {exc}")
            setattr(exc, "partial_result", result)  # noqa: B010 (not an attribute of the type)
            exc.add_note(f"metaknot: the run stopped after {evaluator.n_evaluations} "
                         "evaluations; the exception's `partial_result` holds the best so far")
        interrupt = interrupt_behind(exc)
        if interrupt is not None:  # Ctrl-C, not a fault of the run
            if result is not None:
                setattr(interrupt, "partial_result", result)  # noqa: B010 (as above)
            raise interrupt from None
        raise
    finally:
        for hook in hooks:
            hook.on_end(result)
    return result


def interrupt_behind(exc: BaseException) -> KeyboardInterrupt | None:
    """The :class:`KeyboardInterrupt` behind ``exc`` (its cause or context, however deep), if
    there is one: Ctrl-C that arrives while compiled code runs comes back as a ``SystemError``
    ("returned a result with an exception set") whose cause is the interrupt."""
    seen: set[int] = set()
    current: BaseException | None = exc
    while current is not None and id(current) not in seen:
        if isinstance(current, KeyboardInterrupt):
            return current
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return None


class _Audit:
    """The run's audit: the model fits tallied while the optimizer was set up and ran
    (:func:`~metaknot.budget.add_fits`) against the fits the evaluator accounts for, and the
    budget against its value at the start.

    The audit's own state lives here, in the runner, where neither the optimizer nor the
    evaluator it is handed can reach it by attribute access.
    """

    def __init__(self, evaluator: Evaluator) -> None:
        self._evaluator = evaluator
        self.budget = evaluator.budget  # as given: the record keeps it whatever happens
        self._fits_at_start = fits_tallied()
        self.audited_fits = 0
        self.accounted_fits = 0
        self.violation: str | None = None

    def close(self) -> None:
        """Take the counts at the end of the run and decide whether it kept its budget."""
        evaluator = self._evaluator
        self.audited_fits = fits_tallied() - self._fits_at_start
        self.accounted_fits = evaluator.accounted_fits
        problems = []
        if evaluator.budget != self.budget:
            problems.append(f"the budget changed from {self.budget} to {evaluator.budget} "
                            "during the run")
        if evaluator.n_evaluations > self.budget:
            problems.append(f"{evaluator.n_evaluations} evaluations were recorded against a "
                            f"budget of {self.budget}")
        if self.audited_fits > self.accounted_fits:
            problems.append(
                f"the model layer made {self.audited_fits} fits during the run, the run accounts "
                f"for {self.accounted_fits} ({evaluator.n_evaluations} evaluations, "
                f"{evaluator.external_fits} declared external fits and "
                f"{self.accounted_fits - evaluator.n_evaluations - evaluator.external_fits} "
                "more made during the evaluator's calls)")
        self.violation = "; ".join(problems) or None


class _Clock:
    """Wall-clock seconds of named sections of a run."""

    def __init__(self) -> None:
        self.start = time.perf_counter()
        self.seconds: dict[str, float] = {}

    @contextlib.contextmanager
    def __call__(self, name: str) -> Iterator[None]:
        begin = time.perf_counter()
        try:
            yield
        finally:
            self.seconds[name] = time.perf_counter() - begin


def _record(problem: Problem, described: dict[str, Any], optimizer: Optimizer, seed: Any,
            evaluator: Evaluator, recorder: TraceRecorder, clock: _Clock, audit: _Audit,
            error: str | None = None) -> RunResult:
    """The run record: ``described`` is the problem's description taken before the run."""
    best_x = evaluator.best_x
    with clock("decode_seconds"):
        try:
            solution = problem.decode(best_x) if best_x is not None else None
        except Exception:
            if error is None:
                raise
            solution = None  # already failing: keep the record without the spline
    timings = {k: clock.seconds.get(k, 0.0)
               for k in ("setup_seconds", "optimize_seconds", "decode_seconds")}
    if isinstance(seed, np.random.SeedSequence):
        entropy = seed.entropy if isinstance(seed.entropy, int) else None
        seed_value, spawn_key = entropy, tuple(int(k) for k in seed.spawn_key)
    else:
        seed_value, spawn_key = (None if seed is None else int(seed)), ()
    status = "ok" if error is None else "failed"
    if audit.violation is not None:
        status = "budget_violation"
        error = f"budget violation: {audit.violation}" + ("" if error is None else
                                                          f"; the run also failed: {error}")
    return RunResult(
        problem=problem.name,
        optimizer=optimizer.name,
        seed=seed_value,
        budget=audit.budget,
        n_evaluations=evaluator.n_evaluations,
        best_x=best_x,
        best_f=evaluator.best_f,
        trace=recorder.trace(evaluator.n_evaluations),
        elapsed=time.perf_counter() - clock.start,
        problem_info=described,
        optimizer_params=optimizer.hyperparameters(),
        solution=solution,
        seed_spawn_key=spawn_key,
        timings=timings,
        external_fits=evaluator.external_fits,
        charged_fits=evaluator.charged_fits,
        delta_evaluations=evaluator.delta_evaluations,
        status=status,
        error=error,
        audited_fits=audit.audited_fits,
        accounted_fits=audit.accounted_fits,
        metric_names=tuple(problem.metric_names),
        front=None if evaluator.front is None else evaluator.front.table(),
    )
