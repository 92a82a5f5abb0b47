"""What ``launcher=slurm`` checks before it submits, and how it sizes its tasks, against
stand-in SLURM commands (small scripts on the PATH that answer as sinfo, sacct, squeue and
sbatch do): no cluster needed. The same on a real cluster: tests/test_slurm.py."""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

import pytest
from omegaconf import OmegaConf

from metaknot.experiments import slurm
from metaknot.experiments.spec import ConfigError
from metaknot.experiments.sweep import launcher_workers, runs_per_job, summary

#: sinfo --noheader --exact --format=%P|%a|%c|%D|%m of a cluster of two partitions.
TWO_PARTITIONS = "debug*|up|2|1|21000\nbig|up|64|4|500000\nbig|up|32|2|250000\n"
SACCT_OK = "exit 0"
SACCT_DISABLED = 'echo "sacct: error: Slurm accounting storage is disabled" >&2; exit 1'
SLURM_TARGET = "hydra_plugins.metaknot_study_sweeper.slurm_launcher.SlurmLauncher"


def fake_commands(folder: Path, sinfo: str = TWO_PARTITIONS, sacct: str = SACCT_OK,
                  squeue: str = "") -> Path:
    """Scripts named as SLURM's commands in ``folder/bin``; sbatch and srun record that they
    were called in ``folder/submitted`` and fail."""
    bin_dir = folder / "bin"
    bin_dir.mkdir(exist_ok=True)
    (folder / "sinfo.txt").write_text(sinfo)
    (folder / "squeue.txt").write_text(squeue)
    scripts = {
        "sinfo": f'cat "{folder}/sinfo.txt"',
        "sacct": sacct,
        "squeue": f'cat "{folder}/squeue.txt"',
        "sbatch": f'echo "$@" >> "{folder}/submitted"; echo "sbatch: error: fake" >&2; exit 1',
        "srun": f'echo "$@" >> "{folder}/submitted"; exit 1',
    }
    for name, body in scripts.items():
        path = bin_dir / name
        path.write_text(f"#!/bin/sh\n{body}\n")
        path.chmod(0o755)
    return bin_dir


@pytest.fixture
def cluster(tmp_path, monkeypatch):
    """Stand-in SLURM commands first on the PATH; returns their folder."""
    bin_dir = fake_commands(tmp_path)
    monkeypatch.setenv("PATH", f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    return tmp_path


def launcher(**settings):
    return {"_target_": SLURM_TARGET, "partition": None, "cpus_per_task": 1, "mem_gb": 4,
            "array_parallelism": 256, **settings}


def test_partitions_are_read_from_sinfo(cluster):
    found = slurm.partitions()
    assert sorted(found) == ["big", "debug"]
    assert found["debug"].default and not found["big"].default
    assert found["big"].cpus == 64 * 4 + 32 * 2
    assert (found["big"].node_cpus, found["big"].node_memory_mb) == (64, 500000)
    assert slurm.check(launcher()).name == "debug"
    assert slurm.check(launcher(partition="big", mem_gb=400, cpus_per_task=64)).name == "big"


@pytest.mark.parametrize(("settings", "message"), [
    ({"partition": "gpu"},
     "hydra.launcher.partition=gpu: no such partition on this cluster (it has debug, big)"),
    ({"mem_gb": 32},
     "hydra.launcher.mem_gb=32: the nodes of the partition debug have at most 20.5 GB"),
    ({"cpus_per_task": 4},
     "hydra.launcher.cpus_per_task=4: the nodes of the partition debug have at most 2 CPUs"),
])
def test_a_setting_the_cluster_cannot_take_is_one_line_naming_it(cluster, settings, message):
    with pytest.raises(ConfigError) as caught:
        slurm.check(launcher(**settings))
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_no_default_partition_and_a_partition_that_is_down(cluster):
    (cluster / "sinfo.txt").write_text("debug|up|2|1|21000\nold|down|2|1|21000\n")
    with pytest.raises(ConfigError, match="no default partition; choose one of debug, old"):
        slurm.check(launcher())
    with pytest.raises(ConfigError, match="partition=old: the partition is down"):
        slurm.check(launcher(partition="old"))


def test_a_cluster_without_job_accounting_is_refused(cluster):
    fake_commands(cluster, sacct=SACCT_DISABLED)
    with pytest.raises(ConfigError) as caught:
        slurm.check(launcher())
    message = str(caught.value)
    assert message.startswith("launcher=slurm needs SLURM's job accounting, and sacct fails "
                              "here (Slurm accounting storage is disabled)")
    assert "\n" not in message


def test_a_machine_without_slurm_is_one_line(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))  # no sinfo there
    with pytest.raises(ConfigError, match="sinfo is not on the PATH: this machine has no SLURM"):
        slurm.check(launcher())


def test_auto_batches_count_the_partition_s_cpus_not_array_parallelism(cluster):
    """288 runs on a cluster of two CPUs: about four tasks per CPU, ten runs each (one run per
    task when array_parallelism, 256, was taken for the workers)."""
    config = OmegaConf.create({"hydra": {"launcher": launcher()}})
    assert launcher_workers(config) == 2
    assert runs_per_job("auto", 288, launcher_workers(config)) == 10
    big = OmegaConf.create({"hydra": {"launcher": launcher(partition="big", cpus_per_task=2)}})
    assert launcher_workers(big) == (64 * 4 + 32 * 2) // 2
    small = OmegaConf.create({"hydra": {"launcher": launcher(partition="big",
                                                             array_parallelism=16)}})
    assert launcher_workers(small) == 16


def test_without_sinfo_the_workers_are_array_parallelism(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    assert slurm.workers(launcher(array_parallelism=64)) == 64


def test_a_sweep_the_cluster_cannot_take_is_refused_before_anything_is_submitted(cluster):
    """From the command line: one line, exit status 2, no sbatch call."""
    fake_commands(cluster, sacct=SACCT_DISABLED)
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    common = [sys.executable, "-m", "metaknot.cli", "run", "-m", "launcher=slurm",
              "optimizer=ga", "problem=archimedean", "seed=0,1", "budget=100",
              f"results_dir={cluster / 'results'}"]
    for extra, message in (
            ([], "metaknot run: error: launcher=slurm needs SLURM's job accounting, and sacct "
                 "fails here (Slurm accounting storage is disabled)"),
            (["hydra.launcher.partition=gpu"], "metaknot run: error: hydra.launcher.partition="
                                               "gpu: no such partition on this cluster")):
        done = subprocess.run([*common, *extra], cwd=cluster, capture_output=True, text=True,
                              timeout=300, env=env)
        assert done.returncode == 2, done.stderr
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        assert lines[-1].startswith(message), done.stderr
        assert "Traceback" not in done.stderr
    assert not (cluster / "submitted").exists()


def test_the_summary_names_each_task_without_a_result_then_counts_the_rest(tmp_path):
    ended = [f"task 7_{i} ended CANCELLED: its runs are not stored (seed={i})"
             for i in range(slurm.SHOWN_TASKS + 5)]
    lines = summary(tmp_path, [{"status": "ok"}] * 3, Counter(), 3, 28, ended)
    assert lines[0] == f"study {tmp_path}: 3 ok; 3 of 28 runs stored"
    assert lines[1:1 + slurm.SHOWN_TASKS] == [f"  {line}" for line in
                                             ended[: slurm.SHOWN_TASKS]]
    assert lines[-2].startswith("  ... and 5 more tasks without a result")
    assert lines[-1].startswith("  run the same command")


class _Watcher:
    """submitit's SLURM watcher when sacct fails: no state for any task."""

    def update(self) -> None:
        pass

    def get_state(self, job_id: str, mode: str = "standard") -> str:
        return "UNKNOWN"


def test_a_task_that_left_the_queue_without_a_state_is_given_up(cluster, monkeypatch):
    """sacct failing during a sweep: a task without a result that squeue no longer lists, at
    two checks in a row, has ended; one still listed is waited for."""
    monkeypatch.setattr(slurm, "STATE_INTERVAL", 0.0)
    monkeypatch.setattr(slurm, "RESULT_GRACE", 0.0)
    (cluster / "squeue.txt").write_text("9_1\n")
    watcher = _Watcher()
    result = cluster / "9_1_result.pkl"

    def job(job_id: str, path: Path) -> SimpleNamespace:
        return SimpleNamespace(job_id=job_id, watcher=watcher, paths=SimpleNamespace(
            result_pickle=path), done=path.exists)

    jobs = [job("9_0", cluster / "9_0_result.pkl"), job("9_1", result)]
    start = time.monotonic()
    threading.Timer(4.0, result.touch).start()  # 9_1 ends with a result later
    vanished = slurm._wait(jobs)
    assert list(vanished) == ["9_0"] and "left the queue" in vanished["9_0"]
    assert time.monotonic() - start >= 4.0  # 9_1, still queued, was waited for
