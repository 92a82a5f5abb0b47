"""Batched knot evaluation against a Python loop over scipy, side by side in one run.

1000 random masks (each interior point selected with probability 0.5, fixed seed) on the seed
paper's epitrochoid (361 points, centripetal, cubic). The batched evaluator computes what the
SSE-based objectives need (SSE and control points); the time with the optional maximum-deviation
pass is printed too. Prints the time per candidate of both, the
evaluations per second, the largest relative SSE difference,
``speedup_vs_scipy_1thread: <ratio>`` (the compiled kernel on one thread against the scipy loop)
and ``speedup_vs_scipy: <ratio>`` (on all threads). Then the closed kernel on the closed
epitrochoid (360 points; 1000 random sets of breakpoints at data points, each with probability
0.1), on one thread: ``periodic_vs_open_ratio: <ratio>`` (its time per candidate over the open
kernel's above).

Run: ``python benchmarks/bench_evaluate.py [--candidates 1000] [--repeats 3]``
"""

from __future__ import annotations

import argparse

import numba
import numpy as np
from _timing import best_time
from scipy.interpolate import make_lsq_spline

from metaknot.bspline import _kernel, clamped_knot_vector, parameterize
from metaknot.bspline.curve import OpenCurve, make_curve
from metaknot.problems import get_curve


def scipy_sse(u: np.ndarray, points: np.ndarray, masks: np.ndarray, degree: int) -> np.ndarray:
    """Reference: make_lsq_spline + evaluation for every mask (NaN where it cannot fit)."""
    out = np.full(len(masks), np.nan)
    for b, mask in enumerate(masks):
        t = clamped_knot_vector(u, u[1:-1][mask], degree)
        if t.size - degree - 1 > u.size:
            continue
        spline = make_lsq_spline(u, points, t, degree)
        out[b] = np.sum((points - spline(u)) ** 2)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--candidates", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--degree", type=int, default=3)
    args = parser.parse_args()

    points = get_curve("epitrochoid").points
    u = parameterize(points, "centripetal")
    rng = np.random.default_rng(20130301)
    masks = rng.random((args.candidates, u.size - 2)) < 0.5

    curve = OpenCurve(u, points, args.degree)

    def batched(max_deviation: bool = False):
        return curve.evaluate_masks(masks, max_deviation=max_deviation)

    curve.evaluate_masks(masks[:2])  # compile outside the timing
    batch = batched()
    reference = scipy_sse(u, points, masks, args.degree)

    both = batch.feasible & np.isfinite(reference)
    rel = np.abs(batch.sse[both] - reference[both]) / reference[both]
    print(f"points: {u.size}, candidates: {args.candidates}, feasible: {batch.feasible.sum()}")
    print(f"max relative SSE difference vs scipy: {rel.max():.2e}")
    if rel.max() > 1e-9:
        raise SystemExit("batched evaluator and scipy disagree")

    t_scipy = best_time(lambda: scipy_sse(u, points, masks, args.degree), args.repeats)
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    t_one = best_time(batched, args.repeats)
    numba.set_num_threads(threads)
    t_all = best_time(batched, args.repeats)
    t_dev = best_time(lambda: batched(max_deviation=True), args.repeats)

    per = 1e6 / args.candidates
    print(f"scipy loop:              {t_scipy * per:9.1f} us/candidate")
    print(f"batched, 1 thread:       {t_one * per:9.1f} us/candidate "
          f"(speedup {t_scipy / t_one:.1f}x)")
    print(f"batched, {threads} threads:      {t_all * per:9.1f} us/candidate")
    print(f"  + max deviation pass:  {t_dev * per:9.1f} us/candidate")
    print(f"evaluations_per_second: {args.candidates / t_all:.0f}")
    print(f"speedup_vs_scipy_1thread: {t_scipy / t_one:.1f}")
    print(f"speedup_vs_scipy: {t_scipy / t_all:.1f}")
    periodic(args.candidates, args.repeats, t_one / args.candidates)


def periodic(candidates: int, repeats: int, open_per_candidate: float) -> None:
    """The closed kernel (the open one's factorisation with wrap-around columns) on one
    thread, against the open kernel's time per candidate."""
    curve = make_curve(get_curve("epitrochoid").points, closed=True)
    u, q = curve.params, curve.points
    masks = np.random.default_rng(20130301).random((candidates, u.size - 1)) < 0.1
    counts = masks.sum(axis=1)
    knots = np.ascontiguousarray(np.concatenate([u[1:][mask] for mask in masks]))
    offsets = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)

    def run() -> np.ndarray:
        sse = np.empty(candidates)
        out = (sse, np.empty(0), np.empty(candidates, dtype=np.int64),
               np.empty(candidates, dtype=np.int8))
        _kernel.evaluate_batch(u, q, 3, True, 1, knots, offsets, *out, 1)
        return sse

    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    run()  # compiled
    t_closed = best_time(run, repeats)
    numba.set_num_threads(threads)
    print(f"\nclosed kernel, closed epitrochoid ({u.size} points), 1 thread:")
    print(f"closed fit:              {t_closed / candidates * 1e6:9.1f} us/candidate")
    print(f"periodic_vs_open_ratio: {t_closed / candidates / open_per_candidate:.1f}")


if __name__ == "__main__":
    main()
