"""The report of a study (``metaknot report``): on studies with known outcomes it finds a
dominance that is there and none that is not; its tables equal a recomputation with pandas,
scipy and statsmodels; tests that cannot be applied are said in words; partial studies, failed
runs and broken stores are handled with a clear message; the files it writes (HTML with embedded
figures, Markdown, CSV, LaTeX, PNG, SVG) are complete and the study is never modified."""

from __future__ import annotations

import base64
import functools
import hashlib
import itertools
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from statsmodels.stats.multitest import multipletests

import metaknot.experiments.report.figures as figures_module
from metaknot.cli import main as cli_main
from metaknot.experiments.report import Report, ReportError, build, prepare
from metaknot.experiments.report.data import METRICS
from metaknot.experiments.report.tables import (
    MIN_PAIRS,
    a12,
    friedman_test,
    magnitude,
    pairwise_tests,
    plain_summary,
    summary_table,
)
from metaknot.experiments.spec import run_id, run_spec
from metaknot.experiments.store import COMPLETE_STATUSES, Store, load_study

ALPHA = 0.05
#: Real algorithms behind the synthetic methods (their configurations must rebuild).
ALGORITHMS = {"A": "ga", "B": "random_search", "C": "dolphin", "X": "ga", "Y": "random_search"}
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
SIGMA = "\N{GREEK SMALL LETTER SIGMA}"


# --------------------------------------------------------------------------------------------
# synthetic studies: records written directly with Store.write (no optimisation)


@functools.cache
def _base_config(data: str, algorithm: str) -> str:
    """A real normalised run configuration (JSON) for ``data`` and ``algorithm``."""
    spec = run_spec({
        "study": "s", "results_dir": "unused", "budget": 100, "seed": 0, "label": None,
        "problem": {"name": data, "curve": data, "n_points": 60, "noise": 0.0, "degree": 3,
                    "parameterization": "centripetal"},
        "encoding": {"kind": "mask", "density": 0.5},
        "objective": {"name": "paper", "error_floor": 1e-5},
        "optimizer": {"_name_": algorithm}})
    return json.dumps(spec.config, sort_keys=True)


@functools.cache
def _problem(data: str):
    config = json.loads(_base_config(data, "ga"))
    return run_spec({**config, "study": "s", "results_dir": "unused"}).build_problem()


def _trace(budget: int, final: float, rmse: float, n_cp: float) -> dict[str, np.ndarray]:
    """A best-so-far trace on log-spaced checkpoints, ending at the run's outcome."""
    evaluations = np.unique(np.geomspace(1, budget, 12).round().astype(np.int64))
    factor = np.geomspace(3.0, 1.0, evaluations.size)
    return {"evaluations": evaluations, "best_f": final * factor, "rmse": rmse * factor,
            "n_control_points": np.full(evaluations.size, float(n_cp)),
            "improvement": np.ones(evaluations.size, dtype=bool),
            "checkpoint": np.ones(evaluations.size, dtype=bool)}


def _run(method: str | None, seed: int, budget: int, best_f: float, *, data="archimedean",
         algorithm: str | None = None, status="ok", **fields) -> dict:
    """One synthetic run: its record fields (metrics not given are derived from ``best_f``)."""
    algorithm = algorithm or ALGORITHMS.get(method, "ga")
    config = json.loads(_base_config(data, algorithm))
    config.update(budget=budget, seed=seed)
    finite = best_f if np.isfinite(best_f) else np.nan
    record = {
        "study": "s", "label": method, "timestamp": f"2024-01-01T00:00:{seed % 60:02d}+00:00",
        "problem": "mask", "encoding": "binary", "data": data, "noise": 0.0,
        "degree": 3, "parameterization": "centripetal", "objective": "paper",
        "objective.error_floor": 1e-5, "optimizer": algorithm, "seed": seed, "budget": budget,
        "n_evaluations": budget, "best_f": best_f, "rmse": finite * 1e-3,
        "euclidean_distance": finite * 1e-2, "max_deviation": finite * 3e-3,
        "n_control_points": 20, "dim": int(_problem(data).points.shape[1]),
        "status": status, "error": None if status == "ok" else "RuntimeError: boom",
        "config": json.dumps(config, sort_keys=True)}
    record.update(fields)
    # distinct runs need distinct settings, whose hash is the run id (the store checks it):
    # what tells this synthetic run apart goes into problem.noise_seed, which leaves the
    # noiseless data as they are
    identity = json.dumps({k: v for k, v in record.items() if k not in ("timestamp", "config")},
                          sort_keys=True, default=str)
    config["problem"]["noise_seed"] = int(hashlib.sha256(identity.encode()).hexdigest()[:8], 16)
    record["config"] = json.dumps(config, sort_keys=True)
    record["run_id"] = run_id(config)
    return record


def _write(study_dir: Path, runs: list[dict]) -> Path:
    """Store the runs (each with a valid candidate of its problem and a trace)."""
    store = Store(study_dir)
    for record in runs:
        rng = np.random.default_rng(record["seed"])
        best_x = _problem(record["data"]).sample(rng, 1)[0]
        final = record["best_f"] if np.isfinite(record["best_f"]) else 1.0
        rmse = record["rmse"] if np.isfinite(record["rmse"]) else 1.0
        trace = _trace(record["budget"], final, rmse, record["n_control_points"])
        store.write(record, best_x=best_x, trace=trace)
    assert len(list(store.runs_dir.glob("*.parquet"))) == sum(
        r["status"] in COMPLETE_STATUSES for r in runs), "run ids collide"
    return study_dir


def _snapshot(directory: Path) -> dict[str, tuple]:
    """Every file and folder under ``directory``: size, modification time and bytes."""
    return {p.relative_to(directory).as_posix():
            (p.is_dir(), p.stat().st_size, p.stat().st_mtime_ns,
             None if p.is_dir() else p.read_bytes())
            for p in sorted(directory.rglob("*"))}


def _dominance_runs(methods=("A", "B"), factors=(0.5, 1.0), seeds=12, rng_seed=1,
                    instances=("archimedean", "vivaldi"), budgets=(300, 1000),
                    noise=0.01) -> list[dict]:
    """Every method on every instance, budget and seed: ``base * factor + noise``."""
    rng = np.random.default_rng(rng_seed)
    runs = []
    for data, budget, seed in itertools.product(instances, budgets, range(seeds)):
        base = rng.uniform(1.0, 2.0)
        for method, factor in zip(methods, factors, strict=True):
            value = base * factor + rng.normal(0.0, noise)
            runs.append(_run(method, seed, budget, value, data=data,
                             rmse=value * 1e-3 + abs(rng.normal(0.0, 1e-6))))
    return runs


def _pair_values(runs: pd.DataFrame, instance, budget, a, b, metric="best_f"):
    """The paired values of methods ``a`` and ``b`` on their common seeds (recomputed)."""
    cell = runs[(runs.instance == instance) & (runs.budget == budget)]
    wide = cell.pivot(index="seed", columns="method", values=metric)[[a, b]].dropna()
    return wide[a].to_numpy(), wide[b].to_numpy()


@pytest.fixture(scope="module")
def dominance(tmp_path_factory):
    """A beats B on every seed of 2 instances x 2 budgets (12 seeds)."""
    return _write(tmp_path_factory.mktemp("dominance") / "dominance", _dominance_runs())


@pytest.fixture(scope="module")
def no_dominance(tmp_path_factory):
    """X and Y drawn from the same distribution on paired seeds."""
    rng = np.random.default_rng(2024)
    runs = []
    for data, budget, seed in itertools.product(("archimedean", "vivaldi"), (300, 1000),
                                                range(12)):
        for method in ("X", "Y"):
            runs.append(_run(method, seed, budget, rng.lognormal(0.0, 0.3), data=data))
    return _write(tmp_path_factory.mktemp("same") / "same", runs)


@pytest.fixture(scope="module")
def three_methods(tmp_path_factory):
    """Three methods with a real but noisy difference; every metric drawn independently."""
    rng = np.random.default_rng(7)
    runs = []
    factors = {"A": 1.0, "B": 1.25, "C": 1.6}
    for data, budget, seed in itertools.product(("archimedean", "vivaldi"), (300, 1000),
                                                range(8)):
        for method, factor in factors.items():
            runs.append(_run(method, seed, budget, factor * rng.lognormal(0.0, 0.2),
                             data=data, rmse=rng.lognormal(-9, 0.5),
                             euclidean_distance=rng.lognormal(-6, 0.5),
                             max_deviation=rng.lognormal(-7, 0.5),
                             n_control_points=int(rng.integers(12, 20))))
    return _write(tmp_path_factory.mktemp("three") / "three", runs)


# --------------------------------------------------------------------------------------------
# 1. a dominance that is there is found


def test_dominance_is_found_in_every_cell(dominance):
    comparison = prepare(dominance)
    assert comparison.methods == ["A", "B"]
    assert comparison.instances == ["archimedean", "vivaldi"]
    assert comparison.budgets == [300, 1000]
    runs = comparison.runs
    for metric in ("best_f", "rmse"):
        table = pairwise_tests(comparison, metric, ALPHA)
        assert len(table) == 4
        assert set(zip(table.instance, table.budget, strict=True)) == set(
            itertools.product(["archimedean", "vivaldi"], [300, 1000]))
        for row in table.itertuples():
            x, y = _pair_values(runs, row.instance, row.budget, "A", "B", metric)
            assert (x < y).all()  # the study is what it claims
            assert (row.A, row.B, row.n) == ("A", "B", 12)
            assert (row.wins, row.ties, row.losses) == (12, 0, 0)
            assert row.A12 == pytest.approx(a12(x, y)) and row.A12 > 0.9
            assert row.effect == "large"
            assert row.p == pytest.approx(stats.wilcoxon(x, y).pvalue)
            assert row.p_holm < ALPHA and row.significant and row.note == ""


def test_dominance_in_words_and_ranks(dominance):
    comparison = prepare(dominance)
    pairwise = pairwise_tests(comparison, "best_f", ALPHA)
    friedman = friedman_test(comparison, "best_f", ALPHA)
    assert list(friedman.ranks.index) == ["A", "B"]
    assert friedman.ranks.tolist() == [1.0, 2.0] and friedman.blocks == 4
    # two methods differing in 4 cells: a sign test cannot reach 0.05 (its smallest p is
    # 0.125), so none is reported, and the note says how many cells would do
    assert np.isnan(friedman.p)
    assert friedman.note == ("two methods differ in only 4 cells (A lower in 4, B in 0): a "
                             "sign test needs at least 6 to reach p < 0.05; no test")
    lines = plain_summary(comparison, pairwise, ALPHA, friedman)
    assert len(lines) == 3
    for line, instance in zip(lines, ["archimedean", "vivaldi"], strict=False):
        assert line.startswith(f"On **{instance}**: **A** has the lowest median objective at "
                               "every budget, significantly better than the runner-up at 2 of "
                               "them (A12 1.00, large effect")
        assert "not significantly" not in line and "B has the lowest" not in line
    assert "average ranks (1 = best) are A 1.00, B 2.00" in lines[2]
    assert "sign test needs at least 6" in lines[2] and "p =" not in lines[2]


def test_three_dominating_methods_differ_by_friedman(tmp_path):
    study = _write(tmp_path / "s", _dominance_runs(methods=("A", "B", "C"),
                                                   factors=(0.5, 1.0, 1.5), seeds=8))
    comparison = prepare(study)
    assert comparison.methods == ["A", "B", "C"]
    table = pairwise_tests(comparison, "best_f", ALPHA)
    assert len(table) == 12 and table.significant.all()
    assert (table.wins == 8).all() and (table.A12 > 0.9).all()
    assert (table.effect == "large").all()
    friedman = friedman_test(comparison, "best_f", ALPHA)
    assert friedman.ranks.tolist() == [1.0, 2.0, 3.0]
    assert friedman.p < ALPHA and "differ" in friedman.note
    assert list(friedman.posthoc.columns) == ["A", "B", "C"]
    lines = plain_summary(comparison, table, ALPHA, friedman)
    assert "by a Friedman test the methods differ significantly" in lines[-1]


# --------------------------------------------------------------------------------------------
# 2. no dominance where there is none


def test_no_dominance_between_methods_of_the_same_distribution(no_dominance):
    comparison = prepare(no_dominance)
    table = pairwise_tests(comparison, "best_f", ALPHA)
    assert len(table) == 4
    assert np.isfinite(table.p).all()  # the tests ran (12 paired runs, all differ)
    assert (table.p_holm > ALPHA).all() and not table.significant.any()
    assert (table.note == "").all()
    friedman = friedman_test(comparison, "best_f", ALPHA)
    lines = plain_summary(comparison, table, ALPHA, friedman)
    assert len(lines) == 3
    for line in lines[:2]:
        assert "not significantly better than the runner-up" in line
        assert "significantly better than the runner-up at" not in line
        assert "p = " in line  # the reason: the Holm-corrected p-value


# --------------------------------------------------------------------------------------------
# 3. the tables equal a recomputation


def _recomputed_runs(study_dir: Path) -> pd.DataFrame:
    runs = load_study(study_dir).runs
    runs = runs[runs.status == "ok"].copy()
    runs["method"] = runs["label"]
    runs["instance"] = runs["data"]
    return runs


def test_summary_table_equals_a_groupby(three_methods):
    comparison = prepare(three_methods)
    table = summary_table(comparison)
    runs = _recomputed_runs(three_methods)
    assert len(table) == 2 * 2 * 3
    # ordered by instance, budget, method as the comparison lists them
    keys = list(zip(table.instance, table.budget, table.method, strict=True))
    assert keys == list(itertools.product(comparison.instances, comparison.budgets,
                                          comparison.methods))
    for (instance, budget, method), group in runs.groupby(["instance", "budget", "method"]):
        row = table[(table.instance == instance) & (table.budget == budget)
                    & (table.method == method)]
        assert len(row) == 1
        row = row.iloc[0]
        assert row.runs == len(group) == 8
        for metric in METRICS:
            values = group[metric].to_numpy(dtype=float)
            q25, q75 = np.percentile(values, [25, 75])
            assert row[f"{metric} median"] == pytest.approx(np.median(values), rel=1e-12)
            assert row[f"{metric} IQR"] == pytest.approx(q75 - q25, rel=1e-12)
            assert row[f"{metric} mean"] == pytest.approx(values.mean(), rel=1e-12)
            assert row[f"{metric} sd"] == pytest.approx(values.std(ddof=1), rel=1e-12)
    for metric in METRICS:
        medians = runs.groupby(["instance", "budget", "method"])[metric].median()
        best = medians == medians.groupby(level=["instance", "budget"]).transform("min")
        for row in table.to_dict("records"):
            expected = bool(best[(row["instance"], row["budget"], row["method"])])
            assert bool(row[f"{metric} best"]) == expected, (metric, row["method"])
        assert table[f"{metric} best"].sum() >= 4  # at least one per cell


def test_method_order_is_the_average_rank_of_the_median_objective(three_methods):
    runs = _recomputed_runs(three_methods)
    medians = runs.groupby(["instance", "budget", "method"]).best_f.median().unstack()
    mean_rank = medians.rank(axis=1).mean()
    expected = sorted(mean_rank.index, key=lambda m: (mean_rank[m], m))
    assert prepare(three_methods).methods == expected


def test_holm_is_statsmodels_holm_and_leaves_the_collector_as_it_was():
    import gc

    from metaknot.experiments.report.tables import holm

    def reference(p: np.ndarray) -> np.ndarray:
        gc.freeze()  # statsmodels' gc.collect() then walks only the call's objects (38 s -> 1 s)
        try:
            return multipletests(p, method="holm")[1]
        finally:
            gc.unfreeze()

    frozen = gc.get_freeze_count()
    rng = np.random.default_rng(2)
    for size in (1, 2, 3, 6, 15, 28):
        for _ in range(20):
            p = rng.choice([rng.random(), 0.01, 0.5, 1.0], size=size) * rng.random(size) ** 2
            p[rng.random(size) < 0.3] = 0.04  # ties
            adjusted = holm(p)
            assert gc.get_freeze_count() == frozen
            assert np.array_equal(adjusted, reference(p))


def test_the_wilcoxon_p_is_scipy_s():
    """The same p as ``scipy.stats.wilcoxon(x, y)`` to the last bit, with and without ties and
    zero differences (scipy's permutation test, its exact test and its normal approximation),
    whatever the order of the pairs."""
    from metaknot.experiments.report.tables import wilcoxon_p

    rng = np.random.default_rng(0)
    for trial in range(40):
        # counts of control points, at most 13 pairs (scipy's slow permutation test: 10 cases),
        # more pairs (its normal approximation), and real values (its exact test)
        n = int(rng.integers(6, 14)) if trial < 10 else int(rng.integers(6, 30))
        if trial < 28:
            x = rng.integers(3, 9, n).astype(float)
            y = x + rng.integers(-2, 3, n)
        else:
            x = rng.random(n)
            y = x + rng.normal(0, 0.1, n)
        if (x == y).all():
            continue
        order = rng.permutation(n)
        assert wilcoxon_p(x[order], y[order]) == float(stats.wilcoxon(x, y).pvalue), trial


@pytest.mark.parametrize("metric", ["best_f", "rmse", "n_control_points"])
def test_pairwise_tests_equal_scipy_and_statsmodels(three_methods, metric):
    comparison = prepare(three_methods)
    table = pairwise_tests(comparison, metric, ALPHA)
    runs = _recomputed_runs(three_methods)
    assert len(table) == 2 * 2 * 3
    assert (table.metric == metric).all()
    for (instance, budget), cell in table.groupby(["instance", "budget"], sort=False):
        expected_p = []
        for row in cell.itertuples():
            assert comparison.methods.index(row.A) < comparison.methods.index(row.B)
            x, y = _pair_values(runs, instance, budget, row.A, row.B, metric)
            assert row.n == len(x) == 8
            medians = cell.loc[row.Index, ["median A", "median B"]].to_numpy(dtype=float)
            np.testing.assert_allclose(medians, [np.median(x), np.median(y)], rtol=1e-12)
            lower = sum(a < b for a in x for b in y)
            tied = sum(a == b for a in x for b in y)
            assert row.A12 == pytest.approx((lower + 0.5 * tied) / (len(x) * len(y)))
            assert row.effect == magnitude(row.A12)
            assert (row.wins, row.ties, row.losses) == (
                int((x < y).sum()), int((x == y).sum()), int((x > y).sum()))
            if (x != y).sum() >= MIN_PAIRS:
                p = stats.wilcoxon(x, y).pvalue
                assert row.p == pytest.approx(p, rel=1e-12)
                expected_p.append(p)
            else:
                assert np.isnan(row.p) and "no test" in row.note
        tested = cell[np.isfinite(cell.p)]
        assert len(tested) == len(expected_p)
        if expected_p:
            holm = multipletests(expected_p, method="holm")[1]
            np.testing.assert_allclose(tested.p_holm.to_numpy(), holm, rtol=1e-12)
            np.testing.assert_array_equal(tested.significant.to_numpy(), holm < ALPHA)
    assert table.p.notna().sum() > 0  # the comparison is not vacuous


@pytest.mark.parametrize("metric", ["best_f", "rmse"])
def test_friedman_and_ranks_equal_scipy_and_pandas(three_methods, metric):
    comparison = prepare(three_methods)
    result = friedman_test(comparison, metric, ALPHA)
    runs = _recomputed_runs(three_methods)
    medians = runs.groupby(["instance", "budget", "method"])[metric].median().unstack()
    medians = medians[comparison.methods]
    expected = stats.friedmanchisquare(*(medians[m].to_numpy() for m in comparison.methods))
    assert result.blocks == 4
    assert result.statistic == pytest.approx(expected.statistic, rel=1e-12)
    assert result.p == pytest.approx(expected.pvalue, rel=1e-12)
    ranks = np.vstack([stats.rankdata(row) for row in medians.to_numpy()]).mean(axis=0)
    expected_ranks = pd.Series(ranks, index=comparison.methods)
    # the ranks come sorted by rank (the RMSE's order differs from the objective's here)
    assert result.ranks.is_monotonic_increasing
    assert set(result.ranks.index) == set(comparison.methods)
    pd.testing.assert_series_equal(result.ranks, expected_ranks.reindex(result.ranks.index),
                                   check_names=False)
    if metric == "rmse":
        assert list(result.ranks.index) != comparison.methods
    assert result.posthoc is not None and result.posthoc.shape == (3, 3)
    verdict = "the methods differ" if expected.pvalue < ALPHA else "no significant difference"
    assert result.note.startswith(verdict)


def test_a12_brute_force_and_magnitude_words():
    rng = np.random.default_rng(3)
    for _ in range(20):
        a, b = rng.integers(0, 5, rng.integers(1, 9)), rng.integers(0, 5, rng.integers(1, 9))
        count = sum(1.0 if x < y else 0.5 if x == y else 0.0 for x in a for y in b)
        assert a12(a, b) == pytest.approx(count / (len(a) * len(b)))
        assert a12(a, b) + a12(b, a) == pytest.approx(1.0)
    assert a12([1, 2], [2, 3]) == pytest.approx(3.5 / 4)
    assert np.isnan(a12([], [1.0]))
    words = {0.5: "negligible", 0.559: "negligible", 0.441: "negligible", 0.561: "small",
             0.639: "small", 0.361: "small", 0.641: "medium", 0.709: "medium",
             0.359: "medium", 0.291: "medium", 0.711: "large", 0.289: "large", 1.0: "large",
             0.0: "large"}
    for value, word in words.items():
        assert magnitude(value) == word, value
    assert magnitude(np.nan) == ""


# --------------------------------------------------------------------------------------------
# 4. tests that cannot be applied are said in words, with no p-value


def _one_cell(tmp_path, a_values, b_values, *, methods=("A", "B")) -> Path:
    runs = [_run(m, seed, 300, float(v)) for m, values in zip(methods, (a_values, b_values),
                                                             strict=True)
            for seed, v in enumerate(values)]
    return _write(tmp_path / "s", runs)


def test_too_few_paired_runs_are_not_tested(tmp_path):
    comparison = prepare(_one_cell(tmp_path, [1.0, 1.1, 1.2, 1.3], [2.0, 2.1, 2.2, 2.3]))
    (row,) = pairwise_tests(comparison).itertuples()
    assert (row.n, row.wins, row.A12) == (4, 4, 1.0)
    assert np.isnan(row.p) and np.isnan(row.p_holm) and not row.significant
    assert row.note == ("only 4 paired runs differ (a test needs at least 6 to reach "
                        "p < 0.05): no test")
    lines = plain_summary(comparison, pairwise_tests(comparison), ALPHA)
    assert lines == ["On **archimedean**: A has the lowest median objective at budget 300, "
                     f"but not significantly better than the runner-up ({row.note})."]


def test_all_ties_are_not_tested(tmp_path):
    values = [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5]
    comparison = prepare(_one_cell(tmp_path, values, values))
    (row,) = pairwise_tests(comparison).itertuples()
    assert (row.n, row.wins, row.ties, row.losses) == (8, 0, 8, 0)
    assert row.A12 == 0.5 and row.effect == "negligible"
    assert np.isnan(row.p) and not row.significant
    assert row.note == "all paired runs tie: no test"
    friedman = friedman_test(comparison)
    assert np.isnan(friedman.p) and friedman.note == "the two methods tie in every cell: no test"


def test_infinite_values_are_not_tested(tmp_path):
    a = [1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, np.inf]
    b = [2.0, 2.1, 2.2, 2.3, 2.4, 2.5, 2.6, 2.7]
    study = _one_cell(tmp_path, a, b)
    comparison = prepare(study)
    (row,) = pairwise_tests(comparison, "best_f").itertuples()
    assert row.n == 8 and (row.wins, row.losses) == (7, 1)
    assert np.isnan(row.p) and row.note == "infeasible runs (infinite values): no test"
    # the infeasible run has no RMSE: the RMSE pairs leave it out and are tested
    (rmse,) = pairwise_tests(comparison, "rmse").itertuples()
    assert rmse.n == 7 and rmse.p == pytest.approx(stats.wilcoxon(
        np.array(a[:7]) * 1e-3, np.array(b[:7]) * 1e-3).pvalue)
    report = build(study, tmp_path / "report", figures=False, log=None)
    assert "infeasible runs (infinite values): no test" in report.markdown.read_text()
    summary = report.tables["summary"]
    assert summary.loc[summary.method == "A", "best_f mean"].item() == np.inf


def test_a_single_method_has_nothing_to_compare(tmp_path):
    study = _write(tmp_path / "s", [_run("A", seed, budget, 1.0 + seed)
                                    for seed in range(6) for budget in (300, 1000)])
    comparison = prepare(study)
    pairwise = pairwise_tests(comparison)
    assert pairwise.empty and list(pairwise.columns)[:5] == ["instance", "budget", "metric",
                                                             "A", "B"]
    friedman = friedman_test(comparison)
    assert np.isnan(friedman.p) and friedman.note == "one method only: nothing to compare"
    assert friedman.ranks.tolist() == [1.0]
    assert plain_summary(comparison, pairwise, ALPHA, friedman) == [
        "Only one method (A) ran: there is nothing to compare."]
    report = build(study, tmp_path / "report", figures=False, log=None)
    assert "there is nothing to compare" in report.html.read_text()


def test_two_methods_use_a_sign_test_over_the_cells(tmp_path):
    # A lower in 6 cells, B lower in 2
    runs = []
    for budget, (fa, fb) in zip((100, 200, 300, 500, 1000, 2000, 3000, 5000),
                                ((1, 2), (1, 2), (1, 2), (1, 2), (1, 2), (1, 2), (2, 1), (2, 1)),
                                strict=True):
        for seed in range(6):
            runs += [_run("A", seed, budget, fa + 0.01 * seed),
                     _run("B", seed, budget, fb + 0.01 * seed)]
    comparison = prepare(_write(tmp_path / "s", runs))
    result = friedman_test(comparison)
    assert result.blocks == 8
    assert result.p == pytest.approx(stats.binomtest(6, 8).pvalue)
    assert result.note == ("two methods: sign test over the cells (A lower in 6, B in 2), "
                           "scale-free as the Friedman test")
    assert np.isnan(result.statistic) and result.posthoc is None
    assert result.ranks.to_dict() == pytest.approx({"A": 1.25, "B": 1.75})


def test_friedman_needs_two_complete_cells(tmp_path):
    runs = [_run(m, seed, 300, f + 0.01 * seed)
            for m, f in (("A", 1), ("B", 2), ("C", 3)) for seed in range(6)]
    runs += [_run("A", seed, 1000, 1 + 0.01 * seed) for seed in range(6)]  # A alone here
    comparison = prepare(_write(tmp_path / "s", runs))
    result = friedman_test(comparison)
    assert result.blocks == 1 and np.isnan(result.p)
    assert result.note == ("1 cell(s) where every method ran: the Friedman test needs at "
                           "least 2")


# --------------------------------------------------------------------------------------------
# 5. partial studies


def test_partial_study_reports_its_counts_and_pairs_common_seeds(tmp_path):
    runs = []
    for budget, seed in itertools.product((300, 1000), range(10)):
        runs.append(_run("A", seed, budget, 1.0 + 0.1 * seed))
        if budget == 300 or seed < 7:  # B stopped after 7 seeds at 1000
            runs.append(_run("B", seed, budget, 1.5 + 0.1 * seed + 0.01 * (seed % 3)))
    study = _write(tmp_path / "s", runs)
    report = build(study, tmp_path / "report", figures=False, log=None)
    cells = report.tables["cells"].set_index(["budget", "method"]).runs
    assert cells.to_dict() == {(300, "A"): 10, (300, "B"): 10, (1000, "A"): 10,
                               (1000, "B"): 7}
    assert (report.tables["cells"].instance == "archimedean").all()
    assert pd.read_csv(report.out / "tables" / "cells.csv").runs.tolist() == \
        report.tables["cells"].runs.tolist()
    pairwise = report.tables["pairwise_best_f"].set_index("budget")
    assert pairwise.n.to_dict() == {300: 10, 1000: 7}
    a = np.array([1.0 + 0.1 * s for s in range(7)])
    b = np.array([1.5 + 0.1 * s + 0.01 * (s % 3) for s in range(7)])
    assert pairwise.loc[1000, "p"] == pytest.approx(stats.wilcoxon(a, b).pvalue)
    assert pairwise.loc[1000, "median A"] == pytest.approx(np.median(a))  # common seeds only
    summary = report.tables["summary"].set_index(["budget", "method"])
    assert summary.loc[(1000, "A"), "runs"] == 10 and summary.loc[(1000, "B"), "runs"] == 7
    for text in (report.markdown.read_text(), report.html.read_text()):
        assert "The study is partial: 1 of 4 cells have fewer than 10 runs" in text


def test_methods_that_never_share_a_cell(tmp_path):
    """A partial study where A has run only at one budget and B only at another: nothing to
    pair, but the report still builds and says so."""
    runs = [_run("A", seed, 300, 1.0 + seed) for seed in range(6)]
    runs += [_run("B", seed, 1000, 2.0 + seed) for seed in range(6)]
    study = _write(tmp_path / "s", runs)
    comparison = prepare(study)
    assert pairwise_tests(comparison).empty
    friedman = friedman_test(comparison)
    assert friedman.blocks == 0 and friedman.note == "no cell where both methods ran"
    report = build(study, tmp_path / "report", figures=False, log=None)
    assert report.tables["pairwise_best_f"].empty
    assert report.tables["cells"].runs.tolist() == [6, 6]
    assert "no cell where both methods ran" in report.markdown.read_text()


def test_a_study_whose_methods_did_not_run_on_the_same_instances_says_so(tmp_path):
    shared = [_run(m, seed, 300, f + 0.1 * seed) for m, f in (("A", 1), ("B", 2))
              for seed in range(6)]
    a_alone = [_run("A", seed, 300, 1 + 0.1 * seed, data="vivaldi") for seed in range(6)]
    assert prepare(_write(tmp_path / "s", shared)).notes == []
    study = _write(tmp_path / "mixed", shared + a_alone)
    (note,) = prepare(study).notes
    assert note.startswith("Not every method ran on each of the 2 instance and budget pairs "
                           "(A 2, B 1): the study may mix separate experiments"), note
    report = build(study, tmp_path / "report", figures=False, log=None)
    assert "the study may mix separate experiments" in report.markdown.read_text()


def test_the_default_study_says_its_runs_may_come_from_unrelated_experiments(tmp_path):
    one_cell = [_run(m, seed, 300, f + 0.1 * seed) for m, f in (("A", 1), ("B", 2))
                for seed in range(6)]
    assert prepare(_write(tmp_path / "a" / "default", one_cell)).notes == []
    two_budgets = one_cell + [_run(m, seed, 1000, f + 0.1 * seed) for m, f in (("A", 1),
                              ("B", 2)) for seed in range(6)]
    assert prepare(_write(tmp_path / "b" / "s", two_budgets)).notes == []
    (note,) = prepare(_write(tmp_path / "c" / "default", two_budgets)).notes
    assert note == ("This is the default study, which every run made without study= shares: "
                    "its 2 method(s) on 1 instance(s) and 2 budget(s) may come from unrelated "
                    "experiments; give study=NAME to keep an experiment apart.")


def test_cell_without_common_seeds(tmp_path):
    runs = [_run("A", seed, 300, 1.0 + seed) for seed in range(6)]
    runs += [_run("B", seed, 300, 2.0 + seed) for seed in range(6, 12)]
    comparison = prepare(_write(tmp_path / "s", runs))
    (row,) = pairwise_tests(comparison).itertuples()
    assert row.n == 0 and np.isnan(row.A12) and np.isnan(row.p)
    assert row.note == "no common seeds: no test" and row.effect == ""


# --------------------------------------------------------------------------------------------
# 6. failed runs, broken studies, the command line


def test_failed_runs_are_left_out_with_a_note(tmp_path):
    runs = [_run(m, seed, 300, f + 0.1 * seed) for m, f in (("A", 1), ("B", 2))
            for seed in range(6)]
    # failed before evaluating: best value +inf, as such a run records (never NaN, which
    # the evaluator counts as +inf and the store refuses on load)
    failed = [_run("B", seed, 300, np.inf, status="failed") for seed in (6, 7)]
    study = _write(tmp_path / "s", runs + failed)
    assert len(list((study / "failed").iterdir())) == 2
    comparison = prepare(study)
    assert len(comparison.study.runs) == 14 and len(comparison.runs) == 12
    assert (comparison.runs.status == "ok").all()
    assert comparison.notes == ["2 run(s) failed and are left out (see the study's failed/ "
                                "folder); the tables count the runs each cell has."]
    report = build(study, tmp_path / "report", figures=False, log=None)
    assert report.tables["cells"].runs.tolist() == [6, 6]
    assert "2 run(s) failed and are left out" in report.markdown.read_text()


def test_runs_that_failed_their_budget_audit_are_stored_and_left_out_with_a_note(tmp_path):
    runs = [_run(m, seed, 300, f + 0.1 * seed) for m, f in (("A", 1), ("B", 2))
            for seed in range(6)]
    cheats = [_run("B", seed, 300, 0.01, status="budget_violation", audited_fits=5000,
                   accounted_fits=300) for seed in (6, 7, 8)]
    study = _write(tmp_path / "s", runs + cheats)
    assert len(list((study / "runs").glob("*.parquet"))) == 15  # complete: not run again
    comparison = prepare(study)
    assert len(comparison.runs) == 12 and (comparison.runs.status == "ok").all()
    (note,) = comparison.notes
    assert note.startswith("3 run(s) are left out because their audit found fits beyond "
                           "their budget (status budget_violation: ")
    assert all(c["run_id"] in note for c in cheats)
    report = build(study, tmp_path / "report", figures=False, log=None)
    assert report.tables["cells"].runs.tolist() == [6, 6]
    assert "left out because their audit found fits" in report.markdown.read_text()


def test_a_study_where_every_run_failed(tmp_path):
    study = _write(tmp_path / "s", [_run("A", seed, 300, np.inf, status="failed")
                                    for seed in range(3)])
    with pytest.raises(ReportError, match=r"none of the 3 runs finished \(all failed or left "
                                          r"out by the budget audit\)"):
        build(study, tmp_path / "report", log=None)
    assert not (tmp_path / "report").exists()


def _broken_studies(tmp_path: Path) -> dict[str, tuple[Path, str]]:
    """Studies the report cannot read, with what the message must say."""
    good = [_run("A", seed, 300, 1.0 + seed) for seed in range(2)]
    empty = tmp_path / "empty"
    (empty / "runs").mkdir(parents=True)
    corrupt = _write(tmp_path / "corrupt", good)
    (corrupt / "runs" / "0123456789abcdef.parquet").write_bytes(b"not a parquet file")
    foreign = _write(tmp_path / "foreign", good)
    (foreign / "runs" / "notes.txt").write_text("mine")
    failed = _write(tmp_path / "failed", good)
    (failed / "failed").mkdir()
    (failed / "failed" / "0123456789abcdef.20240101T000000Z.1.parquet").write_bytes(b"junk")
    renamed = _write(tmp_path / "renamed", good)
    record = next((renamed / "runs").glob("*.parquet"))
    (renamed / "runs" / "0123456789abcdef.parquet").write_bytes(record.read_bytes())
    text = _write(tmp_path / "text", good)
    text_record = Store(text).write({**_run("A", 2, 300, 3.0), "best_f": "3.0"})
    results = tmp_path / "results"
    for name in ("second", "first"):
        _write(results / name, good)
    return {
        "missing": (tmp_path / "missing", "no such study directory"),
        "empty": (empty, "the study has no runs yet"),
        "corrupt": (corrupt, "0123456789abcdef.parquet: cannot be read"),
        "foreign": (foreign, "notes.txt: not a metaknot run record"),
        "failed": (failed, "0123456789abcdef.20240101T000000Z.1.parquet: cannot be read"),
        "renamed": (renamed, "0123456789abcdef.parquet: holds the record of run"),
        "text": (text, f"{text_record.name}: 'best_f' must be a number; it is string"),
        "results": (results, "a results folder, not a study; its studies: first, second"),
    }


BROKEN = ["missing", "empty", "corrupt", "foreign", "failed", "renamed", "text", "results"]


@pytest.mark.parametrize("case", BROKEN)
def test_unreadable_studies_raise_a_report_error(tmp_path, case):
    study, message = _broken_studies(tmp_path)[case]
    with pytest.raises(ReportError, match=re.escape(message)) as info:
        build(study, tmp_path / "report", log=None)
    assert str(study) in str(info.value)
    assert not (tmp_path / "report").exists()


@pytest.mark.parametrize("case", BROKEN)
def test_cli_reports_errors_in_one_line(tmp_path, capsys, case):
    study, message = _broken_studies(tmp_path)[case]
    assert cli_main(["report", str(study), "--out", str(tmp_path / "report")]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("metaknot: error: ")
    assert message in lines[0] and "Traceback" not in captured.err


@pytest.mark.parametrize(("options", "message"), [
    (["--alpha", "0"], "alpha must lie in (0, 1)"),
    (["--alpha", "1.5"], "alpha must lie in (0, 1)"),
    (["--metric", "speed"], "unknown metric 'speed'"),
])
def test_cli_reports_bad_settings_in_one_line(tmp_path, capsys, options, message):
    study = _one_cell(tmp_path, [1.0] * 3, [2.0] * 3)
    assert cli_main(["report", str(study), "--no-figures", *options]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert lines == [f"metaknot: error: {lines[0].split(': ', 2)[2]}"]
    assert message in lines[0] and "Traceback" not in captured.out + captured.err


def test_cli_report_writes_the_report(tmp_path, capsys):
    study = _one_cell(tmp_path, [1.0 + s for s in range(6)], [2.0 + s for s in range(6)])
    out = tmp_path / "elsewhere"
    assert cli_main(["report", str(study), "--out", str(out), "--no-figures",
                     "--metric", "rmse", "--alpha", "0.01"]) == 0
    assert (out / "report.html").is_file() and (out / "tables" / "pairwise_rmse.csv").is_file()
    assert not (out / "tables" / "pairwise_best_f.csv").exists()
    printed = capsys.readouterr().out
    assert f"report: {out / 'report.html'}" in printed
    assert f"tables: {out / 'tables'}\n" in printed  # where they are, not where they were built
    assert "significant at 0.01" in (out / "report.md").read_text()
    # the default folder lies beside the study
    assert cli_main(["report", str(study), "--no-figures"]) == 0
    assert (tmp_path / "s-report" / "report.md").is_file()


# --------------------------------------------------------------------------------------------
# 7. the files written; the study is never modified


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"alpha": 0}, "alpha must lie in (0, 1); got 0"),
    ({"alpha": 1.5}, "alpha must lie in (0, 1); got 1.5"),
    ({"alpha": 1.0}, "alpha must lie in (0, 1)"),
    ({"metrics": ["best_f", "speed"]}, "unknown metric 'speed'; choose from best_f, rmse"),
    ({"metrics": []}, "unknown metric None"),
])
def test_bad_settings_raise_a_report_error(dominance, tmp_path, kwargs, message):
    with pytest.raises(ReportError, match=re.escape(message)):
        build(dominance, tmp_path / "report", log=None, **kwargs)
    assert not (tmp_path / "report").exists()


@pytest.mark.parametrize("inside", [".", "report", "runs/report"])
def test_the_report_folder_may_not_be_inside_the_study(tmp_path, inside):
    study = _one_cell(tmp_path, [1.0] * 3, [2.0] * 3)
    before = _snapshot(study)
    with pytest.raises(ReportError, match="inside the study"):
        build(study, study / inside, log=None)
    assert _snapshot(study) == before


def test_the_report_folder_may_not_be_a_file(tmp_path, dominance):
    (tmp_path / "report").write_text("a file")
    with pytest.raises(ReportError, match="exists and is not a folder"):
        build(dominance, tmp_path / "report", log=None)


def test_tables_only_report(tmp_path, dominance):
    before = _snapshot(dominance)
    lines: list[str] = []
    out = tmp_path / "report"
    study = load_study(dominance)
    runs, trace = study.runs.copy(deep=True), study.trace.copy(deep=True)
    report = build(study, out, figures=False, log=lines.append)
    assert _snapshot(dominance) == before
    pd.testing.assert_frame_equal(study.runs, runs)  # nor the loaded study
    pd.testing.assert_frame_equal(study.trace, trace)
    assert isinstance(report, Report) and report.out == out and report.figures == []
    assert lines[0] == ("report of dominance: 96 runs, 2 instance(s), 2 method(s), "
                        "2 budget(s)")
    assert list((out / "figures").iterdir()) == []
    assert "<img" not in report.html.read_text() and "![" not in report.markdown.read_text()
    names = {p.name for p in (out / "tables").iterdir()}
    assert {"summary.csv", "cells.csv", "pairwise_best_f.csv", "ranks_best_f.csv",
            "pairwise_rmse.csv", "ranks_rmse.csv", "summary-archimedean.tex",
            "summary-vivaldi.tex", "pairwise-best_f.tex", "pairwise-rmse.tex"} == names
    comparison = prepare(dominance)
    assert report.summary == plain_summary(comparison, report.tables["pairwise_best_f"],
                                           ALPHA, friedman_test(comparison))
    markdown = report.markdown.read_text()
    for line in report.summary:
        assert line in markdown


def _text(values: pd.Series) -> list[str]:
    return ["" if pd.isna(v) else str(v) for v in values]


def _csv_equal(path: Path, table: pd.DataFrame) -> None:
    read = pd.read_csv(path)
    assert list(read.columns) == list(table.columns), path.name
    assert len(read) == len(table), path.name
    for column in table.columns:
        expected = table[column]
        if expected.dtype == object or pd.api.types.is_string_dtype(expected):
            assert _text(read[column]) == _text(expected), (path.name, column)
        else:
            np.testing.assert_allclose(read[column].to_numpy(dtype=float),
                                       expected.to_numpy(dtype=float), rtol=1e-12,
                                       err_msg=f"{path.name}: {column}")


def test_csv_and_latex_tables(tmp_path, three_methods):
    report = build(three_methods, tmp_path / "report", figures=False, log=None,
                   metrics=("best_f", "n_control_points"))
    folder = report.out / "tables"
    assert set(report.tables) == {"summary", "cells", "pairwise_best_f", "ranks_best_f",
                                  "pairwise_n_control_points", "ranks_n_control_points"}
    for name, table in report.tables.items():
        _csv_equal(folder / f"{name}.csv", table)
    ranks = report.tables["ranks_best_f"]
    assert ranks.method.tolist() == prepare(three_methods).methods
    assert (ranks.metric == "best_f").all() and (ranks.blocks == 4).all()
    for name in ("summary-archimedean", "summary-vivaldi", "pairwise-best_f",
                 "pairwise-n_control_points"):
        tex = (folder / f"{name}.tex").read_text()
        assert tex.index(r"\toprule") < tex.index(r"\midrule") < tex.index(r"\bottomrule")
        assert r"\begin{table}" in tex and r"\caption{" in tex
    # the best median of each budget is bold, and only it
    summary = report.tables["summary"]
    tex = (folder / "summary-archimedean.tex").read_text()
    body = tex[tex.index(r"\midrule"):tex.index(r"\bottomrule")].splitlines()[1:]
    part = summary[summary.instance == "archimedean"].reset_index(drop=True)
    assert len(body) == len(part)
    columns = ["budget", "method", "runs", *METRICS.values()]
    for line, row in zip(body, part.itertuples(index=False), strict=True):
        cells = [c.strip() for c in line.rstrip("\\ ").split("&")]
        assert len(cells) == len(columns)
        assert cells[1] == row.method
        for metric, cell in zip(METRICS, cells[3:], strict=True):
            best = bool(summary.loc[(summary.instance == "archimedean")
                                    & (summary.budget == row.budget)
                                    & (summary.method == row.method), f"{metric} best"].item())
            assert cell.startswith(r"\bfseries") == best, (row.method, metric, cell)
    # significant p-values are bold
    pairwise = report.tables["pairwise_best_f"]
    tex = (folder / "pairwise-best_f.tex").read_text()
    assert tex.count(r"\bfseries") == int(pairwise.significant.sum())


def test_latex_escapes_names(tmp_path):
    """Names with LaTeX's special characters (a study name such as ``seed_paper``, labels,
    the noise's sigma) are escaped in the cells and in the captions."""
    runs = [_run(m, seed, 300, f + 0.1 * seed, noise=noise)
            for m, f in (("ga_tuned", 1.0), ("de 50%", 2.0)) for seed in range(6)
            for noise in (0.0, 0.01)]
    study = _write(tmp_path / "my_study", runs)
    report = build(study, tmp_path / "report", figures=False, log=None)
    folder = report.out / "tables"
    tex = (folder / "pairwise-best_f.tex").read_text()
    assert r"ga\_tuned vs de 50\%" in tex and "ga_tuned" not in tex
    assert r"archimedean $\sigma$=0.01" in tex
    assert sorted(p.name for p in folder.glob("*.tex")) == [
        "pairwise-best_f.tex", "pairwise-rmse.tex", "summary-archimedean-0-01.tex",
        "summary-archimedean-0.tex"]
    for path in folder.glob("*.tex"):
        text = path.read_text()
        caption = next(line for line in text.splitlines() if line.startswith(r"\caption{"))
        assert r"my\_study" in caption, path.name
        bare = text.replace(r"\_", "").replace(r"\%", "").replace(r"\#", "")
        special = f"_%#{SIGMA}\u00b1\u2013\u221e"  # sigma, plus-minus, en dash, infinity
        assert not [c for c in special if c in bare], (path.name, caption)


@pytest.mark.slow
def test_the_same_study_gives_the_same_report_files_in_every_process(three_methods, tmp_path):
    """Every file of a report with its figures, byte for byte, from two processes with different
    string hashing (SVG element ids from a fixed salt, no date; each critical-difference bar
    drawn in rank order) and the build time given by ``SOURCE_DATE_EPOCH``."""
    for hash_seed in ("1", "7"):
        done = subprocess.run(
            [sys.executable, "-m", "metaknot.cli", "report", str(three_methods), "--out",
             str(tmp_path / hash_seed)], capture_output=True, text=True, timeout=600,
            env={**os.environ, "PYTHONHASHSEED": hash_seed, "SOURCE_DATE_EPOCH": "1764633600"})
        assert done.returncode == 0, done.stderr
    files = sorted(p.relative_to(tmp_path / "1") for p in (tmp_path / "1").rglob("*")
                   if p.is_file())
    assert any(f.suffix == ".svg" and f.name.startswith("cd-") for f in files)
    assert files == sorted(p.relative_to(tmp_path / "7") for p in (tmp_path / "7").rglob("*")
                           if p.is_file())
    for name in files:
        assert (tmp_path / "1" / name).read_bytes() == (tmp_path / "7" / name).read_bytes(), name
    assert "2025-12-02 00:00 UTC" in (tmp_path / "1" / "report.md").read_text()


def test_a_malformed_source_date_epoch_is_refused_by_name(three_methods, tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "yesterday")
    with pytest.raises(ReportError, match="SOURCE_DATE_EPOCH must be whole seconds"):
        build(three_methods, tmp_path / "out", figures=False)


def test_full_report_with_figures(tmp_path):
    runs = []
    rng = np.random.default_rng(5)
    for data, budget, seed in itertools.product(("archimedean", "vivaldi"), (300, 1000),
                                                range(6)):
        for method, factor in (("ga", 1.0), ("random_search", 1.3), ("dolphin", 1.7)):
            value = factor * rng.lognormal(0.0, 0.1)
            runs.append(_run(None, seed, budget, value, data=data, algorithm=method,
                             n_control_points=int(rng.integers(15, 30)),
                             rmse=rng.lognormal(-9.0, 0.3)))
    study = _write(tmp_path / "results" / "study", runs)
    before = _snapshot(study)
    lines: list[str] = []
    report = build(study, log=lines.append)  # default folder: beside the study
    assert _snapshot(study) == before
    out = tmp_path / "results" / "study-report"
    assert report.out == out and report.html == out / "report.html"
    assert not any("skipped" in line for line in lines), lines
    assert prepare(study).methods == ["ga", "random_search", "dolphin"]

    expected = {f"{kind}-{data}" for kind in ("convergence", "budget", "ecdf", "front",
                                              "curves")
                for data in ("archimedean", "vivaldi")}
    expected |= {"ecdf-all", "cd-best_f", "cd-rmse"}
    pngs = sorted((out / "figures").glob("*.png"))
    svgs = sorted((out / "figures").glob("*.svg"))
    assert {p.stem for p in pngs} == expected == {p.stem for p in svgs}
    assert sorted(report.figures) == sorted(pngs + svgs)
    for png in pngs:
        assert png.read_bytes().startswith(PNG_MAGIC)
    for svg in svgs:
        assert "<svg" in svg.read_text()[:2000]

    # HTML: self-contained, every PNG embedded once
    page = report.html.read_text()
    images = re.findall(r"<img\b[^>]*>", page)
    assert len(images) == len(pngs)
    sources = [re.search(r"src='([^']*)'", tag).group(1) for tag in images]
    prefix = "data:image/png;base64,"
    assert all(s.startswith(prefix) for s in sources)
    embedded = [base64.b64decode(s[len(prefix):], validate=True) for s in sources]
    assert all(data.startswith(PNG_MAGIC) for data in embedded)
    assert sorted(embedded) == sorted(p.read_bytes() for p in pngs)
    assert not re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", page)
    assert "<link" not in page and "<script" not in page and "@import" not in page
    assert "url(" not in page

    # Markdown: figures linked from figures/, each exists
    markdown = report.markdown.read_text()
    links = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", markdown)
    assert sorted(links) == sorted(f"figures/{p.name}" for p in pngs)
    assert all((out / link).is_file() for link in links)


# --------------------------------------------------------------------------------------------
# 8. methods and instances


def test_same_method_with_different_settings_needs_labels(tmp_path):
    runs = [_run(None, seed, 300, 1.0 + seed, algorithm="ga", **{"optimizer.population": pop})
            for seed in range(3) for pop in (50, 100)]
    study = _write(tmp_path / "s", runs)
    with pytest.raises(ReportError, match=r"6 runs share instance, budget, method and seed "
                                          r"but differ in their settings; give the variants "
                                          r"different labels"):
        prepare(study)
    labelled = [_run(f"ga-{pop}", seed, 300, 1.0 + seed, algorithm="ga",
                     **{"optimizer.population": pop})
                for seed in range(3) for pop in (50, 100)]
    comparison = prepare(_write(tmp_path / "t", labelled))
    assert sorted(comparison.methods) == ["ga-100", "ga-50"]


def test_method_is_the_label_else_the_algorithm(tmp_path):
    runs = [_run("tuned", seed, 300, 1.0 + seed, algorithm="ga") for seed in range(3)]
    runs += [_run(None, seed, 300, 2.0 + seed, algorithm="ga") for seed in range(3)]
    runs += [_run("", seed, 300, 3.0 + seed, algorithm="random_search") for seed in range(3)]
    assert prepare(_write(tmp_path / "s", runs)).methods == ["tuned", "ga", "random_search"]


@pytest.mark.parametrize(("settings", "names"), [
    ([{"n_knots": 39}, {"n_knots": 9}], ["archimedean K=9", "archimedean K=39"]),
    ([{"noise": 0.01}, {"noise": 0.0}], [f"archimedean {SIGMA}=0", f"archimedean {SIGMA}=0.01"]),
    ([{"degree": 3}, {"degree": 5}], ["archimedean p=3", "archimedean p=5"]),
    ([{"parameterization": "uniform"}, {"parameterization": "centripetal"}],
     ["archimedean centripetal", "archimedean uniform"]),
    ([{"objective.error_floor": 1e-4}, {"objective.error_floor": 1e-5}],
     ["archimedean error_floor=0.0001", "archimedean error_floor=1e-05"]),
    ([{"noise": 0.01, "n_knots": 20}, {"noise": 0.0, "n_knots": 20},
      {"noise": 0.01, "n_knots": 5}],
     [f"archimedean {SIGMA}=0 K=20", f"archimedean {SIGMA}=0.01 K=5",
      f"archimedean {SIGMA}=0.01 K=20"]),
    ([{"n_knots": None}, {"n_knots": 20}], ["archimedean", "archimedean K=20"]),
    ([{}], ["archimedean"]),
])
def test_instance_names_show_the_settings_that_vary(tmp_path, settings, names):
    runs = [_run(m, seed, 300, f + seed, **extra) for extra in settings
            for m, f in (("A", 1.0), ("B", 2.0)) for seed in range(3)]
    comparison = prepare(_write(tmp_path / "s", runs))
    assert comparison.instances == names
    assert sorted(summary_table(comparison).instance.unique()) == sorted(names)
    assert [i for i, _ in itertools.groupby(pairwise_tests(comparison).instance)] == names


def test_instances_follow_the_data_then_the_settings(tmp_path):
    runs = [_run(m, seed, 300, f + seed, data=data, n_knots=k)
            for data in ("vivaldi", "archimedean") for k in (12, 4)
            for m, f in (("A", 1.0), ("B", 2.0)) for seed in range(3)]
    comparison = prepare(_write(tmp_path / "s", runs))
    assert comparison.instances == ["archimedean K=4", "archimedean K=12", "vivaldi K=4",
                                    "vivaldi K=12"]


# --------------------------------------------------------------------------------------------
# 9. end to end on a real study


def test_a_record_without_its_spline_is_drawn_from_its_candidate(tmp_path, monkeypatch):
    """Records written before records stored the spline: the curves figure decodes the stored
    candidate with the rebuilt problem."""
    runs = [_run(method, seed, 300, 1.0 + seed / 10 + (method == "B"), n_control_points=20)
            for method in ("A", "B") for seed in range(3)]
    comparison = prepare(_write(tmp_path / "s", runs))
    assert not any(c.startswith("spline.") for c in comparison.runs.columns)
    rebuilt = []
    original = figures_module.rebuild_problem
    monkeypatch.setattr(figures_module, "rebuild_problem",
                        lambda run: rebuilt.append(run.run_id) or original(run))
    figure = figures_module.fitted_curves_figure(comparison, "archimedean")
    assert len(figure.axes) == 2 and len(rebuilt) == 2
    medians = comparison.runs[comparison.runs.seed == 1]
    assert sorted(rebuilt) == sorted(medians.run_id)


@pytest.mark.slow
def test_report_of_a_real_study(tmp_path, monkeypatch):
    done = subprocess.run(
        [sys.executable, "-m", "metaknot.cli", "run", "-m", "optimizer=ga,random_search",
         "problem=archimedean", "budget=300", "seed=range(0,6)", f"results_dir={tmp_path}"],
        cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    study = tmp_path / "default"
    runs = load_study(study).runs
    assert len(runs) == 12 and (runs.status == "ok").all()

    drawn: list[tuple[pd.Series, object]] = []
    original = figures_module.run_fit

    def recording(run, curve):
        fit = original(run, curve)
        drawn.append((run, fit))
        return fit

    def refused(run):
        raise AssertionError("the records store their splines: no problem is rebuilt")

    monkeypatch.setattr(figures_module, "run_fit", recording)
    monkeypatch.setattr(figures_module, "rebuild_problem", refused)
    before = _snapshot(study)
    report = build(study, tmp_path / "report", log=None)
    assert _snapshot(study) == before

    names = {p.stem for p in (tmp_path / "report" / "figures").glob("*.png")}
    assert names == {"convergence-archimedean", "ecdf-archimedean", "front-archimedean",
                     "curves-archimedean"}  # one budget, one instance, two methods: no more
    assert {p.stem for p in (tmp_path / "report" / "figures").glob("*.svg")} == names
    assert report.html.read_text().count("<img ") == 4

    # the curves are the median run of each method, the spline its record stores: the one
    # its stored candidate decodes to
    comparison = prepare(study)
    for method in ("ga", "random_search"):
        part = comparison.runs[comparison.runs.method == method]
        median = part.sort_values(["best_f", "seed"], kind="stable").iloc[(len(part) - 1) // 2]
        assert median.run_id in {run.run_id for run, _ in drawn}, method
    assert drawn
    for run, fit in drawn:
        decoded = figures_module._spec(run).build_problem().decode(
            np.asarray(run["best_x"])).fit
        np.testing.assert_array_equal(fit.spline.t, decoded.spline.t)
        np.testing.assert_array_equal(fit.spline.c, decoded.spline.c)
        assert fit.n_control_points == run["n_control_points"]
        assert fit.rmse == pytest.approx(run["rmse"], rel=1e-9)

    # the tables are those of the stored runs
    summary = report.tables["summary"].set_index("method")
    for method, group in runs.groupby("label"):
        assert summary.loc[method, "runs"] == 6
        assert summary.loc[method, "best_f median"] == pytest.approx(group.best_f.median())
    pairwise = report.tables["pairwise_best_f"]
    (row,) = pairwise.itertuples()
    x, y = _pair_values(comparison.runs, "archimedean", 300, row.A, row.B)
    assert row.n == 6 and row.A12 == pytest.approx(a12(x, y))


def _build_in_a_process(study: str, out: str, metrics: tuple[str, ...]) -> int:
    return len(build(study, out, metrics=metrics, figures=False).summary)


def _whole(out: Path) -> tuple[str, ...]:
    """The metrics of the report in ``out``, checked to be those of its tables and pages."""
    tested = tuple(sorted(p.stem.removeprefix("pairwise_")
                          for p in (out / "tables").glob("pairwise_*.csv")))
    ranked = tuple(sorted(p.stem.removeprefix("ranks_")
                          for p in (out / "tables").glob("ranks_*.csv")))
    assert tested == ranked, (tested, ranked)
    return tested


def test_a_report_replaces_the_whole_report_and_keeps_the_users_files(tmp_path):
    """A report without the rmse tests built after one with them leaves no rmse table
    behind (its files used to be written over the earlier ones, the rest kept), and two
    reports built at once leave one of them whole; a file of the user's in the folder stays,
    and no building folder is left behind."""
    import concurrent.futures
    import multiprocessing

    study = _write(tmp_path / "study", _dominance_runs(seeds=6))
    out = tmp_path / "study-report"
    build(study, out, metrics=("best_f", "rmse"), figures=False)
    (out / "notes.txt").write_text("mine")
    assert _whole(out) == ("best_f", "rmse")
    build(study, out, metrics=("best_f",), figures=False)
    assert _whole(out) == ("best_f",)
    context = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(2, mp_context=context) as pool:
        for _ in range(3):
            jobs = [pool.submit(_build_in_a_process, str(study), str(out), metrics)
                    for metrics in (("best_f",), ("best_f", "rmse"))]
            assert all(job.result() > 0 for job in jobs)
            assert _whole(out) in (("best_f",), ("best_f", "rmse"))
            assert (out / "notes.txt").read_text() == "mine"
            assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
