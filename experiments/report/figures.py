"""The report's figures (matplotlib), each a function returning a ``Figure``.

Convergence and fixed-target views read the stored trace (its log-spaced checkpoints are shared
by all runs, so no interpolation is needed); fitted curves are the splines the records store
(a record written before records stored its spline: its stored best candidate decoded by its
rebuilt problem), never re-optimised.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from .data import Comparison
from .tables import FriedmanResult

__all__ = ["budget_figure", "cd_diagram", "convergence_figure", "ecdf_figure",
           "fitted_curves_figure", "front_figure", "method_styles", "palette", "profile_figure",
           "rebuild_problem", "run_curve", "run_fit", "styles", "suite_ecdf_figure",
           "target_hits"]

TARGETS = 10
#: Okabe and Ito's colour-blind-safe palette (Wong, "Points of view: Color blindness", Nature
#: Methods 8, 441, 2011), in the order methods take it: any first few colours stay apart for
#: normal vision and with protanopia or deuteranopia (CIEDE2000 differences of at least 21 and
#: 11 between any two); yellow and black, the weakest beside the others, come last
COLOURS = ("#0072B2", "#E69F00", "#56B4E9", "#009E73", "#D55E00", "#CC79A7", "#F0E442",
           "#000000")
#: one marker per method up to twelve: a colour comes back at the ninth method, with another
#: marker and line style
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">", "p", "h")
LINESTYLES = ("-", "--", "-.", ":")


def method_styles(methods: Sequence[str]) -> dict[str, dict[str, Any]]:
    """Colour, marker and line style of each method, by its place in ``methods``: the one
    definition every figure of a report draws with.

    Parameters
    ----------
    methods
        The methods, in the report's order.

    Returns
    -------
    dict of str to dict
        Method -> ``{"color", "marker", "linestyle"}`` (keyword arguments of ``plot``). The
        first eight methods get eight colours; up to twelve methods, every method has a marker
        of its own, and two methods of the same colour differ in line style too.
    """
    looks = {}
    for k, method in enumerate(methods):
        # past the colours, the line styles shift by one: the k-th and the (k+8)-th differ
        rounds = k // len(COLOURS)
        looks[method] = {"color": COLOURS[k % len(COLOURS)], "marker": MARKERS[k % len(MARKERS)],
                         "linestyle": LINESTYLES[(k + rounds) % len(LINESTYLES)]}
    return looks


def styles(comparison: Comparison) -> dict[str, dict[str, Any]]:
    """Colour, marker and line style per method of ``comparison`` (:func:`method_styles`):
    two methods whose lines coincide stay apart by their line styles and markers."""
    return method_styles(comparison.methods)


def palette(comparison: Comparison) -> dict[str, Any]:
    """One colour per method, the same in every figure (:func:`method_styles`; the
    critical-difference diagram included)."""
    return {method: look["color"] for method, look in styles(comparison).items()}


def _legend(fig: plt.Figure, fontsize: float = 8, **kwargs: Any) -> None:
    """The figure's legend outside its axes, to their right: the labelled artists of every
    axes, each label once, in the order they were drawn (the methods' order)."""
    handles: dict[str, Any] = {}
    for ax in fig.axes:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(label, handle)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="outside right upper",
                   fontsize=fontsize, **kwargs)


def _markevery(k: int, x: Any, y: Any, n: int = 6) -> tuple[float, float] | None:
    """Markers at ``n`` positions along the line ``(x, y)``, shifted per method so they do
    not overlap; none on a line of fewer than two drawable points (matplotlib cannot place
    markers along an empty path, and a method without values on a scope draws nothing)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    drawable = np.isfinite(x) & np.isfinite(y) & (x > 0)
    if np.count_nonzero(drawable) < 2:
        return None
    return (0.02 + 0.13 * (k % 7) / n, 1.0 / n)


def _largest_budget(comparison: Comparison, instance: str) -> pd.DataFrame:
    """Each method's runs at its largest budget on ``instance``."""
    runs = comparison.runs[comparison.runs.instance == instance]
    top = runs.groupby("method").budget.transform("max")
    return runs[runs.budget == top]


def _band(ax: Any, x: np.ndarray, values: pd.DataFrame, style: dict[str, Any], label: str,
          k: int = 0) -> None:
    median = values.median(axis=1)
    low, high = values.quantile(0.25, axis=1), values.quantile(0.75, axis=1)
    ax.plot(x, median, label=label, lw=1.6, ms=4, markevery=_markevery(k, x, median),
            **style)
    ax.fill_between(x, low, high, color=style["color"], alpha=0.2, lw=0)


def convergence_figure(comparison: Comparison, instance: str) -> plt.Figure:
    """Best-so-far objective and the incumbent's RMSE against evaluations: median and IQR over
    each method's runs at its largest budget."""
    runs = _largest_budget(comparison, instance)
    trace = comparison.trace[comparison.trace.run_id.isin(runs.run_id)
                             & comparison.trace.checkpoint]
    look = styles(comparison)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), constrained_layout=True)
    for ax, column, title in ((axes[0], "best_f", "objective (best so far)"),
                              (axes[1], "rmse", "RMSE of the incumbent")):
        for k, method in enumerate(comparison.methods):
            part = trace[trace.method == method]
            if part.empty or column not in part:
                continue
            wide = part.pivot_table(index="evaluations", columns="run_id", values=column,
                                    aggfunc="first").replace([np.inf, -np.inf], np.nan)
            budget = int(runs[runs.method == method].budget.max())
            _band(ax, wide.index.to_numpy(), wide, look[method],
                  f"{method} ({budget:,} evals)", k)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("evaluations")
        ax.set_title(title)
    _legend(fig)
    fig.suptitle(f"{instance}: convergence (median, IQR band)")
    return fig


def target_hits(comparison: Comparison, instance: str, column: str = "rmse",
                targets: int = TARGETS) -> tuple[pd.DataFrame, np.ndarray]:
    """Evaluations each run (at its method's largest budget) needed to bring the incumbent's
    ``column`` (``rmse`` or ``best_f``) to each of ``targets`` log-spaced targets (``inf``:
    never). Targets run from the worst method's median final value down to the best final
    value of any run."""
    runs = _largest_budget(comparison, instance)
    final = runs.groupby("method")[column].median()
    easy, hard = float(final.max()), float(runs[column].min())
    if not (np.isfinite(easy) and np.isfinite(hard) and easy > 0 and hard > 0):
        return pd.DataFrame(columns=["run_id", "method", "target", "evaluations"]), np.empty(0)
    levels = np.geomspace(easy, hard, targets) if easy > hard else np.array([easy])
    trace = comparison.trace[comparison.trace.run_id.isin(runs.run_id)]
    rows = []
    for (run_id, method), points in trace.groupby(["run_id", "method"], sort=False):
        values = points[column].to_numpy()
        evals = points.evaluations.to_numpy()
        for level in levels:
            hit = np.flatnonzero(values <= level * (1 + 1e-12))
            rows.append((run_id, method, level, evals[hit[0]] if hit.size else np.inf))
    return pd.DataFrame(rows, columns=["run_id", "method", "target", "evaluations"]), levels


def ecdf_figure(comparison: Comparison, instances: list[str], title: str) -> plt.Figure:
    """Fixed-target view: the fraction of (run, target) pairs reached within a number of
    evaluations, per method (COCO / IOHanalyzer style), pooled over ``instances``, for targets
    on the objective (best so far) and on the incumbent's RMSE."""
    look = styles(comparison)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), constrained_layout=True, sharey=True)
    top = max(comparison.budgets)
    x = np.unique(np.geomspace(1, top, 200).round())
    for ax, column, label in ((axes[0], "best_f", "objective targets"),
                              (axes[1], "rmse", "RMSE targets")):
        hits = pd.concat([target_hits(comparison, i, column)[0] for i in instances],
                         ignore_index=True)
        for k, method in enumerate(comparison.methods):
            values = hits.loc[hits.method == method, "evaluations"].to_numpy(dtype=float)
            if values.size == 0:
                continue
            fraction = (values[None, :] <= x[:, None]).mean(axis=1)
            ax.step(x, fraction, where="post", label=method, ms=4,
                    markevery=_markevery(k, x, fraction), **look[method])
        ax.set_xscale("log")
        ax.set_ylim(0, 1.02)
        ax.set_xlabel("evaluations")
        ax.set_title(label)
    axes[0].set_ylabel("fraction of (run, target) pairs reached")
    _legend(fig)
    fig.suptitle(title)
    return fig


def _spec(run: pd.Series) -> Any:
    """The run's spec, from its stored configuration."""
    from metaknot.experiments.spec import run_spec

    config = json.loads(run["config"])
    return run_spec({**config, "study": "report", "results_dir": "."}, check_build=False)


def run_curve(run: pd.Series) -> Any:
    """The run's data as its curve model (same points, same noise, same parameters)."""
    return _spec(run).build_curve()


def rebuild_problem(run: pd.Series) -> Any:
    """The run's problem, rebuilt from its stored configuration (same data, same noise)."""
    return _spec(run).build_problem()


def run_fit(run: pd.Series, curve: Any) -> Any:
    """The run's fitted spline on its data (``curve``): the spline its record stores, or, for
    a record written before records stored it, the decode of its stored candidate by its
    rebuilt problem."""
    from metaknot.experiments.store import stored_fit

    fit = stored_fit(run, curve.params, curve.points)
    return fit if fit is not None else rebuild_problem(run).decode(np.asarray(run["best_x"])).fit


def _median_run(runs: pd.DataFrame) -> pd.Series:
    order = runs.sort_values(["best_f", "seed"], kind="stable")
    return order.iloc[(len(order) - 1) // 2]


def fitted_curves_figure(comparison: Comparison, instance: str) -> plt.Figure:
    """Data points, the fitted curve and its knots for the median run (by objective) of each
    method at its largest budget; 3-D data are drawn in 3-D."""
    runs = _largest_budget(comparison, instance)
    methods = [m for m in comparison.methods if (runs.method == m).any()]
    colours = palette(comparison)  # the fit in its method's colour
    dim = int(runs["dim"].iloc[0]) if "dim" in runs else 2
    columns = min(len(methods), 3)
    rows = -(-len(methods) // columns)
    fig = plt.figure(figsize=(4.2 * columns, 3.9 * rows), constrained_layout=True)
    for k, method in enumerate(methods):
        run = _median_run(runs[runs.method == method])
        projection = "3d" if dim == 3 else None
        ax = fig.add_subplot(rows, columns, k + 1, projection=projection)
        data = run_curve(run)
        fit = run_fit(run, data)
        points = data.points
        lower, upper = data.knot_bounds
        u = np.linspace(lower, upper, 1500)  # a closed curve's whole period
        curve = fit.spline(u)
        knots = fit.spline(fit.interior_knots) if len(fit.interior_knots) else np.empty(
            (0, points.shape[1]))
        def coords(a: np.ndarray) -> tuple[np.ndarray, ...]:
            return tuple(a[:, i] for i in range(min(dim, 3)))

        if dim == 1:
            ax.plot(data.params, points[:, 0], ".", color="0.6", ms=3, label="data")
            ax.plot(u, curve[:, 0], color=colours[method], lw=1.2, label="fit")
            ax.plot(fit.interior_knots, knots[:, 0], "x", color="crimson", ms=5, label="knots")
        else:
            ax.plot(*coords(points), ".", color="0.6", ms=3, label="data")
            ax.plot(*coords(curve), color=colours[method], lw=1.2, label="fit")
            if len(knots):
                ax.plot(*coords(knots), "x", color="crimson", ms=5, label="knots")
            if dim == 2:
                ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{method}: {fit.n_control_points} control points, RMSE {fit.rmse:.2e}\n"
                     f"(median run, seed {int(run['seed'])}, {int(run['budget']):,} evals)",
                     fontsize=9)
    _legend(fig, fontsize=7)  # data, fit (in each method's colour), knots
    fig.suptitle(f"{instance}: fitted curves")
    return fig


def fitpack_front(data: Any, n: int = 40) -> pd.DataFrame:
    """FITPACK's own smoothing fits (``bspline.fitpack``) of ``data`` (a run's curve model)
    over ``n`` smoothing factors: control points and RMSE (one row per control-point count,
    the best RMSE)."""
    from metaknot.bspline import fitpack

    columns = fitpack.front(data.params, data.points, data.degree, n)
    return pd.DataFrame({"n_control_points": columns["n_control_points"],
                         "rmse": columns["rmse"]})


def front_figure(comparison: Comparison, instance: str) -> plt.Figure:
    """Control points against RMSE, one dot per run, with FITPACK's front as a line: a dot
    below the line beats FITPACK at that number of control points."""
    runs = comparison.runs[comparison.runs.instance == instance]
    look = styles(comparison)
    fig, ax = plt.subplots(figsize=(7.5, 4), constrained_layout=True)
    front = fitpack_front(run_curve(runs.sort_values("seed").iloc[0]))
    ax.plot(front.n_control_points, front.rmse, "-", color="0.3", lw=1.2, marker=".",
            label="FITPACK front")
    has_fronts = "front" in runs and runs["front"].map(lambda v: isinstance(v, str)).any()
    for method in comparison.methods:
        part = runs[runs.method == method]
        if not len(part):
            continue
        fronts = part[part["front"].map(lambda v: isinstance(v, str))] if has_fronts \
            else part.iloc[:0]
        if len(fronts):  # a front per run (objective pareto): the median run's front
            median_front = json.loads(_median_run(fronts)["front"])
            ax.step(median_front["n_control_points"], median_front["rmse"], where="post", lw=1.2,
                    label=f"{method} (median-hypervolume run's front)", **look[method])
        else:
            ax.plot(part.n_control_points, part.rmse, linestyle="none", ms=4, alpha=0.6,
                    mec="none", color=look[method]["color"], marker=look[method]["marker"],
                    label=method)
    if has_fronts:
        members = pd.concat([pd.DataFrame(json.loads(v)) for v in runs["front"]
                             if isinstance(v, str)])
        runs = pd.concat([runs, members[["n_control_points", "rmse"]]])
    ax.set_yscale("log")
    lo, hi = runs.n_control_points.min(), runs.n_control_points.max()
    left, right = max(0, lo - 0.15 * (hi - lo + 4)), hi + 0.15 * (hi - lo + 4)
    ax.set_xlim(left, right)
    seen = front[(front.n_control_points >= left) & (front.n_control_points <= right)].rmse
    errors = pd.concat([runs.rmse, seen]).replace([np.inf, -np.inf], np.nan).dropna()
    errors = errors[errors > 0]
    if len(errors):
        ax.set_ylim(errors.min() / 1.5, errors.max() * 1.5)
    ax.set_xlabel("control points")
    ax.set_ylabel("RMSE")
    ax.set_title(f"{instance}: control points against error (FITPACK's data: seed "
                 f"{int(runs.seed.min())})", fontsize=10)
    _legend(fig)
    return fig


def budget_figure(comparison: Comparison, instance: str) -> plt.Figure:
    """Control points and RMSE against the budget, per method (median and IQR over seeds):
    where the objective drives the search as it is given more evaluations."""
    runs = comparison.runs[comparison.runs.instance == instance]
    look = styles(comparison)
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), constrained_layout=True)
    for ax, column, title in ((axes[0], "best_f", "objective"),
                              (axes[1], "n_control_points", "control points"),
                              (axes[2], "rmse", "RMSE")):
        for k, method in enumerate(comparison.methods):
            part = runs[runs.method == method]
            if part.empty:
                continue
            wide = part.pivot_table(index="budget", columns="seed", values=column,
                                    aggfunc="first")
            _band(ax, wide.index.to_numpy(), wide, look[method], method, k)
        ax.set_xscale("log")
        if column != "n_control_points":
            ax.set_yscale("log")
        ax.set_xlabel("budget (evaluations)")
        ax.set_title(title)
    _legend(fig)
    fig.suptitle(f"{instance}: outcome against budget (median, IQR band)")
    return fig


def cd_diagram(comparison: Comparison, friedman: FriedmanResult,
               alpha: float = 0.05, blocks: str = "cells") -> plt.Figure | None:
    """Critical-difference diagram of the average ranks (scikit-posthocs), when the Friedman
    test applies; each method in its colour of the other figures."""
    import scikit_posthocs as sp

    if friedman.posthoc is None or len(friedman.ranks) < 3:
        return None
    fig, ax = plt.subplots(figsize=(7, 0.6 + 0.35 * len(friedman.ranks)),
                           constrained_layout=True)
    colours = {m: matplotlib.colors.to_hex(c) for m, c in palette(comparison).items()}
    drawn = sp.critical_difference_diagram(friedman.ranks, friedman.posthoc, ax=ax,
                                           alpha=alpha, color_palette=colours)
    for lines in drawn["crossbars"]:  # each bar is drawn through a set of names: in rank
        for line in lines:  # order, so the same ranks give the same pixels in every process
            x, y = map(np.asarray, line.get_data())
            line.set_data(np.sort(x), y)
    from .data import METRICS

    ax.set_title(f"average ranks of the {METRICS.get(friedman.metric, friedman.metric)} over "
                 f"{friedman.blocks} {blocks} (Nemenyi, alpha {alpha:g})", fontsize=10)
    return fig


def _scopes(families: list[str]) -> tuple[plt.Figure, list[Any]]:
    """A grid of panels: the whole suite first, then one per family."""
    panels = 1 + len(families)
    columns = min(panels, 3)
    rows = -(-panels // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.0 * columns, 3.0 * rows),
                             constrained_layout=True, squeeze=False)
    for ax in axes.ravel()[panels:]:
        ax.set_visible(False)
    return fig, list(axes.ravel()[:panels])


def suite_ecdf_figure(comparison: Comparison, suite: Any, hits: pd.DataFrame) -> plt.Figure:
    """COCO-style ECDF of the (run, target) pairs over log evaluations, pooled over the
    suite's problems and per family."""
    from .suite import ALL, ecdf

    look = styles(comparison)
    x = np.unique(np.geomspace(1, suite.budget, 200).round())
    families = [f for f in suite.family_names if (hits.family == f).any()]
    fig, axes = _scopes(families)
    for ax, scope in zip(axes, [ALL, *families], strict=True):
        part = hits if scope == ALL else hits[hits.family == scope]
        shares = ecdf(part, x)
        for k, method in enumerate(suite.methods):
            if method in shares:
                ax.step(x, shares[method], where="post", label=method, ms=4,
                        markevery=_markevery(k, x, shares[method]), **look[method])
        ax.set_xscale("log")
        ax.set_ylim(-0.02, 1.02)
        problems = part.problem.nunique()
        ax.set_title(f"{scope} ({problems} problems)", fontsize=9)
        ax.set_xlabel("evaluations")
    axes[0].set_ylabel("fraction of (run, target) pairs")
    _legend(fig, fontsize=7)
    return fig


def profile_figure(comparison: Comparison, suite: Any) -> plt.Figure:
    """Dolan–Moré performance profiles of the median final objective, over the suite and per
    family."""
    from .suite import ALL, performance_profile, profile_taus

    look = styles(comparison)
    fig, axes = _scopes(suite.family_names)
    for ax, scope in zip(axes, [ALL, *suite.family_names], strict=True):
        medians = suite.medians if scope == ALL else suite.medians[suite.families == scope]
        taus = profile_taus(medians)
        profile, left_out = performance_profile(medians, taus)
        for k, method in enumerate(suite.methods):
            if method not in profile:  # not compared in this scope (s.comparable)
                continue
            ax.step(taus, profile[method], where="post", label=method, ms=4,
                    markevery=_markevery(k, taus, profile[method]), **look[method])
        ax.set_xscale("log")
        # a panel spanning less than a decade labels its minor ticks, which then overlap
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_ylim(-0.02, 1.02)
        ax.set_title(f"{scope} ({len(medians) - left_out} problems)", fontsize=9)
        ax.set_xlabel("τ (ratio to the best median)")
    axes[0].set_ylabel("share of problems within τ")
    _legend(fig, fontsize=7)
    return fig
