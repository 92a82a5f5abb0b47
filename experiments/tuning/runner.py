"""Running a tuning study: storage, trials on the training instances, parallel workers."""

from __future__ import annotations

import json
import multiprocessing
import sys
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from ..spec import ConfigError, run_spec
from .spec import Instance, TuneSpec

__all__ = ["evaluate_setting", "open_storage", "open_study", "references", "run_workers",
           "trial_objective"]

#: Trial states that count towards ``n_trials``.
FINISHED = ("COMPLETE", "PRUNED")


def storage_description(spec: TuneSpec) -> str:
    """Where the study lives: the SQLite file, the journal file or the URL."""
    if spec.storage is None:
        name = "optuna.journal" if spec.workers > 1 else "optuna.db"
        return str(spec.study_dir / name)
    return spec.storage


def open_storage(spec: TuneSpec) -> Any:
    """The Optuna storage of ``spec``.

    ``storage: null`` is an SQLite file in the study directory for one worker and a journal
    file for several; ``journal`` / ``journal:<file>`` a journal file; anything else an
    Optuna RDB URL (``sqlite:///...``, ``postgresql+psycopg://...``). RDB storages get a
    heartbeat: a trial whose worker died is marked FAIL after ``grace_period`` seconds and
    retried (``max_retry``) with the same parameters.

    Raises
    ------
    ConfigError
        If the storage cannot be opened (one line, before any trial starts).
    """
    import optuna
    from optuna.storages import JournalStorage, RDBStorage, RetryHeartbeatStaleTrialCallback
    from optuna.storages.journal import JournalFileBackend

    spec.study_dir.mkdir(parents=True, exist_ok=True)
    url = spec.storage
    if url is None and spec.workers > 1:
        url = "journal"
    if url is None:
        url = f"sqlite:///{spec.study_dir / 'optuna.db'}"
    if url == "journal" or url.startswith("journal:"):
        path = url.partition(":")[2] or str(spec.study_dir / "optuna.journal")
        try:
            return JournalStorage(JournalFileBackend(path))
        except OSError as exc:
            raise ConfigError(f"storage: cannot open the journal file {path}: {exc}") from None
    if url.startswith("sqlite") and spec.workers > 1:
        raise ConfigError("storage: SQLite is not safe for several workers; use journal (one "
                          "machine) or PostgreSQL (several machines)")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
    try:
        return RDBStorage(
            url, heartbeat_interval=spec.heartbeat_interval, grace_period=spec.grace_period,
            heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(
                max_retry=spec.max_retry),
            engine_kwargs={"pool_pre_ping": True},
        )
    except Exception as exc:  # SQLAlchemy's errors for bad URLs, drivers and servers
        reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ConfigError(f"storage: cannot open {url}: {reason}") from None


def _sampler(spec: TuneSpec, worker_index: int) -> Any:
    import optuna

    seed = spec.seed + worker_index
    if spec.sampler == "random":
        return optuna.samplers.RandomSampler(seed=seed)
    return optuna.samplers.TPESampler(seed=seed)


def _pruner(spec: TuneSpec) -> Any:
    import optuna

    steps = len(spec.train)
    return {
        "none": lambda: optuna.pruners.NopPruner(),
        "median": lambda: optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=1),
        "percentile": lambda: optuna.pruners.PercentilePruner(25.0, n_startup_trials=5,
                                                              n_warmup_steps=1),
        "successive_halving": lambda: optuna.pruners.SuccessiveHalvingPruner(
            min_resource=1, reduction_factor=2),
        "hyperband": lambda: optuna.pruners.HyperbandPruner(
            min_resource=1, max_resource=steps, reduction_factor=2),
    }[spec.pruner]()


def open_study(spec: TuneSpec, storage: Any, worker_index: int = 0) -> Any:
    """Create the Optuna study, or load it to resume. A stored study made with other
    settings (search space, instances, budget, ...) is refused, never overwritten."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(study_name=spec.study, storage=storage,
                                sampler=_sampler(spec, worker_index), pruner=_pruner(spec),
                                direction="minimize", load_if_exists=True)
    identity = json.dumps(spec.identity(), sort_keys=True, default=str)
    stored = study.user_attrs.get("metaknot_identity")
    if stored is None:
        study.set_user_attr("metaknot_identity", identity)
    elif stored != identity:
        old, new = json.loads(stored), json.loads(identity)
        differ = sorted(k for k in new if old.get(k) != new.get(k))
        raise ConfigError(f"study {spec.study!r} already exists in {storage_description(spec)} "
                          f"with other settings ({', '.join(differ)}); it is left as it is: "
                          "choose another study name")
    return study


def evaluate_setting(spec: TuneSpec, instance: Instance, seeds: tuple[int, ...], *,
                     algorithm: str | None = None, params: dict[str, Any] | None = None,
                     encoding: dict[str, Any] | None = None) -> list[float]:
    """``best_f`` of one setting on ``instance`` for each replicate seed (in-process runs)."""
    from metaknot.runner import minimize

    values = []
    for seed in seeds:
        run = run_spec(spec.run_config(instance, seed, algorithm=algorithm, params=params,
                                       encoding=encoding), check_build=False)
        reason = run.compatible()
        if reason:
            raise ValueError(reason)
        result = minimize(run.build_problem(), run.build_optimizer(), budget=spec.budget,
                          seed=run.optimizer_seed(), checkpoints_per_decade=1)
        values.append(float(result.best_f))
    return values


def references(spec: TuneSpec, study: Any) -> dict[str, float]:
    """The reference method's median ``best_f`` per training instance (computed once and kept
    in the study's user attributes)."""
    out = {}
    for instance in spec.train:
        key = f"reference:{instance.key}"
        if key not in study.user_attrs:
            values = evaluate_setting(spec, instance, spec.train_seeds,
                                      algorithm=spec.reference, params={})
            median = float(np.median(values))
            if not np.isfinite(median) or median <= 0:
                raise ConfigError(
                    f"reference: {spec.reference!r} scores {median:g} on {instance.key}; the "
                    "per-instance ratio needs positive values (objective paper or "
                    "error_bounded)")
            study.set_user_attr(key, median)
        out[instance.key] = float(study.user_attrs[key])
    return out


def trial_objective(spec: TuneSpec, reference: dict[str, float]) -> Callable[[Any], float]:
    """The function Optuna minimises: for each training instance in turn, the median
    ``best_f`` over the training seeds divided by the reference's median; the trial's value is
    the mean of these ratios (reported after each instance, so the pruner can stop a trial
    early). Per-instance ratios and values are kept as user attributes."""
    import optuna

    def objective(trial: Any) -> float:
        params, encoding = spec.trial_setting(spec.space.suggest(trial))
        ratios = []
        for step, instance in enumerate(spec.train):
            values = evaluate_setting(spec, instance, spec.train_seeds, params=params,
                                      encoding=encoding)
            ratio = float(np.median(values)) / reference[instance.key]
            trial.set_user_attr(f"ratio:{instance.key}", ratio)
            trial.set_user_attr(f"best_f:{instance.key}", values)
            ratios.append(ratio)
            trial.report(float(np.mean(ratios)), step)
            if trial.should_prune():
                raise optuna.TrialPruned()
        return float(np.mean(ratios))

    return objective


def finished_trials(study: Any) -> int:
    from optuna.trial import TrialState

    states = tuple(getattr(TrialState, s) for s in FINISHED)
    return len(study.get_trials(deepcopy=False, states=states))


def work(spec: TuneSpec, worker_index: int = 0, progress: bool = False) -> None:
    """One worker: add trials until the study holds ``n_trials`` finished ones (or the
    timeout passes). Several workers (processes, machines) can work on one study."""
    import numba
    import optuna
    from optuna.study import MaxTrialsCallback
    from optuna.trial import TrialState

    if spec.workers > 1:
        numba.set_num_threads(1)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    storage = open_storage(spec)
    study = open_study(spec, storage, worker_index)
    reference = references(spec, study)
    if finished_trials(study) >= spec.n_trials:
        return
    states = tuple(getattr(TrialState, s) for s in FINISHED)
    callbacks = [MaxTrialsCallback(spec.n_trials, states=states)]
    if progress:
        callbacks.append(_Progress(spec.n_trials, finished_trials(study)))
    study.optimize(trial_objective(spec, reference), timeout=spec.timeout,
                   callbacks=callbacks, catch=(ValueError,), gc_after_trial=False)
    for callback in callbacks[1:]:
        callback.close()


class _Progress:
    """A progress bar over the study's finished trials (this worker's view)."""

    def __init__(self, total: int, done: int) -> None:
        from tqdm.auto import tqdm

        self.bar = tqdm(total=total, initial=done, desc="trials", unit="trial",
                        disable=not sys.stderr.isatty())

    def __call__(self, study: Any, trial: Any) -> None:
        self.bar.n = min(self.bar.total, finished_trials(study))
        best = study.best_value if finished_trials(study) else float("nan")
        self.bar.set_postfix(best=f"{best:.4g}", refresh=True)

    def close(self) -> None:
        self.bar.close()


def _work_in_process(raw: dict[str, Any], worker_index: int) -> None:
    from .spec import tune_spec

    work(tune_spec({**raw, "worker_index": worker_index}), worker_index)


def run_workers(spec: TuneSpec, progress: bool = True) -> list[int]:
    """Run ``spec.workers`` workers on the study: this process and ``workers - 1`` spawned
    ones. Returns the exit codes of the spawned workers (a killed worker's trial is retried
    by the others through the heartbeat, RDB storages only)."""
    context = multiprocessing.get_context("spawn")
    others = [context.Process(target=_work_in_process, args=(spec.raw, spec.worker_index + i),
                              daemon=False)
              for i in range(1, spec.workers)]
    for process in others:
        process.start()
        time.sleep(0.2)  # let each open the storage in turn
    try:
        work(spec, spec.worker_index, progress=progress)
    finally:
        for process in others:
            process.join()
    return [p.exitcode for p in others]
