"""What a tuning study leaves behind: the best configuration as a ``metaknot run --preset``
file, the trials as a table, Optuna's figures, the held-out comparison and a short report."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..spec import run_spec
from .study import TuneSpec

__all__ = ["best_setting", "evaluate_held_out", "write_best_config", "write_figures",
           "write_report", "write_trials"]


def best_setting(spec: TuneSpec, study: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """Hyperparameters and encoding of the study's best trial."""
    return spec.trial_setting(study.best_trial.params)


def write_best_config(spec: TuneSpec, study: Any) -> Path:
    """The best configuration as a method preset, ``<optimizer>_tuned.yaml`` in the study
    directory: plain data, for ``metaknot run --preset FILE`` (:mod:`..preset`)."""
    import yaml

    params, encoding = best_setting(spec, study)
    trial = study.best_trial
    path = spec.study_dir / f"{spec.optimizer}_tuned.yaml"
    body = {"optimizer": {"_name_": spec.optimizer, **{k: _plain(v) for k, v in params.items()}},
            "encoding": {k: _plain(v) for k, v in encoding.items()},
            "label": f"{spec.optimizer}-tuned"}
    header = (f"# {spec.optimizer} tuned by study {spec.study!r}: trial {trial.number}, mean "
              f"ratio to {spec.reference} {trial.value:.4g} on the training instances.\n"
              f"# {run_command(path)}\n")
    path.write_text(header + yaml.safe_dump(body, sort_keys=False))
    return path


def run_command(preset: Path) -> str:
    """The ``metaknot run`` command line that runs a written preset."""
    return f"metaknot run --preset {preset} problem=... seed=..."


def _plain(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value


def write_trials(spec: TuneSpec, study: Any) -> Path:
    """Every trial (number, state, value, parameters, per-instance ratios, times) as
    ``trials.parquet`` and ``trials.csv``."""
    frame = study.trials_dataframe(attrs=("number", "state", "value", "params", "user_attrs",
                                          "datetime_start", "datetime_complete", "duration"))
    for column in frame.columns:  # lists (per-seed values) as JSON text
        if frame[column].map(lambda v: isinstance(v, list | tuple)).any():
            frame[column] = frame[column].map(
                lambda v: json.dumps(v) if isinstance(v, list | tuple) else v)
    if "duration" in frame:
        frame["duration"] = frame["duration"].dt.total_seconds()
    path = spec.study_dir / "trials.parquet"
    frame.to_parquet(path, index=False)
    frame.to_csv(spec.study_dir / "trials.csv", index=False)
    return path


def write_figures(spec: TuneSpec, study: Any) -> list[Path]:
    """Optuna's optimisation history, parameter importances and slice plots (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import optuna
    from matplotlib.figure import Figure
    from optuna.trial import TrialState
    from optuna.visualization import matplotlib as ovm

    folder = spec.study_dir / "figures"
    folder.mkdir(exist_ok=True)
    complete = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    plots: list[tuple[str, Callable[..., Any]]] = [("history", ovm.plot_optimization_history)]
    if len(complete) >= 2 and len(spec.space.names()) >= 2:
        plots.append(("importances", ovm.plot_param_importances))
    if complete:
        plots.append(("slice", ovm.plot_slice))
    out = []
    optuna.logging.set_verbosity(optuna.logging.ERROR)
    for name, plot in plots:
        try:
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # Optuna marks its matplotlib plots experimental
                axes = plot(study)
        except (ValueError, RuntimeError) as exc:  # e.g. importances of a constant value
            print(f"tune: figure {name} skipped: {exc}")
            continue
        # Optuna draws on a figure of its own (matplotlib's stubs allow a subfigure too)
        figure = cast(Figure, np.ravel(axes)[0].figure if isinstance(axes, np.ndarray)
                      else axes.figure)
        path = folder / f"{name}.png"
        figure.savefig(path, dpi=110, bbox_inches="tight")
        plt.close(figure)
        out.append(path)
    return out


def evaluate_held_out(spec: TuneSpec, study: Any, workers: int = 1) -> Path:
    """The tuned configuration, the defaults and the ``compare_with`` methods on the held-out
    test instances and seeds, as the study ``<study>-test`` in the results store (resumable:
    stored runs are kept). Returns its directory."""
    from ..app import execute

    params, encoding = best_setting(spec, study)
    settings = [(f"{spec.optimizer}-tuned", spec.optimizer, params, encoding),
                (spec.optimizer, spec.optimizer, {}, spec.encoding),
                *((name, name, {}, spec.encoding) for name in spec.compare_with)]
    runs = []
    for label, optimizer, hyper, enc in settings:
        for instance in spec.test:
            for seed in spec.test_seeds:
                config = spec.run_config(instance, seed, optimizer=optimizer, params=hyper,
                                         encoding=enc, study=spec.test_study,
                                         threads=1 if workers > 1 else "auto")
                runs.append(run_spec({**config, "label": label}))
    if workers > 1:
        from joblib import Parallel, delayed

        Parallel(n_jobs=workers)(delayed(execute)(r, multirun=True) for r in runs)
    else:
        for run in runs:
            execute(run, multirun=True)
    return spec.results_dir / spec.test_study


def held_out_summary(spec: TuneSpec) -> tuple[list[str], dict[str, float]]:
    """Markdown lines comparing the tuned configuration with each other method on the test
    instances, for the objective (``best_f``) and the RMSE: median ratio tuned / other over
    the pairs (instance, seed), how often the tuned one is better, the Wilcoxon signed-rank p
    (paired) and Vargha-Delaney A12 within each instance, averaged over the instances.
    Returns the lines and the median objective ratio against each method."""
    from ..report.tables import wilcoxon_p
    from ..store import load_study

    runs = load_study(spec.results_dir / spec.test_study).runs
    runs = runs[runs.status == "ok"]
    tuned_label = f"{spec.optimizer}-tuned"
    lines = ["| outcome | tuned against | pairs | median ratio tuned / other | tuned better | "
             "Wilcoxon p | A12 |", "|---|---|---|---|---|---|---|"]
    headline: dict[str, float] = {}
    for value in ("best_f", "rmse"):
        wide = runs.pivot_table(index=["data", "noise", "seed"], columns="label", values=value)
        for other in [c for c in wide.columns if c != tuned_label]:
            pair = wide[[tuned_label, other]].dropna()
            ratio = pair[tuned_label] / pair[other]
            diff = pair[tuned_label] - pair[other]
            p = wilcoxon_p(pair[tuned_label].to_numpy(), pair[other].to_numpy()) \
                if (diff != 0).any() else 1.0
            a12 = float(np.mean([_a12(part[tuned_label].to_numpy(), part[other].to_numpy())
                                 for _, part in pair.groupby(level=["data", "noise"])]))
            lines.append(f"| {value} | {other} | {len(pair)} | {ratio.median():.3f} | "
                         f"{int((diff < 0).sum())}/{len(pair)} | {p:.2g} | {a12:.2f} |")
            if value == "best_f":
                headline[other] = float(ratio.median())
    return lines, headline


def _a12(a: np.ndarray, b: np.ndarray) -> float:
    """Vargha-Delaney A12 for minimisation: the chance a value of ``a`` is below one of
    ``b`` (ties count half)."""
    return float(((a[:, None] < b[None, :]) + 0.5 * (a[:, None] == b[None, :])).mean())


def write_report(spec: TuneSpec, study: Any, figures: list[Path], best_config: Path,
                 test_dir: Path | None) -> Path:
    """``report.md`` in the study directory: the study, the best configuration, the figures
    and (if run) the held-out comparison, with a link to its full report."""
    from optuna.trial import TrialState

    counts = {s.name: len(study.get_trials(deepcopy=False, states=(s,)))
              for s in (TrialState.COMPLETE, TrialState.PRUNED, TrialState.FAIL)}
    best = study.best_trial
    lines = [f"# Tuning {spec.optimizer}: study {spec.study}", "",
             f"{counts['COMPLETE']} complete, {counts['PRUNED']} pruned and {counts['FAIL']} "
             f"failed trials ({spec.sampler} sampler, {spec.pruner} pruner). A trial runs "
             f"{spec.optimizer} with {spec.budget:,} evaluations on "
             f"{len(spec.train)} training instances x {len(spec.train_seeds)} seeds; its value "
             f"is the mean over instances of the median `best_f` divided by the median of "
             f"`{spec.reference}` on that instance (lower is better; 1 = as good as "
             f"{spec.reference}).", "",
             f"Training instances: {', '.join(i.key for i in spec.train)}. Held-out test "
             f"instances: {', '.join(i.key for i in spec.test)} (seeds 0-"
             f"{len(spec.test_seeds) - 1}; training seeds start at {spec.train_seeds[0]}).", "",
             f"## Best configuration (trial {best.number}, value {best.value:.4g})", "",
             "| parameter | value |", "|---|---|",
             *(f"| {k} | {v!r} |" for k, v in best.params.items()), "",
             f"As a preset: `{best_config}` (plain data; see docs/tuning.md) —", "",
             f"    {run_command(best_config)}", ""]
    if test_dir is not None:
        table, _ = held_out_summary(spec)
        lines += ["## Held out: tuned against the defaults", "",
                  f"Study `{spec.test_study}` in the results store; full report: "
                  f"`metaknot report {test_dir}`.", "", *table, "",
                  "Ratios below 1 and A12 above 0.5 favour the tuned configuration; "
                  "Wilcoxon signed-rank test paired by instance and seed; A12 within each "
                  "instance, averaged.", ""]
    if figures:
        lines += ["## Figures", "", *(f"![{p.stem}](figures/{p.name})" for p in figures), ""]
    path = spec.study_dir / "report.md"
    path.write_text("\n".join(lines))
    return path
