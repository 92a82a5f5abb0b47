"""The report's tables and tests, as flat functions over a :class:`Comparison`.

* :func:`summary_table` — the seed paper's table shape: per instance, budget and method, the
  median, IQR, mean and standard deviation of every outcome, the best median per cell marked.
* :func:`pairwise_tests` — per instance and budget, every pair of methods on their common
  replicate seeds: Wilcoxon signed-rank test (scipy), Holm-corrected within the cell
  (statsmodels), Vargha–Delaney A12 and win/tie/loss counts.
* :func:`friedman_test` — across instances and budgets: Friedman test (scipy) on the cells'
  medians, average ranks, Nemenyi post-hoc (scikit-posthocs); for two methods a sign test
  over the cells (scipy), scale-free as the Friedman test is.
* :func:`plain_summary` — sentences a reader can take in first.

A test that cannot be applied (too few paired runs, every pair tied, a single method) is reported
in words in the ``note`` column; its p-value is left empty.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import pandas as pd
from scipy import stats

from .data import METRICS, Comparison

__all__ = ["FriedmanResult", "a12", "design_power_note", "friedman_blocks", "friedman_test",
           "magnitude", "pairwise_tests", "plain_summary", "seeds_needed", "smallest_p",
           "summary_table"]

#: Fewest paired runs with a difference for which a two-sided Wilcoxon test at 0.05 can reject
#: (with 5 the smallest exact p-value is 0.0625).
MIN_PAIRS = 6


def summary_table(comparison: Comparison) -> pd.DataFrame:
    """Per instance, budget and method: ``runs`` and, for each outcome, ``<metric> median``,
    ``IQR``, ``mean``, ``sd`` and ``best`` (the lowest median of the cell)."""
    runs = comparison.runs
    metrics = [m for m in METRICS if m in runs]
    grouped = runs.groupby(["instance", "budget", "method"], sort=False)
    table = grouped.size().rename("runs").to_frame()
    for metric in metrics:
        values = grouped[metric]
        table[f"{metric} median"] = values.median()
        table[f"{metric} IQR"] = values.quantile(0.75) - values.quantile(0.25)
        table[f"{metric} mean"] = values.mean()
        table[f"{metric} sd"] = values.std()
    table = table.reset_index()
    for metric in metrics:
        column = f"{metric} median"
        best = table.groupby(["instance", "budget"])[column].transform("min")
        table[f"{metric} best"] = np.isclose(table[column], best, rtol=1e-12, atol=0.0)
    return _ordered(table, comparison)


def a12(a: np.ndarray, b: np.ndarray) -> float:
    """Vargha–Delaney A12 for minimisation: the probability that a run of ``a`` has a lower
    value than a run of ``b`` (ties count half). 0.5: no difference; 1: ``a`` always lower."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.size == 0 or b.size == 0:
        return np.nan
    less = (a[:, None] < b[None, :]).sum()
    equal = (a[:, None] == b[None, :]).sum()
    return float((less + 0.5 * equal) / (a.size * b.size))


def magnitude(value: float) -> str:
    """Vargha and Delaney's (2000) words for an A12 value: negligible, small, medium, large."""
    if not np.isfinite(value):
        return ""
    distance = abs(value - 0.5)
    if distance < 0.06:
        return "negligible"
    if distance < 0.14:
        return "small"
    if distance < 0.21:
        return "medium"
    return "large"


def holm(p: list[float] | np.ndarray) -> np.ndarray:
    """Holm's step-down adjusted p-values: ``statsmodels.stats.multitest.multipletests(p,
    method="holm")[1]``. statsmodels runs ``gc.collect()`` on every call, which walks every
    object the process holds (a large study: 0.3-0.7 s a call, a quarter of a report's
    time); the objects that exist before the call are frozen (``gc.freeze``) so that the
    collection walks only the call's own."""
    import gc

    from statsmodels.stats.multitest import multipletests

    gc.freeze()
    try:
        return multipletests(p, method="holm")[1]
    finally:
        gc.unfreeze()


def wilcoxon_p(x: np.ndarray, y: np.ndarray) -> float:
    """The two-sided Wilcoxon signed-rank p of the pairs ``(x, y)``: ``scipy.stats.wilcoxon``'s
    p to the last bit, faster where scipy is slow.

    With ties or zero differences among at most 13 pairs scipy's exact test is a permutation
    test over the 2^n sign flips whose statistic it computes one flip at a time (about a
    second a test; a suite study has thousands). Here the same ``scipy.stats.permutation_test``
    gets the statistic (the sum of the ranks of the positive differences; flipping signs keeps
    the ranks) for all flips at once."""
    d = np.asarray(x, dtype=np.float64) - np.asarray(y, dtype=np.float64)
    nonzero = d[d != 0]
    ties = nonzero.size < d.size or np.unique(np.abs(nonzero)).size < nonzero.size
    if not ties or d.size > 13:  # scipy's exact or normal test: fast
        return float(stats.wilcoxon(d).pvalue)
    rank = np.zeros(d.size)
    rank[d != 0] = stats.rankdata(np.abs(nonzero))  # zeros drop out, as scipy's "wilcox"

    def positive_ranks(sample: np.ndarray, axis: int) -> np.ndarray:
        return ((sample > 0) * rank).sum(axis=axis)

    return float(stats.permutation_test((d,), positive_ranks, permutation_type="samples",
                                        vectorized=True, n_resamples=9999,
                                        alternative="two-sided", axis=-1).pvalue)


def pairwise_tests(comparison: Comparison, metric: str = "best_f",
                   alpha: float = 0.05) -> pd.DataFrame:
    """Every pair of methods per instance and budget, paired by replicate seed.

    Columns: ``instance``, ``budget``, ``A``, ``B``, ``n`` (common seeds), medians of A and B,
    ``A12`` (A lower than B), ``effect``, ``wins``/``ties``/``losses`` of A, ``p`` (Wilcoxon),
    ``p_holm`` (Holm over the cell's pairs), ``significant`` and ``note``.
    """
    rows = []
    runs = comparison.runs
    wide = (runs.groupby(["instance", "budget", "seed", "method"], sort=False)[metric].first()
            .unstack("method"))
    groups = wide.groupby(level=["instance", "budget"], sort=False)
    # pandas-stubs type a group's key as Hashable: here (instance, budget)
    for (instance, budget), values in cast(Iterable[tuple[tuple[str, int], pd.DataFrame]],
                                           groups):
        values = values.droplevel(["instance", "budget"]).dropna(axis=1, how="all")
        methods = [m for m in comparison.methods if m in values]
        cell_rows = []
        for a, b in itertools.combinations(methods, 2):
            pair = values[[a, b]].dropna()
            x, y = pair[a].to_numpy(), pair[b].to_numpy()
            row: dict[str, Any] = {
                "instance": instance, "budget": int(budget), "metric": metric, "A": a,
                "B": b, "n": len(pair), "median A": np.median(x) if len(x) else np.nan,
                "median B": np.median(y) if len(y) else np.nan, "A12": a12(x, y),
                "wins": int((x < y).sum()), "ties": int((x == y).sum()),
                "losses": int((x > y).sum()), "p": np.nan, "note": ""}
            row["effect"] = magnitude(row["A12"])
            differing = row["wins"] + row["losses"]
            finite = np.isfinite(x - y) if len(x) else np.array([], dtype=bool)
            if len(pair) == 0:
                row["note"] = "no common seeds: no test"
            elif differing == 0:
                row["note"] = "all paired runs tie: no test"
            elif not finite.all():
                row["note"] = "infeasible runs (infinite values): no test"
            elif differing < MIN_PAIRS:
                row["note"] = (f"only {differing} paired runs differ (a test needs at least "
                               f"{MIN_PAIRS} to reach p < 0.05): no test")
            else:
                row["p"] = wilcoxon_p(x, y)
            cell_rows.append(row)
        tested = [r for r in cell_rows if np.isfinite(r["p"])]
        if tested:
            adjusted = holm([r["p"] for r in tested])
            for r, p in zip(tested, adjusted, strict=True):
                r["p_holm"] = float(p)
        rows += cell_rows
    columns = ["instance", "budget", "metric", "A", "B", "n", "median A", "median B", "A12",
               "effect", "wins", "ties", "losses", "p", "p_holm", "significant", "note"]
    table = pd.DataFrame(rows, columns=[c for c in columns if c != "significant"])
    if "p_holm" not in table:
        table["p_holm"] = np.nan
    table["significant"] = table["p_holm"] < alpha
    return _ordered(table[columns], comparison)


@dataclass
class FriedmanResult:
    """The across-instance comparison (see :func:`friedman_test`)."""

    metric: str
    blocks: int
    ranks: pd.Series
    statistic: float
    p: float
    posthoc: pd.DataFrame | None
    note: str


def friedman_test(comparison: Comparison, metric: str = "best_f",
                  alpha: float = 0.05) -> FriedmanResult:
    """Friedman test over the cells (instance × budget) where every method ran, on each
    method's median; average ranks (1 = best); Nemenyi post-hoc when the test rejects."""
    medians = (comparison.runs.groupby(["instance", "budget", "method"])[metric].median()
               .unstack("method"))
    methods = [m for m in comparison.methods if m in medians]
    return friedman_blocks(medians[methods], metric, alpha)


def friedman_blocks(medians: pd.DataFrame, metric: str = "best_f", alpha: float = 0.05,
                    blocks: str = "cells") -> FriedmanResult:
    """Friedman test over the blocks (rows of ``medians``, one column per method) where every
    method has a value; average ranks (1 = best), sorted; Nemenyi post-hoc (scikit-posthocs).
    For two methods, a sign test over the blocks (scipy). ``blocks`` names the rows in the
    notes ("cells", "problems")."""
    import scikit_posthocs as sp

    methods = list(medians.columns)
    complete = medians.dropna()
    ranks = (complete.rank(axis=1).mean().sort_values(kind="stable") if len(complete)
             else pd.Series(dtype=float))
    base: dict[str, Any] = {"metric": metric, "blocks": len(complete), "ranks": ranks,
            "statistic": np.nan, "p": np.nan, "posthoc": None}
    if len(methods) < 2:
        return FriedmanResult(**{**base, "ranks": pd.Series(1.0, index=methods)},
                              note="one method only: nothing to compare")
    if len(methods) == 2:
        if len(complete) == 0:
            return FriedmanResult(**base, note=f"no {blocks[:-1]} where both methods ran")
        first, second = complete[methods[0]].to_numpy(), complete[methods[1]].to_numpy()
        wins, losses = int((first < second).sum()), int((first > second).sum())
        if wins + losses == 0:
            return FriedmanResult(**base, note=f"the two methods tie in every {blocks[:-1]}: "
                                               "no test")
        counts = f"{methods[0]} lower in {wins}, {methods[1]} in {losses}"
        needed = sign_test_blocks_needed(alpha)
        if wins + losses < needed:
            return FriedmanResult(**base, note=(
                f"two methods differ in only {wins + losses} {blocks} ({counts}): a sign "
                f"test needs at least {needed} to reach p < {alpha:g}; no test"))
        p = float(stats.binomtest(wins, wins + losses).pvalue)
        return FriedmanResult(**{**base, "p": p}, note=(
            f"two methods: sign test over the {blocks} ({counts}), scale-free as the "
            "Friedman test"))
    if len(complete) < 2:
        return FriedmanResult(**base, note=f"{len(complete)} {blocks[:-1]}(s) where every "
                                           "method ran: the Friedman test needs at least 2")
    values = complete.to_numpy()
    if np.all(values == values[:, :1]):
        return FriedmanResult(**base, note=f"every method ties in every {blocks[:-1]}: no test")
    result = stats.friedmanchisquare(*values.T)
    posthoc = sp.posthoc_nemenyi_friedman(complete.reset_index(drop=True))
    note = ("the methods differ (Nemenyi post-hoc below)" if result.pvalue < alpha else
            "no significant difference between the methods")
    return FriedmanResult(**{**base, "statistic": float(result.statistic),
                             "p": float(result.pvalue), "posthoc": posthoc}, note=note)


def smallest_p(pairs: int, comparisons: int = 1) -> float:
    """The smallest two-sided p-value an exact Wilcoxon signed-rank (or sign) test on ``pairs``
    differing pairs can give, ``2 / 2**pairs``, Holm-corrected over ``comparisons`` tests
    (the smallest p is multiplied by their number)."""
    return min(1.0, comparisons * 2.0 ** (1 - pairs)) if pairs > 0 else 1.0


def seeds_needed(comparisons: int, alpha: float = 0.05) -> int:
    """Fewest differing pairs with which one of ``comparisons`` Holm-corrected exact tests can
    reach p < ``alpha``."""
    pairs = 1
    while smallest_p(pairs, comparisons) >= alpha:
        pairs += 1
    return pairs


def sign_test_blocks_needed(alpha: float = 0.05) -> int:
    """Fewest differing blocks with which a two-sided sign test can reach p < ``alpha``."""
    return seeds_needed(1, alpha)


def design_power_note(comparison: Comparison, alpha: float = 0.05) -> str | None:
    """Why no pair of methods can be significant in some cells, and how many seeds would let
    one be (``None`` if every cell can reach ``alpha``): with ``n`` paired seeds and ``m`` pairs
    of methods per cell, the smallest Holm-corrected Wilcoxon p is ``m · 2 / 2**n``."""
    methods = comparison.runs.groupby(["instance", "budget"], sort=False).method.nunique()
    seeds = comparison.runs.groupby(["instance", "budget", "method"], sort=False).seed.nunique()
    seeds = seeds.groupby(level=[0, 1], sort=False).min()
    cells = pd.DataFrame({"methods": methods, "seeds": seeds})
    cells = cells[cells.methods >= 2]
    cells["pairs"] = cells.methods * (cells.methods - 1) // 2
    cells["reachable"] = [smallest_p(n, m) for n, m in zip(cells.seeds, cells.pairs,
                                                           strict=True)]
    blocked = cells[cells.reachable >= alpha]
    if blocked.empty:
        return None
    worst = blocked.sort_values(["reachable", "pairs"], ascending=False).iloc[0]
    n, m = int(worst.seeds), int(worst.pairs)
    scope = ("every cell" if len(blocked) == len(cells)
             else f"{len(blocked)} of {len(cells)} cells")
    return (f"The design cannot reach significance in {scope}: with {n} paired seeds and "
            f"{m} pair(s) of methods, the smallest Holm-corrected Wilcoxon p-value is "
            f"{smallest_p(n, m):.2g} (≥ {alpha:g}), so no pair can be significant whatever "
            f"the results; {seeds_needed(m, alpha)} seeds per method (all differing) would "
            "make it possible.")


def plain_summary(comparison: Comparison, pairwise: pd.DataFrame, alpha: float = 0.05,
                  friedman: FriedmanResult | None = None,
                  metric: str | None = None) -> list[str]:
    """A few sentences: per instance, which method is best at how many budgets, by how much
    and whether significantly; then the comparison across instances. ``metric`` defaults to
    the pairwise table's (or the objective)."""
    if metric is None:
        metric = str(pairwise["metric"].iloc[0]) if len(pairwise) else "best_f"
    metric_name = METRICS.get(metric, metric)
    lines = []
    runs = comparison.runs
    if len(comparison.methods) < 2:
        return [f"Only one method ({comparison.methods[0]}) ran: there is nothing to compare."]
    for instance in comparison.instances:
        cells = []
        for budget in comparison.budgets:
            cell = runs[(runs.instance == instance) & (runs.budget == budget)]
            if cell.empty:
                continue
            medians = cell.groupby("method")[metric].median().sort_values()
            if len(medians) < 2:
                continue
            tied = medians.index[medians == medians.iloc[0]].tolist()
            if len(tied) > 1:  # an exact tie: no method is "lowest"
                cells.append((budget, " and ".join(sorted(tied)), None, medians.iloc[0],
                              medians.iloc[0], np.nan, False, "tie"))
                continue
            best, second = medians.index[0], medians.index[1]
            pair = pairwise[(pairwise.instance == instance) & (pairwise.budget == budget)
                            & (((pairwise.A == best) & (pairwise.B == second))
                               | ((pairwise.A == second) & (pairwise.B == best)))]
            row = pair.iloc[0] if len(pair) else None
            effect = np.nan if row is None else (row.A12 if row.A == best else 1 - row.A12)
            significant = bool(row is not None and row.significant)
            why = "no pair" if row is None else (row.note or f"p = {_p_text(row.p_holm)}")
            cells.append((budget, best, second, medians.iloc[0], medians.iloc[1], effect,
                          significant, why))
        if not cells:
            continue
        winners = pd.Series([c[1] for c in cells]).value_counts()
        parts = []
        for method, count in winners.items():
            won = [c for c in cells if c[1] == method]
            sig = [c for c in won if c[6]]
            effects = [c[5] for c in sig] or [c[5] for c in won]
            budgets = ", ".join(_budget(c[0]) for c in won)
            where = "at every budget" if count == len(cells) and len(cells) > 1 else (
                f"at {count} of {len(cells)} budgets ({budgets})" if len(cells) > 1
                else f"at budget {budgets}")
            if won[0][7] == "tie":
                text = (f"{method} tie for the lowest median {metric_name} {where} (equal "
                        f"medians, {', '.join(dict.fromkeys(f'{c[3]:.3g}' for c in won))})")
            elif sig:
                text = (f"**{method}** has the lowest median {metric_name} {where}, "
                        f"significantly better than the runner-up at {len(sig)} of them "
                        f"(A12 {_range(effects)}, {magnitude(float(np.median(effects)))} "
                        f"effect, Holm-corrected Wilcoxon p < {alpha:g})")
            else:
                reasons = sorted({c[7] for c in won})
                text = (f"{method} has the lowest median {metric_name} {where}, but not "
                        f"significantly better than the runner-up ({'; '.join(reasons)})")
            parts.append(text)
        lines.append(f"On **{instance}**: " + "; ".join(parts) + ".")
    if friedman is not None:
        ranks = ", ".join(f"{m} {r:.2f}" for m, r in friedman.ranks.items())
        if np.isfinite(friedman.p):
            verdict = ("differ significantly" if friedman.p < alpha else
                       "do not differ significantly")
            test = "a sign test" if len(friedman.ranks) == 2 else "a Friedman test"
            lines.append(f"Across {friedman.blocks} instance–budget cells the average ranks "
                         f"(1 = best) are {ranks}; by {test} the methods {verdict} "
                         f"(p = {friedman.p:.2g}).")
        elif len(friedman.ranks):
            lines.append(f"Across {friedman.blocks} instance–budget cells the average ranks "
                         f"(1 = best) are {ranks} ({friedman.note}).")
    return lines


def _p_text(value: float) -> str:
    return "n/a" if not np.isfinite(value) else f"{value:.2g}"


def _budget(value: int) -> str:
    return f"{value:,}"


def _range(values: list[float]) -> str:
    finite = [v for v in values if np.isfinite(v)]
    if not finite:
        return "n/a"
    low, high = min(finite), max(finite)
    return f"{low:.2f}" if np.isclose(low, high) else f"{low:.2f}–{high:.2f}"


def _ordered(table: pd.DataFrame, comparison: Comparison) -> pd.DataFrame:
    order: dict[str, Any] = {"instance": comparison.instances, "budget": comparison.budgets,
                             **dict.fromkeys(("method", "A", "B"), comparison.methods)}
    keys = []
    for column, values in order.items():
        if column in table:
            rank = {v: i for i, v in enumerate(values)}
            table[f"_{column}"] = table[column].map(rank)
            keys.append(f"_{column}")
    table = table.sort_values(keys, kind="stable").drop(columns=keys)
    return table.reset_index(drop=True)
