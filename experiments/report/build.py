"""Assemble a report: tables, tests, figures, written as HTML, Markdown, CSV, LaTeX, PNG, SVG."""

from __future__ import annotations

import base64
import datetime as _dt
import html
import os
import re
import shutil
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from .data import METRICS, Comparison, ReportError, prepare
from .suite import SuiteComparison
from .tables import (
    FriedmanResult,
    design_power_note,
    friedman_test,
    pairwise_tests,
    plain_summary,
    summary_table,
)

__all__ = ["Report", "build"]

#: Per-problem figures are drawn for studies of at most this many instances (a suite study's
#: problems are shown together in its suite section).
MAX_INSTANCE_FIGURES = 12


@dataclass
class Report:
    """What :func:`build` wrote, and the tables it computed."""

    out: Path
    html: Path
    markdown: Path
    summary: list[str]
    tables: dict[str, pd.DataFrame]
    figures: list[Path] = field(default_factory=list)


@dataclass
class _Figure:
    name: str
    title: str
    caption: str
    png: Path
    svg: Path


def build(study: Any, out: str | os.PathLike | None = None, *, alpha: float = 0.05,
          metrics: Sequence[str] = ("best_f", "rmse"), figures: bool = True,
          log: Callable[[str], None] | None = print) -> Report:
    """Build the report of a study.

    Parameters
    ----------
    study
        A study directory (``<results_dir>/<study>``) or a loaded
        :class:`~metaknot.experiments.store.Study`.
    out
        Output folder (default: ``<results_dir>/<study>-report``); created if missing, files in
        it are replaced. It may not be inside the study. The report is built in a private
        folder beside it and moved into place when complete (other files in the folder are
        moved along), so that reports built at once each stay whole: the last one wins.
    alpha
        Significance level of the tests.
    metrics
        Outcomes tested pairwise and across instances (first: the summary's); any of
        ``best_f`` (the objective), ``rmse``, ``euclidean_distance``, ``max_deviation``,
        ``n_control_points``.
    figures
        Draw the figures (off: tables only, faster).
    log
        Called with one line per stage (``None``: silent).

    Raises
    ------
    ReportError
        The study is missing, empty, all failed, or holds a file the store cannot read; or a
        setting is wrong. The message says which.
    """
    say = log or (lambda _: None)
    if not 0 < alpha < 1:
        raise ReportError(f"alpha must lie in (0, 1); got {alpha}")
    _built_at()  # a malformed SOURCE_DATE_EPOCH is refused before any work
    unknown = [m for m in metrics if m not in METRICS]
    if unknown or not metrics:
        raise ReportError(f"unknown metric {unknown[0] if unknown else None!r}; choose from "
                          f"{', '.join(METRICS)}")
    comparison = prepare(study)
    study_dir = comparison.study.path.resolve()
    out = Path(out) if out is not None else study_dir.parent / f"{study_dir.name}-report"
    if out.resolve() == study_dir or study_dir in out.resolve().parents:
        raise ReportError(f"the report folder {out} is inside the study; choose another")
    if out.exists() and not out.is_dir():
        raise ReportError(f"{out} exists and is not a folder")
    final = out
    final.parent.mkdir(parents=True, exist_ok=True)
    out = Path(tempfile.mkdtemp(prefix=f".{final.name}.", suffix=".building",
                                dir=final.parent))
    umask = os.umask(0)
    os.umask(umask)
    out.chmod(0o777 & ~umask)  # as a folder made by mkdir (mkdtemp's is private)
    try:
        report = _build(comparison, out, alpha, metrics, figures, say)
        _move_into_place(out, final)
    except BaseException:
        shutil.rmtree(out, ignore_errors=True)
        raise
    moved = Report(out=final, html=final / report.html.name, markdown=final / report.markdown.name,
                   summary=report.summary, tables=report.tables,
                   figures=[final / path.relative_to(out) for path in report.figures])
    # the folders as they are now (they were built aside, under another name)
    say(f"tables: {final / 'tables'}")
    if figures:
        say(f"figures: {sum(p.suffix == '.png' for p in moved.figures)} in {final / 'figures'}")
    say(f"report: {moved.html}")
    return moved


#: What a report writes into its folder (the rest of a folder's files are the user's).
REPORT_ENTRIES = ("tables", "figures", "report.html", "report.md")


def _move_into_place(built: Path, final: Path, attempts: int = 20) -> None:
    """Put the complete report folder ``built`` at ``final``: the files of an earlier
    ``final`` that are not the report's are moved into ``built`` first; then the earlier
    folder is renamed aside, ``built`` renamed into place, and the earlier one removed. A
    report moved into place at the same moment by another process makes a rename fail: it is
    tried again (the last one in place wins, each whole)."""
    for _ in range(attempts):
        aside = None
        if final.exists():
            for entry in final.iterdir():
                if entry.name not in REPORT_ENTRIES and not (built / entry.name).exists():
                    try:
                        entry.rename(built / entry.name)
                    except FileNotFoundError:
                        pass  # taken along by another report being moved at once
            aside = final.with_name(f".{final.name}.{os.getpid()}.{time.monotonic_ns()}.old")
            try:
                final.rename(aside)
            except FileNotFoundError:
                aside = None  # moved aside by another report just now
            except OSError:
                continue
        try:
            built.rename(final)
        except OSError:  # another report took the place first: move it aside again
            if aside is not None:
                shutil.rmtree(aside, ignore_errors=True)
            continue
        if aside is not None:
            shutil.rmtree(aside, ignore_errors=True)
        return
    raise ReportError(f"the report could not be moved into {final}: other reports kept "
                      "taking its place")


def _build(comparison: Comparison, out: Path, alpha: float, metrics: Sequence[str],
           figures: bool, say: Callable[[str], None]) -> Report:
    """The report's tables, figures and pages, written into ``out``."""
    (out / "tables").mkdir(parents=True, exist_ok=True)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    say(f"report of {comparison.name}: {len(comparison.runs)} runs, "
        f"{len(comparison.instances)} instance(s), {len(comparison.methods)} method(s), "
        f"{len(comparison.budgets)} budget(s)")

    tables: dict[str, pd.DataFrame] = {"summary": summary_table(comparison),
                                       "cells": comparison.cell_counts()}
    friedman: dict[str, FriedmanResult] = {}
    for metric in metrics:
        tables[f"pairwise_{metric}"] = pairwise_tests(comparison, metric, alpha)
        friedman[metric] = friedman_test(comparison, metric, alpha)
        tables[f"ranks_{metric}"] = _ranks_table(friedman[metric])
    summary = plain_summary(comparison, tables[f"pairwise_{metrics[0]}"], alpha,
                            friedman[metrics[0]], metric=metrics[0])
    power = design_power_note(comparison, alpha)
    if power:
        summary.append(power)
    suite = _suite_tables(comparison, tables, alpha)
    if suite is not None:
        summary = suite.summary + summary
    for name, table in tables.items():
        table.to_csv(out / "tables" / f"{name}.csv", index=False)
    _write_latex(comparison, tables, metrics, out / "tables")

    drawn: list[_Figure] = []
    if figures:
        drawn = _draw(comparison, friedman, metrics, alpha, out / "figures", say, suite)
    report = Report(out=out, html=out / "report.html", markdown=out / "report.md",
                    summary=summary, tables=tables,
                    figures=[f.png for f in drawn] + [f.svg for f in drawn])
    sections = _sections(comparison, tables, friedman, metrics, alpha, drawn, summary,
                         suite)
    report.html.write_text(_html(comparison, sections, out), encoding="utf-8")
    report.markdown.write_text(_markdown(comparison, sections, out), encoding="utf-8")
    return report


# --------------------------------------------------------------------------------------------
# the suite


@dataclass
class _Suite:
    """The suite section's computed parts (see :mod:`.suite`)."""

    view: SuiteComparison
    hits: pd.DataFrame
    friedman: dict[str, FriedmanResult]
    summary: list[str]


def _suite_tables(comparison: Comparison, tables: dict[str, pd.DataFrame],
                  alpha: float) -> _Suite | None:
    """The suite section's tables (added to ``tables``), or ``None`` for a study not on the
    suite."""
    from . import suite as s

    view = s.suite_comparison(comparison)
    if view is None:
        return None
    hits = s.target_hits(view)
    results = s.friedman_by_family(view, alpha)
    ranks, tests = s.ranks_by_family(results)
    solved = s.solved_table(view, hits)
    ranked = list(results[s.ALL].ranks.index)
    order = ranked + [m for m in view.methods if m not in ranked]
    profile, left_out = s.performance_profile(view.medians, np.array([1.0]))
    best = profile.T.reindex(view.methods).rename(columns={1.0: "best on (share of problems)"})
    if len(view.task_names) > 1:  # and per task: the shares of its problems
        for task in view.task_names:
            part, _ = s.performance_profile(view.medians[view.tasks == task], np.array([1.0]))
            best[f"{s.TASK_SCOPE}{task}"] = part.T.iloc[:, 0]
    best.index.name, best.columns.name = "method", None
    gaps = s.gap_table(view)
    tables.update(suite_solved=solved.reset_index(), suite_gap=gaps,
                  suite_ranks=ranks, suite_friedman=tests,
                  suite_wins=s.wins_matrix(view.medians, order),
                  suite_best=best.reindex(order).reset_index(),
                  suite_medians=view.medians.reset_index())
    if left_out:
        view.notes.append(f"{left_out} problem(s) are left out of the suite-wide performance "
                          "profile (a compared method without runs there, or a best median "
                          "not above 0).")
    return _Suite(view, hits, results, s.suite_summary(view, results, solved, alpha, gaps))


# --------------------------------------------------------------------------------------------
# figures


def _draw(comparison: Comparison, friedman: dict[str, FriedmanResult], metrics: Sequence[str],
          alpha: float, folder: Path, say: Callable[[str], None],
          suite: _Suite | None = None) -> list[_Figure]:
    import matplotlib.pyplot as plt

    from . import figures as f

    plans: list[tuple[str, str, str, Callable[..., Any]]] = []  # drawn with no argument
    if suite is not None:
        from .suite import ALL, LEVELS

        plans.append(("suite-ecdf", "Suite: targets reached",
                      f"COCO-style ECDF: share of (run, target) pairs reached within a number "
                      f"of evaluations; {len(LEVELS)} targets per problem at precisions "
                      f"(f − f*)/|f*| from {LEVELS[0]:g} to {LEVELS[-1]:g} (f*: the "
                      "best-known value), pooled over the problems, in all and per family.",
                      lambda: f.suite_ecdf_figure(comparison, suite.view, suite.hits)))
        plans.append(("suite-profile", "Suite: performance profiles",
                      "Dolan–Moré performance profiles: share of problems on which a method's "
                      "median final objective (over its seeds) is within a factor τ of the best "
                      "method's; at τ = 1 the share of problems it is best on (ties count for "
                      "each).",
                      lambda: f.profile_figure(comparison, suite.view)))
        for scope, result in suite.friedman.items():
            name = "suite-cd" if scope == ALL else f"suite-cd-{_slug(scope)}"
            plans.append((name, f"Critical difference: {scope}",
                          "Average ranks of the median objective over the problems; methods "
                          "joined by a bar are not significantly different (Nemenyi).",
                          lambda r=result: f.cd_diagram(comparison, r, alpha, "problems")))
    per_instance = len(comparison.instances) <= MAX_INSTANCE_FIGURES
    for instance in comparison.instances if per_instance else []:
        slug = _slug(instance)
        plans.append((f"convergence-{slug}", f"{instance}: convergence",
                      "Best-so-far objective and the incumbent's RMSE at the log-spaced "
                      "checkpoints; median and interquartile band over each method's runs at "
                      "its largest budget.",
                      lambda i=instance: f.convergence_figure(comparison, i)))
        if len(comparison.budgets) > 1:
            plans.append((f"budget-{slug}", f"{instance}: outcome against budget",
                          "Objective, control points and RMSE of the best solution against "
                          "the evaluation budget (median, interquartile band): where the "
                          "objective drives the search.",
                          lambda i=instance: f.budget_figure(comparison, i)))
        plans.append((f"ecdf-{slug}", f"{instance}: fixed-target view",
                      f"Fraction of (run, target) pairs reached within a number of "
                      f"evaluations, for {f.TARGETS} targets on the objective and on the "
                      "incumbent's RMSE, log-spaced from the worst method's median final value "
                      "to the best run's (runs at each method's largest budget).",
                      lambda i=instance: f.ecdf_figure(comparison, [i],
                                                       f"{i}: targets reached")))
        plans.append((f"front-{slug}", f"{instance}: control points against RMSE",
                      "One dot per run (for the objective pareto: the front of each method's "
                      "median run); the grey line is FITPACK's own smoothing fits over a range "
                      "of smoothing factors. Below the line beats FITPACK at that size.",
                      lambda i=instance: f.front_figure(comparison, i)))
        plans.append((f"curves-{slug}", f"{instance}: fitted curves",
                      "The median run (by objective) of each method at its largest budget, "
                      "rebuilt from its stored best candidate: data, fitted curve, knots.",
                      lambda i=instance: f.fitted_curves_figure(comparison, i)))
    if 1 < len(comparison.instances) <= MAX_INSTANCE_FIGURES:
        plans.append(("ecdf-all", "All instances: fixed-target view",
                      "The fixed-target view pooled over every instance (each with its own "
                      "targets).",
                      lambda: f.ecdf_figure(comparison, comparison.instances,
                                            "all instances: targets reached")))
    for metric in metrics:
        plans.append((f"cd-{metric}", f"Critical difference ({METRICS[metric]})",
                       "Average ranks over the instance–budget cells; methods joined by a bar "
                       "are not significantly different (Nemenyi).",
                       lambda m=metric: f.cd_diagram(comparison, friedman[m], alpha)))
    drawn = []
    for name, title, caption, draw in plans:
        try:
            figure = draw()
        except Exception as exc:  # one figure that cannot be drawn must not sink the report
            say(f"figure {name} skipped: {type(exc).__name__}: {exc}")
            continue
        if figure is None:
            continue
        png, svg = folder / f"{name}.png", folder / f"{name}.svg"
        figure.savefig(png, dpi=110)
        # the same figure, the same file: element ids from a fixed salt, no date
        with plt.rc_context({"svg.hashsalt": name}):
            figure.savefig(svg, metadata={"Date": None})
        plt.close(figure)
        drawn.append(_Figure(name, title, caption, png, svg))
    return drawn


# --------------------------------------------------------------------------------------------
# tables as text


def _num(value: Any, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "–" if value is None or np.isnan(value) else ("∞" if value > 0 else "-∞")
    if isinstance(value, int | np.integer):
        return f"{int(value):,}"
    value = float(value)
    if value == 0:
        return "0"
    if value.is_integer() and abs(value) < 1e6:
        return f"{int(value):,}"
    return f"{value:.{digits}g}"


def _p(value: Any) -> str:
    if value is None or not np.isfinite(value):
        return "–"
    return "<1e-6" if value < 1e-6 else f"{value:.2g}"


def _summary_display(summary: pd.DataFrame, instance: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """One instance's summary as text: ``median (IQR)`` per outcome, and a mask of the best."""
    part = summary[summary.instance == instance]
    text = pd.DataFrame({"budget": part.budget.map(_num), "method": part.method,
                         "runs": part.runs.map(_num)})
    best = pd.DataFrame(False, index=text.index, columns=text.columns)
    for metric, label in METRICS.items():
        if f"{metric} median" not in part:
            continue
        text[label] = [f"{_num(m)} ({_num(i, 2)})"
                       for m, i in zip(part[f"{metric} median"], part[f"{metric} IQR"],
                                       strict=True)]
        best[label] = part[f"{metric} best"].to_numpy()
    return text.reset_index(drop=True), best.reset_index(drop=True)


def _mean_display(summary: pd.DataFrame) -> pd.DataFrame:
    text = pd.DataFrame({"instance": summary.instance, "budget": summary.budget.map(_num),
                         "method": summary.method, "runs": summary.runs.map(_num)})
    for metric, label in METRICS.items():
        if f"{metric} mean" in summary:
            text[label] = [f"{_num(m)} ± {_num(s, 2)}" for m, s in
                           zip(summary[f"{metric} mean"], summary[f"{metric} sd"], strict=True)]
    return text.reset_index(drop=True)


def _pairwise_display(pairwise: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    text = pd.DataFrame({
        "instance": pairwise.instance, "budget": pairwise.budget.map(_num),
        "A vs B": pairwise.A + " vs " + pairwise.B, "n": pairwise.n.map(_num),
        "median A": pairwise["median A"].map(_num), "median B": pairwise["median B"].map(_num),
        "A12": pairwise.A12.map(lambda v: _num(v, 2)), "effect": pairwise.effect,
        "W/T/L": [f"{w}/{t}/{loss}" for w, t, loss in
                  zip(pairwise.wins, pairwise.ties, pairwise.losses, strict=True)],
        "p (Holm)": pairwise.p_holm.map(_p),
        "note": pairwise.note,
    })
    best = pd.DataFrame(False, index=text.index, columns=text.columns)
    best["p (Holm)"] = pairwise.significant.to_numpy()
    return text.reset_index(drop=True), best.reset_index(drop=True)


def _ranks_table(result: FriedmanResult) -> pd.DataFrame:
    return pd.DataFrame({"method": result.ranks.index, "average rank": result.ranks.values,
                         "metric": result.metric, "blocks": result.blocks, "p": result.p,
                         "note": result.note})


def _write_latex(comparison: Comparison, tables: dict[str, pd.DataFrame],
                 metrics: Sequence[str], folder: Path) -> None:
    for instance in comparison.instances:
        text, best = _summary_display(tables["summary"], instance)
        _latex_table(text, best, folder / f"summary-{_slug(instance)}.tex",
                     f"{comparison.name}, {instance}: median (IQR) over replicate seeds; best "
                     "median per budget in bold.")
    for metric in metrics:
        text, best = _pairwise_display(tables[f"pairwise_{metric}"])
        _latex_table(text.drop(columns=["note"]), best.drop(columns=["note"]),
                     folder / f"pairwise-{metric}.tex",
                     f"{comparison.name}: pairwise comparison of the {METRICS[metric]}, "
                     "Wilcoxon signed-rank on paired seeds, Holm-corrected per instance and "
                     "budget; A12 = probability that A is lower; significant in bold.")


def _latex_table(text: pd.DataFrame, best: pd.DataFrame, path: Path, caption: str) -> None:
    styled = text.style.hide(axis="index").format(escape="latex")
    styled = styled.apply(lambda _: np.where(best, "font-weight: bold;", ""), axis=None)
    body = styled.to_latex(hrules=True, convert_css=True, caption=_latex_escape(caption),
                           column_format="l" * text.shape[1])
    path.write_text(_latex_symbols(body), encoding="utf-8")


#: LaTeX's special characters in text, as pandas' own ``escape="latex"`` writes them.
_LATEX_SPECIAL = {"\\": r"\textbackslash ", "&": r"\&", "%": r"\%", "$": r"\$",
                  "#": r"\#", "_": r"\_", "{": r"\{", "}": r"\}",
                  "~": r"\textasciitilde ", "^": r"\textasciicircum "}


def _latex_escape(text: str) -> str:
    """Text (a caption) with LaTeX's special characters escaped."""
    return re.sub(r"[\\&%$#_{}~^]", lambda m: _LATEX_SPECIAL[m.group(0)], text)


def _latex_symbols(body: str) -> str:
    """The few non-ASCII symbols of the tables as LaTeX (math mode), and p below 1e-6."""
    for symbol, latex in (("±", r"$\pm$"), ("–", "--"), ("∞", r"$\infty$"),
                          ("σ", r"$\sigma$"), ("×", r"$\times$"), ("<1e-6", r"$<10^{-6}$")):
        body = body.replace(symbol, latex)
    return body if body.endswith("\n") else body + "\n"


# --------------------------------------------------------------------------------------------
# documents


@dataclass
class _Section:
    title: str
    level: int = 2
    paragraphs: list[str] = field(default_factory=list)
    table: tuple[pd.DataFrame, pd.DataFrame] | None = None
    figures: list[_Figure] = field(default_factory=list)


def _sections(comparison: Comparison, tables: dict[str, pd.DataFrame],
              friedman: dict[str, FriedmanResult], metrics: Sequence[str], alpha: float,
              drawn: list[_Figure], summary: list[str],
              suite: _Suite | None = None) -> list[_Section]:
    by_name = {f.name: f for f in drawn}
    runs = comparison.runs
    cells = tables["cells"]
    sections = [_Section("Summary", paragraphs=list(summary))]
    facts = [
        f"{len(runs)} finished runs: {len(comparison.instances)} instance(s) × "
        f"{len(comparison.methods)} method(s) ({', '.join(comparison.methods)}) × "
        f"{len(comparison.budgets)} budget(s) ({', '.join(_num(b) for b in comparison.budgets)}"
        f" evaluations); replicate seeds {_num(int(runs.seed.min()))}–"
        f"{_num(int(runs.seed.max()))}, paired across methods.",
        *comparison.notes,
    ]
    expected = int(cells.runs.max())
    thin = cells[cells.runs < expected]
    if len(thin):
        facts.append(f"The study is partial: {len(thin)} of {len(cells)} cells have fewer than "
                     f"{expected} runs (the tables give each cell's count).")
    if len(comparison.instances) > MAX_INSTANCE_FIGURES:
        facts.append(f"With {len(comparison.instances)} instances the per-instance figures "
                     f"are left out (drawn for at most {MAX_INSTANCE_FIGURES}); the tables "
                     "give every instance.")
    sections.append(_Section("The study", paragraphs=facts))
    if suite is not None:
        sections += _suite_sections(suite, tables, by_name)
    for instance in comparison.instances:
        section = _Section(f"{instance}", paragraphs=[
            "Median (interquartile range) over replicate seeds at each budget; the best median "
            "of each budget in bold (lower is better for every column)."])
        section.table = _summary_display(tables["summary"], instance)
        section.figures = [by_name[n] for n in (
            f"{kind}-{_slug(instance)}" for kind in ("budget", "convergence", "ecdf", "front",
                                                      "curves")) if n in by_name]
        sections.append(section)
    for metric in metrics:
        text, best = _pairwise_display(tables[f"pairwise_{metric}"])
        sections.append(_Section(
            f"Pairwise tests: {METRICS[metric]}",
            paragraphs=[f"Wilcoxon signed-rank test on the seeds both methods ran, "
                        f"Holm-corrected over the pairs of each instance and budget "
                        f"(significant at {alpha:g} in bold). A12 (Vargha–Delaney): the "
                        "probability that a run of A gives a lower value than a run of B; "
                        "W/T/L: paired wins, ties and losses of A."],
            table=(text, best)))
        result = friedman[metric]
        ranks = tables[f"ranks_{metric}"][["method", "average rank"]]
        verdict = (f"{result.note}; p = {_p(result.p)}" if np.isfinite(result.p)
                   else result.note)
        figs = [by_name[n] for n in (f"cd-{metric}",) if n in by_name]
        sections.append(_Section(
            f"Across instances: {METRICS[metric]}", level=3,
            paragraphs=[f"Average rank (1 = best) of each method's median over the "
                        f"{result.blocks} instance–budget cells where every method ran: "
                        f"{verdict}."],
            table=_plain(ranks, {"average rank": lambda v: _num(v, 3)}),
            figures=figs))
    if "ecdf-all" in by_name:
        sections.append(_Section("All instances", figures=[by_name["ecdf-all"]]))
    sections.append(_Section("Appendix: mean ± standard deviation", paragraphs=[
        "The summary tables' cells as mean ± standard deviation over replicate seeds."],
        table=_plain(_mean_display(tables["summary"]))))
    sections.append(_Section("Files", paragraphs=[
        "Every table as CSV in `tables/`, the main tables as LaTeX (booktabs) in `tables/`, "
        "every figure as PNG and SVG in `figures/`. Each number comes from the stored runs of "
        f"the study `{comparison.study.path}`; `load_study` reads them back."]))
    return sections


def _plain(table: pd.DataFrame, formats: dict[str, Callable[[Any], str]] | None = None,
           ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A table as text (numbers through :func:`_num` unless ``formats`` says), nothing bold."""
    formats = formats or {}
    text = pd.DataFrame({c: table[c].map(formats.get(c, _num)) if c in formats or
                         pd.api.types.is_numeric_dtype(table[c]) else table[c].astype(str)
                         for c in table.columns})
    return text, pd.DataFrame(False, index=text.index, columns=text.columns)


def _share(value: Any) -> str:
    return "–" if value is None or not np.isfinite(value) else f"{value:.0%}"


def _suite_sections(suite: _Suite, tables: dict[str, pd.DataFrame],
                    by_name: dict[str, _Figure]) -> list[_Section]:
    from .suite import ALL, LEVELS

    view = suite.view
    problems = len(view.medians)
    figures = [by_name[n] for n in ("suite-ecdf", "suite-profile") if n in by_name]
    intro = _Section("The suite", paragraphs=[
        f"{problems} problems (an instance and a task each) in {len(view.family_names)} "
        f"families ({', '.join(view.family_names)}), {len(view.methods)} methods, compared at "
        f"{view.budget:,} evaluations. Targets are relative to the suite's best-known values "
        f"(`metaknot.suite.best`): a run reaches the target of precision ε when its "
        f"best-so-far objective f has (f − f*)/|f*| ≤ ε, ε in "
        f"{', '.join(f'{v:g}' for v in LEVELS)}; a (run, target) pair is reached at the first "
        "trace point that gets there. Ranks, profiles and wins compare each method's median "
        "final objective over its seeds, one block per problem.",
        "Computed with numpy and pandas (targets, ECDFs as in COCO's cocopp and IOHanalyzer, "
        "Dolan–Moré profiles, gaps, wins), scipy (`friedmanchisquare`, `binomtest`) and "
        "scikit-posthocs (`posthoc_nemenyi_friedman`, `critical_difference_diagram`).",
        *view.notes], figures=figures)
    solved = tables["suite_solved"].copy()
    sections = [intro, _Section(
        "Targets reached at the end", level=3,
        paragraphs=["Share of (run, target) pairs reached at the end of the runs, over the "
                    "suite and per family (problems with a best-known value)."],
        table=_plain(solved, {c: _share for c in solved.columns if c != "method"}))]
    gap = tables["suite_gap"]
    if len(gap):
        shares: dict[str, Callable[[Any], str]] = {
            c: _share for c in ("within 1%", "at best-known")}
        sections.append(_Section(
            "Gap to the best-known value", level=3,
            paragraphs=["Per problem the median over seeds of (f − f*)/|f*|; per method the "
                        "median over problems, the worst and the problem where it is, the "
                        "family of the largest median gap, and the shares of problems within "
                        "1 % and at (or below) the best-known value; sorted by the median "
                        "gap."],
            table=_plain(gap, shares)))
    ranks = tables["suite_ranks"]
    tests = tables["suite_friedman"]
    verdicts = [f"{row.scope}: " + (f"χ² = {row.chi2:.3g}, p = {_p(row.p)} ({row.note})"
                                    if np.isfinite(cast(float, row.p)) else str(row.note))
                + f"; {row.problems} problems" for row in tests.itertuples()]
    cds = [by_name[n] for n in by_name if n == "suite-cd" or n.startswith("suite-cd-")]
    sections.append(_Section(
        "Ranks over the problems", level=3,
        paragraphs=["Average rank (1 = best) of each method's median objective, one Friedman "
                    "block per problem, over the suite and per family; sorted by the "
                    f"suite-wide rank. {ALL.capitalize()} and per family:", *verdicts],
        table=_plain(ranks, {c: (lambda v: _num(v, 3)) for c in ranks.columns
                             if c != "method"}),
        figures=cds))
    best = tables["suite_best"]
    sections.append(_Section(
        "Wins, ties and losses", level=3,
        paragraphs=["Row method against column method over the problems: problems where its "
                    "median is lower / equal / higher (W/T/L). The share of problems each "
                    "method is best on (the performance profile at τ = 1, ties counting for "
                    "each): " + ", ".join(f"{m} {_share(v)}" for m, v in
                                          zip(best.method, best.iloc[:, 1], strict=True))
                    + "."],
        table=_plain(tables["suite_wins"])))
    return sections


def _header(comparison: Comparison) -> str:
    from metaknot import __version__

    return f"metaknot {__version__}, {_built_at().strftime('%Y-%m-%d %H:%M UTC')}"


def _built_at() -> _dt.datetime:
    """When the report is built: now, or the time ``SOURCE_DATE_EPOCH`` gives (seconds since
    1970, the reproducible-builds convention: the same study then gives the same files)."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    if epoch is None:
        return _dt.datetime.now(_dt.UTC)
    if not epoch.strip().isdigit():
        raise ReportError(f"SOURCE_DATE_EPOCH must be whole seconds since 1970; got {epoch!r}")
    return _dt.datetime.fromtimestamp(int(epoch), _dt.UTC)


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;
max-width:1100px;padding:0 1em;color:#222;line-height:1.45}
h1{font-size:1.7em}h2{border-bottom:1px solid #ddd;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.8em 0;font-size:.86em}
th,td{border-bottom:1px solid #e4e4e4;padding:.25em .6em;text-align:right}
th{background:#f6f6f6}td:first-child,th:first-child{text-align:left}
figure{margin:1.2em 0}figure img{max-width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.85em;color:#555}.meta{color:#666;font-size:.9em}
.scroll{overflow-x:auto}
"""


def _html_table(text: pd.DataFrame, best: pd.DataFrame) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in text.columns)
    values, bold = text.astype(str).to_numpy(), best.to_numpy(dtype=bool)
    rows = ["<tr>" + "".join(f"<td><strong>{html.escape(v)}</strong></td>" if b
                             else f"<td>{html.escape(v)}</td>"
                             for v, b in zip(row, marks, strict=True)) + "</tr>"
            for row, marks in zip(values, bold, strict=True)]
    return (f'<div class="scroll"><table><thead><tr>{head}</tr></thead><tbody>'
            + "".join(rows) + "</tbody></table></div>")


def _inline(text: str) -> str:
    """Markdown ``**bold**`` and ```code``` as HTML."""
    text = html.escape(text)
    text = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", text)
    return re.sub(r"`(.+?)`", r"<code>\1</code>", text)


def _html(comparison: Comparison, sections: list[_Section], out: Path) -> str:
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
             "<meta name='viewport' content='width=device-width, initial-scale=1'>"
             f"<title>metaknot report: {html.escape(comparison.name)}</title>"
             f"<style>{_CSS}</style></head><body>",
             f"<h1>Study {html.escape(comparison.name)}</h1>",
             f"<p class='meta'>{html.escape(_header(comparison))}</p>"]
    for section in sections:
        parts.append(f"<h{section.level}>{html.escape(section.title)}</h{section.level}>")
        parts += [f"<p>{_inline(p)}</p>" for p in section.paragraphs]
        if section.table is not None:
            parts.append(_html_table(*section.table))
        for figure in section.figures:
            data = base64.b64encode(figure.png.read_bytes()).decode()
            parts.append(f"<figure><img alt='{html.escape(figure.title)}' "
                         f"src='data:image/png;base64,{data}'>"
                         f"<figcaption><strong>{html.escape(figure.title)}.</strong> "
                         f"{html.escape(figure.caption)}</figcaption></figure>")
    parts.append("</body></html>")
    return "\n".join(parts)


def _md_table(text: pd.DataFrame, best: pd.DataFrame) -> str:
    def cell(value: str, bold: bool) -> str:
        value = value.replace("|", "\\|")
        return f"**{value}**" if bold and value else value

    values, bold = text.astype(str).to_numpy(), best.to_numpy(dtype=bool)
    lines = ["| " + " | ".join(str(c) for c in text.columns) + " |",
             "| " + " | ".join("---" for _ in text.columns) + " |"]
    lines += ["| " + " | ".join(cell(v, b) for v, b in zip(row, marks, strict=True)) + " |"
              for row, marks in zip(values, bold, strict=True)]
    return "\n".join(lines)


def _markdown(comparison: Comparison, sections: list[_Section], out: Path) -> str:
    parts = [f"# Study {comparison.name}", "", f"*{_header(comparison)}*", ""]
    for section in sections:
        parts += ["#" * section.level + " " + section.title, ""]
        for paragraph in section.paragraphs:
            parts += [paragraph, ""]
        if section.table is not None:
            parts += [_md_table(*section.table), ""]
        for figure in section.figures:
            relative = figure.png.relative_to(out).as_posix()
            parts += [f"![{figure.title}]({relative})", "",
                      f"*{figure.title}.* {figure.caption}", ""]
    return "\n".join(parts)


def _slug(text: str) -> str:
    slug = re.sub(r"[^A-Za-z0-9]+", "-", text).strip("-").lower()
    return slug or "instance"
