"""Command line: ``metaknot run`` (Hydra runs and sweeps into the results store), ``metaknot
tune`` (hyperparameter studies with Optuna), ``metaknot fit`` (a user's points within a
tolerance), ``metaknot report`` (statistical comparison of a stored study), ``metaknot
export`` (a study's traces for IOHanalyzer), ``metaknot migrate`` (a stored study carried over
to the current record format), ``metaknot demo`` (optimizers on the seed curves), ``metaknot
suite`` (the benchmark suite), ``metaknot list``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from .apps import commands, suite_command
from .registry import available_optimizers, available_problems


def _list(args: argparse.Namespace) -> int:
    # the registered problems are the encodings a study chooses (encoding=mask, ...); the data
    # curve is the config group problem
    print("encodings: ", ", ".join(available_problems()))
    print("optimizers:", ", ".join(available_optimizers()))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="metaknot", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    commands.add_demo(sub)
    lst = sub.add_parser("list", help="the encodings (registered problems) and optimizers")
    lst.set_defaults(func=_list)
    commands.add_fit(sub)
    suite_command.add_suite(sub)
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
    export = sub.add_parser("export", help="a stored study's traces in another tool's format",
                            description="Writes the study's traces for IOHanalyzer and "
                                        "IOHinspector (--format iohprofiler: the files ioh's "
                                        "Analyzer logger writes). Never modifies the study.")
    export.add_argument("study", help="the study folder, RESULTS_DIR/STUDY")
    export.add_argument("--format", required=True, choices=["iohprofiler"],
                        help="the output format")
    export.add_argument("--out", default=None,
                        help="output folder (default: RESULTS_DIR/STUDY-FORMAT)")
    export.add_argument("--force", action="store_true",
                        help="write into a folder that is not empty")
    export.set_defaults(func=_export)
    migrate = sub.add_parser("migrate", help="carry a stored study over to the current record "
                                             "format (new run ids), in place",
                             description="Rewrites the records of a study stored in an earlier "
                                         "format under the current names and run ids, in "
                                         "place: every new record is written completely "
                                         "before a former one is removed, and a study already "
                                         "current is left as it is. No run may write into the "
                                         "study meanwhile.")
    migrate.add_argument("study", nargs="+", help="the study folder(s), RESULTS_DIR/STUDY")
    migrate.set_defaults(func=_migrate)
    sub.add_parser("run", add_help=False,
                   help="runs and sweeps from Hydra overrides into the results store "
                        "(metaknot run --help lists the config groups)")
    sub.add_parser("tune", add_help=False,
                   help="hyperparameter study with Optuna: tune=dolphin n_trials=100 "
                        "(metaknot tune --help lists the settings)")
    return parser


def _report(args: argparse.Namespace) -> int:
    from metaknot.experiments.report import build

    build(args.study, args.out, alpha=args.alpha, metrics=args.metric,
          figures=not args.no_figures)
    return 0


def _export(args: argparse.Namespace) -> int:
    from pathlib import Path

    from metaknot.experiments.export import export_iohprofiler

    study = Path(args.study)
    out = Path(args.out) if args.out else study.with_name(f"{study.name}-{args.format}")
    written = export_iohprofiler(study, out, force=args.force)
    print(f"metaknot export: {len(written)} files in {out}")
    return 0


def _migrate(args: argparse.Namespace) -> int:
    from metaknot.experiments.migrate import migrate_study

    for study in args.study:
        done = migrate_study(study)
        moved = len(done.run_ids)
        print(f"metaknot migrate: {done.study_dir}: {moved} record(s) carried over to new run "
              f"ids, {done.current} already current", file=sys.stderr)
        for name in done.tuning:
            print(f"metaknot migrate: {done.study_dir}: tuning study {name!r} carried over",
                  file=sys.stderr)
        for path in done.set_aside:
            print(f"metaknot migrate: {path}: a run the study holds a newer record of; its "
                  "carried-over record is kept here", file=sys.stderr)
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
    except KeyboardInterrupt:  # Ctrl-C: one line, the exit code of a shell's SIGINT
        print(f"metaknot {argv[0] if argv else ''}: interrupted".replace("  ", " "),
              file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
