"""Running a tuning study: storage, trials on the training instances, parallel workers."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
import warnings
from collections.abc import Callable
from typing import Any, cast

import numpy as np

from ..errors import ConfigError
from ..interrupt import Interrupted, interrupt_on_signals, interruptible, raise_pending
from ..spec import run_spec
from .study import Instance, TuneSpec

__all__ = ["HOLD_WORKER_ENV", "evaluate_setting", "fail_trials_of_dead_workers", "open_storage",
           "open_study", "references", "run_workers", "trial_objective",
           "wait_for_running_trials", "worker_name"]

#: Trial states that count towards ``n_trials``.
FINISHED = ("COMPLETE", "PRUNED")
#: Fault injection for the tests: the worker whose ``worker_index`` this variable holds stops
#: inside the first trial it starts, once its parameters are sampled, writes
#: ``<study dir>/worker-<index>.held`` (``{"trial": number, "pid": pid}``) and waits there, its
#: heartbeat beating, until it is killed. ``references`` stops the command inside the first
#: run of the reference method (``<study dir>/references.held``, ``{"pid": pid}``).
HOLD_WORKER_ENV = "METAKNOT_TUNE_HOLD_WORKER"


def worker_name(pid: int | None = None) -> str:
    """``host:pid`` of a worker process (this one by default), kept in each trial it runs as
    the user attribute ``worker``."""
    return f"{socket.gethostname()}:{os.getpid() if pid is None else pid}"


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
    if url is None:
        url = "journal" if spec.workers > 1 else f"sqlite:///{spec.study_dir / 'optuna.db'}"
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
    for attempt in range(SCHEMA_ATTEMPTS):
        try:
            return RDBStorage(
                url, heartbeat_interval=spec.heartbeat_interval, grace_period=spec.grace_period,
                heartbeat_stale_trial_callback=RetryHeartbeatStaleTrialCallback(
                    max_retry=spec.max_retry),
                engine_kwargs={"pool_pre_ping": True},
            )
        except Exception as exc:  # SQLAlchemy's errors for bad URLs, drivers and servers
            if attempt + 1 < SCHEMA_ATTEMPTS and _schema_race(exc):
                time.sleep(0.2 * (attempt + 1))  # the other worker's tables exist by then
                continue
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else \
                type(exc).__name__
            raise ConfigError(f"storage: cannot open {url}: {reason}") from None
    raise AssertionError("unreachable")


#: Tries at opening an RDB storage whose tables another worker is creating at the same time.
SCHEMA_ATTEMPTS = 5


def _schema_race(exc: Exception) -> bool:
    """True for the errors of two workers (or two commands) creating Optuna's tables in a new
    database at once: PostgreSQL's unique violation on its catalogue or "already exists";
    SQLite's "table studies already exists" or "database is locked" (an OperationalError) and
    its unique violation on the schema version ("UNIQUE constraint failed")."""
    from sqlalchemy.exc import IntegrityError, OperationalError, ProgrammingError

    text = str(exc)
    if isinstance(exc, OperationalError):
        return "already exists" in text or "database is locked" in text
    return isinstance(exc, IntegrityError | ProgrammingError) and (
        "already exists" in text or "duplicate key" in text
        or "UNIQUE constraint failed" in text)


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
                     optimizer: str | None = None, params: dict[str, Any] | None = None,
                     encoding: dict[str, Any] | None = None) -> list[float]:
    """``best_f`` of one setting on ``instance`` for each replicate seed (in-process runs).

    Raises
    ------
    ValueError
        If the setting does not fit the instance, or a run fails its budget audit (a trial
        then fails: its value could not be compared with the others).
    """
    from metaknot.runner import minimize

    values = []
    for seed in seeds:
        run = run_spec(spec.run_config(instance, seed, optimizer=optimizer, params=params,
                                       encoding=encoding), check_build=False)
        reason = run.compatible()
        if reason:
            raise ValueError(reason)
        result = minimize(run.build_problem(), run.build_optimizer(), budget=spec.budget,
                          seed=run.optimizer_seed(), checkpoints_per_decade=1)
        if result.status == "budget_violation":  # its value cannot be compared: the trial fails
            raise ValueError(f"{run.optimizer} on {instance.key}, seed {seed}: {result.error}")
        values.append(float(result.best_f))
    return values


def references(spec: TuneSpec, study: Any) -> dict[str, float]:
    """The reference method's median ``best_f`` per training instance (computed once and kept
    in the study's user attributes)."""
    out = {}
    for instance in spec.train:
        key = f"reference:{instance.key}"
        if key not in study.user_attrs:
            # a signal stops the runs at once (nothing is stored); the storage call after
            # them is not cut short
            with interruptible():
                if os.environ.get(HOLD_WORKER_ENV) == "references":
                    _hold(spec, "references")
                values = evaluate_setting(spec, instance, spec.train_seeds,
                                          optimizer=spec.reference, params={})
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
    early). Per-instance ratios and values are kept as user attributes, and so is the
    ``worker`` that ran the trial (:func:`worker_name`)."""
    import optuna

    def objective(trial: Any) -> float:
        trial.set_user_attr("worker", worker_name())
        params, encoding = spec.trial_setting(spec.space.suggest(trial))
        # a signal stops the runs at once (the trial fails); Optuna's storage calls between
        # them are not cut short (a journal's file lock), the signal waits for the next runs
        if os.environ.get(HOLD_WORKER_ENV) == str(spec.worker_index):
            with interruptible():
                _hold(spec, f"worker-{spec.worker_index}", trial.number)
        ratios = []
        for step, instance in enumerate(spec.train):
            with interruptible():
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


def _hold(spec: TuneSpec, name: str, trial: int | None = None) -> None:
    """Stop here until killed (:data:`HOLD_WORKER_ENV`), once ``<study dir>/<name>.held``
    says where (the pid, and the ``trial`` if one)."""
    marker = spec.study_dir / f"{name}.held"
    partial = marker.with_suffix(".partial")
    where = {"pid": os.getpid()} if trial is None else {"trial": trial, "pid": os.getpid()}
    partial.write_text(json.dumps(where))
    partial.replace(marker)
    threading.Event().wait()


def finished_trials(study: Any) -> int:
    from optuna.trial import TrialState

    states = tuple(getattr(TrialState, s) for s in FINISHED)
    return len(study.get_trials(deepcopy=False, states=states))


def _wants_trials(study: Any, n_trials: int) -> bool:
    """Fewer than ``n_trials`` finished trials, or a retry waiting to run."""
    from optuna.trial import TrialState

    return finished_trials(study) < n_trials or bool(
        study.get_trials(deepcopy=False, states=(TrialState.WAITING,)))


class _StopWhenDone:
    """Stops a worker once the study holds ``n_trials`` finished trials and no retry waits."""

    def __init__(self, n_trials: int) -> None:
        self.n_trials = n_trials

    def __call__(self, study: Any, trial: Any) -> None:
        raise_pending()  # a signal during Optuna's bookkeeping of the trial: stop here
        if not _wants_trials(study, self.n_trials):
            study.stop()


def work(spec: TuneSpec, worker_index: int = 0, progress: bool = False,
         ready: Any = None) -> None:
    """One worker: add trials until the study holds ``n_trials`` finished ones (or the
    timeout passes), then wait for the trials still running (:func:`wait_for_running_trials`)
    and run the retries of those that failed. Several workers (processes, machines) can work
    on one study; ``ready`` (an event) is set once the study is open."""
    import numba
    import optuna

    if spec.workers > 1:
        numba.set_num_threads(1)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    _quiet_when_interrupted()
    storage = open_storage(spec)
    study = open_study(spec, storage, worker_index)
    objective = trial_objective(spec, references(spec, study))
    if ready is not None:
        ready.set()
    callbacks: list[Any] = [_StopWhenDone(spec.n_trials)]
    if progress:
        callbacks.append(_Progress(spec.n_trials, finished_trials(study)))
    deadline = None if spec.timeout is None else time.monotonic() + spec.timeout
    while True:
        left = None if deadline is None else deadline - time.monotonic()
        if _wants_trials(study, spec.n_trials) and (left is None or left > 0):
            study.optimize(objective, timeout=left, callbacks=callbacks, catch=(ValueError,),
                           gc_after_trial=False)
        wait_for_running_trials(spec, study, storage)  # may leave retries waiting
        if not _wants_trials(study, spec.n_trials) or (
                deadline is not None and time.monotonic() >= deadline):
            break
    for callback in callbacks[1:]:
        callback.close()


def _quiet_when_interrupted() -> None:
    """Drop Optuna's report of a trial that failed because the worker was interrupted (a
    traceback, "Trial N failed with value None"): the command's one line says so."""
    import logging

    for handler in logging.getLogger("optuna").handlers:
        if _not_an_interrupt not in handler.filters:
            handler.addFilter(_not_an_interrupt)


def _not_an_interrupt(record: Any) -> bool:
    """False for Optuna's log records about a trial an interrupt failed."""
    message = record.getMessage()
    return not ((record.exc_info is not None
                 and isinstance(record.exc_info[1], KeyboardInterrupt))
                or "Interrupted(" in message
                or (Interrupted.raised and "failed with value None" in message))


def wait_for_running_trials(spec: TuneSpec, study: Any, storage: Any) -> None:
    """On a storage with a heartbeat (RDB), wait until no trial of the study is running: a
    live worker's trial finishes, a dead worker's is failed once its heartbeat is
    ``grace_period`` old, and retried (``max_retry``). A trial whose worker died before its
    first heartbeat gets one from here after ``grace_period + heartbeat_interval`` s of
    waiting, so it, too, is failed in the end; their retries may then be waiting. Without a
    heartbeat it returns at once.
    """
    import optuna
    from optuna.storages import RDBStorage, fail_stale_trials
    from optuna.trial import TrialState

    if not isinstance(storage, RDBStorage):
        return
    first_seen: dict[int, float] = {}
    given_a_heartbeat: set[int] = set()
    waiting = False
    while True:
        now = time.monotonic()
        for trial in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
            first_seen.setdefault(trial.number, now)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
            fail_stale_trials(study)
        running = study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
        if not running:
            break
        if not waiting:
            print(f"tune {spec.study}: waiting for {_trials([t.number for t in running])} of "
                  f"other workers; a dead worker's trial is failed {spec.grace_period} s after "
                  "its last heartbeat", flush=True)
            waiting = True
        for trial in running:
            waited = now - first_seen[trial.number]
            if trial.number not in given_a_heartbeat \
                    and waited > spec.grace_period + spec.heartbeat_interval:
                storage.record_heartbeat(trial._trial_id)  # the storage knows trials by id
                given_a_heartbeat.add(trial.number)
        with interruptible():
            time.sleep(spec.heartbeat_interval)
    states = {t.number: t.state for t in study.get_trials(deepcopy=False)}
    failed = [n for n in sorted(first_seen) if states[n] == TrialState.FAIL]
    if failed:
        retried = {t.system_attrs["retry_history"][-1]: t.number  # noted by Optuna's retry
                   for t in study.get_trials(deepcopy=False) if t.system_attrs.get(
                       "retry_history")}
        retries = [f"{n} as {retried[n]}" for n in failed if n in retried]
        print(f"tune {spec.study}: {_trials(failed)} ended FAIL meanwhile"
              + (f"; retried: {', '.join(retries)}" if retries else ""), flush=True)


def _trials(numbers: list[int]) -> str:
    """``trial 3`` or ``trials 3, 5``."""
    return ("trial " if len(numbers) == 1 else "trials ") + ", ".join(map(str, numbers))


def fail_running_trials(study: Any, workers: set[str]) -> list[int]:
    """Mark FAIL the trials of ``workers`` (their :func:`worker_name`) still RUNNING (the
    workers were stopped); returns their numbers."""
    from optuna.trial import TrialState

    left = [t.number for t in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,))
            if t.user_attrs.get("worker") in workers]
    for number in left:
        study.tell(number, state=TrialState.FAIL, skip_if_finished=True)
    return left


def fail_trials_of_dead_workers(study: Any, workers: list[tuple[int, int, int]]) -> list[str]:
    """For each spawned worker ``(index, pid, exit code)`` that ended abnormally, mark FAIL
    the trials it left RUNNING (on a journal storage, which has no heartbeat, nothing else
    would), and say what happened: one line per such worker."""

    lines = []
    for index, pid, code in workers:
        if code == 0:
            continue
        try:
            how = f"was killed by {signal.Signals(-code).name}" if code < 0 else \
                f"ended with exit code {code}"
        except ValueError:
            how = f"was killed by signal {-code}"
        left = fail_running_trials(study, {worker_name(pid)})
        what = (f"{_trials(left)} it was running marked FAIL (not retried)" if left
                else "no trial of it is still running")
        lines.append(f"tune: worker {index} (pid {pid}) {how}; {what}")
    return lines


class _Progress:
    """A progress bar over the study's finished trials (this worker's view)."""

    def __init__(self, total: int, done: int) -> None:
        from tqdm.auto import tqdm

        self.bar = tqdm(total=total, initial=done, desc="trials", unit="trial",
                        disable=not sys.stderr.isatty())

    def __call__(self, study: Any, trial: Any) -> None:
        self.bar.n = min(cast(int, self.bar.total), finished_trials(study))  # given above
        best = study.best_value if finished_trials(study) else float("nan")
        self.bar.set_postfix(best=f"{best:.4g}", refresh=True)

    def close(self) -> None:
        self.bar.close()


def _work_in_process(raw: dict[str, Any], worker_index: int, ready: Any) -> None:
    """A spawned worker: Ctrl-C is the leader's to handle (it stops the workers with
    SIGTERM); SIGTERM fails the trial running here (Optuna marks it FAIL) and ends the
    process with exit code 143, without a traceback."""
    from .spec import tune_spec

    try:
        with interrupt_on_signals(anywhere=False):
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            work(tune_spec({**raw, "worker_index": worker_index}), worker_index, ready=ready)
    except Interrupted as stop:
        sys.exit(stop.exit_code)


def run_workers(spec: TuneSpec, progress: bool = True) -> list[tuple[int, int, int]]:
    """Run ``spec.workers`` workers on the study: ``workers - 1`` spawned ones and, once each
    of them has opened the study (or died), this process. Returns ``(worker index, pid, exit
    code)`` of each spawned worker (see :func:`fail_trials_of_dead_workers`)."""
    context = multiprocessing.get_context("spawn")
    others = []
    for i in range(1, spec.workers):
        ready = context.Event()
        process = context.Process(target=_work_in_process,
                                  args=(spec.raw, spec.worker_index + i, ready), daemon=False)
        process.start()
        others.append((process, ready))
    try:
        for process, ready in others:
            while not ready.wait(0.1) and process.is_alive():
                raise_pending()
        work(spec, spec.worker_index, progress=progress)
    except BaseException:  # Ctrl-C, SIGTERM, an error: stop the spawned workers too
        for process, _ in others:
            if process.is_alive():
                process.terminate()
        raise
    finally:
        for process, _ in others:
            process.join()
    # started and joined: every pid and exit code is set
    return [(spec.worker_index + i, cast(int, process.pid), cast(int, process.exitcode))
            for i, (process, _) in enumerate(others, start=1)]
