"""The ``fit`` and ``demo`` commands of the ``metaknot`` command line (their arguments and what
they do); :mod:`metaknot.cli` dispatches to them. Nothing heavy is imported until a command
runs."""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import numpy as np

__all__ = ["SEED_CURVES", "add_demo", "add_fit", "default_out", "demo", "fit"]

SEED_CURVES = ("epitrochoid", "archimedean", "vivaldi")


def add_demo(sub: Any) -> None:
    """Add the ``demo`` command to the subcommands ``sub``."""
    parser = sub.add_parser("demo", help="optimizers compared on the seed paper's three curves")
    parser.add_argument("--optimizers", nargs="+", default=["dolphin", "ga", "random_search"])
    parser.add_argument("--budget", type=int, default=3000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--degree", type=int, default=3)
    parser.add_argument("--curves", nargs="+", default=list(SEED_CURVES), choices=SEED_CURVES)
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.set_defaults(func=demo)


def add_fit(sub: Any) -> None:
    """Add the ``fit`` command to the subcommands ``sub``."""
    parser = sub.add_parser(
        "fit", help="a user's points to the fewest control points within a tolerance",
        description="Fit a clamped B-spline with the fewest control points whose error stays "
                    "within the tolerance (never more than FITPACK needs), and write "
                    "knots, control points, metrics, a figure and a DXF file.")
    parser.add_argument("points", help="a .csv/.txt table (one point per row, values separated "
                                    "by semicolons, commas or spaces, decimal points only; a "
                                    "header row and # comments are skipped) or a .npy array; "
                                    "see docs/input-files.md")
    parser.add_argument("--tolerance", "--tol", type=float, required=True,
                        help="the tolerance (--tol: the same)")
    parser.add_argument("--relative", action="store_true",
                     help="--tolerance is a fraction of the bounding-box diagonal")
    parser.add_argument("--metric", choices=["max_deviation", "rmse"], default="max_deviation")
    parser.add_argument("--function", action="store_true",
                     help="the first column is x, the others f(x); x is the parameter")
    parser.add_argument("--degree", type=int, default=3,
                        help="spline degree, 1 to 5 (the points must be at least degree + 2)")
    parser.add_argument("--parameterization", choices=["centripetal", "chord", "uniform"],
                     default="centripetal")
    shape = parser.add_mutually_exclusive_group()
    shape.add_argument("--closed", dest="closed", action="store_const", const=True,
                       help="a closed outline: a periodic spline, no seam")
    shape.add_argument("--open", dest="closed", action="store_const", const=False,
                       help="an open curve: clamped at its ends")
    shape.add_argument("--auto-closed", dest="closed", action="store_const", const=None,
                       help="closed if the chord from the last point back to the first "
                            "is at most 2.5 typical point spacings (the default; the output "
                            "says which was chosen)")
    parser.add_argument("--method", default="auto",
                     help="auto: knot removal then a search at fixed counts (the default); "
                          "removal: knot removal only; fitpack: FITPACK's answer; or a "
                          "method from the literature: newknt, equidistribution, "
                          "dominant_points, lyche_morken, bisection, sparse_l1")
    parser.add_argument("--corners", action="store_true",
                        help="allow knots of multiplicity up to the degree (the curve only "
                             "continuous there): the search also starts with a multiple knot "
                             "at each corner it finds; the result says where they are")
    parser.add_argument("--no-polish", dest="polish", action="store_false",
                        help="skip the last stage (the default polishes: where knot removal "
                             "stops, the knots of the most promising removal are moved freely "
                             "by variable projection, and removal goes on if that is within "
                             "the tolerance)")
    parser.add_argument("--budget", type=int, default=5000,  # fit's FIXED_COUNT_BUDGET
                        help="evaluations of the GA at each count of the fixed-count search "
                             "(the local search gets a quarter)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the searches")
    parser.add_argument("--out", default=None,
                        help="output folder (default: the points file's whole name and -fit, "
                             "next to it: ellipse.csv-fit for ellipse.csv, so that "
                             "ellipse.txt beside it gets its own folder)")
    parser.add_argument("--force", action="store_true",
                     help="replace the files of a previous fit in the --out folder (only "
                          "those its fit.json lists)")
    parser.set_defaults(func=fit)


def demo(args: argparse.Namespace) -> int:
    """``metaknot demo``: the optimizers on the seed paper's curves, one seed, one table."""
    from metaknot.problems import Paper, get_curve
    from metaknot.runner import minimize

    header = (f"{'curve':<12} {'optimizer':<14} {'CP':>4} {'objective':>11} {'RMSE':>10} "
              f"{'ED':>10} {'max dev':>10} {'evals':>6} {'sec':>6}")
    rows = []
    for name in args.curves:
        data = get_curve(name)
        for optimizer in args.optimizers:
            result = minimize(
                "mask", optimizer, budget=args.budget, seed=args.seed,
                problem_kwargs={"points": data, "degree": args.degree, "objective": "paper"},
                progress=not args.quiet,
            )
            if result.solution is None:
                rows.append(f"{name:<12} {optimizer:<14}   no feasible candidate")
                continue
            m = result.solution.fit.metrics
            rows.append(
                f"{name:<12} {optimizer:<14} {m['n_control_points']:>4} "
                f"{result.best_f:>11.4g} {m['rmse']:>10.3e} {m['euclidean_distance']:>10.3e} "
                f"{m['max_deviation']:>10.3e} {result.n_evaluations:>6} {result.elapsed:>6.2f}"
            )
    print(f"The seed paper's setting: 0/1 knot masks, degree {args.degree}, centripetal, "
          f"objective 'paper' (control points x Euclidean distance, error floor "
          f"{Paper().error_floor:g} x diagonal); {args.budget} evaluations, seed {args.seed}")
    print(header)
    print("\n".join(rows))
    return 0


def default_out(points: str | Path) -> Path:
    """The output folder of ``metaknot fit`` without ``--out``: the points file's whole name
    with ``-fit`` added, beside it (``ellipse.csv`` to ``ellipse.csv-fit``). The suffix is
    kept so that files of one stem (``ellipse.csv``, ``ellipse.txt``, ``ellipse.npy``) in one
    folder get a folder each."""
    points = Path(points)
    return points.with_name(points.name + "-fit")


def fit(args: argparse.Namespace) -> int:
    """``metaknot fit``: read the points, check the destination, fit, write the files."""

    from metaknot.problems import header_line, load_points

    from .fit_output import check_destination

    points = load_points(args.points, degree=args.degree).points  # enough for --degree
    header = header_line(args.points)
    out = Path(args.out) if args.out else default_out(args.points)
    check_destination(out, force=args.force)
    created = not out.exists()
    try:  # made before the fit, so that a folder that cannot be made costs no fit
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out {out}: cannot make the folder ({exc.strerror or exc})") \
            from None
    try:
        return _fit_into(args, points, out, header)
    except BaseException:
        if created:  # leave no empty folder behind
            with contextlib.suppress(OSError):
                out.rmdir()
        raise


def _fit_into(args: argparse.Namespace, points: np.ndarray, out: Path,
              header: tuple[int, str] | None = None) -> int:
    """The rest of ``metaknot fit``: fit ``points``, print the stages and the result, write
    the files into the folder ``out`` (which exists). ``header``: the line number and text of
    the header row the reader skipped, which the first line names."""
    from .fit import fit as fit_points
    from .fit_output import write_fit

    if args.function and points.shape[1] < 2:
        raise ValueError(f"--function: {args.points} needs two or more columns (x, f(x)); it "
                         f"has {points.shape[1]}")
    n, dims = points.shape[0], points.shape[1] - (1 if args.function else 0)
    what = f"{dims}-D{', function of x' if args.function else ''}"
    if points.shape[1] == 1:
        what = ("one column: read as a 1-D curve of values; for y = f(x) give x as the first "
                "column and --function")
    skipped = "" if header is None else \
        f"; line {header[0]} skipped as a header: {header[1][:80]!r}"
    print(f"read {n} points ({what}) from {args.points}{skipped}", flush=True)
    result = fit_points(points, args.tolerance, relative=args.relative, metric=args.metric,
                 function=args.function, degree=args.degree,
                 parameterization=args.parameterization, closed=args.closed,
                 method=args.method, budget=args.budget, seed=args.seed,
                 corners=args.corners, polish=args.polish, progress=True,
                 on_stage=lambda line: print(line, flush=True))  # each stage as it ends
    m = result.metrics
    print(f"result: {m['n_control_points']} control points by {result.method} (FITPACK: "
          f"{result.fitpack['n_control_points']}), max deviation {m['max_deviation']:.4g}, "
          f"RMSE {m['rmse']:.4g} (tolerance {result.tolerance:.4g} on {result.metric}), "
          f"{m['seconds']:.2f} s", flush=True)
    values, counts = result.interior_knots
    if (counts > 1).any():
        print("multiple knots: " + ", ".join(
            f"{value:.6g} ({count}x)" for value, count in zip(values[counts > 1],
                                                            counts[counts > 1], strict=True)),
            flush=True)
    try:
        fitted = points[:, 1:] if args.function else \
            points if result.points is None else result.points
        written = write_fit(result, fitted, out, force=args.force)
    except OSError as exc:
        raise ValueError(f"--out {out}: cannot write the files ({exc.strerror or exc})") \
            from None
    print(f"wrote {len(written)} files to {out}")
    return 0
