"""Throughput of whole runs and of parallel sweeps, side by side with the kernel alone.

1. Run overhead. Random search, the GA and Dolphin Echolocation on the epitrochoid 0/1-mask
   problem (population 50, 20,000 evaluations, one kernel thread). Each run is timed; then the
   same candidates (recorded in a second run with the same seed) are fitted again by the kernel
   alone, in the same batches. Printed: evaluations per second of the run and of the kernel, and
   their ratio (kernel time / run time: 1 means the optimizer and the framework cost nothing).

2. Sequential optimizers, one kernel thread, side by side. Random search with batches of one
   candidate: its whole-run time per evaluation against the kernel's time per candidate on the
   same candidates fitted in batches of 50. The (1+1) EA (every child a local move, scored by
   delta evaluation): its whole-run time per evaluation against the time of one delta move
   (every one-bit flip of the run's best mask, scored by a ``MoveEvaluator`` in one call,
   repeated until as many moves as the run made are timed: on a shared machine a short
   timing would catch a quiet moment that the whole run does not). And the floors of both:
   random search's draw plus one bare kernel call per candidate (no evaluator, objective or
   trace), and the EA's batches of moves (it asks for its next steps ahead) scored again by
   the problem alone (``evaluate_near``: the moves, often of several flips, the incumbent's
   rebinds and the problem's work per batch), each over the same reference as its ratio.

3. Sweep scaling. 40 runs as a ``metaknot run -m`` sweep with the joblib launcher, once with one
   worker and once with two (each worker runs the kernel on one thread), each into a fresh
   results directory, alternated twice. The budget per run is sized by time: enough that the
   one-worker sweep computes for at least ``--sweep-seconds`` (60 s) at the rate the runs of
   part 1 reached, so that starting the workers does not dominate on a fast machine. Printed:
   the wall times and the ratio of the best of each (the whole command: start-up, validation,
   workers, runs and records).

4. Store writes. The record of a GA run (20,000 evaluations: settings, best candidate and
   trace) written into a results store in the current directory (the disk results go to, not a
   temp file system), each as a new run: synced to disk (file and folder, as every run is
   stored) and, for comparison, with the syncs skipped. Printed: milliseconds per record and
   the share of the fastest run of part 1 that the write adds.

The last lines are::

    run_overhead_ratio: <the worst optimizer's kernel time / run time>       (target >= 0.5)
    sequential_overhead_ratio: <random search batch 1, run time per evaluation / kernel time
                                per candidate in a batch>
    sequential_floor_ratio: <random search's draw and one bare kernel call per candidate /
                             kernel time per candidate in a batch>   (what no framework beats)
    sequential_over_floor: <sequential_overhead_ratio / sequential_floor_ratio: what the
                            run adds over that floor>                      (target <= 1.25)
    one_plus_one_move_ratio: <(1+1) EA, run time per evaluation / delta-move time per move>
    one_plus_one_problem_ratio: <the EA's batches scored again by the problem alone, per
                                 evaluation / delta-move time per move>  (its moves' own cost)
    one_plus_one_over_floor: <one_plus_one_move_ratio / one_plus_one_problem_ratio: what
                              the run adds over its problem>               (target <= 1.25)
    store_write_ms: <one synced record write, in milliseconds>
    store_write_share: <that write / the fastest run of part 1>
    sweep_scaling_2_workers: <one-worker time / two-worker time>             (target >= 1.7)

Run: ``python benchmarks/bench_runs.py [--evaluations 20000] [--sweep-runs 40]
[--sweep-seconds 60]``; ``--sweep-budget`` fixes the budget per run instead, ``--no-sweep``
skips part 3. The figures are ratios measured in one run, as the machine may be shared.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numba
import numpy as np
from _timing import best_time, metaknot_run, timed

import metaknot as mk
from metaknot.bspline.moves import MoveEvaluator, bit_flips
from metaknot.experiments.store import Store
from metaknot.problems import KnotSelection, get_curve

OPTIMIZERS = ("random_search", "ga", "dolphin")
OPTIONS = {"random_search": {"batch_size": 50}, "ga": {"population": 50},
           "dolphin": {"population": 50}}


class Recording(KnotSelection):
    """The epitrochoid mask problem, keeping a copy of every evaluated batch (and, for batches
    of moves, the candidate they were made from)."""

    def evaluate_with_metrics(self, X):
        self.batches.append(np.array(X, copy=True))
        return super().evaluate_with_metrics(X)

    def evaluate_near(self, X, near):
        self.near_batches.append((np.array(X, copy=True), np.array(near, copy=True)))
        return super().evaluate_near(X, near)


def kernel_seconds(problem: KnotSelection, batches: list[np.ndarray], repeats: int) -> float:
    """Best-of-``repeats`` time of the kernel alone on the recorded batches."""
    masks = [b.astype(bool) for b in batches]

    def kernel() -> None:
        for m in masks:
            problem.curve.evaluate_masks(m)

    return best_time(kernel, repeats)


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
        run = best_time(lambda p=problem, n=name: mk.minimize(
            p, n, budget=evaluations, seed=1, optimizer_kwargs=OPTIONS[n]), repeats)
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


def sequential_overhead(evaluations: int, repeats: int) -> tuple[float, float, float, float]:
    """Random search with batches of one against the kernel on its candidates, and the (1+1)
    EA against one delta move: the two ratios (run time per evaluation / kernel time); and
    their floors: random search's draw plus one bare kernel call per candidate, and the EA's
    batches scored again by the problem alone, over the same references."""
    numba.set_num_threads(1)
    data = get_curve("epitrochoid")
    problem = KnotSelection(data)
    single = {"batch_size": 1}

    def best_run(name: str, options: dict) -> float:
        mk.minimize(problem, name, budget=500, seed=0, optimizer_kwargs=options)  # warm
        return best_time(lambda: mk.minimize(problem, name, budget=evaluations, seed=1,
                                             optimizer_kwargs=options), repeats) / evaluations

    per_random = best_run("random_search", single)
    recording = Recording(data)
    recording.batches, recording.near_batches = [], []
    mk.minimize(recording, "random_search", budget=evaluations, seed=1, optimizer_kwargs=single)
    candidates = np.concatenate(recording.batches)
    batches = np.array_split(candidates, max(1, len(candidates) // 50))
    per_kernel = kernel_seconds(problem, batches, repeats) / len(candidates)
    # the floor: the sampler's draw and one bare kernel call per candidate, no framework
    rng, curve = np.random.default_rng(1), problem.curve
    one_by_one = [c[None, :] for c in candidates]

    def floor() -> None:
        for c in one_by_one:
            problem.sample(rng, 1)
            curve.evaluate_masks(c, max_deviation=False)

    per_floor = best_time(floor, repeats) / len(candidates)
    per_ea = best_run("one_plus_one", {})
    recording = Recording(data)
    recording.batches, recording.near_batches = [], []
    mk.minimize(recording, "one_plus_one", budget=evaluations, seed=1)
    per_problem = np.inf  # the EA's batches scored again by the problem alone
    for _ in range(repeats):
        again = KnotSelection(data)
        start = time.perf_counter()
        for X, near in recording.near_batches:
            again.evaluate_near(X, near)
        per_problem = min(per_problem, (time.perf_counter() - start) / evaluations)
    best = mk.minimize(problem, "one_plus_one", budget=evaluations, seed=1).best_x.astype(bool)
    moves = MoveEvaluator(problem.params, problem.points, problem.params[1:-1][best])
    flips = bit_flips(problem.params, best, np.arange(best.size))
    moves.evaluate_replacements(*flips)  # compile outside the timing
    calls = -(-evaluations // best.size)  # as many moves as the run made: timed alike

    def replacements() -> None:
        for _ in range(calls):
            moves.evaluate_replacements(*flips)

    per_move = best_time(replacements, repeats) / (calls * best.size)
    print(f"\nsequential optimizers on the epitrochoid masks, {evaluations} evaluations, one "
          f"kernel thread, best of {repeats}")
    print(f"random search, batch 1:  {1e6 * per_random:7.2f} us/evaluation; kernel on its "
          f"candidates in batches of 50: {1e6 * per_kernel:6.2f} us/candidate")
    print(f"(1+1) EA:                {1e6 * per_ea:7.2f} us/evaluation; one delta move "
          f"(every one-bit flip of its best mask): {1e6 * per_move:6.2f} us/move", flush=True)
    print(f"floors: random search's draw and a bare kernel call per candidate "
          f"{1e6 * per_floor:6.2f} us; the EA's {len(recording.near_batches)} batches scored "
          f"again by the problem alone {1e6 * per_problem:6.2f} us/evaluation", flush=True)
    return (per_random / per_kernel, per_ea / per_move, per_floor / per_kernel,
            per_problem / per_move)


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
        overrides = ["launcher=joblib", f"hydra.launcher.n_jobs={workers}",
                     "optimizer=ga,random_search", "problem=epitrochoid", f"budget={budget}",
                     f"seed=range(0,{seeds})", f"results_dir={results}", "progress=false"]
        done, seconds = timed(metaknot_run, overrides, capture_output=True, timeout=3600)
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
    parser.add_argument("--sweep-seconds", type=float, default=60.0)
    parser.add_argument("--sweep-budget", type=int, default=None)
    parser.add_argument("--sweep-repeats", type=int, default=2)
    parser.add_argument("--store-records", type=int, default=50)
    parser.add_argument("--no-sweep", action="store_true")
    args = parser.parse_args()

    worst, runs = run_overhead(args.evaluations, args.repeats)
    sequential, one_plus_one, sequential_floor, one_plus_one_floor = sequential_overhead(
        args.evaluations, args.repeats)
    synced, unsynced, size = store_write_seconds(args.evaluations, args.store_records)
    fastest = min(runs.values())
    print(f"\nstore writes ({args.store_records} records of {size / 1000:.0f} KB into "
          f"{os.path.abspath('.')}): {1e3 * synced:.2f} ms synced, {1e3 * unsynced:.2f} ms "
          f"without the syncs; the fastest run above takes {1e3 * fastest:.0f} ms", flush=True)
    scaling = None
    if not args.no_sweep:
        budget = args.sweep_budget
        if budget is None:  # one worker computes for at least --sweep-seconds
            rate = args.evaluations / min(runs["ga"], runs["random_search"])
            budget = int(np.ceil(args.sweep_seconds * rate / args.sweep_runs / 1000)) * 1000
        print(f"\nsweep of {args.sweep_runs} runs (GA and random search, epitrochoid masks, "
              f"{budget} evaluations each), joblib launcher")
        times: dict[int, list[float]] = {1: [], 2: []}
        for _ in range(args.sweep_repeats):  # alternated, so a slow spell hits both alike
            for workers in (1, 2):
                times[workers].append(sweep_seconds(workers, args.sweep_runs, budget))
                print(f"{workers} worker{'s' if workers > 1 else ' '}: "
                      f"{times[workers][-1]:6.1f} s", flush=True)
        scaling = min(times[1]) / min(times[2])
    print(f"\nrun_overhead_ratio: {worst:.2f}")
    print(f"sequential_overhead_ratio: {sequential:.2f}")
    print(f"sequential_floor_ratio: {sequential_floor:.2f}")
    print(f"sequential_over_floor: {sequential / sequential_floor:.3f}")
    print(f"one_plus_one_move_ratio: {one_plus_one:.2f}")
    print(f"one_plus_one_problem_ratio: {one_plus_one_floor:.2f}")
    print(f"one_plus_one_over_floor: {one_plus_one / one_plus_one_floor:.3f}")
    print(f"store_write_ms: {1e3 * synced:.2f}")
    print(f"store_write_share: {synced / fastest:.3f}")
    if scaling is not None:
        print(f"sweep_scaling_2_workers: {scaling:.2f}")


if __name__ == "__main__":
    main()
