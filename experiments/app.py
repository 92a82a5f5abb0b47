"""``metaknot run``: one optimisation run per Hydra job, stored in the results store.

Single run::

    metaknot run optimizer=ga problem=vivaldi seed=3

Sweep (Hydra multirun; the study sweeper validates every job first, skips the runs already
stored and the optimizer/encoding pairs that cannot work, and shows a bar over the jobs)::

    metaknot run -m optimizer=dolphin,ga problem=archimedean,vivaldi seed='range(0,30)'
    metaknot run -m experiment=seed_paper launcher=joblib
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from omegaconf import OmegaConf

from .errors import ConfigError
from .interrupt import Interrupted, interrupt_on_signals, leave_ctrl_c_to_the_leader
from .preset import expand_preset
from .run import ENCODINGS, RunSpec
from .spec import RUN, config_node, plain_config, run_spec
from .store import (
    DEFAULT_STUDY,
    Store,
    StoreError,
    check_writable,
    default_study_note,
    read_record,
    spline_fields,
)

if TYPE_CHECKING:
    from metaknot.result import RunResult

__all__ = ["execute", "main", "register_hydra_plugins", "register_signature_configs"]

CONFIG_DIR = Path(__file__).resolve().parent / "conf"


def register_hydra_plugins() -> None:
    """Make the study sweeper and the SLURM launcher known to Hydra (its plugin scan misses
    editable installs) and register every optimizer's config
    (:func:`register_signature_configs`)."""
    from hydra.core.plugins import Plugins

    plugins = Plugins.instance()  # the plugin scan first: it may import the sweeper module
    from hydra_plugins.metaknot_study_sweeper.slurm_launcher import SlurmLauncher
    from hydra_plugins.metaknot_study_sweeper.study_sweeper import StudySweeper

    plugins.register(StudySweeper)
    plugins.register(SlurmLauncher)
    register_signature_configs()


def register_signature_configs() -> None:
    """Fill the config groups ``optimizer`` and ``objective`` in Hydra's config store: every
    registered optimizer, built-in or an entry-point plugin, is ``optimizer=<name>`` and every
    objective ``objective=<name>``, with their settings and defaults read from their
    signatures (:func:`~.spec.config_node`). No YAML restates them."""
    from hydra.core.config_store import ConfigStore

    from metaknot.problems import OBJECTIVES
    from metaknot.registry import available_optimizers

    store = ConfigStore.instance()
    for name in available_optimizers():
        try:
            node = config_node("optimizer", name)
        except ConfigError:
            continue
        store.store(group="optimizer", name=name, node=node, provider="metaknot")
    for name in OBJECTIVES:
        store.store(group="objective", name=name, node=config_node("objective", name),
                    provider="metaknot")


def _in_multirun() -> bool:
    try:
        from hydra.core.hydra_config import HydraConfig
        from hydra.types import RunMode

        return HydraConfig.initialized() and HydraConfig.get().mode == RunMode.MULTIRUN
    except Exception:
        return False


def execute(spec: RunSpec, *, multirun: bool = False,
            raise_errors: bool = False) -> dict[str, Any]:
    """Run ``spec`` unless its record exists, store the record, and return a summary.

    A run that raises is stored as ``failed`` (with the best so far, if any) and, unless
    ``raise_errors``, does not stop a sweep. Returns ``{"run_id", "status", "path"}`` with
    status ``ok``, ``failed``, ``skipped`` (already stored), ``not_run`` (the study's disk has
    less than :data:`~.store.MIN_FREE_BYTES` free: not computed) or ``not_stored`` (computed,
    but the record could not be written: it is kept under :func:`unsaved_dir` if possible,
    ``path``, else ``None``); the last two add ``error`` (the system's reason, e.g. "No space
    left on device") and ``detail`` (the full message).
    """
    import numba

    from metaknot.experiments.environment import environment
    from metaknot.runner import minimize

    store = Store(spec.study_dir)
    if store.has(spec.run_id):
        return {"run_id": spec.run_id, "status": "skipped", "path": str(store.path(spec.run_id))}
    try:
        store.check_space()
    except OSError as exc:
        return {"run_id": spec.run_id, "status": "not_run", "path": None,
                "error": _reason(exc), "detail": str(exc)}
    threads = spec.threads
    if threads == "auto":
        # numba's stubs do not declare the settings numba.config sets at import
        threads = 1 if multirun else numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    numba.set_num_threads(min(int(threads), numba.config.NUMBA_NUM_THREADS))  # type: ignore[attr-defined]
    progress = spec.progress
    if progress == "auto":
        progress = not multirun and sys.stderr.isatty()
    base = {
        "run_id": spec.run_id,
        "study": spec.study,
        "label": spec.label,
        "timestamp": _dt.datetime.now(_dt.UTC).isoformat(timespec="milliseconds"),
        **environment(),
        "kernel_threads": numba.get_num_threads(),
        "config": json.dumps(spec.config, sort_keys=True, default=str),
        **spec.suite_fields(),
    }
    problem = optimizer = error = None
    try:
        incompatible = spec.compatible()
        if incompatible:
            raise ConfigError(incompatible)
        problem = spec.build_problem()
        optimizer = spec.build_optimizer()
        result = minimize(problem, optimizer, budget=spec.budget, seed=spec.optimizer_seed(),
                          progress=bool(progress),
                          checkpoints_per_decade=spec.config["checkpoints_per_decade"])
    except Exception as exc:
        if raise_errors or isinstance(exc, ConfigError):
            raise
        error = f"{type(exc).__name__}: {exc}"
        result = getattr(exc, "partial_result", None) or _nothing_evaluated(
            spec, problem, optimizer, error)
    fit = getattr(result.solution, "fit", None)
    record = {**base, **result.record(), **({} if fit is None else spline_fields(fit))}
    if error is not None:
        record["status"], record["error"] = "failed", error
    trace, best_x = result.trace.columns(), result.best_x
    try:
        path = store.write(record, best_x=best_x, trace=trace)
    except OSError as exc:  # a full disk, a folder without write permission: keep it elsewhere
        try:
            kept = str(Store(unsaved_dir(spec.study)).write(record, best_x=best_x, trace=trace))
        except OSError:
            kept = None
        return {"run_id": spec.run_id, "status": "not_stored", "path": kept,
                "error": _reason(exc), "detail": str(exc)}
    return {"run_id": spec.run_id, "status": record["status"], "path": str(path)}


def unsaved_dir(study: str) -> Path:
    """Where a record the study could not take is written instead: a study folder of the
    same name under ``<system temp dir>/metaknot-unsaved`` (move its files into the study's
    ``runs/`` and ``failed/`` once there is space)."""
    return Path(tempfile.gettempdir()) / "metaknot-unsaved" / study


def _reason(exc: OSError) -> str:
    """The system's reason for an OSError, without the file name (the same for every run)."""
    return os.strerror(exc.errno) if exc.errno else type(exc).__name__


def _nothing_evaluated(spec: RunSpec, problem: Any, optimizer: Any, error: str) -> RunResult:
    """The result of a run that failed before its first evaluation, so that its record is
    built as every run's is (:meth:`~metaknot.result.RunResult.record`): the settings of its
    problem and optimizer (where they could be built), no outcome."""
    from metaknot.callbacks import TraceRecorder
    from metaknot.result import RunResult

    seed = spec.optimizer_seed()
    return RunResult(
        problem=ENCODINGS[spec.config["encoding"]["kind"]][0] if problem is None
        else problem.name,
        optimizer=spec.optimizer if optimizer is None else optimizer.name,
        seed=spec.seed, seed_spawn_key=tuple(int(k) for k in seed.spawn_key),
        budget=spec.budget, n_evaluations=0, best_x=None, best_f=float("inf"),
        trace=TraceRecorder(spec.config["checkpoints_per_decade"]).trace(), elapsed=0.0,
        problem_info={} if problem is None else problem.describe(),
        optimizer_params={} if optimizer is None else optimizer.hyperparameters(),
        metric_names=() if problem is None else tuple(problem.metric_names),
        status="failed", error=error)


def task(cfg: Any) -> dict[str, Any] | list[dict[str, Any]]:
    """The Hydra task function: validate, run (unless stored), store.

    A list of seeds (``seed=[3,4,5]``, as the study sweeper batches runs) runs each seed as its
    own run and returns their outcomes.
    """
    multirun = _in_multirun()
    if multirun:
        leave_ctrl_c_to_the_leader()
    seeds = cfg.get("seed")
    if OmegaConf.is_list(seeds) or isinstance(seeds, list):
        plain = plain_config(cfg)
        return [execute(run_spec({**plain, "seed": seed}, check_build=False), multirun=multirun)
                for seed in seeds]
    spec = run_spec(cfg, check_build=False)  # execute builds the problem and the optimizer
    try:
        outcome = execute(spec, multirun=multirun)
    except Interrupted as stop:
        stop.stored, stop.total = int(Store(spec.study_dir).has(spec.run_id)), 1
        raise
    if not multirun:
        where = outcome["path"]
        if outcome["status"] == "skipped":
            print(f"run {spec.run_id} is already stored: {where}")
        elif outcome["status"] in ("not_run", "not_stored"):
            print(f"metaknot run: error: run {spec.run_id} {_not_stored(outcome, spec)}",
                  file=sys.stderr)
            raise SystemExit(1)
        else:
            print(describe_run(read_record(where), where))
            if spec.study == DEFAULT_STUDY:
                print(default_study_note(spec.study_dir), file=sys.stderr)
    return outcome


#: Control points a single run prints in full (more: the first and last few).
SHOWN_CONTROL_POINTS = 24


def describe_run(record: dict[str, Any], path: str | Path) -> str:
    """What a single ``metaknot run`` prints: the run's status, objective, RMSE and control
    points (the distinct ones: the first ``n_control_points`` coefficients of its spline),
    and where its record is."""
    lines = [f"run {record['run_id']}: {record['status']}, {record['n_evaluations']:,} of "
             f"{record['budget']:,} evaluations"]
    if record.get("error"):
        lines.append(f"  error: {record['error']}")
    if np.isfinite(record.get("best_f", np.nan)):
        lines.append(f"  objective ({record['objective']}) {record['best_f']:.6g}, RMSE "
                     f"{record['rmse']:.4g}, max deviation {record['max_deviation']:.4g}, "
                     f"{record['n_control_points']} control points")
    coefficients = record.get("spline.coefficients")
    if coefficients is not None:
        points = np.asarray(coefficients)[: record["n_control_points"]]
        rows = [" ".join(f"{value:>12.6g}" for value in point) for point in points]
        if len(rows) > SHOWN_CONTROL_POINTS:
            half = SHOWN_CONTROL_POINTS // 2
            rows = [*rows[:half], f"  ... {len(rows) - 2 * half} more ...", *rows[-half:]]
        lines += ["  control points:", *(f"  {row}" for row in rows)]
    lines.append(f"  record: {path}")
    return "\n".join(lines)


def _not_stored(outcome: dict[str, Any], spec: RunSpec) -> str:
    """What happened to a run that is not stored, and what to do (one line)."""
    if outcome["status"] == "not_run":
        return f"not run: {outcome['detail']}"
    if outcome["path"] is None:
        return f"computed but lost: {outcome['detail']} (its record could not be kept either)"
    kept = Path(outcome["path"])
    return (f"computed but not stored ({outcome['error']}); its record is kept in {kept}: "
            f"move it into {spec.study_dir / kept.parent.name}/ once there is space")


def not_a_setting(args: list[str], example: str) -> str | None:
    """The first of ``args`` that is neither a setting (``key=value``, ``~key``) nor an option,
    as a one-line error showing ``example``, or ``None``: a bare word (a file name, say) got
    Hydra's "missing EQUAL at '<EOF>'"."""
    for arg in args:
        if "=" not in arg and not arg.startswith(("-", "~")):
            return f"{arg!r} is not a setting: settings are key=value, e.g. {example}"
    return None


def check_choices(args: list[str]) -> str | None:
    """The first config group choice of ``args`` (Hydra overrides, swept or not) that does not
    exist, as a one-line error with the closest names, or ``None`` if every choice exists;
    an optimizer (``optimizer=NAME`` or ``optimizer._name_=NAME``) is looked up in the
    optimizer registry, which names the closest. ``null`` is refused too: Hydra composes no
    job from a group set to null. A top-level setting that does not exist (``optimiser=ga``)
    is named with the known ones, a setting under a config choice (``launcher.n_jobs=2``)
    as such; so is a setting Hydra cannot read (``seed=range(0,3``, :func:`unreadable`) and
    a problem chosen beside a suite (``problem=archimedean suite=mini``), which would give no
    job a suite instance."""
    import difflib

    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        loader = GlobalHydra.instance().config_loader()
    parser = OverridesParser.create(config_loader=loader)
    overrides = []
    for arg in (a for a in args if ("=" in a and not a.startswith("-")) or a.startswith("~")):
        try:  # not Hydra's options nor their values (--cfg job)
            overrides += parser.parse_overrides([arg])
        except HydraException as exc:
            return unreadable(arg, exc)
    groups = set(loader.list_groups(""))
    roots = groups | RUN.keys()
    chosen = {o.key_or_group: o for o in overrides}
    problem = chosen.get("problem")
    if "suite" in chosen and problem is not None and problem.input_line is not None \
            and problem.value() != "suite":
        return (f"{problem.input_line:.80}: a suite sweeps the suite's instances "
                "(problem=suite); leave problem= out with suite=")
    for override in overrides:
        top = override.key_or_group.partition(".")[0]
        if top not in roots and not (override.is_add() or override.is_force_add()
                                     or override.is_delete() or top == "hydra"):
            close = difflib.get_close_matches(top, sorted(RUN), n=1)
            hint = f"; did you mean {close[0]}?" if close else ""
            return (f"{top}: unknown setting{hint} (known: "
                    f"{', '.join(sorted(RUN))})")
        if top in groups - RUN.keys() - {"hydra"} and "." in override.key_or_group \
                and not (override.is_add() or override.is_force_add() or override.is_delete()):
            return (f"{override.key_or_group}: unknown setting; {top} is a choice of config "
                    f"({top}={', '.join(loader.get_group_options(top))}), not a group of "
                    "settings")
        group = override.key_or_group.replace(".", "/")
        parent, _, name = group.rpartition("/")
        is_group = not override.is_delete() and name in loader.list_groups(parent)
        if not is_group and override.key_or_group != "optimizer._name_":
            continue
        if not override.is_sweep_override():
            value = override.value()
            values = ["null" if value is None else str(value)]
        elif override.is_discrete_sweep():
            values = list(override.sweep_string_iterator())
        else:
            continue  # a glob: Hydra picks among the existing choices
        options = loader.get_group_options(group) if is_group else []
        for value in values:
            key = f"{override.key_or_group}={value:.80}"
            if group in ("optimizer", "optimizer/_name_") and value not in options:
                unknown = _unknown_optimizer(value)
                if unknown:
                    return f"{key}: {unknown}"
            if not is_group:
                continue
            if value == "null":
                instead = f"sweep {override.key_or_group}=default,NAME to compare NAME with " \
                    "the defaults" if "default" in options else "or choose one of " \
                    f"{', '.join(options)}"
                return (f"{key}: not a choice; leave {override.key_or_group}= out for none, "
                        f"{instead}")
            if value not in options:
                close = difflib.get_close_matches(value, options, n=3, cutoff=0.6)
                hint = f"did you mean {' or '.join(close)}? " if close else ""
                return (f"{key}: no such {name} config; {hint}(choices: "
                        f"{', '.join(options)})")
    return None


def unreadable(arg: str, exc: Exception) -> str:
    """One line for a setting Hydra cannot read (``seed=range(0,3``): the setting, the
    command-line text, and Hydra's reason without its own framing."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()
             and not line.startswith(("Error parsing override", "See https://"))]
    key, _, value = arg.partition("=")
    key = key.lstrip("+~") if value or "=" in arg else arg
    reason = lines[0] if lines else type(exc).__name__
    if value and not value.isascii() and value[:1] not in "'\"":  # Hydra's grammar is ASCII
        return (f"{key}: cannot read {arg[:80]!r}: a value with characters beyond ASCII is "
                f"read only in quotes: {key}='{value}'")
    return f"{key}: cannot read {arg[:80]!r}: {reason}"


#: Sections of a run whose settings :func:`~.spec.run_spec` checks, key by key.
RUN_SECTIONS = ("problem", "encoding", "objective", "optimizer")


def open_run_settings(args: list[str]) -> list[str]:
    """``args`` with every plain setting of a run section (``optimizer.population=30``) given
    as ``++optimizer.population=30``: Hydra then adds a key the section lacks instead of
    answering "Could not override", and :func:`~.spec.run_spec` refuses it by name, with the
    known keys. A setting of a key the section has is the same either way."""
    out = []
    for arg in args:
        key = arg.partition("=")[0]
        if "=" in arg and not arg.startswith(("-", "+", "~")) and "@" not in key \
                and key.partition(".")[0] in RUN_SECTIONS and "." in key:
            arg = f"++{arg}"
        out.append(arg)
    return out


def _unknown_optimizer(name: str) -> str | None:
    """The registry's answer (one line, with the closest names) if it has no optimizer
    ``name``, else ``None``."""
    from metaknot.registry import _lookup

    try:
        _lookup("optimizer", name)
    except ValueError as exc:
        return str(exc)
    return None


def _check_single_run(overrides: list[str]) -> str | None:
    """The configuration error of a single run, in one line (``None`` if it can run). Errors
    of Hydra itself (override syntax) are left for Hydra to report, unknown choices for
    :func:`check_choices`."""
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException

    try:
        with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
            cfg = compose("config", overrides=overrides)
    except HydraException:
        return None
    try:
        spec = run_spec(cfg)
        reason = spec.compatible()
        if reason:
            raise ConfigError(reason)
        Store(spec.study_dir).check_format()  # a study to migrate takes no new record
        check_writable(spec.study_dir)  # Hydra's run folder and the record go there
    except (ConfigError, StoreError) as exc:
        return str(exc)
    return None


def main(argv: list[str] | None = None) -> int:
    """Hand ``argv`` (Hydra overrides, ``-m`` for a sweep, ``--preset FILE`` for a method
    preset read as data: :mod:`.preset`) to Hydra.

    On SIGINT or SIGTERM the workers are stopped, one line says how many of the planned runs
    are stored, and the exit status is 130 or 143 (see :mod:`.interrupt`).
    """

    from metaknot.experiments.environment import git_commit

    register_hydra_plugins()
    git_commit()  # once here; run workers inherit it through the environment
    try:
        args = open_run_settings(expand_preset(list(sys.argv[1:] if argv is None else argv)))
    except ConfigError as exc:
        print(f"metaknot run: error: {exc}", file=sys.stderr)
        return 2
    single = not any(a.startswith("-") for a in args)
    error = not_a_setting(args, "optimizer=ga problem=vivaldi seed=3 (a preset file goes "
                                "after --preset)") if single else None
    error = error or check_choices(args)
    if error is None and single:  # a single run
        error = _check_single_run(args)  # checked before Hydra starts
    if error:
        print(f"metaknot run: error: {error}", file=sys.stderr)
        return 2
    try:
        with interrupt_on_signals():
            return launch(task, "config", args)
    except Interrupted as stop:
        print(stop.message(), file=sys.stderr, flush=True)
        return stop.exit_code


def _command_line_errors() -> tuple[type[Exception], ...]:
    """Hydra's errors about a configuration (composition, override syntax, a missing choice)
    and metaknot's (:class:`~.errors.ConfigError`): a bad command line."""
    from hydra.errors import ConfigCompositionException, OverrideParseException

    return ConfigError, ConfigCompositionException, OverrideParseException


def launch(task_function: Any, config_name: str, args: list[str]) -> int:
    """Run ``task_function`` as a Hydra app on the configuration ``config_name`` of
    ``experiments/conf`` with ``args`` as its command line (Hydra reads ``sys.argv``).

    A configuration that cannot work, found by Hydra or by the study sweeper before any run
    starts, is one line on stderr naming the setting (``metaknot run: error: ...``, without
    Hydra's hint about ``HYDRA_FULL_ERROR``) and exit status 2. Any other error propagates
    with its traceback; with ``HYDRA_FULL_ERROR=1`` set, so do configuration errors.
    """
    import hydra

    hydra_main = hydra.main(version_base="1.3", config_path=str(CONFIG_DIR),
                            config_name=config_name)(task_function)
    command = "metaknot run" if config_name == "config" else "metaknot tune"
    full_errors = os.environ.get("HYDRA_FULL_ERROR")
    old = sys.argv
    sys.argv = [old[0] if old else "metaknot", *args]
    os.environ["HYDRA_FULL_ERROR"] = "1"  # Hydra raises, so the error can be told here
    try:
        hydra_main()
    except _command_line_errors() as exc:
        if full_errors == "1":
            raise
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        print(f"{command}: error: {' '.join(lines[:2]) or type(exc).__name__}",
              file=sys.stderr)
        return 2
    finally:
        sys.argv = old
        if full_errors is None:
            del os.environ["HYDRA_FULL_ERROR"]
        else:
            os.environ["HYDRA_FULL_ERROR"] = full_errors
    return 0


if __name__ == "__main__":
    sys.exit(main())
