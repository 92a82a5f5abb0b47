"""The report of a suite study (:mod:`metaknot.suite`): the methods compared over the suite's
problems, in all and per family.

A *problem* is an (instance, task) pair; the methods are compared on the runs at the study's
largest budget (their traces hold every smaller budget's progress).

* :func:`target_hits` — COCO-style (run, target) pairs: targets relative to the best-known
  value ``f*`` (:func:`metaknot.suite.best.load_best_known`), ``f* + level · |f*|`` for each
  precision ``level`` of :data:`LEVELS`; a pair is hit at the first trace point whose best-so-far
  objective reaches it. :func:`ecdf` gives the share of pairs hit within a number of
  evaluations (pairs pooled over problems: each problem counts its runs × targets).
* :func:`performance_profile` — Dolan–Moré: per problem, each method's median final objective
  over its seeds divided by the best method's median; the share of problems within a factor τ.
* :func:`gap_table` — the median relative gap to the best-known value per method.
* :func:`wins_matrix` — wins/ties/losses of each method against each other over the problems.
* :func:`friedman_by_family` — the Friedman test over the problems (one block per problem, each
  method's median) with Nemenyi post-hoc (scikit-posthocs), over the suite, per family and,
  in a study of several tasks, per task (their objectives differ: a method may lead on one).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from .data import Comparison, suite_task_ids
from .tables import FriedmanResult, friedman_blocks

__all__ = ["LEVELS", "SuiteComparison", "ecdf", "friedman_by_family", "gap_table",
           "performance_profile", "suite_comparison", "target_hits", "wins_matrix"]

#: Precision levels of the targets, ``(f - f*) / |f*|``: 10 down to 1e-4, half a decade apart.
LEVELS = 10.0 ** np.arange(1.0, -4.25, -0.5)
#: The scope of the whole suite in per-family tables.
ALL = "all problems"
#: The prefix of a task's scope in those tables.
TASK_SCOPE = "task: "


@dataclass
class SuiteComparison:
    """A suite study's runs at its largest budget, by problem.

    Attributes
    ----------
    budget
        The budget compared.
    runs
        The runs at that budget with ``problem``, ``family``, ``task``, ``best_known``
        (``NaN`` where the problem has none usable) and ``gap`` (relative to it).
    trace
        Their trace points.
    medians
        Each method's median final objective per problem (rows: problems, in the study's
        order; columns: methods).
    families
        Each problem's family.
    tasks
        Each problem's task (``tolerance_1e-3``, ``seed``, ``fixed_k_small.indices``, ...).
    methods
        In display order.
    notes
        What was left out and why.
    """

    budget: int
    runs: pd.DataFrame
    trace: pd.DataFrame
    medians: pd.DataFrame
    families: pd.Series
    tasks: pd.Series
    methods: list[str]
    notes: list[str] = field(default_factory=list)

    @property
    def family_names(self) -> list[str]:
        return list(dict.fromkeys(self.families))

    @property
    def task_names(self) -> list[str]:
        return list(dict.fromkeys(self.tasks))


def suite_comparison(comparison: Comparison) -> SuiteComparison | None:
    """The suite view of a study (``None`` if none of its runs is on a suite task)."""
    runs = comparison.runs
    if "suite.task" not in runs or runs["suite.task"].isna().all():
        return None
    notes = []
    on_suite = runs["suite.task"].notna()
    if not on_suite.all():
        notes.append(f"{int((~on_suite).sum())} run(s) not on a suite task are left out of "
                     "the suite section.")
    runs = runs[on_suite]
    budget = int(runs.budget.max())
    if runs.budget.nunique() > 1:
        notes.append(f"The suite section compares the runs at the largest budget, {budget:,} "
                     "evaluations; the per-problem tables show every budget.")
    runs = runs[runs.budget == budget].copy()
    runs["problem"] = runs["instance"]
    runs["task"] = suite_task_ids(runs)
    runs["family"] = runs["suite.family"].astype(str)
    runs["best_known"] = _best_known(runs, notes)
    runs["gap"] = (runs.best_f - runs.best_known) / runs.best_known.abs()
    order = [i for i in comparison.instances if i in set(runs.problem)]
    medians = (runs.groupby(["problem", "method"]).best_f.median().unstack("method")
               .reindex(index=order))
    methods = [m for m in comparison.methods if m in medians]
    families = runs.groupby("problem").family.first().reindex(order)
    tasks = runs.groupby("problem").task.first().reindex(order)
    trace = comparison.trace[comparison.trace.run_id.isin(runs.run_id)]
    ran = medians[methods].notna()
    if not ran.to_numpy().all():
        groups: dict[tuple[int, tuple[str, ...]], list[str]] = {}
        for method in methods:
            key = (int(ran[method].sum()), tuple(sorted(set(tasks[ran[method]]))))
            groups.setdefault(key, []).append(method)
        parts = [f"{', '.join(names)} on {count} (tasks {', '.join(on)})"
                 for (count, on), names in groups.items()]
        notes.append(f"Not every method ran on all {len(ran)} problems: {'; '.join(parts)}. "
                     "Ranks and profiles compare a method only in the scopes where it ran on "
                     f"at least {COVERAGE:.0%} of the problems, with the methods that did, on "
                     "the problems where all of them ran.")
    return SuiteComparison(budget, runs.reset_index(drop=True), trace, medians[methods],
                           families, tasks, methods, notes)


def _best_known(runs: pd.DataFrame, notes: list[str]) -> pd.Series:
    """Each run's best-known value (``NaN`` for a problem without one, or one not above 0:
    a relative target needs ``f* > 0``), with a note on what is left out."""
    from metaknot.suite.best import load_best_known

    known = load_best_known()
    keys = list(zip(runs["suite.instance"].astype(str), runs["task"], strict=True))
    values = pd.Series([known[k].value if k in known else np.nan for k in keys],
                       index=runs.index, dtype=float)
    problems = runs.groupby("problem").task.first()
    by_problem = values.groupby(runs.problem).first()
    missing = by_problem[by_problem.isna()].index
    if len(missing):
        tasks = ", ".join(sorted(set(problems[missing])))
        notes.append(f"{len(missing)} of {len(by_problem)} problem(s) have no best-known value "
                     f"(tasks: {tasks}; `metaknot suite best` computes them): they are left "
                     "out of the target-based parts (ECDF, gap) and kept in the rank-based ones.")
    not_positive = by_problem[by_problem <= 0].index
    if len(not_positive):
        notes.append(f"{len(not_positive)} problem(s) have a best-known value ≤ 0, for which a "
                     "relative target is undefined: they are left out of the target-based "
                     "parts.")
        values[runs.problem.isin(not_positive)] = np.nan
    beaten = (runs.best_f < values).groupby(runs.problem).any()
    if beaten.any():
        notes.append(f"On {int(beaten.sum())} problem(s) a run of this study beat the "
                     "best-known value (`metaknot suite best --from-study` records it); such "
                     "runs reach every target.")
    return values


def target_hits(suite: SuiteComparison, levels: np.ndarray = LEVELS) -> pd.DataFrame:
    """Evaluations at which each run first reached each target (``inf``: never): one row per
    run with a best-known value (``run_id``, ``method``, ``problem``, ``family``), one column
    per precision level. Vectorised over the trace."""
    runs = suite.runs[suite.runs.best_known.notna()]
    reference = runs.set_index("run_id").best_known
    trace = suite.trace[suite.trace.run_id.isin(reference.index)]
    f_star = trace.run_id.map(reference).to_numpy()
    precision = (trace.best_f.to_numpy() - f_star) / np.abs(f_star)
    with np.errstate(invalid="ignore"):
        reached = precision[:, None] <= levels[None, :]
    evaluations = np.where(reached, trace.evaluations.to_numpy(dtype=float)[:, None], np.inf)
    first = (pd.DataFrame(evaluations, columns=list(levels)).groupby(trace.run_id.to_numpy())
             .min().reindex(runs.run_id, fill_value=np.inf))
    first.index.name = "run_id"
    meta = runs.set_index("run_id")[["method", "problem", "family"]]
    return meta.join(first).reset_index()


def ecdf(hits: pd.DataFrame, evaluations: np.ndarray, levels: np.ndarray = LEVELS,
         by: str | None = None) -> pd.DataFrame:
    """Share of (run, target) pairs hit within each number of ``evaluations``, per method
    (and per ``by``, e.g. ``family``): rows are evaluations, columns methods (or
    (``by``, method) pairs)."""
    keys = ["method"] if by is None else [by, "method"]
    columns = {}
    for key, part in hits.groupby(keys, sort=False):
        values = np.sort(part[list(levels)].to_numpy(dtype=float).ravel())
        share = np.searchsorted(values, evaluations, side="right") / values.size
        columns[key[0] if by is None else key] = share
    return pd.DataFrame(columns, index=pd.Index(evaluations, name="evaluations"))


def solved_table(suite: SuiteComparison, hits: pd.DataFrame,
                 levels: np.ndarray = LEVELS) -> pd.DataFrame:
    """Share of (run, target) pairs hit at the end, per method: over the suite and per family
    (one column each)."""
    reached = np.isfinite(hits[list(levels)].to_numpy(dtype=float)).mean(axis=1)
    frame = hits[["method", "family"]].assign(solved=reached)
    table = pd.DataFrame({ALL: frame.groupby("method").solved.mean()})
    table = table.join(frame.pivot_table(index="method", columns="family", values="solved",
                                         aggfunc="mean"))
    families = [f for f in suite.family_names if f in table]
    return table[[ALL, *families]].reindex([m for m in suite.methods if m in table.index])


#: A method enters a scope's rank-based comparison (Friedman ranks, profiles) if it ran on at
#: least this share of the scope's problems.
COVERAGE = 0.5


def comparable(medians: pd.DataFrame) -> pd.DataFrame:
    """The part of a scope's medians that rank-based comparisons use: the methods with a median
    on at least :data:`COVERAGE` of the scope's problems, on the problems where each of them
    has one.

    A study whose methods ran on different tasks (BOBYQA on free knots only, the mask methods
    on masks) has no problem where every method ran: each method is then compared with the
    methods of its own tasks, and a partial study keeps its methods and compares them where
    all have finished.
    """
    if medians.empty:
        return medians
    coverage = medians.notna().mean()
    return medians[[m for m in medians.columns if coverage[m] >= COVERAGE]].dropna()


def performance_profile(medians: pd.DataFrame, taus: np.ndarray) -> tuple[pd.DataFrame, int]:
    """Dolan–Moré performance profile of the median final values: for each τ, the share of
    problems on which a method's median is within a factor τ of the best method's. Compared
    are :func:`comparable`'s methods and problems; problems where the best median is not above
    0 (no ratio) are left out too. Returns the profile (rows τ, columns the methods compared)
    and the number of problems left out."""
    complete = comparable(medians)
    best = complete.min(axis=1)
    usable = np.isfinite(best) & (best > 0)
    ratios = complete[usable].to_numpy() / best[usable].to_numpy()[:, None]
    profile = (ratios[None, :, :] <= taus[:, None, None]).mean(axis=1) if len(ratios) else \
        np.full((len(taus), complete.shape[1]), np.nan)
    return (pd.DataFrame(profile, index=pd.Index(taus, name="tau"), columns=complete.columns),
            int(len(medians) - usable.sum()))


def profile_taus(medians: pd.DataFrame, points: int = 200) -> np.ndarray:
    """τ from 1 to a little beyond the largest finite ratio of the medians (at least 2)."""
    complete = comparable(medians)
    best = complete.min(axis=1)
    ratios = complete[(best > 0) & np.isfinite(best)].div(best[(best > 0)
                                                                & np.isfinite(best)], axis=0)
    finite = ratios.to_numpy()[np.isfinite(ratios.to_numpy())]
    top = max(2.0, float(finite.max()) * 1.1) if finite.size else 2.0
    return np.unique(np.concatenate([[1.0], np.geomspace(1.0, top, points)]))


def gap_table(suite: SuiteComparison) -> pd.DataFrame:
    """Per method, over the problems with a best-known value: the median over problems of
    the median relative gap ``(f - f*) / |f*|`` over seeds, its worst and the problem where it
    is (``worst problem``), the family of the largest median gap (``worst family``), and the
    shares of problems within 1 % and at (or below) the best-known value; per family and, in a
    study of several tasks, per task (``median gap: task: <id>``) the median gap. Sorted by
    the median gap."""
    runs = suite.runs[suite.runs.best_known.notna()]
    gaps = runs.groupby(["problem", "method"]).gap.median().unstack("method")
    families = suite.families.reindex(gaps.index)
    tasks = suite.tasks.reindex(gaps.index)
    several_tasks = len(suite.task_names) > 1
    rows = []
    for method in [m for m in suite.methods if m in gaps]:
        values = gaps[method].dropna()
        by_family = values.groupby(families[values.index]).median()
        row = {"method": method, "problems": len(values),
               "median gap": values.median(), "worst gap": values.max(),
               "worst problem": values.idxmax() if len(values) else None,
               "worst family": by_family.idxmax() if len(by_family) else None,
               "within 1%": (values <= 1e-2).mean(), "at best-known": (values <= 0).mean()}
        for family, median in by_family.items():
            row[f"median gap: {family}"] = median
        if several_tasks:
            for task, part in values.groupby(tasks[values.index]):
                row[f"median gap: {TASK_SCOPE}{task}"] = part.median()
        rows.append(row)
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    ordered = [f"median gap: {f}" for f in suite.family_names if f"median gap: {f}" in table]
    ordered += [f"median gap: {TASK_SCOPE}{t}" for t in suite.task_names
                if f"median gap: {TASK_SCOPE}{t}" in table]
    table = table[["method", "problems", "median gap", "worst gap", "worst problem",
                   "worst family", "within 1%", "at best-known", *ordered]]
    return table.sort_values(["median gap", "method"], kind="stable").reset_index(drop=True)


def wins_matrix(medians: pd.DataFrame, order: list[str]) -> pd.DataFrame:
    """Wins/ties/losses of the row method against the column method over the problems where
    both ran, comparing their median final values (equal medians tie): ``"W/T/L"`` text."""
    cells = {}
    for a in order:
        row = {}
        for b in order:
            if a == b:
                row[b] = "–"
                continue
            pair = medians[[a, b]].dropna()
            x, y = pair[a].to_numpy(), pair[b].to_numpy()
            row[b] = f"{int((x < y).sum())}/{int((x == y).sum())}/{int((x > y).sum())}"
        cells[a] = row
    table = pd.DataFrame.from_dict(cells, orient="index")[order]
    table.index.name = "method"
    return table.reset_index()


def friedman_by_family(suite: SuiteComparison,
                       alpha: float = 0.05) -> dict[str, FriedmanResult]:
    """The Friedman test (Nemenyi post-hoc) over the problems of the suite, of each family and,
    with several tasks, of each task (scope ``task: <id>``): one block per problem, each
    method's median final objective (:func:`comparable`'s methods and problems)."""
    scopes = {ALL: suite.medians}
    for family in suite.family_names:
        scopes[family] = suite.medians[suite.families == family]
    if len(suite.task_names) > 1:
        for task in suite.task_names:
            scopes[f"{TASK_SCOPE}{task}"] = suite.medians[suite.tasks == task]
    return {scope: friedman_blocks(comparable(medians), "best_f", alpha, blocks="problems")
            for scope, medians in scopes.items()}


def ranks_by_family(results: dict[str, FriedmanResult]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The average ranks (methods × scopes, sorted by the suite-wide rank) and the tests
    (one row per scope: problems, statistic, p, note)."""
    ranks = pd.DataFrame({scope: r.ranks for scope, r in results.items()})
    ranks = ranks.sort_values(ALL, kind="stable")
    ranks.index.name = "method"
    tests = pd.DataFrame([{"scope": scope, "problems": r.blocks, "chi2": r.statistic,
                           "p": r.p, "note": r.note} for scope, r in results.items()])
    return ranks.reset_index(), tests


def suite_summary(suite: SuiteComparison, results: dict[str, FriedmanResult],
                  solved: pd.DataFrame, alpha: float = 0.05,
                  gaps: pd.DataFrame | None = None) -> list[str]:
    """A few sentences on the suite as a whole; with the :func:`gap_table` ``gaps``, where
    each method fails: its worst problem and family, beside its rank."""
    overall = results[ALL]
    lines = []
    ranks = overall.ranks
    if len(ranks) >= 2:
        text = ", ".join(f"{m} {r:.2f}" for m, r in ranks.items())
        leaders = ranks[ranks == ranks.iloc[0]].index.tolist()
        lead = (f"{' and '.join(leaders)} tie for the best average rank" if len(leaders) > 1
                else f"**{leaders[0]}** has the best average rank")
        verdict = (f"the Friedman test finds a difference (p = {overall.p:.2g})"
                   if np.isfinite(overall.p) and overall.p < alpha else
                   f"the methods do not differ significantly (p = {overall.p:.2g})"
                   if np.isfinite(overall.p) else overall.note)
        lines.append(f"Over the {overall.blocks} problems of the suite ({len(suite.family_names)}"
                     f" families, budget {suite.budget:,}): {lead} (average ranks, 1 = best: "
                     f"{text}); {verdict}.")
    by_task = [(scope[len(TASK_SCOPE):], r) for scope, r in results.items()
               if scope.startswith(TASK_SCOPE) and len(r.ranks) > 1]
    if by_task:
        parts = []
        for task, r in by_task:
            leaders = r.ranks[r.ranks == r.ranks.min()].index.tolist()
            parts.append(f"{task}: {' and '.join(leaders)} ({r.ranks.min():.2f}, "
                         f"{r.blocks} problems)")
        lines.append("Best average rank by task: " + "; ".join(parts) + ".")
    if gaps is not None and len(gaps):
        listed = gaps.set_index("method")
        parts = []
        for method in [m for m in ranks.index if m in listed.index]:
            row = listed.loc[method]
            if row["worst problem"] is None:
                continue
            family = row["worst family"]
            parts.append(f"{method} on {row['worst problem']} (gap {row['worst gap']:.3g}; "
                         f"its worst family {family}, median gap "
                         f"{row['median gap: ' + family]:.3g})")
        if parts:
            lines.append("Where each method fails, in the order of its rank (the largest "
                         "relative gap to the best-known value): " + "; ".join(parts) + ".")
    if len(solved):
        shares = solved[ALL].sort_values(ascending=False, kind="stable")
        text = ", ".join(f"{m} {v:.0%}" for m, v in shares.items())
        lines.append(f"Share of (run, target) pairs reached at the end, targets "
                     f"{LEVELS[0]:g} to {LEVELS[-1]:g} relative to the best-known value: "
                     f"{text}.")
    return lines
