"""Throughput of whole runs and of parallel sweeps, side by side with the kernel alone.

1. Run overhead. Random search, the GA and Dolphin Echolocation on the epitrochoid 0/1-mask
   problem (population 50, 20,000 evaluations, one kernel thread). Each run is timed; then the
   same candidates (recorded in a second run with the same seed) are fitted again by the kernel
   alone, in the same batches. Printed: evaluations per second of the run and of the kernel, and
   their ratio (kernel time / run time: 1 means the optimizer and the framework cost nothing).

2. Sweep scaling. The same 40 short runs as a ``metaknot run -m`` sweep with the joblib launcher,
   once with one worker and once with two (each worker runs the kernel on one thread), each into
   a fresh results directory, alternated twice. Printed: the wall times and the ratio of the
   best of each (the whole command: start-up, validation, workers, runs and records).

3. Store writes. The record of a GA run (20,000 evaluations: settings, best candidate and
   trace) written into a results store in the current directory (the disk results go to, not a
   temp file system), each as a new run: synced to disk (file and folder, as every run is
   stored) and, for comparison, with the syncs skipped. Printed: milliseconds per record and
   the share of the fastest run of part 1 that the write adds.

The last lines are::

    run_overhead_ratio: <the worst optimizer's kernel time / run time>       (target >= 0.5)
    store_write_ms: <one synced record write, in milliseconds>
    store_write_share: <that write / the fastest run of part 1>
    sweep_scaling_2_workers: <one-worker time / two-worker time>             (target >= 1.7)

Run: ``python benchmarks/bench_runs.py [--evaluations 20000] [--sweep-runs 40]``; ``--no-sweep``
skips part 2. The figures are ratios measured in one run, as the machine may be shared.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

import metaknot as mk
from metaknot.bspline import evaluate_masks
from metaknot.experiments.store import Store
from metaknot.problems import KnotSelection, get_curve

OPTIMIZERS = ("random_search", "ga", "dolphin")
OPTIONS = {"random_search": {"batch_size": 50}, "ga": {"population": 50},
           "dolphin": {"population": 50}}


class Recording(KnotSelection):
    """The epitrochoid mask problem, keeping a copy of every evaluated batch."""

    def evaluate_with_metrics(self, X):
        self.batches.append(np.array(X, copy=True))
        return super().evaluate_with_metrics(X)


def kernel_seconds(problem: KnotSelection, batches: list[np.ndarray], repeats: int) -> float:
    """Best-of-``repeats`` time of the kernel alone on the recorded batches."""
    masks = [b.astype(bool) for b in batches]
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        for m in masks:
            evaluate_masks(problem.params, problem.points, m, problem.degree)
        best = min(best, time.perf_counter() - start)
    return best


def run_overhead(evaluations: int, repeats: int) -> tuple[float, dict[str, float]]:
    numba.set_num_threads(1)
    data = get_curve("epitrochoid")
    print(f"runs on the epitrochoid masks (361 points), {evaluations} evaluations, "
          f"one kernel thread, best of {repeats}")
    print(f"{'optimizer':<14} {'run eval/s':>11} {'kernel eval/s':>14} {'kernel/run':>11}")
    ratios, runs = {}, {}
    for name in OPTIMIZERS:
        problem = KnotSelection(data)
        mk.minimize(problem, name, budget=500, seed=0, optimizer_kwargs=OPTIONS[name])  # warm
        run = np.inf
        for _ in range(repeats):
            start = time.perf_counter()
            mk.minimize(problem, name, budget=evaluations, seed=1,
                        optimizer_kwargs=OPTIONS[name])
            run = min(run, time.perf_counter() - start)
        recording = Recording(data)
        recording.batches = []
        mk.minimize(recording, name, budget=evaluations, seed=1, optimizer_kwargs=OPTIONS[name])
        assert sum(len(b) for b in recording.batches) == evaluations
        kernel = kernel_seconds(problem, recording.batches, repeats)
        ratios[name] = kernel / run
        runs[name] = run
        print(f"{name:<14} {evaluations / run:>11.0f} {evaluations / kernel:>14.0f} "
              f"{ratios[name]:>11.2f}", flush=True)
    return min(ratios.values()), runs


def store_write_seconds(evaluations: int, records: int) -> tuple[float, float, int]:
    """Seconds per record written into a store in the current directory, synced and with the
    syncs skipped, and the record's size in bytes."""
    result = mk.minimize(KnotSelection(get_curve("epitrochoid")), "ga", budget=evaluations,
                         seed=1, optimizer_kwargs=OPTIONS["ga"])
    record = {"study": "bench", "status": "ok", **result.record()}
    trace = result.trace.columns()
    seconds = {}
    with tempfile.TemporaryDirectory(dir=".") as folder:
        for synced in (True, False):
            store = Store(os.path.join(folder, f"synced-{synced}"))
            fsync = os.fsync
            if not synced:
                os.fsync = lambda fd: None
            try:
                start = time.perf_counter()
                for i in range(records):
                    path = store.write({**record, "run_id": f"{i:016x}"}, best_x=result.best_x,
                                       trace=trace)
                seconds[synced] = (time.perf_counter() - start) / records
            finally:
                os.fsync = fsync
        size = path.stat().st_size
    return seconds[True], seconds[False], size


def sweep_seconds(workers: int, runs: int, budget: int) -> float:
    """Wall time of a ``metaknot run -m`` sweep of ``runs`` runs with ``workers`` workers."""
    seeds = runs // 2
    with tempfile.TemporaryDirectory() as results:
        command = [sys.executable, "-m", "metaknot.cli", "run", "-m", "launcher=joblib",
                   f"hydra.launcher.n_jobs={workers}", "optimizer=ga,random_search",
                   "problem=epitrochoid", f"budget={budget}", f"seed=range(0,{seeds})",
                   f"results_dir={results}", "progress=false"]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, timeout=3600,
                              env={**os.environ, "PYTHONUNBUFFERED": "1"})
        seconds = time.perf_counter() - start
        if done.returncode != 0:
            raise RuntimeError(done.stderr)
        if f"{2 * seeds} ok" not in done.stderr:
            raise RuntimeError(f"the sweep did not run every run:\n{done.stderr}")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--evaluations", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--sweep-runs", type=int, default=40)
    parser.add_argument("--sweep-budget", type=int, default=30_000)
    parser.add_argument("--sweep-repeats", type=int, default=2)
    parser.add_argument("--store-records", type=int, default=50)
    parser.add_argument("--no-sweep", action="store_true")
    args = parser.parse_args()

    worst, runs = run_overhead(args.evaluations, args.repeats)
    synced, unsynced, size = store_write_seconds(args.evaluations, args.store_records)
    fastest = min(runs.values())
    print(f"\nstore writes ({args.store_records} records of {size / 1000:.0f} KB into "
          f"{os.path.abspath('.')}): {1e3 * synced:.2f} ms synced, {1e3 * unsynced:.2f} ms "
          f"without the syncs; the fastest run above takes {1e3 * fastest:.0f} ms", flush=True)
    scaling = None
    if not args.no_sweep:
        print(f"\nsweep of {args.sweep_runs} runs (GA and random search, epitrochoid masks, "
              f"{args.sweep_budget} evaluations each), joblib launcher")
        times: dict[int, list[float]] = {1: [], 2: []}
        for _ in range(args.sweep_repeats):  # alternated, so a slow spell hits both alike
            for workers in (1, 2):
                times[workers].append(sweep_seconds(workers, args.sweep_runs,
                                                    args.sweep_budget))
                print(f"{workers} worker{'s' if workers > 1 else ' '}: "
                      f"{times[workers][-1]:6.1f} s", flush=True)
        scaling = min(times[1]) / min(times[2])
    print(f"\nrun_overhead_ratio: {worst:.2f}")
    print(f"store_write_ms: {1e3 * synced:.2f}")
    print(f"store_write_share: {synced / fastest:.3f}")
    if scaling is not None:
        print(f"sweep_scaling_2_workers: {scaling:.2f}")


if __name__ == "__main__":
    main()
