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
from typing import Any

from omegaconf import OmegaConf

from .interrupt import Interrupted, interrupt_on_signals, leave_ctrl_c_to_the_leader
from .preset import expand_preset
from .spec import ENCODINGS, ConfigError, RunSpec, algorithm_defaults, plain_config, run_spec
from .store import Store

__all__ = ["execute", "main", "register_hydra_plugins", "register_plugin_configs"]

CONFIG_DIR = Path(__file__).resolve().parent / "conf"


def register_hydra_plugins() -> None:
    """Make the study sweeper known to Hydra (its plugin scan misses editable installs) and
    register the configs of plugin optimizers (:func:`register_plugin_configs`)."""
    from hydra.core.plugins import Plugins

    # the plugin scan re-executes Hydra's core plugin modules: let it run before the sweeper
    # module subclasses BasicSweeper, or the subclass would refer to a stale class
    plugins = Plugins.instance()
    from hydra_plugins.metaknot_study_sweeper.study_sweeper import StudySweeper

    plugins.register(StudySweeper)
    register_plugin_configs()


def register_plugin_configs() -> None:
    """Give every registered optimizer without a YAML of its own (entry-point plugins) a
    config ``optimizer=<name>`` built from its signature, so it runs like a built-in."""
    from hydra.core.config_store import ConfigStore

    from metaknot.registry import available_optimizers

    shipped = {p.stem for p in (CONFIG_DIR / "optimizer").glob("*.yaml")}
    store = ConfigStore.instance()
    for name in available_optimizers():
        if name not in shipped:
            try:
                node = algorithm_defaults(name)
            except ConfigError:
                continue
            store.store(group="optimizer", name=name, node=node, provider="metaknot")


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
        threads = 1 if multirun else numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(min(int(threads), numba.config.NUMBA_NUM_THREADS))
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
    }
    result, error = None, None
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
        result = getattr(exc, "partial_result", None)
        error = f"{type(exc).__name__}: {exc}"
    if result is not None:
        record = {**base, **result.record()}
        trace = result.trace.columns()
        best_x = result.best_x
    else:
        record = {**base, **_failed_record(spec)}
        trace, best_x = None, None
    if error is not None:
        record["status"], record["error"] = "failed", error
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


def _failed_record(spec: RunSpec) -> dict[str, Any]:
    """The settings of a run that failed before anything was evaluated."""
    problem, encoding = spec.config["problem"], spec.config["encoding"]
    objective = dict(spec.config["objective"])
    params = {f"optimizer.{k}": v for k, v in spec.config["optimizer"].items() if k != "_name_"}
    problem_name, kind = ENCODINGS[encoding["kind"]]
    return {
        "problem": problem_name, "encoding": kind,
        "data": problem["name"], "noise": problem["noise"], "degree": problem["degree"],
        "parameterization": problem["parameterization"],
        "objective": objective.pop("name"),
        **{f"objective.{k}": v for k, v in objective.items()},
        "optimizer": spec.optimizer, **params, "seed": spec.seed, "budget": spec.budget,
        "n_evaluations": 0, "status": "failed",
    }


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
        return [execute(run_spec({**plain, "seed": seed}), multirun=multirun)
                for seed in seeds]
    spec = run_spec(cfg)
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
            print(f"run {spec.run_id}: {outcome['status']}; record in {where}")
    return outcome


def _not_stored(outcome: dict[str, Any], spec: RunSpec) -> str:
    """What happened to a run that is not stored, and what to do (one line)."""
    if outcome["status"] == "not_run":
        return f"not run: {outcome['detail']}"
    if outcome["path"] is None:
        return f"computed but lost: {outcome['detail']} (its record could not be kept either)"
    kept = Path(outcome["path"])
    return (f"computed but not stored ({outcome['error']}); its record is kept in {kept}: "
            f"move it into {spec.study_dir / kept.parent.name}/ once there is space")


def _check_single_run(overrides: list[str]) -> str | None:
    """The configuration error of a single run, in one line (``None`` if it can run). Errors
    of Hydra itself (override syntax, unknown config) are left for Hydra to report."""
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
    except ConfigError as exc:
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
        args = expand_preset(list(sys.argv[1:] if argv is None else argv))
    except ConfigError as exc:
        print(f"metaknot run: error: {exc}", file=sys.stderr)
        return 2
    if not any(a.startswith("-") for a in args):  # a single run: check it before Hydra starts
        error = _check_single_run(args)
        if error:
            print(f"metaknot run: error: {error}", file=sys.stderr)
            return 2
    try:
        with interrupt_on_signals():
            return launch(task, "config", args)
    except Interrupted as stop:
        print(stop.message(), file=sys.stderr, flush=True)
        return stop.exit_code


def launch(task_function: Any, config_name: str, args: list[str]) -> int:
    """Run ``task_function`` as a Hydra app on the configuration ``config_name`` of
    ``experiments/conf`` with ``args`` as its command line (Hydra reads ``sys.argv``)."""
    import hydra

    hydra_main = hydra.main(version_base="1.3", config_path=str(CONFIG_DIR),
                            config_name=config_name)(task_function)
    old = sys.argv
    sys.argv = [old[0] if old else "metaknot", *args]
    try:
        hydra_main()
    finally:
        sys.argv = old
    return 0


if __name__ == "__main__":
    sys.exit(main())
