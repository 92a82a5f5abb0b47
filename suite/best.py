"""Best-known values of the suite's tasks: the knots, who found them, and whether optimal.

Every (instance, task) of kind ``fixed_k``, ``tolerance`` or ``seed`` carries the lowest
objective value found so far, the interior knots and candidate that reach it, the method, budget
and seed that found it, and ``proven``: true when an exhaustive search over every candidate of
the task's encoding found it (index sets of a small ``fixed_k`` task, e.g. titanium's 49 points
at ``K = 3``). The values ship in ``metaknot/suite/data/best_known.json``;
:func:`improve` (``metaknot suite best``) searches again with a portfolio of the strongest
methods and never replaces a value by a worse one.

A Pareto front (task ``front``, objective ``pareto``) is known by the best front found: its
value is the front's hypervolume gap (what a run of that task reports as ``best_f``), its
members are stored as masks (:func:`front_candidates`), and ``knots`` / ``candidate`` /
``metrics`` describe its knee. It is made of the averaging and the uniform knots at every
count, every stored knot set of the instance's other mask and index tasks, and the front stored
before: so it never gets worse.
"""

from __future__ import annotations

import itertools
import json
import math
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from metaknot.problems import KnotProblem
from metaknot.problems.objectives import Pareto

from .tasks import Task

__all__ = [
    "BEST_KNOWN_FILE",
    "KINDS_WITH_BEST",
    "PORTFOLIO",
    "BestKnown",
    "absorb",
    "front_candidates",
    "improve",
    "load_best_known",
    "save_best_known",
    "search",
    "search_front",
]

BEST_KNOWN_FILE = Path(__file__).with_name("data") / "best_known.json"
KINDS_WITH_BEST = ("fixed_k", "tolerance", "seed", "front")
#: The methods :func:`search` runs per encoding (registered optimizers and their options).
PORTFOLIO: dict[str, tuple[tuple[str, dict[str, Any]], ...]] = {
    "indices": (("ga", {}), ("local_search", {}), ("one_plus_one", {})),
    "mask": (("ga", {}), ("local_search", {}), ("one_plus_one", {})),
    "free": (("nlopt", {"restarts": 20}), ("varpro", {})),
}
#: Index-set tasks with at most this many candidates are searched exhaustively.
EXHAUSTIVE_LIMIT = 300_000
#: A new value replaces a stored one only if lower by more than this relative margin.
IMPROVEMENT = 1e-12
#: A run's candidate, evaluated again, must give its recorded value within this relative
#: difference (a delta move's value and the full fit's agree to rounding) to be absorbed.
RECHECK = 1e-8
_FORMAT_VERSION = 1


@dataclass
class BestKnown:
    """The best value known for one task on one instance.

    Attributes
    ----------
    instance, task
        Ids of the instance and the task.
    value
        The objective value.
    knots
        The interior knots (parameter values) that reach it.
    candidate
        The candidate in the task's encoding: data indices of the knots (``mask``,
        ``indices``) or the knot positions (``free``).
    method, budget, seed
        Who found it: a registered optimizer (``exhaustive`` for a complete enumeration, or
        ``<optimizer> via indices`` for a ``free`` task reached by the best index set),
        its evaluation budget and seed.
    proven
        True if no candidate of the encoding does better (exhaustive search).
    metrics
        ``n_control_points``, ``rmse`` and ``max_deviation`` of the fit.
    front
        Task ``front`` only: the front's members, each a mask as hexadecimal bytes
        (``numpy.packbits``; :func:`front_candidates` reads them); ``knots``, ``candidate``
        and ``metrics`` are then those of its knee.
    """

    instance: str
    task: str
    value: float
    knots: list[float]
    candidate: list[float]
    method: str
    budget: int
    seed: int | None
    proven: bool = False
    metrics: dict[str, float] = field(default_factory=dict)
    front: list[str] | None = None


def load_best_known(path: str | Path = BEST_KNOWN_FILE) -> dict[tuple[str, str], BestKnown]:
    """The stored best-known values by ``(instance, task)`` (empty if the file is missing)."""
    path = Path(path)
    if not path.exists():
        return {}
    data = json.loads(path.read_text())
    if data.get("version") != _FORMAT_VERSION:
        raise ValueError(f"{path}: best-known values of format {data.get('version')!r}; this "
                         f"version reads format {_FORMAT_VERSION}")
    return {(e["instance"], e["task"]): BestKnown(**e) for e in data["entries"]}


def _without_empty_front(entry: BestKnown) -> dict[str, Any]:
    data = asdict(entry)
    if data["front"] is None:
        del data["front"]
    return data


def save_best_known(entries: dict[tuple[str, str], BestKnown],
                    path: str | Path = BEST_KNOWN_FILE) -> None:
    """Write ``entries`` (sorted, one per line) atomically: a temporary file renamed over."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [json.dumps(_without_empty_front(entries[key]), separators=(",", ":"))
             for key in sorted(entries)]
    text = (f'{{"version": {_FORMAT_VERSION}, "entries": [\n' + ",\n".join(lines) + "\n]}\n")
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(text)
    os.replace(temporary, path)


def _entry(task: Task, problem: KnotProblem, x: np.ndarray, value: float, method: str,
           budget: int, seed: int | None, proven: bool = False) -> BestKnown:
    solution = problem.decode(x)
    metrics = solution.metrics
    knots = solution.fit.interior_knots
    kind = task.encoding["kind"]
    if kind == "mask":
        candidate = np.flatnonzero(solution.x).astype(float) + 1
    elif kind == "indices":
        candidate = np.sort(solution.x).astype(float)
    else:
        candidate = np.sort(solution.x)
    return BestKnown(task.instance, task.id, float(value), [float(k) for k in knots],
                     [float(c) for c in candidate], method, int(budget), seed, proven,
                     {k: float(metrics[k]) for k in ("n_control_points", "rmse",
                                                     "max_deviation")})


def candidate_of(entry: BestKnown, problem: KnotProblem) -> np.ndarray:
    """The entry's candidate as the task's problem takes it."""
    c = np.asarray(entry.candidate, dtype=np.float64)
    if problem.encoding.kind == "binary":
        x = np.zeros(problem.encoding.n_var, dtype=np.int64)
        x[c.astype(np.int64) - 1] = 1
        return x
    if problem.encoding.kind == "integer":
        return c.astype(np.int64)
    return c


def front_candidates(entry: BestKnown, problem: KnotProblem) -> np.ndarray:
    """The members of a stored front as masks of ``problem`` (shape ``(members, n_var)``)."""
    if entry.front is None:
        raise ValueError(f"{entry.instance} {entry.task}: not a front")
    n = problem.encoding.n_var
    return np.array([np.unpackbits(np.frombuffer(bytes.fromhex(member), np.uint8))[:n]
                     for member in entry.front], dtype=np.int64).reshape(-1, n)


def _front_entry(task: Task, problem: KnotProblem, X: np.ndarray, method: str,
                 budget: int) -> BestKnown | None:
    """The front of the masks ``X`` under the task's objective ``pareto`` (None if empty)."""
    from metaknot.front import ParetoArchive

    objective = problem.objective
    assert isinstance(objective, Pareto)  # a front task's objective
    archive = ParetoArchive(objective.reference, objective.ideal)
    archive.add(X, problem.evaluate(X))
    if not len(archive) or archive.X is None:
        return None
    entry = _entry(task, problem, archive.X[archive.knee()], archive.gap, method, budget, None)
    entry.front = [np.packbits(x.astype(np.uint8)).tobytes().hex() for x in archive.X]
    return entry


def search_front(task: Task, *, stored: Iterable[BestKnown] = (),
                 previous: BestKnown | None = None) -> BestKnown | None:
    """The best front of ``task`` (kind ``front``) from the averaging and the uniform knots at
    every count, the knots of ``stored`` entries (other tasks of the same instance: any knot
    set is a member candidate) and the ``previous`` front's members."""
    from metaknot.algorithms.baselines import knots_to_candidate
    from metaknot.bspline import averaging_knots

    problem = task.problem()
    u, degree = problem.params, problem.degree
    lower, upper = u[0], u[-1]
    counts = range(1, problem.last_candidate_point + 1)
    knots = [averaging_knots(u, k, degree) for k in counts if k <= u.size - degree - 1]
    knots += [np.linspace(lower, upper, k + 2)[1:-1] for k in counts]
    knots += [np.asarray(e.knots) for e in stored if e.front is None]
    candidates = [knots_to_candidate(problem, t) for t in knots]
    if previous is not None and previous.front is not None:
        candidates += list(front_candidates(previous, problem))
    X = np.unique(np.array(candidates, dtype=np.int64), axis=0)
    return _front_entry(task, problem, X, "averaging + uniform + suite knots", len(X))


def _exhaustive(task: Task, problem: KnotProblem) -> BestKnown | None:
    """The best index set of a small ``indices`` task by complete enumeration."""
    n_var, high = problem.encoding.n_var, int(problem.encoding.upper[0])
    if math.comb(high, n_var) > EXHAUSTIVE_LIMIT:
        return None
    best_value, best_x = np.inf, None
    combos = itertools.combinations(range(1, high + 1), n_var)
    while chunk := list(itertools.islice(combos, 20_000)):
        X = np.array(chunk, dtype=np.int64)
        values = problem.evaluate(X)
        i = int(np.argmin(values))
        if values[i] < best_value:
            best_value, best_x = float(values[i]), X[i]
    if best_x is None:
        return None
    return _entry(task, problem, best_x, best_value, "exhaustive", math.comb(high, n_var), None,
                  proven=True)


def search(task: Task, *, budget: int, seeds: Sequence[int] = (0,),
           start: BestKnown | None = None, incumbent: BestKnown | None = None
           ) -> BestKnown | None:
    """The best candidate the portfolio finds for ``task`` (``None`` if nothing feasible).

    Index-set tasks small enough are enumerated (and proven); the others run every method of
    :data:`PORTFOLIO` for the task's encoding with each seed. A ``free`` task also tries
    ``start`` (the best index set of the same ``K``: its knots are free positions too), and
    ``varpro`` started from it and from ``incumbent`` (the task's stored best: a local search
    from there ends no worse, and often better: on galvez_f2 at the larger K from 0.01508 to
    0.00911).
    """
    from metaknot import minimize

    problem = task.problem()
    kind = task.encoding["kind"]
    if kind == "indices":
        found = _exhaustive(task, problem)
        if found is not None:
            return found
    best: BestKnown | None = None
    for name, options in PORTFOLIO[kind]:
        for seed in seeds:
            result = minimize(problem, name, budget=budget, seed=seed,
                              optimizer_kwargs=options)
            if result.best_x is not None and (best is None or result.best_f < best.value):
                best = _entry(task, problem, result.best_x, result.best_f, name, budget, seed)
    if kind != "free":
        return best
    if start is not None:
        x = np.asarray(start.knots, dtype=np.float64)
        value = float(problem.evaluate(x[None, :])[0])
        if np.isfinite(value) and (best is None or value < best.value):
            best = _entry(task, problem, x, value, f"{start.method} via indices", start.budget,
                          start.seed, proven=False)
    for origin, entry in (("indices", start), ("best-known", incumbent)):
        if entry is None:
            continue
        x = np.sort(np.asarray(entry.knots, dtype=np.float64))
        for seed in seeds:  # variable projection from there: ends no worse than it
            result = minimize(problem, "varpro", budget=budget, seed=seed,
                              optimizer_kwargs={"initial": [float(k) for k in x]})
            if result.best_x is not None and (best is None or result.best_f < best.value):
                best = _entry(task, problem, result.best_x, result.best_f,
                              f"varpro from {origin}", budget, seed)
    return best


def improve(instance_ids: Iterable[str], *, budget: int, seeds: Sequence[int] = (0,),
            path: str | Path = BEST_KNOWN_FILE, kinds: Sequence[str] = KINDS_WITH_BEST,
            report: Callable[[str], None] = print) -> dict[str, int]:
    """Search every task with a best-known value on ``instance_ids`` (of the task ``kinds``)
    and store what improves.

    A value is replaced only by a lower one (by more than a relative ``1e-12``); a proven
    value is never searched again. The file is written after each instance, so an interrupted
    search keeps what it found. Returns counts: ``searched``, ``improved``, ``new``, ``kept``.
    """
    from .tasks import get_task, tasks

    unknown = set(kinds) - set(KINDS_WITH_BEST)
    if unknown:
        raise ValueError(f"task kinds with best-known values are {', '.join(KINDS_WITH_BEST)}; "
                         f"got {', '.join(sorted(unknown))}")
    entries = load_best_known(path)
    counts = {"searched": 0, "improved": 0, "new": 0, "kept": 0}
    instance_ids = list(instance_ids)
    for number, instance_id in enumerate(instance_ids, 1):
        report(f"[{number}/{len(instance_ids)}] {instance_id}")
        by_k: dict[int, BestKnown] = {}
        fronts: list[tuple[Task, tuple[str, str], BestKnown | None]] = []
        for task in tasks(instance_id):
            if task.kind not in kinds:
                continue
            key = (task.instance, task.id)
            old = entries.get(key)
            found: BestKnown | None
            if task.kind == "front":  # after the other tasks: their knots are members too
                fronts.append((task, key, old))
                continue
            if old is not None and old.proven:
                counts["kept"] += 1
                found = old
            else:
                counts["searched"] += 1
                found = search(task, budget=budget, seeds=seeds,
                               start=by_k.get(task.encoding.get("n_knots", -1)),
                               incumbent=old)
                if found is None:
                    report(f"{instance_id} {task.id}: nothing feasible found")
                    found = old
                elif old is None:
                    counts["new"] += 1
                    entries[key] = found
                elif found.value < old.value - IMPROVEMENT * abs(old.value):
                    counts["improved"] += 1
                    report(f"{instance_id} {task.id}: {old.value:.10g} -> {found.value:.10g} "
                           f"({found.method})")
                    entries[key] = found
                else:
                    counts["kept"] += 1
                    found = old
            if found is not None and task.encoding["kind"] == "indices":
                by_k[task.encoding["n_knots"]] = found
        for task, key, old in fronts:
            counts["searched"] += 1
            stored = [e for (i, t), e in entries.items()
                      if i == instance_id and get_task(i, t).encoding["kind"] != "free"]
            found = search_front(task, stored=stored, previous=old)
            if found is not None and (old is None or
                                      found.value < old.value - IMPROVEMENT * abs(old.value)):
                counts["new" if old is None else "improved"] += 1
                entries[key] = found
            else:
                counts["kept"] += 1
        save_best_known(entries, path)
    return counts


def absorb(runs: Iterable[Mapping[str, Any]], *, path: str | Path = BEST_KNOWN_FILE,
           report: Callable[[str], None] = print) -> dict[str, int]:
    """Store the best run of each suite task among ``runs`` where it improves the best-known
    value (``metaknot suite best --from-study``).

    Parameters
    ----------
    runs
        Run records of a study (rows of ``metaknot.experiments.load_study(...).runs``):
        ``suite.instance``, ``suite.task``, ``status``, ``best_f``, ``best_x`` and who found
        it (``label``, else ``optimizer``; ``budget``, ``seed``). Runs that did not finish
        (``status`` other than ``ok``), runs outside the suite and runs of tasks without a
        single best candidate (``front``) are passed over.
    path
        The best-known file to update (written once, at the end, if anything changed).
    report
        Receives one line per improvement and per refused run.

    Returns
    -------
    dict
        ``tasks`` (with a usable run), of which ``improved``, ``new`` and ``kept`` (a task
        without a stored value whose every run was refused is none of these), and
        ``refused``: the runs refused.

    Notes
    -----
    Per (instance, task) the runs are tried in the order of their ``best_f``, lowest first.
    A run's candidate is evaluated again on the task's problem
    (:meth:`metaknot.suite.tasks.Task.problem`); if that does not give the recorded value
    within a relative :data:`RECHECK`, the run was made on other data or settings than the
    suite's task and is refused (named in the report), and the next run is tried, as long as
    its recorded value could still improve the stored one. The first run that passes is the
    task's best: its value evaluated again is stored when it is lower than the stored one by
    more than a relative :data:`IMPROVEMENT`; a proven value is never replaced.
    """
    from .tasks import get_task

    suite_tasks: dict[tuple[str, str], Task] = {}  # by the name a record gives (an alias too)
    task_runs: dict[tuple[str, str], tuple[Task, list[Mapping[str, Any]]]] = {}
    for run in runs:
        instance, task_id = run.get("suite.instance"), run.get("suite.task")
        value = run.get("best_f")
        if (run.get("status") != "ok" or not isinstance(instance, str)
                or not isinstance(task_id, str) or value is None
                or not np.isfinite(value) or run.get("best_x") is None):
            continue
        if (instance, task_id) not in suite_tasks:
            suite_tasks[instance, task_id] = get_task(instance, task_id)
        task = suite_tasks[instance, task_id]
        # ``tolerance`` stored as the task it names
        task_runs.setdefault((instance, task.id), (task, []))[1].append(run)
    entries = load_best_known(path)
    counts = {"tasks": 0, "improved": 0, "new": 0, "kept": 0, "refused": 0}
    for key in sorted(task_runs):
        task, candidates = task_runs[key]
        if task.kind == "front" or task.kind not in KINDS_WITH_BEST:
            continue
        counts["tasks"] += 1
        old = entries.get(key)
        if old is not None and old.proven:
            counts["kept"] += 1
            continue
        problem = task.problem()
        found: tuple[Mapping[str, Any], np.ndarray, float] | None = None
        for run in sorted(candidates, key=lambda r: float(r["best_f"])):  # stable: ties in order
            recorded = float(run["best_f"])
            if old is not None and not _could_improve(recorded, old.value):
                break  # neither can the runs after it: the stored value is kept
            candidate: np.ndarray = np.asarray(run["best_x"], dtype=problem.encoding.dtype)
            value = float(problem.evaluate(candidate[None, :])[0])
            if abs(value - recorded) <= RECHECK * abs(recorded):
                found = (run, candidate, value)
                break
            counts["refused"] += 1
            report(f"{key[0]} {key[1]}: run {run.get('run_id')} recorded {recorded:.10g} but its "
                   f"candidate gives {value:.10g} on the suite's task (other data or settings?)"
                   ": not stored")
        if found is None:  # every run that could improve the stored value was refused
            if old is not None:
                counts["kept"] += 1
            continue
        run, x, value = found
        if old is not None and not value < old.value - IMPROVEMENT * abs(old.value):
            counts["kept"] += 1
            continue
        method = next((m for m in (run.get("label"), run.get("optimizer"))
                       if isinstance(m, str) and m), "unknown")
        seed = run.get("seed")  # NaN in a table of runs where some have none
        entries[key] = _entry(task, problem, x, value, method, int(run["budget"]),
                              int(seed) if seed is not None and seed == seed else None)
        if old is None:
            counts["new"] += 1
        else:
            counts["improved"] += 1
            report(f"{key[0]} {key[1]}: {old.value:.10g} -> {value:.10g} ({method}, "
                   f"run {run.get('run_id')})")
    if counts["improved"] or counts["new"]:
        save_best_known(entries, path)
    return counts


def _could_improve(recorded: float, stored: float) -> bool:
    """Whether a run that recorded ``recorded`` may, evaluated again (within a relative
    :data:`RECHECK`), improve the ``stored`` value by more than :data:`IMPROVEMENT`."""
    return recorded - RECHECK * abs(recorded) < stored - IMPROVEMENT * abs(stored)
