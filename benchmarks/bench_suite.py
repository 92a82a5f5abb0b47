"""A study over the whole benchmark suite and its report (targets on 2 cores: study <= 600 s,
report <= 120 s).

Five optimizers that search masks (GA, Dolphin Echolocation, the (1+1) EA, local search and
random search) × 3 seeds × every instance of the suite (``suite=all``), each on the instance's
tolerance task (``problem.task=tolerance``: the maximum deviation within 1e-3 of the scale on
an instance without noise, and on a noisy instance its own ``tolerance_noise``, the RMSE within
1.05 σ), 2,000 evaluations per run, as one ``metaknot run -m`` sweep with the joblib launcher
(one worker per core), into a fresh results directory; then the study's report with figures.

Printed::

    suite_instances: <instances in the suite>
    suite_families: <families>
    suite_runs: <runs stored>  (<runs per second>)
    suite_study_seconds: <the whole sweep command: start-up, workers, runs and records>
    suite_report_seconds: <metaknot report of the study, figures included>

Run: ``python benchmarks/bench_suite.py [--quick] [--budget 2000] [--seeds 3] [--no-figures]
[--keep DIR]``. ``--quick`` is a smoke size: ``suite=mini`` (one instance per family) and one
seed; ``--no-figures`` builds the report's tables only; ``--keep`` keeps the study and its
report in DIR (default: a temporary folder, removed at the end).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from _timing import metaknot_run, timed

from metaknot.experiments import load_study
from metaknot.experiments.report import build
from metaknot.suite import instances

OPTIMIZERS = ("ga", "dolphin", "one_plus_one", "local_search", "random_search")
STUDY = "bench_suite"


def study_seconds(results: Path, split: str, seeds: int, budget: int) -> float:
    """Wall time of the sweep command (raises if a run is missing or failed)."""
    overrides = [f"suite={split}", "problem.task=tolerance", f"optimizer={','.join(OPTIMIZERS)}",
                 f"seed=range(0,{seeds})", f"budget={budget}", "launcher=joblib",
                 f"study={STUDY}", f"results_dir={results}", "progress=false"]
    done, seconds = timed(metaknot_run, overrides, capture_output=True, timeout=7200)
    if done.returncode != 0:
        raise RuntimeError(done.stderr[-2000:])
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="smoke size: suite=mini and one seed")
    parser.add_argument("--budget", type=int, default=2000, help="evaluations per run")
    parser.add_argument("--seeds", type=int, default=None, help="seeds (default 3; quick 1)")
    parser.add_argument("--no-figures", action="store_true",
                        help="report tables only (figures take most of the report's time)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="results folder to keep the study and report in (default: temp)")
    args = parser.parse_args()
    split = "mini" if args.quick else "all"
    seeds = args.seeds or (1 if args.quick else 3)

    suite = instances()
    print(f"suite_instances: {len(suite)}")
    print(f"suite_families: {len({i.family for i in suite})}")
    with tempfile.TemporaryDirectory() as temp:
        results = args.keep or Path(temp)
        print(f"study: suite={split}, {len(OPTIMIZERS)} optimizers x {seeds} seeds, "
              f"tolerance task, {args.budget} evaluations per run, joblib", flush=True)
        study = study_seconds(results, split, seeds, args.budget)
        runs = load_study(results / STUDY).runs
        ok = int((runs["status"] == "ok").sum())
        if ok != len(runs):
            raise RuntimeError(f"{len(runs) - ok} of {len(runs)} runs did not finish")
        print(f"suite_runs: {ok}  ({ok / study:.1f} runs per second)")
        print(f"suite_study_seconds: {study:.1f}", flush=True)
        _, seconds = timed(build, results / STUDY, results / f"{STUDY}-report",
                           figures=not args.no_figures, log=None)
        print(f"suite_report_seconds: {seconds:.1f}")


if __name__ == "__main__":
    main()
