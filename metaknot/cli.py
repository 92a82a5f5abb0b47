"""Command line: ``metaknot run`` (Hydra runs and sweeps into the results store), ``metaknot
tune`` (hyperparameter studies with Optuna), ``metaknot fit`` (a user's points within a
tolerance), ``metaknot report`` (statistical comparison of a
stored study), ``metaknot demo`` (optimizers on the seed
curves), ``metaknot list``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from .registry import available_optimizers, available_problems
from .runner import minimize

SEED_CURVES = ("epitrochoid", "archimedean", "vivaldi")


def _demo(args: argparse.Namespace) -> int:
    from metaknot.problems import Paper, get_curve

    header = (f"{'curve':<12} {'optimizer':<14} {'CP':>4} {'objective':>11} {'RMSE':>10} "
              f"{'ED':>10} {'max dev':>10} {'evals':>6} {'sec':>6}")
    rows = []
    for name in args.curves:
        data = get_curve(name)
        for optimizer in args.optimizers:
            result = minimize(
                "knot_selection", optimizer, budget=args.budget, seed=args.seed,
                problem_kwargs={"points": data, "degree": args.degree, "objective": "paper"},
                progress=not args.quiet,
            )
            if result.solution is None:
                rows.append(f"{name:<12} {optimizer:<14}   no feasible candidate")
                continue
            m = result.solution.fit.metrics()
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


def _list(args: argparse.Namespace) -> int:
    print("problems:  ", ", ".join(available_problems()))
    print("optimizers:", ", ".join(available_optimizers()))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="metaknot", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="optimizers compared on the seed paper's three curves")
    demo.add_argument("--optimizers", nargs="+", default=["dolphin", "ga", "random_search"])
    demo.add_argument("--budget", type=int, default=3000)
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument("--degree", type=int, default=3)
    demo.add_argument("--curves", nargs="+", default=list(SEED_CURVES), choices=SEED_CURVES)
    demo.add_argument("--quiet", action="store_true", help="no progress bars")
    demo.set_defaults(func=_demo)
    lst = sub.add_parser("list", help="registered problems and optimizers")
    lst.set_defaults(func=_list)
    fit = sub.add_parser(
        "fit", help="a user's points to the fewest control points within a tolerance",
        description="Fit a clamped B-spline with the fewest control points whose error stays "
                    "within the tolerance (never more than FITPACK's splprep needs), and write "
                    "knots, control points, metrics, a figure and a DXF file.")
    fit.add_argument("points", help="a .csv/.txt table (one point per row, values separated "
                                    "by commas or spaces; a header row and # comments are "
                                    "skipped) or a .npy array; see docs/input-files.md")
    fit.add_argument("--tol", type=float, required=True, help="the tolerance")
    fit.add_argument("--relative", action="store_true",
                     help="--tol is a fraction of the bounding-box diagonal")
    fit.add_argument("--metric", choices=["max_deviation", "rmse"], default="max_deviation")
    fit.add_argument("--function", action="store_true",
                     help="the first column is x, the others f(x); x is the parameter")
    fit.add_argument("--degree", type=int, default=3)
    fit.add_argument("--parameterization", choices=["centripetal", "chord", "uniform"],
                     default="centripetal")
    shape = fit.add_mutually_exclusive_group()
    shape.add_argument("--closed", dest="closed", action="store_const", const=True,
                       help="a closed outline: a periodic spline, no seam")
    shape.add_argument("--open", dest="closed", action="store_const", const=False,
                       help="an open curve: clamped at its ends")
    shape.add_argument("--auto-closed", dest="closed", action="store_const", const=None,
                       help="closed if the first and last points coincide within the "
                            "tolerance (the default)")
    fit.add_argument("--method", choices=["auto", "removal", "fitpack"], default="auto",
                     help="auto: knot removal then a search at fixed counts (the default); "
                          "removal: knot removal only; fitpack: FITPACK's answer")
    fit.add_argument("--budget", type=int, default=20000,
                     help="evaluations of the GA at each count of the fixed-count search")
    fit.add_argument("--seed", type=int, default=0, help="seed of the searches")
    fit.add_argument("--out", default=None, help="output folder (default: <points>-fit)")
    fit.add_argument("--force", action="store_true",
                     help="replace the files of a previous fit in the --out folder (only "
                          "those its fit.json lists)")
    fit.set_defaults(func=_fit)
    report = sub.add_parser("report", help="statistical comparison report of a stored study",
                            description="Tables, tests and figures of a study in the results "
                                        "store, as report.html (self-contained), report.md, "
                                        "CSV, LaTeX, PNG and SVG. Works on partial studies; "
                                        "never modifies the study.")
    report.add_argument("study", help="the study folder, RESULTS_DIR/STUDY")
    report.add_argument("--out", default=None,
                        help="output folder (default: RESULTS_DIR/STUDY-report)")
    report.add_argument("--alpha", type=float, default=0.05, help="significance level")
    report.add_argument("--metric", nargs="+", default=["best_f", "rmse"],
                        help="outcomes to test: best_f (the objective), rmse, "
                             "euclidean_distance, max_deviation, n_control_points")
    report.add_argument("--no-figures", action="store_true", help="tables only (faster)")
    report.set_defaults(func=_report)
    sub.add_parser("run", add_help=False,
                   help="runs and sweeps from Hydra overrides into the results store "
                        "(metaknot run --help lists the config groups)")
    sub.add_parser("tune", add_help=False,
                   help="hyperparameter study with Optuna: tune=dolphin n_trials=100 "
                        "(metaknot tune --help lists the settings)")
    return parser


def _fit(args: argparse.Namespace) -> int:
    from pathlib import Path

    from metaknot.problems import load_points

    from .fit_output import check_destination, write_fit
    from .tolerance_fit import fit

    out = Path(args.out) if args.out else Path(args.points).with_name(
        Path(args.points).stem + "-fit")
    check_destination(out, force=args.force)
    points = load_points(args.points).points
    if args.function and points.shape[1] < 2:
        raise ValueError(f"--function: {args.points} needs two or more columns (x, f(x)); it "
                         f"has {points.shape[1]}")
    n, dims = points.shape[0], points.shape[1] - (1 if args.function else 0)
    print(f"read {n} points ({dims}-D{', function of x' if args.function else ''}) from "
          f"{args.points}", flush=True)
    result = fit(points, args.tol, relative=args.relative, metric=args.metric,
                 function=args.function, degree=args.degree,
                 parameterization=args.parameterization, closed=args.closed,
                 method=args.method, budget=args.budget, seed=args.seed, progress=True)
    for stage in result.stages:
        print(stage, flush=True)
    written = write_fit(result, result.points if not args.function else points[:, 1:], out,
                        force=args.force)
    m = result.metrics
    print(f"result: {m['n_control_points']} control points by {result.method} (FITPACK: "
          f"{result.fitpack['n_control_points']}), max deviation {m['max_deviation']:.4g}, "
          f"RMSE {m['rmse']:.4g} (tolerance {result.tolerance:.4g} on {result.metric}), "
          f"{m['seconds']:.2f} s")
    print(f"wrote {len(written)} files to {out}")
    return 0


def _report(args: argparse.Namespace) -> int:
    from metaknot.experiments.report import build

    build(args.study, args.out, alpha=args.alpha, metrics=args.metric,
          figures=not args.no_figures)
    return 0


def _run(rest: list[str]) -> int:
    from metaknot.experiments.app import main as run_main

    return run_main(rest)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``metaknot`` command."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "run":
        return _run(argv[1:])
    if argv and argv[0] == "tune":
        from metaknot.experiments.tuning.app import main as tune_main

        return tune_main(argv[1:])
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileExistsError) as exc:
        print(f"metaknot: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
