"""The report of a suite study: its suite section (targets relative to the best-known values,
ECDFs, performance profiles, Friedman over the problems, gaps, wins) equals a recomputation
from the stored runs; and the report's statistical honesty (ties said as ties, designs that
cannot reach significance flagged, no sign test over too few cells, methods kept apart in the
figures, rank tables sorted)."""

from __future__ import annotations

import subprocess
import sys

import matplotlib
import numpy as np
import pandas as pd
import pytest
from scipy import stats

from metaknot.experiments import load_study
from metaknot.experiments.report import build, prepare
from metaknot.experiments.report import figures as figures_module
from metaknot.experiments.report import suite as suite_module
from metaknot.experiments.report.tables import (
    design_power_note,
    friedman_blocks,
    friedman_test,
    pairwise_tests,
    plain_summary,
    seeds_needed,
    smallest_p,
)
from metaknot.suite.best import load_best_known
from metaknot.suite.splits import split
from metaknot.suite.tasks import get_task
from tests.test_report import _one_cell, _run, _write

# one shared study or build for the module: keep its tests on one xdist worker
pytestmark = pytest.mark.xdist_group("suite_report")

ALPHA = 0.05
METHODS = ("random_search", "one_plus_one", "ga")


@pytest.fixture(scope="session")  # kept if other modules run in between
def suite_study(tmp_path_factory):
    """A real suite study: the mini split, two tasks, three cheap optimizers, two seeds."""
    folder = tmp_path_factory.mktemp("suite")
    done = subprocess.run(
        [sys.executable, "-m", "metaknot.cli", "run", "-m", "suite=mini",
         "problem.task=tolerance,fixed_k_small.indices", f"optimizer={','.join(METHODS)}",
         "budget=60", "seed=range(0,2)", "study=mini", f"results_dir={folder}"],
        capture_output=True, text=True, timeout=900, cwd=folder)
    assert done.returncode == 0, done.stderr
    return folder / "mini"


@pytest.fixture(scope="session")  # kept if other modules run in between
def suite_report(suite_study, tmp_path_factory):
    return build(suite_study, tmp_path_factory.mktemp("out") / "report", log=None)


@pytest.fixture(scope="session")  # kept if other modules run in between
def view(suite_study):
    return suite_module.suite_comparison(prepare(suite_study))


def _best_known_of(runs: pd.DataFrame) -> pd.Series:
    """Each stored run's best-known value, looked up afresh (alias ``tolerance`` resolved)."""
    known = load_best_known()
    values = []
    for instance, task in zip(runs["suite.instance"], runs["suite.task"], strict=True):
        key = (instance, get_task(instance, task).id)
        values.append(known[key].value if key in known else np.nan)
    return pd.Series(values, index=runs.index)


def test_the_suite_section_is_written(suite_report, suite_study):
    text = suite_report.markdown.read_text()
    for title in ("## The suite", "### Targets reached at the end",
                  "### Gap to the best-known value", "### Ranks over the problems",
                  "### Wins, ties and losses"):
        assert title in text
    assert "scikit-posthocs" in text and "scipy" in text
    assert (suite_report.out / "figures" / "suite-ecdf.png").exists()
    assert (suite_report.out / "figures" / "suite-profile.png").exists()
    runs = load_study(suite_study).runs
    assert suite_report.tables["suite_medians"].shape[0] == 2 * len(split("mini"))
    assert set(runs["suite.family"]) <= set(suite_report.tables["suite_ranks"].columns)


def test_ecdf_at_the_end_counts_the_targets_reached(view, suite_study):
    runs = load_study(suite_study).runs
    f_star = _best_known_of(runs)
    hits = suite_module.target_hits(view)
    end = suite_module.ecdf(hits, np.array([60.0]))
    for method, part in runs.groupby("label"):
        keep = f_star[part.index].notna()
        precision = ((part.best_f - f_star[part.index]) / f_star[part.index].abs())[keep]
        reached = (precision.to_numpy()[:, None] <= suite_module.LEVELS[None, :]).sum()
        pairs = keep.sum() * len(suite_module.LEVELS)
        assert end.loc[60.0, method] == pytest.approx(reached / pairs, abs=1e-12)
    # nothing is reached before the first evaluation, and the ECDF never decreases
    curve = suite_module.ecdf(hits, np.geomspace(1, 60, 30))
    assert (curve.diff().dropna() >= 0).all().all()
    assert (curve.iloc[0] <= curve.iloc[-1]).all()


def test_the_profile_at_one_is_the_share_of_problems_a_method_is_best_on(view, suite_study):
    runs = load_study(suite_study).runs
    medians = runs.groupby([runs["suite.instance"], runs["suite.task"], "label"]).best_f \
        .median().unstack("label")
    best = medians.min(axis=1)
    profile, left_out = suite_module.performance_profile(view.medians, np.array([1.0, 1e9]))
    assert left_out == 0
    for method in METHODS:
        assert profile.loc[1.0, method] == pytest.approx((medians[method] == best).mean())
        assert profile.loc[1e9, method] == 1.0


def test_friedman_over_the_problems_equals_scipy(view, suite_study):
    runs = load_study(suite_study).runs
    medians = runs.groupby([runs["suite.instance"], runs["suite.task"], "label"]).best_f \
        .median().unstack("label")
    expected = stats.friedmanchisquare(*(medians[m].to_numpy() for m in METHODS))
    result = suite_module.friedman_by_family(view, ALPHA)[suite_module.ALL]
    assert result.blocks == len(medians)
    assert result.statistic == pytest.approx(expected.statistic, rel=1e-12)
    assert result.p == pytest.approx(expected.pvalue, rel=1e-12)
    # per family and per task: the same test on their blocks
    family = runs.groupby([runs["suite.instance"], runs["suite.task"]])["suite.family"].first()
    task = pd.Series(medians.index.get_level_values(1), index=medians.index)
    results = suite_module.friedman_by_family(view, ALPHA)
    tasks = [n for n in results if n.startswith(suite_module.TASK_SCOPE)]
    assert len(tasks) == 2  # the study's two tasks
    for name, r in results.items():
        if name == suite_module.ALL or not np.isfinite(r.statistic):
            continue
        if name in tasks:
            part = medians[task.str.startswith(name[len(suite_module.TASK_SCOPE):])]
        else:
            part = medians[family[medians.index] == name]
        assert r.blocks == len(part)
        assert r.statistic == pytest.approx(
            stats.friedmanchisquare(*(part[m].to_numpy() for m in METHODS)).statistic)


def test_suite_rank_tables_are_sorted_by_rank(suite_report):
    ranks = suite_report.tables["suite_ranks"]
    assert ranks["all problems"].is_monotonic_increasing
    wins = suite_report.tables["suite_wins"]
    assert list(wins.method) == list(ranks.method)


def test_gap_and_wins_recomputed(view, suite_study, suite_report):
    runs = load_study(suite_study).runs
    f_star = _best_known_of(runs)
    runs = runs.assign(gap=(runs.best_f - f_star) / f_star.abs())
    gaps = runs.groupby([runs["suite.instance"], runs["suite.task"], "label"]).gap.median() \
        .unstack("label")
    table = suite_report.tables["suite_gap"].set_index("method")
    for method in METHODS:
        assert table.loc[method, "median gap"] == pytest.approx(gaps[method].median())
    # and per task (the study has two): the median over that task's problems
    task_of = pd.Series([get_task(i, t).id for i, t in gaps.index], index=gaps.index)
    assert task_of.nunique() == 2
    medians = view.medians
    best_on = suite_report.tables["suite_best"].set_index("method")
    for task, part in gaps.groupby(task_of):
        for method in METHODS:
            assert table.loc[method, f"median gap: task: {task}"] == pytest.approx(
                part[method].median())
        # the share of the task's problems each method is best on (ties count for each)
        rows = medians[view.tasks == task]
        share = rows.eq(rows.min(axis=1), axis=0).mean()
        for method in METHODS:
            assert best_on.loc[method, f"task: {task}"] == pytest.approx(share[method])
    assert table["median gap"].is_monotonic_increasing
    wins = suite_report.tables["suite_wins"].set_index("method")
    a, b = METHODS[0], METHODS[1]
    x, y = medians[a].to_numpy(), medians[b].to_numpy()
    assert wins.loc[a, b] == f"{(x < y).sum()}/{(x == y).sum()}/{(x > y).sum()}"


def test_each_methods_worst_problem_and_family_are_named(view, suite_study, suite_report):
    """Where a method fails, beside its rank: the problem of its largest gap and the family of
    its largest median gap, in the gap table and in the summary's sentence."""
    runs = load_study(suite_study).runs
    f_star = _best_known_of(runs)
    runs = runs.assign(gap=(runs.best_f - f_star) / f_star.abs(),
                       family=runs["suite.family"].astype(str))
    table = suite_report.tables["suite_gap"].set_index("method")
    text = suite_report.markdown.read_text()
    assert "Where each method fails" in text
    for method in METHODS:
        mine = runs[runs.label == method]
        per_problem = mine.groupby(["suite.instance", "suite.task"]).gap.median()
        family_of = mine.groupby(["suite.instance", "suite.task"]).family.first()
        instance, task = per_problem.idxmax()
        assert table.loc[method, "worst gap"] == pytest.approx(per_problem.max())
        assert table.loc[method, "worst problem"] == f"{instance} {get_task(instance, task).id}"
        by_family = per_problem.groupby(family_of).median()
        assert table.loc[method, "worst family"] == by_family.idxmax()
        assert f"{method} on {table.loc[method, 'worst problem']} (gap" in text


def test_suite_best_from_study_stores_each_tasks_best_run(suite_study, tmp_path):
    """`metaknot suite best --from-study`: against a file whose values are all worse than the
    study's runs, each task's value becomes its lowest run's, evaluated again."""
    import dataclasses

    from metaknot.suite.best import save_best_known

    runs = load_study(suite_study).runs
    runs = runs.assign(task=[get_task(i, t).id for i, t in
                             zip(runs["suite.instance"], runs["suite.task"], strict=True)])
    lowest = runs.groupby(["suite.instance", "task"]).best_f.min()
    known = load_best_known()
    path = tmp_path / "best.json"
    save_best_known({key: dataclasses.replace(known[key], value=value * 10, proven=False)
                     for key, value in lowest.items()}, path)
    done = subprocess.run([sys.executable, "-m", "metaknot.cli", "suite", "best",
                           "--from-study", str(suite_study), "--file", str(path)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert f"{len(lowest)} tasks with runs: {len(lowest)} improved" in done.stdout
    stored = load_best_known(path)
    for key, value in lowest.items():
        assert stored[key].value == pytest.approx(value, rel=1e-12)
        assert stored[key].budget == 60
    refused = subprocess.run([sys.executable, "-m", "metaknot.cli", "suite", "best",
                              "--from-study", str(suite_study), "--family", "aspline"],
                             capture_output=True, text=True, timeout=600)
    assert refused.returncode != 0 and "--family" in refused.stderr
    refused = subprocess.run([sys.executable, "-m", "metaknot.cli", "suite", "best",
                              "--from-study", str(suite_study), "--budget", "500"],
                             capture_output=True, text=True, timeout=600)
    assert refused.returncode != 0 and "--budget" in refused.stderr  # not silently ignored


def test_methods_of_different_tasks_are_ranked_with_their_own():
    """A study whose methods ran on different tasks (BOBYQA on free knots, the rest on masks)
    has no problem where all ran: each scope ranks the methods that ran on at least half its
    problems, where all of them ran (a partial study keeps its methods)."""
    rng = np.random.default_rng(3)
    mask_rows, free_rows = [f"i{k} mask" for k in range(12)], [f"i{k} free" for k in range(8)]
    medians = pd.DataFrame(np.nan, index=mask_rows + free_rows,
                           columns=["ga", "one_plus_one", "local_search", "bobyqa"])
    medians.loc[mask_rows, ["ga", "one_plus_one", "local_search"]] = rng.random((12, 3)) + 0.5
    medians.loc[free_rows, "bobyqa"] = rng.random(8) + 0.5
    medians.loc["i0 mask", "local_search"] = np.nan  # not finished there yet
    kept = suite_module.comparable(medians)
    assert list(kept.columns) == ["ga", "one_plus_one", "local_search"]
    assert list(kept.index) == mask_rows[1:]
    result = friedman_blocks(kept, blocks="problems")
    expected = stats.friedmanchisquare(*kept.to_numpy().T)
    assert result.blocks == 11
    assert result.p == pytest.approx(expected.pvalue) and result.statistic == pytest.approx(
        expected.statistic)
    # the profile at τ = 1 over the same problems: the share each method is best on
    profile, left_out = suite_module.performance_profile(medians, np.array([1.0]))
    assert list(profile.columns) == list(kept.columns) and left_out == len(medians) - 11
    best = kept.eq(kept.min(axis=1), axis=0).mean()
    assert profile.iloc[0].to_dict() == pytest.approx(best.to_dict())
    # within the free task BOBYQA is the only method: nothing to rank it against
    alone = suite_module.comparable(medians.loc[free_rows])
    assert list(alone.columns) == ["bobyqa"] and len(alone) == 8


# --------------------------------------------------------------------------------------------
# statistical honesty


def test_an_exact_tie_is_said_as_a_tie(tmp_path):
    values = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
    comparison = prepare(_one_cell(tmp_path, values, values[::-1]))  # equal medians
    lines = plain_summary(comparison, pairwise_tests(comparison), ALPHA)
    assert lines == ["On **archimedean**: A and B tie for the lowest median objective at "
                     "budget 300 (equal medians, 4)."]
    assert "lowest median objective at budget 300, but" not in lines[0]


def test_a_design_that_cannot_reach_significance_says_so(tmp_path):
    # 6 methods (15 pairs) on 8 seeds: the smallest Holm-corrected p is 15 * 2 / 2**8
    assert smallest_p(8, 15) == pytest.approx(15 / 128)
    assert seeds_needed(15) == 10 and smallest_p(10, 15) < ALPHA <= smallest_p(9, 15)
    assert seeds_needed(1) == 6  # one pair: the Wilcoxon test needs 6 differing pairs
    methods = ("A", "B", "C", "D", "E", "F")
    runs = [_run(m, seed, 300, (k + 1) * (1 + 0.01 * seed))
            for k, m in enumerate(methods) for seed in range(8)]
    study = _write(tmp_path / "s", runs)
    note = design_power_note(prepare(study), ALPHA)
    assert note == ("The design cannot reach significance in every cell: with 8 paired seeds "
                    "and 15 pair(s) of methods, the smallest Holm-corrected Wilcoxon p-value "
                    "is 0.12 (≥ 0.05), so no pair can be significant whatever the results; 10 "
                    "seeds per method (all differing) would make it possible.")
    report = build(study, tmp_path / "report", figures=False, log=None)
    assert note in report.summary and note in report.markdown.read_text()
    # with two methods and 12 seeds a pair can be significant: nothing is said
    two = [_run(m, seed, 300, (k + 1) * (1 + 0.01 * seed))
           for k, m in enumerate(("A", "B")) for seed in range(12)]
    assert design_power_note(prepare(_write(tmp_path / "t", two)), ALPHA) is None


def test_a_sign_test_over_one_cell_is_not_reported(tmp_path):
    comparison = prepare(_one_cell(tmp_path, [1.0] * 6, [2.0] * 6))
    result = friedman_test(comparison, "best_f", ALPHA)
    assert np.isnan(result.p)
    assert result.note == ("two methods differ in only 1 cells (A lower in 1, B in 0): a sign "
                           "test needs at least 6 to reach p < 0.05; no test")
    lines = plain_summary(comparison, pairwise_tests(comparison), ALPHA, result)
    assert "p = 1" not in " ".join(lines)


def test_figures_keep_methods_apart(tmp_path):
    # three methods with identical runs: their lines coincide
    runs = [_run(m, seed, 300, 1.0 + 0.1 * seed) for m in ("A", "B", "C") for seed in range(4)]
    comparison = prepare(_write(tmp_path / "s", runs))
    look = figures_module.styles(comparison)
    keys = {(v["linestyle"], v["marker"]) for v in look.values()}
    assert len(keys) == 3
    figure = figures_module.ecdf_figure(comparison, comparison.instances, "t")
    lines = [line for line in figure.axes[0].get_lines() if line.get_label() in look]
    assert {(line.get_linestyle(), line.get_marker()) for line in lines} == {
        (matplotlib.lines.Line2D([], [], linestyle=v["linestyle"]).get_linestyle(),
         v["marker"]) for v in look.values()}
    matplotlib.pyplot.close(figure)


def test_the_cd_diagram_uses_the_methods_colours(tmp_path, monkeypatch):
    import scikit_posthocs as sp

    rng = np.random.default_rng(3)
    runs = [_run(m, seed, budget, f * rng.lognormal(0, 0.1), data=data)
            for data in ("archimedean", "vivaldi") for budget in (300, 1000)
            for m, f in (("A", 1.0), ("B", 2.0), ("C", 3.0)) for seed in range(4)]
    comparison = prepare(_write(tmp_path / "s", runs))
    seen = {}
    original = sp.critical_difference_diagram

    def recording(*args, **kwargs):
        seen.update(kwargs)
        return original(*args, **kwargs)

    monkeypatch.setattr(sp, "critical_difference_diagram", recording)
    figure = figures_module.cd_diagram(comparison, friedman_test(comparison), ALPHA)
    assert figure is not None
    colours = figures_module.palette(comparison)
    assert seen["color_palette"] == {m: matplotlib.colors.to_hex(c) for m, c in colours.items()}
    matplotlib.pyplot.close(figure)


def test_markers_skip_lines_with_nothing_to_draw(tmp_path) -> None:
    """A method without values on a scope (nlopt on mask tasks) draws an empty line: it gets
    no markers, which matplotlib cannot place along an empty path (the knotbench report
    crashed there)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from metaknot.experiments.report.figures import _markevery

    x, empty = np.array([1.0, 2.0, 4.0]), np.full(3, np.nan)
    assert _markevery(0, x, empty) is None and _markevery(1, x, [0.1, 0.2, 0.3]) is not None
    fig, ax = plt.subplots()
    ax.step(x, empty, where="post", marker="o", markevery=_markevery(0, x, empty))
    ax.step(x, [0.1, 0.5, 1.0], where="post", marker="s",
            markevery=_markevery(1, x, [0.1, 0.5, 1.0]))
    ax.set_xscale("log")
    fig.savefig(tmp_path / "lines.png")
    plt.close(fig)
