"""What the study sweeper does with a multirun: plan, skip, launch, watch.

1. Expand the sweep (command line and ``hydra.sweeper.params``) into jobs, as Hydra's basic
   sweeper does, and compose every job's configuration.
2. Validate each (:func:`~metaknot.experiments.spec.run_spec`): the first bad value stops the
   sweep before any run starts, naming the key and the job.
3. Drop the jobs whose run is already stored (resume), the duplicates, and the
   optimizer/encoding pairs that cannot work together (listed, not run).
4. Launch the rest with the configured launcher and show a bar over the jobs, fed by the records
   appearing in the store (so it works for every launcher).
5. Sum up (:func:`summary`): what the runs did and how many of the planned runs are stored;
   one line per kind of run that could not be stored (a full disk) or job that crashed, and
   then the exit status is 1. On SIGINT/SIGTERM the workers stop and one line says how many
   of the planned runs are stored (:mod:`~metaknot.experiments.interrupt`).
"""

from __future__ import annotations

import copy
import itertools
import os
import sys
import threading
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any, cast

from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.errors import HydraException
from omegaconf import OmegaConf
from tqdm.auto import tqdm

from . import slurm
from .errors import ConfigError
from .interrupt import Interrupted, leave_ctrl_c_to_the_leader
from .run import RunSpec
from .spec import run_spec
from .store import (
    COMPLETE_STATUSES,
    DEFAULT_STUDY,
    Store,
    StoreError,
    check_writable,
    default_study_note,
)

__all__ = ["expand", "plan", "summary", "sweep"]


class Plan:
    """The jobs of a sweep, sorted out."""

    def __init__(self) -> None:
        self.to_run: list[tuple[list[str], RunSpec]] = []
        self.stored: list[RunSpec] = []
        self.duplicates = 0
        self.incompatible: Counter[str] = Counter()

    @property
    def n_jobs(self) -> int:
        return (len(self.to_run) + len(self.stored) + self.duplicates
                + sum(self.incompatible.values()))

    def describe(self, study_dir: Path) -> str:
        parts = [f"{self.n_jobs} jobs", f"{len(self.to_run)} to run"]
        if self.stored:
            parts.append(f"{len(self.stored)} already stored")
        if self.duplicates:
            parts.append(f"{self.duplicates} duplicates")
        skipped = sum(self.incompatible.values())
        if skipped:
            parts.append(f"{skipped} skipped")
        lines = [f"study {study_dir}: " + ", ".join(parts)]
        lines += [f"  skipped {count} job(s): {reason}"
                  for reason, count in sorted(self.incompatible.items())]
        return "\n".join(lines)


def expand(parser: OverridesParser, params: Mapping[str, Any],
           arguments: list[str]) -> list[list[str]]:
    """Every job of a sweep: the product of the swept values of ``hydra.sweeper.params`` and
    then the command line (a key given in both takes the command line's values, in the
    position of its first mention), each job a list of ``key=value`` overrides.

    Raises
    ------
    ConfigError
        For a sweep other than a list or a range (``a=1,2``, ``a=range(0,5)``).
    """
    lines = [f"{key}={value}" for key, value in params.items()] + list(arguments)
    choices: dict[str, list[str]] = {}
    for override in parser.parse_overrides(lines):
        key = override.get_key_element()  # with its prefix (``++key``), as the job gives it
        if not override.is_sweep_override():
            choices[override.key_or_group] = [f"{key}={override.get_value_element_as_str()}"]
        elif override.is_discrete_sweep():
            choices[override.key_or_group] = [f"{key}={value}"
                                              for value in override.sweep_string_iterator()]
        else:
            raise ConfigError(f"{key}: a study sweeps lists and ranges (a=1,2,3 or "
                              f"a='range(0,10)'); got {override.input_line:.80}")
    return [list(job) for job in itertools.product(*choices.values())]


def plan(sweeper: Any, arguments: list[str]) -> tuple[Plan, Path]:
    """Expand and validate a sweep; see the module notes."""
    parser = OverridesParser.create(config_loader=sweeper.hydra_context.config_loader)
    jobs = expand(parser, sweeper.params, arguments)
    composer = _Composer(sweeper, parser)
    result = Plan()
    seen: set[str] = set()
    reasons: dict[str, str | None] = {}
    completed: dict[Path, set[str]] = {}
    study_dir = None
    for job in jobs:
        try:
            spec = run_spec(_compose(composer, job), check_build=False)
            key = _build_key(spec)
            if key not in reasons:  # checked and built once per setting, the seed aside
                reasons[key] = spec.compatible()
                if reasons[key] is None:
                    spec.build_optimizer()
                    spec.build_problem(noise=False)
            reason = reasons[key]
        except ConfigError as exc:
            shown = " ".join(o.removeprefix("++") for o in job)  # as the command line had it
            raise ConfigError(f"{exc} (in the job {shown})") from None
        study_dir = spec.study_dir
        if reason is not None:
            result.incompatible[reason] += 1
            continue
        if spec.run_id in seen:
            result.duplicates += 1
            continue
        seen.add(spec.run_id)
        if spec.study_dir not in completed:
            try:
                completed[spec.study_dir] = Store(spec.study_dir).completed()
            except StoreError as exc:  # one line, as a bad setting is (not a traceback)
                raise ConfigError(str(exc)) from None
        if spec.run_id in completed[spec.study_dir]:
            result.stored.append(spec)
        else:
            result.to_run.append((list(job), spec))
    if study_dir is None:
        study_dir = Path(str(sweeper.config.results_dir)) / str(sweeper.config.study)
    return result, study_dir


def _compose(composer: _Composer, job: list[str]) -> Any:
    """The job's configuration; Hydra's composition errors as one line."""
    try:
        return composer(job)
    except (HydraException, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        raise ConfigError(lines[0] if lines else type(exc).__name__) from None


class _Composer:
    """Each job's configuration, composing with Hydra once per choice of config groups.

    Composition costs tens of milliseconds; a sweep of a thousand runs mostly changes plain
    values (seed, budget). Jobs are grouped by their group overrides (and any ``+``/``~``
    override); the group's configuration is composed once, and each job's ``key=value`` and
    ``++key=value`` overrides are set on a copy of its settings (``++`` adds a key the
    configuration lacks, for :func:`~.spec.run_spec` to refuse by name). A configuration with
    interpolations outside ``hydra`` is composed in full for every job, as a value could feed
    into them; so is a job with a value holding an interpolation or a plain ``key=value`` of a
    key the configuration does not have (Hydra then reports it).
    """

    def __init__(self, sweeper: Any, parser: OverridesParser) -> None:
        self.sweeper = sweeper
        self.parser = parser
        self.loader = sweeper.hydra_context.config_loader
        self._bases: dict[tuple[str, ...], dict[str, Any] | None] = {}
        self._groups: dict[str, list[str]] = {}

    def __call__(self, job: list[str]) -> Any:
        structural: list[str] = []
        values = []
        for override in self.parser.parse_overrides(job):
            line = override.input_line
            assert line is not None  # an override parsed from text keeps it
            simple = not (override.is_add() or override.is_delete()
                          or override.package is not None or "$" in line)
            key = override.key_or_group
            if simple and not key.startswith("hydra") and not self._is_group(key):
                values.append(override)
            else:
                structural.append(line)
        base_key = tuple(structural)
        if base_key not in self._bases:
            cfg = self._load(structural)
            self._bases[base_key] = None if _has_interpolations(cfg) else _plain_copy(cfg)
        base = self._bases[base_key]
        if base is None or not all(o.is_force_add() or _has_key(base, o.key_or_group)
                                   for o in values):
            return self._load(job)  # Hydra composes it, and reports what is wrong with it
        plain = copy.deepcopy(base)
        for override in values:
            _set(plain, override.key_or_group, override.value())
        return plain

    def _is_group(self, key: str) -> bool:
        """Whether ``key`` (``optimizer``, ``hydra.launcher``) names a config group."""
        parent, _, name = key.replace(".", "/").rpartition("/")
        if parent not in self._groups:
            self._groups[parent] = self.loader.list_groups(parent)
        return name in self._groups[parent]

    def _load(self, job: list[str]) -> Any:
        return self.loader.load_sweep_config(self.sweeper.config, list(job))


def _has_interpolations(cfg: Any) -> bool:
    container = cast(dict[str, Any], OmegaConf.to_container(cfg, resolve=False))  # a mapping
    container.pop("hydra", None)
    return "${" in repr(container)


def _plain_copy(cfg: Any) -> dict[str, Any]:
    container = dict(cast(dict[str, Any], OmegaConf.to_container(cfg, resolve=True)))
    container.pop("hydra", None)
    return container


def _has_key(config: dict[str, Any], dotted: str) -> bool:
    node: Any = config
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return False
        node = node[part]
    return True


def _set(config: dict[str, Any], dotted: str, value: Any) -> None:
    *parents, last = dotted.split(".")
    node = config
    for part in parents:
        node = node.setdefault(part, {})
    node[last] = value


def _build_key(spec: RunSpec) -> str:
    config = {k: v for k, v in spec.config.items() if k != "seed"}
    return repr(sorted(config.items(), key=lambda kv: kv[0]))


def sweep(sweeper: Any, arguments: list[str]) -> list[Any]:
    """The study sweeper's ``sweep``: plan, print what will happen, launch, watch.

    On SIGINT or SIGTERM (:class:`~metaknot.experiments.interrupt.Interrupted`, raised in the
    launcher's wait: joblib has killed its workers when it gets here) the workers' unfinished
    temp files are removed, and the exception carries how many of the planned runs are
    stored.
    """
    sweep_dir = Path(sweeper.config.hydra.sweep.dir)
    the_plan = warming = None
    try:
        warming = _warm_joblib_workers(sweeper.config)
        the_plan, study_dir = plan(sweeper, arguments)
        if warming is not None:
            warming.join()
        if not the_plan.to_run and not the_plan.stored and the_plan.incompatible:
            reasons = "; ".join(f"{reason} ({count} job{'s' * (count > 1)})"
                                for reason, count in sorted(the_plan.incompatible.items()))
            raise ConfigError(f"no job of the sweep can run: {reasons}")
        if the_plan.to_run:  # nothing is computed that could not be stored
            for folder in (study_dir, sweep_dir):
                check_writable(folder)
            if _is_slurm(sweeper.config):  # nor submitted that the cluster cannot take
                slurm.check(OmegaConf.select(sweeper.config, "hydra.launcher"))
        print(the_plan.describe(study_dir), file=sys.stderr, flush=True)
        if not the_plan.to_run:
            return []
        default = [spec for _, spec in the_plan.to_run if spec.study == DEFAULT_STUDY]
        if default:
            print(default_study_note(default[0].study_dir), file=sys.stderr, flush=True)
        returns = _launch(sweeper, the_plan, sweep_dir)
    except Interrupted as stop:
        if warming is not None:
            warming.join()  # then joblib's idle workers end cleanly with this process
        if the_plan is not None:
            stop.stored, stop.total = _stored(the_plan, stop.workers)
        raise
    outcomes: list[dict[str, Any]] = []
    crashes: Counter[str] = Counter()
    ended: list[str] = []
    for results in returns:
        for r in results:
            if isinstance(r._return_value, slurm.TaskEnded):  # a task without a result
                ended.append(str(r._return_value))
                continue
            try:
                outcome = r.return_value
            except Exception as exc:  # a job that crashed outside the run (a launcher error)
                crashes[f"{type(exc).__name__}: {exc}"[:120]] += 1
                continue
            outcomes.extend(outcome if isinstance(outcome, list) else [outcome])
    stored, total = _stored(the_plan)
    lines = summary(study_dir, outcomes, crashes, stored, total, ended)
    print("\n".join(lines), file=sys.stderr, flush=True)
    if len(lines) > 1:  # runs that could not be stored, jobs that crashed, tasks lost
        raise SystemExit(1)
    return returns


def summary(study_dir: Path, outcomes: list[dict[str, Any]], crashes: Counter[str],
            stored: int, total: int, ended: Sequence[str] = ()) -> list[str]:
    """The sweep's last words: what its runs did and how many of the planned runs are stored,
    then one line per kind of run that could not be stored, per kind of crashed job and per
    SLURM task that ended without a result (``ended``, the first
    :data:`~.slurm.SHOWN_TASKS` of them, and then their count)."""
    statuses = Counter(o["status"] for o in outcomes)
    order = sorted(statuses, key=lambda status: (status not in COMPLETE_STATUSES,
                                                 status in ("not_run", "not_stored"), status))
    counts = ", ".join(f"{statuses[status]} {status.replace('_', ' ')}" for status in order)
    lines = [f"study {study_dir}: {counts or 'nothing run'}; {stored} of {total} runs stored"
             + (" (failed runs are kept under failed/)" if statuses["failed"] else "")]
    kinds: dict[tuple[str, str, str | None], list[dict[str, Any]]] = {}
    for o in outcomes:
        if o["status"] in ("not_run", "not_stored"):
            kept = None if o["path"] is None else str(Path(o["path"]).parent)
            kinds.setdefault((o["status"], o["error"], kept), []).append(o)
    for (status, error, kept), members in sorted(kinds.items(), key=str):
        if status == "not_run":
            lines.append(f"  {len(members)} not run: {members[0]['detail']}")
        elif kept is None:
            lines.append(f"  {len(members)} computed but lost: {members[0]['detail']} (their "
                         "records could not be kept elsewhere either)")
        else:
            lines.append(f"  {len(members)} computed but not stored ({error}): their records "
                         f"are kept in {kept}: move them into "
                         f"{study_dir / Path(kept).name}/ once there is space")
    lines += [f"  {n} job(s) ended with an error: {error}" for error, n in sorted(crashes.items())]
    lines += [f"  {line}" for line in ended[: slurm.SHOWN_TASKS]]
    if len(ended) > slurm.SHOWN_TASKS:
        lines.append(f"  ... and {len(ended) - slurm.SHOWN_TASKS} more tasks without a result "
                     "(their logs are in the sweep's .submitit/ folder)")
    if len(lines) > 1:
        lines.append("  run the same command to compute the missing runs once the cause is "
                     "fixed")
    return lines


def _launch(sweeper: Any, the_plan: Plan, sweep_dir: Path) -> list[Any]:
    """Hand the plan's runs to the launcher in jobs, with a progress bar."""
    sweep_dir = _new_folder(sweep_dir)
    try:
        OmegaConf.save(sweeper.config, sweep_dir / "multirun.yaml")
    except OSError as exc:  # a full disk: the runs report it too
        print(f"metaknot: cannot write {sweep_dir / 'multirun.yaml'}: {exc.strerror or exc}",
              file=sys.stderr, flush=True)
    per_job = runs_per_job(getattr(sweeper, "runs_per_job", 1), len(the_plan.to_run),
                           launcher_workers(sweeper.config))
    jobs = batch_jobs(the_plan.to_run, per_job)
    size = sweeper.max_batch_size or len(jobs)
    watcher = _Watcher([spec for _, spec in the_plan.to_run])
    returns = []
    watcher.start()
    try:
        for first in range(0, len(jobs), size):
            batch = jobs[first : first + size]
            returns.append(sweeper.launcher.launch(batch, initial_job_idx=first))
    finally:
        watcher.stop()
    return returns


def _new_folder(path: Path) -> Path:
    """Create the folder ``path``, or ``path-2``, ``path-3``, ... if it exists (sweeps of a
    study started in the same second share their configured folder name)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    candidate, number = path, 1
    while True:
        try:
            candidate.mkdir()
            return candidate
        except FileExistsError:
            number += 1
            candidate = path.with_name(f"{path.name}-{number}")


def _stored(the_plan: Plan, stopped: Iterable[int] = ()) -> tuple[int, int]:
    """(planned runs with a complete record, planned runs), once the temp files of the
    ``stopped`` workers are removed."""
    specs = the_plan.stored + [spec for _, spec in the_plan.to_run]
    stored = 0
    for study_dir in {spec.study_dir for spec in specs}:
        store = Store(study_dir)
        store.remove_temp_files(stopped)
        done = store.completed()
        stored += sum(spec.run_id in done for spec in specs if spec.study_dir == study_dir)
    return stored, len(specs)


def _warm_worker() -> int:
    """Import what a run needs and load the compiled kernel (in a joblib worker)."""
    import numpy as np

    leave_ctrl_c_to_the_leader()

    import metaknot.algorithms
    import metaknot.experiments.app  # noqa: F401
    from metaknot.problems import KnotSelection, get_curve

    problem = KnotSelection(get_curve("archimedean", n_points=12))
    problem.evaluate(np.ones((1, problem.encoding.n_var), dtype=np.int64))
    return os.getpid()


def _warm_joblib_workers(config: Any) -> threading.Thread | None:
    """Start the joblib launcher's worker processes while the sweep is validated: joblib
    reuses them for the jobs, which then start at once instead of after a second of imports.
    Uses the launcher's own joblib settings, or joblib would start a new set."""
    launcher = OmegaConf.select(config, "hydra.launcher")
    if launcher is None or "Joblib" not in str(launcher.get("_target_", "")):
        return None
    workers = launcher_workers(config)
    if workers < 2:
        return None
    from joblib import Parallel, delayed

    options = cast(dict[str, Any], OmegaConf.to_container(launcher, resolve=True))  # a mapping
    settings = {k: v for k, v in options.items() if k != "_target_"}
    settings["backend"] = "loky"
    for key in ("pre_dispatch", "batch_size", "max_nbytes"):  # "100": a count, as the
        value = settings.get(key)                                # launcher reads it
        if isinstance(value, str) and value.isdigit():
            settings[key] = int(value)

    def warm() -> None:
        try:
            Parallel(**settings)(delayed(_warm_worker)() for _ in range(workers))
        except Exception:  # only an optimisation: the launcher starts its own workers
            pass

    thread = threading.Thread(target=warm, daemon=True)
    thread.start()
    return thread


def _is_slurm(config: Any) -> bool:
    """Whether the sweep goes to SLURM (``launcher=slurm``, or submitit's own launcher)."""
    return "Slurm" in str(OmegaConf.select(config, "hydra.launcher._target_") or "")


def launcher_workers(config: Any) -> int:
    """How many jobs the configured launcher runs at once (1 for Hydra's basic launcher; on
    SLURM, what :func:`~.slurm.workers` counts)."""
    launcher = OmegaConf.select(config, "hydra.launcher") or {}
    target = str(launcher.get("_target_", ""))
    cores = os.cpu_count() or 1
    if "Joblib" in target:
        n_jobs = int(launcher.get("n_jobs", -1) or -1)
        return max(1, n_jobs if n_jobs > 0 else cores + 1 + n_jobs)
    if "Slurm" in target:  # the partition's CPUs, at most array_parallelism at once
        return slurm.workers(launcher)
    if "Local" in target:  # submitit_local: one process per job, all at once
        return max(1, cores)
    return 1


def runs_per_job(setting: Any, n_runs: int, workers: int = 1) -> int:
    """Runs per launched job: ``setting`` if an int >= 1; ``"auto"``: about four jobs per
    worker, from 1 to 10 runs per job (1440 runs on two workers go out as 144 jobs of ten
    seeds; 40 runs on 64 cores as 40 jobs)."""
    if setting == "auto":
        return max(1, min(10, n_runs // (4 * max(1, workers))))
    if isinstance(setting, bool) or not isinstance(setting, int) or setting < 1:
        raise ConfigError(f"hydra.sweeper.runs_per_job: an integer >= 1 or auto, got "
                          f"{setting!r}")
    return setting


def batch_jobs(to_run: list[tuple[list[str], RunSpec]], per_job: int) -> list[list[str]]:
    """The launched jobs: runs that differ only in their seed go together, ``per_job`` seeds
    at a time (``seed=[3,4,5]``: the task runs and stores each seed as its own run). Jobs are
    ordered by their evaluations, the largest first, so no long job starts last."""
    groups: dict[tuple[str, ...], list[tuple[list[str], RunSpec]]] = {}
    for job, spec in to_run:
        seeds = [o for o in job if o.startswith("seed=")]
        key = tuple(o for o in job if not o.startswith("seed="))
        groups.setdefault(key if per_job > 1 and len(seeds) == 1 else tuple(job), []).append(
            (job, spec))
    launched: list[tuple[int, list[str]]] = []
    for key, members in groups.items():
        for first in range(0, len(members), per_job):
            chunk = members[first : first + per_job]
            if len(chunk) == 1:
                job = chunk[0][0]
            else:
                seed_list = ",".join(str(spec.seed) for _, spec in chunk)
                job = [*key, f"seed=[{seed_list}]"]
            launched.append((sum(spec.budget for _, spec in chunk), job))
    launched.sort(key=lambda item: -item[0])
    return [job for _, job in launched]


class _Watcher:
    """A progress bar over the sweep's jobs, counting their records as they appear."""

    def __init__(self, specs: list[RunSpec], interval: float = 0.5) -> None:
        self.specs = specs
        self.interval = interval
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, daemon=True)
        self._bar = tqdm(total=len(specs), desc="runs", unit="run", disable=None)
        self.done = 0  # runs of this sweep with a record (ok or failed)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()
        self._update()
        self._bar.close()

    def _loop(self) -> None:
        while not self._stop.wait(self.interval):
            self._update()

    def _update(self) -> None:
        done = 0
        by_dir: dict[Path, list[str]] = {}
        for spec in self.specs:
            by_dir.setdefault(spec.study_dir, []).append(spec.run_id)
        for study_dir, ids in by_dir.items():
            store = Store(study_dir)
            names = {p.name.split(".", 1)[0] for d in (store.runs_dir, store.failed_dir)
                     if d.is_dir() for p in d.iterdir()}
            done += sum(run_id in names for run_id in ids)
        self._bar.update(done - self.done)
        self.done = done
