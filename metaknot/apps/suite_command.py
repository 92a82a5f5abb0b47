"""``metaknot suite``: the benchmark suite's instances, tasks and best-known values."""

from __future__ import annotations

import argparse
from typing import Any, cast

__all__ = ["add_suite"]


def add_suite(sub: Any) -> None:
    """Add the ``suite`` command (``list``, ``tasks``, ``best``) to the subcommands ``sub``."""
    parser = sub.add_parser("suite", help="the benchmark suite: instances, tasks, best-known "
                                          "values",
                            description="The knot-placement benchmark suite (metaknot.suite, "
                                        "docs/guide/suite.md).")
    actions = parser.add_subparsers(dest="action", required=True)
    listing = actions.add_parser("list", help="the instances: id, family, kind, points, "
                                              "dimension, definition")
    listing.add_argument("--family", default=None, help="only this family")
    listing.add_argument("--no-noise", action="store_true", help="base instances only")
    listing.set_defaults(func=_list)
    show = actions.add_parser("tasks", help="the tasks of an instance and their best-known "
                                            "values")
    show.add_argument("instance")
    show.set_defaults(func=_tasks)
    best = actions.add_parser(
        "best", help="search the tasks again (or read a study's runs) and store every value "
                     "that improves",
        description="Run the portfolio of metaknot.suite.best (exhaustive search where the "
                    "space is small) on every task with a best-known value and store what "
                    "improves; with --from-study, take each task's best run of the studies "
                    "instead (its candidate evaluated again). A stored value is never "
                    "replaced by a worse one.")
    best.add_argument("--budget", type=int, default=None,
                      help=f"evaluations per method run (default {SEARCH_BUDGET})")
    best.add_argument("--seeds", type=int, default=None,
                      help="seeds per method (0, 1, ...; default 1)")
    best.add_argument("--kind", nargs="+", default=None,
                      choices=("fixed_k", "tolerance", "seed", "front"),
                      help="only tasks of these kinds")
    best.add_argument("--family", default=None, help="only this family")
    best.add_argument("--instance", nargs="+", default=None, help="only these instances")
    best.add_argument("--file", default=None,
                      help="the best-known file (default: the one the package ships)")
    best.add_argument("--from-study", nargs="+", default=None, metavar="STUDY_DIR",
                      help="search nothing: store each suite task's best run of these studies "
                           "(results/<study>) where it improves the stored value")
    best.set_defaults(func=_best)


#: Evaluations per method run of ``metaknot suite best`` (without ``--from-study``).
SEARCH_BUDGET = 2000


def _list(args: argparse.Namespace) -> int:
    from metaknot.suite import instances

    found = instances(family=args.family, noise=not args.no_noise)
    for instance in found:
        data = instance.point_set()
        print(f"{instance.id:32} {instance.family:18} {instance.kind:8} {data.n_points:5} "
              f"{data.dim}-D  {instance.definition[:60]}")
    families = {i.family for i in found}
    print(f"{len(found)} instances in {len(families)} families")
    return 0


def _tasks(args: argparse.Namespace) -> int:
    from metaknot.suite import get_instance
    from metaknot.suite.best import load_best_known
    from metaknot.suite.tasks import tasks

    entries = load_best_known()
    for task in tasks(get_instance(args.instance)):
        entry = entries.get((task.instance, task.id))
        best = "no best-known value" if entry is None else (
            f"best {entry.value:.6g} ({entry.method}{', proven' if entry.proven else ''}; "
            f"{entry.metrics.get('n_control_points', float('nan')):.0f} control points)")
        settings = ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                             for k, v in {**task.encoding, **task.objective}.items())
        print(f"{task.id:24} {settings}\n{'':24} {best}")
    return 0


def _best(args: argparse.Namespace) -> int:
    from metaknot.suite import instances
    from metaknot.suite.best import BEST_KNOWN_FILE, KINDS_WITH_BEST, improve

    if args.from_study:
        return _absorb(args)
    budget = SEARCH_BUDGET if args.budget is None else args.budget
    seeds = 1 if args.seeds is None else args.seeds
    if budget < 1 or seeds < 1:
        raise ValueError("--budget and --seeds must be at least 1")
    ids = args.instance or [i.id for i in instances(family=args.family)]
    counts = improve(ids, budget=budget, seeds=range(seeds),
                     path=args.file or BEST_KNOWN_FILE, kinds=args.kind or KINDS_WITH_BEST)
    print(f"{counts['searched']} tasks searched: {counts['improved']} improved, "
          f"{counts['new']} new, {counts['kept']} kept")
    return 0


def _absorb(args: argparse.Namespace) -> int:
    from metaknot.experiments import load_study
    from metaknot.suite.best import BEST_KNOWN_FILE, absorb

    chosen = [f"--{name}" for name in ("kind", "family", "instance", "budget", "seeds")
              if getattr(args, name) is not None]
    if chosen:
        raise ValueError(f"--from-study stores the studies' runs of every task, searching "
                         f"nothing; {', '.join(chosen)} only set what a search covers")
    rows: list[dict[str, Any]] = []
    for folder in args.from_study:
        runs = load_study(folder).runs
        if "suite.instance" not in runs:
            raise ValueError(f"{folder}: no run of this study is on a suite task")
        rows += cast(list[dict[str, Any]], runs.to_dict("records"))  # pandas-stubs: Hashable keys
    counts = absorb(rows, path=args.file or BEST_KNOWN_FILE)
    print(f"{counts['tasks']} tasks with runs: {counts['improved']} improved, {counts['new']} "
          f"new, {counts['kept']} kept, {counts['refused']} refused")
    return 1 if counts["refused"] else 0
