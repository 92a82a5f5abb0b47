"""A study's runs, arranged for comparison: problem instances, methods, budgets, replicates.

A *problem instance* is what the methods are compared on: the data (with its noise level), the
degree, the parameterization, the objective with its options, and the knot count K where the
encoding fixes one. A *method* is the run's ``label`` (the optimizer's name unless a
configuration names it), so the same optimizer on indices and on free knots, or tuned and
default, can be told apart. Runs are paired across methods by their replicate ``seed``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import cast

import numpy as np
import pandas as pd

from metaknot.experiments.store import DEFAULT_STUDY, StoreError, Study, load_study

__all__ = ["METRICS", "Comparison", "ReportError", "prepare"]

#: Outcome columns of the seed paper's tables, lower is better for each.
METRICS = {
    "best_f": "objective",
    "rmse": "RMSE",
    "euclidean_distance": "Euclidean distance",
    "max_deviation": "max deviation",
    "n_control_points": "control points",
}
#: Settings that make a problem instance (those that vary within a study name it).
INSTANCE_SETTINGS = ("data", "n_points", "noise", "degree", "parameterization", "objective",
                     "n_knots", "closed")
SHORT = {"n_points": "N", "noise": "σ", "degree": "p", "parameterization": "", "objective": "",
         "n_knots": "K", "closed": "closed"}


class ReportError(ValueError):
    """The study cannot be reported on; the message says why (no traceback needed)."""


@dataclass
class Comparison:
    """The runs of a study arranged for comparison.

    Attributes
    ----------
    study
        The study as read from the store (never modified).
    runs
        The ``ok`` runs, with ``instance`` (a readable name), ``method`` and ``budget``.
    trace
        The trace points of those runs, with ``instance`` and ``method``.
    instances, methods, budgets
        In display order.
    """

    study: Study
    runs: pd.DataFrame
    trace: pd.DataFrame
    instances: list[str]
    methods: list[str]
    budgets: list[int]
    notes: list[str] = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.study.name

    def cell_counts(self) -> pd.DataFrame:
        """Runs per instance, budget and method (to show where a partial study is thin)."""
        return (self.runs.groupby(["instance", "budget", "method"], sort=False).size()
                .rename("runs").reset_index())


def prepare(study: Study | str | Path) -> Comparison:
    """Read (if a path) and arrange a study; raises :class:`ReportError` if nothing to report."""
    if not isinstance(study, Study):
        try:
            study = load_study(study)
        except StoreError as exc:
            raise ReportError(str(exc)) from None
    runs = study.runs
    if runs.empty:
        raise ReportError(f"{study.path}: the study has no runs yet")
    ok = runs[runs["status"] == "ok"].copy()
    notes = []
    violations = runs[runs["status"] == "budget_violation"]
    if len(violations):
        listed = ", ".join(sorted(violations["run_id"].astype(str))[:5])
        more = f" and {len(violations) - 5} more" if len(violations) > 5 else ""
        notes.append(
            f"{len(violations)} run(s) are left out because their audit found fits beyond "
            f"their budget (status budget_violation: {listed}{more}); their records keep both "
            "counts (audited_fits, accounted_fits) and the reason (error).")
    failed = len(runs) - len(ok) - len(violations)
    if failed:
        notes.append(f"{failed} run(s) failed and are left out (see the study's failed/ "
                     "folder); the tables count the runs each cell has.")
    if ok.empty:
        raise ReportError(f"{study.path}: none of the {len(runs)} runs finished (all failed or "
                          "left out by the budget audit)")
    ok["method"] = _methods(ok)
    ok["instance"] = _instances(ok)
    ok["budget"] = ok["budget"].astype(int)
    for metric in METRICS:
        if metric in ok:
            ok[metric] = pd.to_numeric(ok[metric], errors="coerce")
    duplicated = ok.duplicated(["instance", "budget", "method", "seed"], keep=False)
    if duplicated.any():
        raise ReportError(
            f"{study.path}: {int(duplicated.sum())} runs share instance, budget, method and "
            "seed but differ in their settings; give the variants different labels "
            "(label=... in the configuration) to compare them")
    mixture = _mixture_note(ok, study.name)
    if mixture:
        notes.append(mixture)
    instances = _order(ok["instance"], ok["data"])
    methods = sorted(ok["method"].unique(), key=lambda m: (_mean_rank(ok, m), m))
    budgets = sorted(int(b) for b in ok["budget"].unique())
    trace = study.trace.merge(ok[["run_id", "instance", "method", "budget"]], on="run_id")
    return Comparison(study=study, runs=ok.reset_index(drop=True), trace=trace,
                      instances=instances, methods=methods, budgets=budgets, notes=notes)


def _mixture_note(runs: pd.DataFrame, study_name: str) -> str | None:
    """Why the runs may not be one experiment (``None`` if nothing suggests it): the methods
    were not all run on the same instances and budgets, or the study is the default one
    (every run made without ``study=``) and spans several instances or budgets."""
    # pandas-stubs: apply's function may return any object (a frozenset here), not only scalars
    cells = runs.groupby("method")[["instance", "budget"]].apply(  # type: ignore[call-overload]
        lambda group: frozenset(zip(group["instance"], group["budget"], strict=True)))
    n_cells = len(frozenset().union(*cells))
    notes = []
    if cells.nunique() > 1:
        counts = ", ".join(f"{method} {len(c)}" for method, c in cells.items())
        notes.append(f"Not every method ran on each of the {n_cells} instance and budget pairs "
                     f"({counts}): the study may mix separate experiments (or a sweep is "
                     "unfinished); compare methods only where they share runs.")
    if study_name == DEFAULT_STUDY and n_cells > 1:
        notes.append(f"This is the default study, which every run made without study= shares: "
                     f"its {len(cells)} method(s) on {runs['instance'].nunique()} instance(s) "
                     f"and {runs['budget'].nunique()} budget(s) may come from unrelated "
                     "experiments; give study=NAME to keep an experiment apart.")
    return " ".join(notes) or None


def _methods(runs: pd.DataFrame) -> pd.Series:
    label = runs["label"] if "label" in runs else pd.Series(np.nan, index=runs.index)
    return label.where(label.notna() & (label.astype(str) != ""), runs["optimizer"]).astype(str)


def _instances(runs: pd.DataFrame) -> pd.Series:
    """A readable instance name: the data, then each setting that varies within the runs of
    the same data (the number of points differs between curves, but names none). A run on a
    suite task is named by its instance and task (``galvez_f1 tolerance_1e-3``): the task
    fixes every other setting."""
    if "suite.task" in runs and runs["suite.task"].notna().all():
        return runs["data"].astype(str) + " " + suite_task_ids(runs)
    def varies(column: str) -> bool:
        text = runs[column].astype(str)
        return bool((text.groupby(runs["data"]).nunique(dropna=False) > 1).any())

    varying = [c for c in INSTANCE_SETTINGS[1:] if c in runs and varies(c)]
    columns = cast(list[str], list(runs))  # pandas-stubs: Hashable column names
    options = [c for c in columns if c.startswith("objective.") and varies(c)]
    names = runs["data"].astype(str)
    for column in varying + options:
        values: pd.Series = runs[column]
        prefix = SHORT.get(column, column.split(".", 1)[-1])
        text = values.map(lambda v, p=prefix: "" if _missing(v) else
                          f"{p}={_fmt(v)}" if p else _fmt(v))
        names = names + text.map(lambda t: f" {t}" if t else "")
    return names


def suite_task_ids(runs: pd.DataFrame) -> pd.Series:
    """Each suite run's task id with the alias ``tolerance`` resolved (``tolerance_1e-3``, or
    ``tolerance_noise`` on a noisy instance), as the best-known values name it."""
    from metaknot.suite.tasks import get_task

    pairs = runs[["data", "suite.task"]].astype(str)
    resolved = {(d, t): get_task(d, t).id if t == "tolerance" else t
                for d, t in pairs.drop_duplicates().itertuples(index=False)}
    return pd.Series([resolved[p] for p in pairs.itertuples(index=False, name=None)],
                     index=runs.index)


def _missing(value: object) -> bool:
    return value is None or (isinstance(value, float) and np.isnan(value))


def _fmt(value: object) -> str:
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def _order(instances: pd.Series, data: pd.Series) -> list[str]:
    """Instances in the order their data first appear, then by name."""
    first = {d: i for i, d in enumerate(dict.fromkeys(data))}
    pairs = dict(zip(instances, data, strict=True))
    return sorted(pairs, key=lambda inst: (first[pairs[inst]], _natural(inst)))


def _natural(text: str) -> list:
    import re

    return [float(t) if t.replace(".", "", 1).isdigit() else t
            for t in re.split(r"(\d+(?:\.\d+)?)", text)]


def _mean_rank(runs: pd.DataFrame, method: str) -> float:
    """Average within-cell rank of a method's median objective (display order: best first)."""
    medians = runs.groupby(["instance", "budget", "method"]).best_f.median().unstack()
    ranks = medians.rank(axis=1)
    return float(ranks[method].mean()) if method in ranks else np.inf
