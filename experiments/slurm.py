"""A sweep on a SLURM cluster (``launcher=slurm``): the cluster checked first, every task
waited for.

Hydra's submitit launcher submits the sweep's jobs as one SLURM job array and collects their
results in array order. Three things went wrong with it, and are handled here:

- A setting the cluster cannot take (a partition it does not have, more memory or CPUs than
  its nodes) surfaced as sbatch's error inside a long traceback. :func:`check` asks ``sinfo``
  first and names the setting in one line, before anything is submitted.
- A task that ended without a result (``scancel``, a time limit, a lost node) ended the
  leader with submitit's ``UncompletedJobError`` while later tasks still ran.
  :func:`launch` waits for every task, then returns one failed job per task that left no
  result (a :class:`TaskEnded` saying how it ended), for the study sweeper's summary.
- submitit learns that a task ended from ``sacct``; without job accounting, a task killed
  before it wrote its result was waited for for ever. :func:`check` refuses a cluster whose
  ``sacct`` does not answer; :func:`launch` also gives up on a task that has no result, no
  state in ``sacct`` and is no longer queued (accounting that fails during a sweep).

:func:`workers` counts the CPUs of the chosen partition, from which the study sweeper sizes its
jobs (``hydra.sweeper.runs_per_job=auto``).
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import ConfigError

__all__ = ["Partition", "TaskEnded", "check", "launch", "partitions", "workers"]

#: Seconds a SLURM command may take to answer.
COMMAND_TIMEOUT = 60.0
#: Seconds between two questions to ``sacct`` (and ``squeue``) while tasks have no result.
STATE_INTERVAL = 10.0
#: Seconds to wait for the result files of tasks SLURM says have completed (a network file
#: system shows new files late).
RESULT_GRACE = 15.0
#: Tasks named one by one in the leader's summary; more are counted.
SHOWN_TASKS = 20


class TaskEnded(Exception):
    """A SLURM task that ended without a result: its runs are not stored (those it stored
    before it ended are). The message is the summary's line for it."""


@dataclass(frozen=True)
class Partition:
    """A SLURM partition as ``sinfo`` reports it."""

    name: str
    default: bool
    state: str
    #: CPUs of all its nodes.
    cpus: int
    #: The most CPUs, and the most memory (MB), of one of its nodes.
    node_cpus: int
    node_memory_mb: int


def _command(args: list[str]) -> str:
    """The output of a SLURM command; a :class:`ConfigError` (one line) if it fails."""
    try:
        done = subprocess.run(args, capture_output=True, text=True, timeout=COMMAND_TIMEOUT)
    except FileNotFoundError:
        raise ConfigError(f"launcher=slurm: {args[0]} is not on the PATH: this machine has no "
                          "SLURM commands (submit from a cluster's login node)") from None
    except subprocess.TimeoutExpired:
        raise ConfigError(f"launcher=slurm: {args[0]} did not answer within "
                          f"{COMMAND_TIMEOUT:.0f} s") from None
    if done.returncode != 0:
        lines = [line.strip() for line in done.stderr.splitlines() if line.strip()]
        reason = lines[0].removeprefix(f"{args[0]}: ").removeprefix("error: ") if lines \
            else f"exit status {done.returncode}"
        raise ConfigError(f"launcher=slurm: {args[0]} fails: {reason}")
    return done.stdout


def _number(text: str) -> int:
    """A count of ``sinfo`` (``2``, ``64+``, ``N/A``)."""
    digits = text.strip().rstrip("+")
    return int(digits) if digits.isdigit() else 0


def partitions() -> dict[str, Partition]:
    """The cluster's partitions (``sinfo``), by name.

    Raises
    ------
    ConfigError
        If ``sinfo`` is missing or fails (no controller), in one line.
    """
    rows: dict[str, list[list[str]]] = {}
    for line in _command(["sinfo", "--noheader", "--exact",
                          "--format=%P|%a|%c|%D|%m"]).splitlines():
        fields = line.strip().split("|")
        if len(fields) == 5:
            rows.setdefault(fields[0], []).append(fields[1:])
    found = {}
    for label, groups in rows.items():
        name = label.rstrip("*")
        found[name] = Partition(
            name=name, default=label.endswith("*"), state=groups[0][0],
            cpus=sum(_number(cpus) * _number(nodes) for _, cpus, nodes, _ in groups),
            node_cpus=max(_number(cpus) for _, cpus, _, _ in groups),
            node_memory_mb=max(_number(memory) for *_, memory in groups))
    return found


def _chosen(launcher: Mapping[str, Any], found: dict[str, Partition]) -> Partition:
    """The partition the sweep goes to: ``hydra.launcher.partition``, or the default one."""
    names = ", ".join(found) or "none"
    name = launcher.get("partition")
    if name is None:
        default = [p for p in found.values() if p.default]
        if not default:
            raise ConfigError(f"hydra.launcher.partition: the cluster has no default "
                              f"partition; choose one of {names}")
        return default[0]
    if str(name) not in found:
        raise ConfigError(f"hydra.launcher.partition={name}: no such partition on this "
                          f"cluster (it has {names})")
    return found[str(name)]


def check(launcher: Mapping[str, Any]) -> Partition:
    """Check that the cluster can take the sweep, before anything is submitted, and return
    the partition it goes to.

    The partition must exist and be up, its nodes must have the CPUs and the memory a task
    asks for (``cpus_per_task``, ``mem_gb``), and ``sacct`` must answer: it is how a task
    that ended without a result (``scancel``, a time limit) is told from one still running.

    Raises
    ------
    ConfigError
        Naming the setting or the missing service, in one line.
    """
    partition = _chosen(launcher, partitions())
    name = partition.name
    if partition.state != "up":
        raise ConfigError(f"hydra.launcher.partition={name}: the partition is "
                          f"{partition.state}, its tasks would wait for ever")
    cpus = int(launcher.get("cpus_per_task") or 1)
    if cpus > partition.node_cpus:
        raise ConfigError(f"hydra.launcher.cpus_per_task={cpus}: the nodes of the partition "
                          f"{name} have at most {partition.node_cpus} CPUs")
    memory = launcher.get("mem_gb")
    if memory is not None and float(memory) * 1024 > partition.node_memory_mb:
        raise ConfigError(f"hydra.launcher.mem_gb={memory}: the nodes of the partition {name} "
                          f"have at most {partition.node_memory_mb / 1024:.1f} GB "
                          "(RealMemory in slurm.conf)")
    try:
        _command(["sacct", "--noheader", "--allocations", "--format=JobID",
                  "--starttime=now", "--endtime=now"])
    except ConfigError as exc:
        reason = str(exc).partition("fails: ")[2] or str(exc)
        raise ConfigError(f"launcher=slurm needs SLURM's job accounting, and sacct fails here "
                          f"({reason}): without it a cancelled or killed task would be waited "
                          "for for ever; enable accounting (slurmdbd) or use "
                          "launcher=joblib") from None
    return partition


def workers(launcher: Mapping[str, Any]) -> int:
    """How many tasks of the sweep can run at once: the CPUs of its partition over
    ``cpus_per_task``, at most ``array_parallelism`` (``array_parallelism`` alone where
    ``sinfo`` cannot tell)."""
    parallelism = max(1, int(launcher.get("array_parallelism") or 256))
    try:
        partition = _chosen(launcher, partitions())
    except ConfigError:
        return parallelism
    per_task = max(1, int(launcher.get("cpus_per_task") or 1))
    return max(1, min(parallelism, partition.cpus // per_task))


# --------------------------------------------------------------------------------------------
# submitting and waiting


def launch(launcher: Any, job_overrides: Sequence[Sequence[str]],
           initial_job_idx: int) -> list[Any]:
    """Submit the jobs as one array, as Hydra's submitit launcher does, and wait for every
    task; a task that ended without a result is a failed job whose value is a
    :class:`TaskEnded` (a task whose code raised outside the run, too).

    Parameters
    ----------
    launcher
        The ``SlurmLauncher`` (its ``params``, ``config``; it is the function each task runs).
    job_overrides, initial_job_idx
        As Hydra's ``Launcher.launch``.

    Raises
    ------
    ConfigError
        If ``sbatch`` refuses the array (an account or QOS the cluster does not have), with
        its reason, in one line.
    """
    import submitit
    from hydra.core.singleton import Singleton
    from hydra.core.utils import JobReturn, JobStatus
    from hydra_plugins.hydra_submitit_launcher.config import BaseQueueConf
    from omegaconf import OmegaConf

    params = dict(launcher.params)
    init = {"folder": params.pop("submitit_folder")}
    if "max_num_timeout" in params:
        init["slurm_max_num_timeout"] = params.pop("max_num_timeout")
    executor = submitit.AutoExecutor(cluster="slurm", **init)
    shared = set(OmegaConf.structured(BaseQueueConf).keys())
    executor.update_parameters(**{key if key in shared else f"slurm_{key}": value
                                  for key, value in params.items()})
    sweep_dir = Path(str(launcher.config.hydra.sweep.dir))
    sweep_dir.mkdir(parents=True, exist_ok=True)
    arguments = [(list(overrides), "hydra.sweep.dir", initial_job_idx + i,
                  f"job_id_for_{initial_job_idx + i}", Singleton.get_state())
                 for i, overrides in enumerate(job_overrides)]
    try:
        jobs = executor.map_array(launcher, *zip(*arguments, strict=True))
    except submitit.core.utils.FailedJobError as exc:
        lines = [line.strip() for line in str(exc).splitlines() if "error" in line.lower()]
        raise ConfigError(f"launcher=slurm: sbatch refused the sweep: "
                          f"{lines[-1] if lines else exc}") from None
    first = jobs[0].job_id.partition("_")[0]
    print(f"SLURM job {first}: {len(jobs)} task{'s' * (len(jobs) > 1)} (scancel {first} "
          "cancels them all)", file=sys.stderr, flush=True)
    ended = _wait(jobs)
    returns = []
    for job, overrides in zip(jobs, job_overrides, strict=True):
        failure = ended.get(job.job_id)
        if failure is None and not job.paths.result_pickle.exists():
            failure = f"ended {_state(job)}"
        if failure is None:
            try:
                returns.append(job.results()[0])
                continue
            except submitit.core.utils.UncompletedJobError:
                failure = f"ended {_state(job)}"
            except submitit.core.utils.FailedJobError as exc:  # it raised outside the run
                failure = f"failed: {_last_line(str(exc))} (log: {job.paths.stderr})"
        returns.append(JobReturn(overrides=list(overrides), status=JobStatus.FAILED,
                                 _return_value=TaskEnded(_describe(job.job_id, failure,
                                                                   overrides))))
    return returns


def _wait(jobs: list[Any]) -> dict[str, str]:
    """Wait until every task has a result or has ended (``sacct``); a task that has neither
    a result nor a state in ``sacct`` and is not queued (``squeue``) at two checks in a row
    has vanished. Returns ``{job id: how it ended}`` for the vanished ones."""
    vanished: dict[str, str] = {}
    missing: set[str] = set()  # no result, no state, not queued at the last check
    pending = list(jobs)
    last = time.monotonic()
    while pending:
        pending = [job for job in pending if job.job_id not in vanished and not job.done()]
        if not pending:
            break
        time.sleep(1.0)
        if time.monotonic() - last < STATE_INTERVAL:
            continue
        last = time.monotonic()
        pending[0].watcher.update()  # every task's state in one sacct call
        unknown = [job for job in pending if _state(job) == "UNKNOWN"
                   and not job.paths.result_pickle.exists()]
        queued = _queued({job.job_id.partition("_")[0] for job in unknown}) if unknown else None
        gone = set() if queued is None else {job.job_id for job in unknown} - queued
        for job_id in gone & missing:
            vanished[job_id] = ("left the queue, and sacct does not say how it ended "
                                "(is job accounting down?)")
        missing = gone
    deadline = time.monotonic() + RESULT_GRACE
    while time.monotonic() < deadline and any(
            _state(job) == "COMPLETED" and not job.paths.result_pickle.exists()
            for job in jobs):
        time.sleep(1.0)  # completed, its result not seen yet (a network file system)
    return vanished


def _queued(array_ids: set[str]) -> set[str] | None:
    """The tasks of the arrays ``array_ids`` that SLURM still has queued or running (``None``
    if ``squeue`` does not answer)."""
    try:
        done = subprocess.run(["squeue", "--noheader", "--array", "--format=%i",
                               "--jobs", ",".join(sorted(array_ids))],
                              capture_output=True, text=True, timeout=COMMAND_TIMEOUT)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if done.returncode != 0 and "Invalid job id" not in done.stderr:
        return None
    return {line.strip() for line in done.stdout.splitlines() if line.strip()}


def _state(job: Any) -> str:
    """The task's state as ``sacct`` last reported it (``CANCELLED``, not ``CANCELLED by
    0``); ``UNKNOWN`` if it has none."""
    state = job.watcher.get_state(job.job_id, mode="cache")
    return str(state).split()[0] if str(state).strip() else "UNKNOWN"


def _last_line(text: str) -> str:
    """The exception line of a traceback in ``text``."""
    lines = [line.strip() for line in text.splitlines()
             if line.strip() and not line.startswith(("-", " "))]
    errors = [line for line in lines if "Error" in line or "Exception" in line]
    return (errors or lines or ["no message"])[-1][:200]


#: Overrides left out of a task's description: the same for every task of the sweep.
_COMMON = ("launcher=", "results_dir=", "study=", "hydra.", "experiment=")


def _describe(job_id: str, failure: str, overrides: Sequence[str]) -> str:
    """The summary's line for a task without a result: its id, what happened, its runs."""
    shown = " ".join(o.removeprefix("++") for o in overrides
                     if not o.removeprefix("++").startswith(_COMMON))
    return f"task {job_id} {failure}: its runs are not stored ({shown[:120]})"
