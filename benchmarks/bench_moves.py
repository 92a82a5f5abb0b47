"""Delta evaluation of one-bit moves against the batched kernel, side by side in one run.

On the seed paper's epitrochoid (361 points, centripetal, cubic) at mask densities 0.5 and 0.2:
for several random incumbents, every one-bit flip (insertions and removals of one knot) is
scored by a :class:`~metaknot.bspline.moves.MoveEvaluator` bound to the incumbent and by the
batched kernel (:meth:`~metaknot.bspline.curve.Curve.evaluate_knots`, the evaluator every full
evaluation goes through), both on one thread, best of ``--repeats``. The move evaluator is
timed on the moves themselves (``evaluate_replacements`` with
:func:`~metaknot.bspline.moves.bit_flips`: flip bit j) and on the candidates they make
(``evaluate``: whole knot vectors, compared with the incumbent's). Printed per density: the
time per move of each, the ratios, the share of moves the delta path decided, the largest
relative SSE difference, the time of one call with a single move (what a (1+1) EA pays per
step), and the cost of moving the incumbent (``rebind``: one forward and one backward sweep) in
full fits.

Then the (1+1) EA in the seed's setting (the three seed curves, 0/1 masks, the guarded
``paper`` objective) at a fixed wall-clock allowance per run (``--seconds``, seeds
``0..--seeds-1``), with delta evaluation off (every child fitted in full) and on: evaluations
reached and the median objective. Last line
``move_speedup_vs_batched: <ratio of the moves at density 0.5>``.

The same for closed curves: the epitrochoid as a closed outline (its repeated last point
dropped), every one-bit flip of random incumbents at density 0.5, scored by a
:class:`~metaknot.bspline.moves.PeriodicMoveEvaluator` and by the periodic batched kernel
(:meth:`~metaknot.bspline.curve.ClosedCurve.evaluate_positions`), side by side on one thread;
the line ``periodic_move_speedup_vs_batched: <periodic batched time per candidate / periodic
move time>``.

Run: ``python benchmarks/bench_moves.py [--incumbents 5] [--repeats 5] [--seconds 5]
[--seeds 5]`` (run it on a quiet machine: the wall-clock part is a race against the clock).
"""

from __future__ import annotations

import argparse

import numba
import numpy as np
from _timing import best_time

import metaknot as mk
from metaknot.bspline import closed_parameterize, parameterize
from metaknot.bspline.curve import ClosedCurve, OpenCurve
from metaknot.bspline.knots import stack_masks
from metaknot.bspline.moves import PATH_DELTA, MoveEvaluator, PeriodicMoveEvaluator, bit_flips
from metaknot.problems import KnotSelection, get_curve

CURVES = ("epitrochoid", "archimedean", "vivaldi")


def ea_at_fixed_wall_clock(seconds: float, seeds: int) -> None:
    """The (1+1) EA for ``seconds`` per run, delta evaluation off and on."""
    print(f"\n(1+1) EA, seed setting (masks, guarded paper), {seconds:g} s per run, "
          f"seeds 0-{seeds - 1}: evaluations reached and median objective")
    print(f"{'curve':12s} {'full fits':>22s} {'delta evaluation':>24s}  evaluations")
    for name in CURVES:
        cells = []
        for delta in (False, True):
            problem = KnotSelection(name, objective="paper")
            problem.delta_evaluation = delta
            mk.minimize(problem, "one_plus_one", budget=200, seed=0)  # compile first
            evals, best = [], []
            for seed in range(seeds):
                result = mk.minimize(problem, "one_plus_one", budget=10**8, seed=seed,
                                     callbacks=[lambda pr: pr.elapsed >= seconds])
                evals.append(result.n_evaluations)
                best.append(result.best_f)
            cells.append((float(np.median(evals)), float(np.median(best))))
        (e0, f0), (e1, f1) = cells
        print(f"{name:12s} {e0:10.0f} evals {f0:9.4g} {e1:12.0f} evals {f1:9.4g}  "
              f"x{e1 / e0:.2f}")


def periodic_moves(incumbents: int, repeats: int, degree: int, density: float = 0.5) -> float:
    """Every one-bit flip of random incumbents on the closed epitrochoid, by the periodic move
    evaluator and by the periodic batched kernel; returns the speedup per move."""
    points = get_curve("epitrochoid").points[:-1]  # its last point repeats the first
    u = closed_parameterize(points, "centripetal")
    full = ClosedCurve(u, points, degree)
    n_var = u.size - 1
    rng = np.random.default_rng(20130302)
    t_moves = t_full = t_single = t_rebind = 0.0
    moves = delta_share = 0
    worst = 0.0
    done = 0
    while done < incumbents:
        mask = rng.random(n_var) < density
        try:
            evaluator = PeriodicMoveEvaluator(u, points, u[1:][mask], degree)
        except ValueError:
            continue  # an infeasible incumbent: draw another
        done += 1
        flips = np.repeat(mask[None], n_var, axis=0) ^ np.eye(n_var, dtype=bool)
        positions = np.where(flips, u[1:][None, :], np.nan)
        flipped = bit_flips(u, mask, np.arange(n_var), closed=True)
        by_moves, path = evaluator.evaluate_replacements(*flipped)  # compile outside the timing
        ref = full.evaluate_positions(positions, max_deviation=False, nan_is_absent=True)
        if not np.array_equal(by_moves.reason, ref.reason):
            raise SystemExit("periodic delta and full evaluation disagree on feasibility")
        ok = ref.feasible
        worst = max(worst, float(np.max(np.abs(by_moves.sse[ok] - ref.sse[ok]) / ref.sse[ok])))
        moves += n_var
        delta_share += int(np.count_nonzero(path == PATH_DELTA))
        t_moves += best_time(lambda e=evaluator, f=flipped: e.evaluate_replacements(*f),
                             repeats)
        t_full += best_time(lambda x=positions: full.evaluate_positions(
            x, max_deviation=False, nan_is_absent=True), repeats)
        one = bit_flips(u, mask, [0], closed=True)
        t_single += best_time(lambda e=evaluator, f=one: [
            e.evaluate_replacements(*f) for _ in range(100)], repeats) / 100
        t_rebind += best_time(lambda e=evaluator, m=mask: e.rebind(u[1:][m]), repeats)
    per_moves = t_moves / moves * 1e6
    per_full = t_full / moves * 1e6
    print(f"\nclosed epitrochoid ({u.size} points, periodic), density {density}, "
          f"{incumbents} incumbents:")
    print(f"  periodic batched kernel:       {per_full:8.2f} us/move")
    print(f"  periodic delta evaluation:     {per_moves:8.2f} us/move  (speedup "
          f"{per_full / per_moves:.1f}x; {delta_share / moves:.1%} decided by the delta path)")
    print(f"  one move per call: {t_single / incumbents * 1e6:7.2f} us/call")
    print(f"  rebind (a fit, forward + backward sweeps from two cuts): "
          f"{t_rebind / incumbents / (per_full * 1e-6):.1f} full fits")
    print(f"  max relative SSE difference: {worst:.1e}")
    if worst > 1e-10:
        raise SystemExit("periodic delta evaluation is not exact")
    return per_full / per_moves


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--incumbents", type=int, default=5)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--degree", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    numba.set_num_threads(1)

    points = get_curve("epitrochoid").points
    u = parameterize(points, "centripetal")
    p = args.degree
    full = OpenCurve(u, points, p)
    rng = np.random.default_rng(20130301)
    ratios: dict[float, float] = {}
    candidates: dict[float, float] = {}
    print(f"epitrochoid, {u.size} points, degree {p}, one thread; every one-bit flip of "
          f"{args.incumbents} random incumbents per density")
    for density in (0.5, 0.2):
        t_delta = t_moves = t_full = t_single = t_rebind = 0.0
        moves = delta_share = 0
        worst = 0.0
        for _ in range(args.incumbents):
            mask = rng.random(u.size - 2) < density
            evaluator = MoveEvaluator(u, points, u[1:-1][mask], p)
            flips = np.repeat(mask[None], u.size - 2, axis=0) ^ np.eye(u.size - 2, dtype=bool)
            knots, offsets = stack_masks(u, flips)
            flipped = bit_flips(u, mask, np.arange(u.size - 2))
            fit, path = evaluator.evaluate(knots, offsets)  # compile outside the timing
            by_moves, _ = evaluator.evaluate_replacements(*flipped)
            ref = full.evaluate_knots(knots, offsets, max_deviation=False)
            if not (np.array_equal(fit.reason, ref.reason)
                    and np.array_equal(by_moves.reason, ref.reason)):
                raise SystemExit("delta and full evaluation disagree on feasibility")
            ok = ref.feasible
            for got in (fit, by_moves):
                worst = max(worst, float(np.max(np.abs(got.sse[ok] - ref.sse[ok])
                                                / ref.sse[ok])))
            moves += len(flips)
            delta_share += int(np.count_nonzero(path == PATH_DELTA))
            t_delta += best_time(lambda e=evaluator, k=knots, o=offsets: e.evaluate(k, o),
                                 args.repeats)
            t_moves += best_time(lambda e=evaluator, f=flipped: e.evaluate_replacements(*f),
                                 args.repeats)
            t_full += best_time(lambda k=knots, o=offsets: full.evaluate_knots(
                k, o, max_deviation=False), args.repeats)
            one = bit_flips(u, mask, [0])
            t_single += best_time(lambda e=evaluator, f=one: [
                e.evaluate_replacements(*f) for _ in range(100)], args.repeats) / 100
            t_rebind += best_time(lambda e=evaluator, m=mask: e.rebind(u[1:-1][m]),
                                  args.repeats)
        per_delta = t_delta / moves * 1e6
        per_moves = t_moves / moves * 1e6
        per_full = t_full / moves * 1e6
        ratios[density] = per_full / per_moves
        candidates[density] = per_full / per_delta
        print(f"\ndensity {density}:")
        print(f"  batched kernel:                {per_full:8.2f} us/move")
        print(f"  delta evaluation, moves:       {per_moves:8.2f} us/move  (speedup "
              f"{ratios[density]:.1f}x; {delta_share / moves:.1%} decided by the delta path)")
        print(f"  delta evaluation, candidates:  {per_delta:8.2f} us/move  (speedup "
              f"{candidates[density]:.1f}x)")
        print(f"  one move per call: {t_single / args.incumbents * 1e6:7.2f} us/call")
        print(f"  rebind (forward + backward sweeps): "
              f"{t_rebind / args.incumbents / (per_full * 1e-6):.1f} full fits")
        print(f"  max relative SSE difference: {worst:.1e}")
        if worst > 1e-10:
            raise SystemExit("delta evaluation is not exact")
    periodic = periodic_moves(args.incumbents, args.repeats, p)
    if args.seconds > 0:
        ea_at_fixed_wall_clock(args.seconds, args.seeds)
    print(f"periodic_move_speedup_vs_batched: {periodic:.1f}")
    print(f"candidate_speedup_vs_batched: {candidates[0.5]:.1f}")
    print(f"move_speedup_vs_batched_density_0.2: {ratios[0.2]:.1f}")
    print(f"move_speedup_vs_batched: {ratios[0.5]:.1f}")


if __name__ == "__main__":
    main()
