"""Evaluations whose results must not depend on what the kernels' workspaces held.

Run as a script by ``tests/test_filled_workspaces.py``, once with the package as it is and once
with a copy whose every ``np.empty`` is filled (NaN, or a large negative integer): it writes
every result of a fixed set of evaluations to an ``.npz`` file. Both files must hold the same
bits; a result that reads memory its kernel never wrote differs between them (or crashes one).

The cases: batch fits of masks, indices and positions; move evaluators (fresh, rebound, by
knots and by replacements) on incumbents from the fewest interior knots to a few more than
``2p``; ``metaknot.fit`` on outlines of five to twelve points; and short optimizer runs. Open
and closed curves, degrees 1 to 5, with and without the maximum deviation.
"""

from __future__ import annotations

import sys
from collections.abc import Callable

import numba
import numpy as np

import metaknot as mk
from metaknot.bspline.curve import Curve, make_curve

Results = dict[str, np.ndarray]


def data(n_points: int, dim: int, seed: int) -> np.ndarray:
    """A smooth curve with a little noise (an outline when read as closed)."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 2 * np.pi, n_points, endpoint=False)
    columns = [np.cos((k + 1) * s + k) + 0.2 * np.sin(3 * s) for k in range(dim)]
    return np.column_stack(columns) + 1e-3 * rng.standard_normal((n_points, dim))


def record(out: Results, name: str, make: Callable[..., object], *args: object,
           **kwargs: object) -> None:
    """Store what ``make(*args, **kwargs)`` returns under ``name``; an error is stored as its
    message."""
    try:
        value = make(*args, **kwargs)
    except (ValueError, RuntimeError) as error:
        out[name + ":error"] = np.array(f"{type(error).__name__}: {error}")
        return
    if isinstance(value, tuple):
        fit, path = value
        out[name + ":path"] = np.asarray(path)
        value = fit
    if hasattr(value, "sse"):  # a BatchFit
        out[name + ":sse"] = value.sse
        out[name + ":n_ctrl"] = value.n_control_points
        out[name + ":reason"] = value.reason
        if value.max_deviation is not None:
            out[name + ":max_dev"] = value.max_deviation
    else:
        out[name] = np.asarray(value)


def candidate_moves(curve: Curve, interior: np.ndarray, rng: np.random.Generator
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The incumbent itself, every one-knot insertion, removal and shift to a neighbouring
    data parameter, and a few random knot sets: flat sorted knots and offsets."""
    params = curve.candidate_params
    rows = [interior]
    free = params[~np.isin(params, interior)]
    rows += [np.sort(np.append(interior, t)) for t in free]
    rows += [np.delete(interior, i) for i in range(interior.size)]
    for i, t in enumerate(interior):
        at = int(np.searchsorted(params, t))
        for j in (at - 1, at + 1):
            if 0 <= j < params.size and params[j] not in interior:
                rows.append(np.sort(np.where(np.arange(interior.size) == i, params[j],
                                             interior)))
    for _ in range(4):
        rows.append(np.sort(rng.choice(params, size=min(params.size, interior.size + 1),
                                       replace=False)))
    offsets = np.concatenate(([0], np.cumsum([r.size for r in rows]))).astype(np.int64)
    return np.concatenate(rows).astype(np.float64), offsets


def curve_cases(out: Results) -> None:
    """Batch fits and move evaluators on small and moderate curves."""
    for closed in (False, True):
        for degree in range(1, 6):
            for n_points in sorted({degree + 2, degree + 4, 2 * degree + 3, 40}):
                for dim in (2, 3) if n_points == 40 else (2,):
                    name = f"{'closed' if closed else 'open'}-p{degree}-n{n_points}-d{dim}"
                    try:
                        curve = make_curve(data(n_points, dim, n_points), degree=degree,
                                           closed=closed)
                    except ValueError as error:
                        out[name + ":error"] = np.array(str(error))
                        continue
                    batches(out, name, curve, np.random.default_rng(n_points + degree))
                    moves(out, name, curve, np.random.default_rng(n_points * degree))


def batches(out: Results, name: str, curve: Curve, rng: np.random.Generator) -> None:
    n_var = curve.candidate_params.size
    masks = np.vstack([rng.random((3, n_var)) < density for density in (0.0, 0.2, 0.6, 1.0)])
    count = min(n_var, max(1, curve.degree))
    indices = np.vstack([np.sort(rng.choice(np.arange(1, curve.max_index + 1), count,
                                            replace=False)) for _ in range(6)])
    low, high = curve.knot_bounds
    positions = low + (high - low) * rng.random((6, n_var + 2))
    positions[rng.random(positions.shape) < 0.5] = np.nan
    for max_dev in (True, False):
        tag = f"{name}-maxdev{int(max_dev)}"
        record(out, tag + "-masks", curve.evaluate_masks, masks, max_deviation=max_dev)
        record(out, tag + "-indices", curve.evaluate_indices, indices, max_deviation=max_dev)
        record(out, tag + "-positions", curve.evaluate_positions, positions,
               max_deviation=max_dev, nan_is_absent=True)


def moves(out: Results, name: str, curve: Curve, rng: np.random.Generator) -> None:
    params = curve.candidate_params
    smallest = curve.min_interior_knots
    for k in range(smallest, min(params.size, 2 * curve.degree + 3) + 1):
        interior = np.sort(rng.choice(params, size=k, replace=False)) if k else np.empty(0)
        try:
            evaluator = curve.move_evaluator(interior)
        except ValueError as error:
            out[f"{name}-k{k}:error"] = np.array(str(error))
            continue
        if evaluator is None:
            out[f"{name}-k{k}:unbound"] = np.array(True)
            continue
        knots, offsets = candidate_moves(curve, interior, rng)
        for max_dev in (True, False):
            tag = f"{name}-k{k}-maxdev{int(max_dev)}"
            record(out, tag + "-moves", evaluator.evaluate, knots, offsets,
                   max_deviation=max_dev)
            if interior.size:  # remove each knot by a replacement
                starts = np.arange(interior.size)
                record(out, tag + "-replace", evaluator.evaluate_replacements, starts,
                       starts + 1, np.empty(0), np.zeros(starts.size + 1, np.int64),
                       max_deviation=max_dev)
        if k > smallest:  # rebound to one knot fewer
            record(out, f"{name}-k{k}-rebound", rebound, evaluator, interior[1:], knots,
                   offsets)


def rebound(evaluator, interior: np.ndarray, knots: np.ndarray, offsets: np.ndarray):
    """The moves scored by ``evaluator`` once rebound to ``interior``."""
    evaluator.rebind(interior)
    return evaluator.evaluate(knots, offsets, max_deviation=True)


def fit_cases(out: Results) -> None:
    """``metaknot.fit`` on few-point outlines, open and closed, three tolerances."""
    for n in range(5, 13):
        angle = np.linspace(0, 2 * np.pi, n, endpoint=False)
        points = np.column_stack((np.cos(angle), np.sin(angle) * (1 + 0.1 * np.cos(2 * angle))))
        for closed in (False, True):
            for tolerance in (1e-3, 5e-2, 1e-1):
                name = f"fit-n{n}-closed{int(closed)}-tol{tolerance:g}"
                try:
                    result = mk.fit(points, tolerance, relative=True, closed=closed)
                except ValueError as error:
                    out[name + ":error"] = np.array(str(error))
                    continue
                out[name + ":knots"] = result.spline.t
                out[name + ":coefficients"] = result.spline.c
                out[name + ":n_ctrl"] = np.array(result.n_control_points)


RUNS = {
    "mask": ["ga", "dolphin", "one_plus_one", "local_search", "random_search"],
    "indices": ["one_plus_one", "local_search", "ga"],
    "free": ["nlopt", "random_search"],
}


def run_cases(out: Results) -> None:
    """Short runs of optimizers that use the move evaluators and the compiled draws."""
    for closed in (False, True):
        for problem, optimizers in RUNS.items():
            for optimizer in optimizers:
                kwargs: dict[str, object] = {"points": "archimedean", "closed": closed}
                if problem != "mask":
                    kwargs["n_knots"] = 12
                result = mk.minimize(problem, optimizer, budget=300, seed=3,
                                     problem_kwargs=kwargs)
                name = f"run-{problem}-{optimizer}-closed{int(closed)}"
                out[name + ":best_x"] = np.asarray(result.best_x, dtype=np.float64)
                out[name + ":trace_best"] = np.asarray(result.trace_best)
                out[name + ":delta"] = np.array(result.delta_evaluations)


def main(path: str) -> None:
    from metaknot.bspline import moves as moves_module

    numba.set_num_threads(1)
    out: Results = {"module": np.array(moves_module.__file__)}
    curve_cases(out)
    fit_cases(out)
    run_cases(out)
    np.savez(path, **out)


if __name__ == "__main__":
    main(sys.argv[1])
