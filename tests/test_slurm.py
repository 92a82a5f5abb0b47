"""``launcher=slurm`` on a real SLURM cluster: the one-node cluster of ``make slurm``
(``.ci/slurm``: Debian's SLURM on 127.0.0.1, with job accounting), which ``.ci/run`` starts
before the tests and stops after them.

CI sets ``METAKNOT_SLURM=1``: these tests then fail if SLURM is down. Without it (a machine
where nobody ran ``make slurm``) they are skipped, with a reason that says how to start it.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from metaknot.experiments.store import load_study

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("slurm")]
ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}
#: The small study: two optimizers, two seeds, one seed curve.
STUDY = ("optimizer=ga,random_search", "problem=archimedean", "seed=0,1", "budget=300")


def slurm_down() -> str | None:
    """Why SLURM cannot take jobs here, or ``None`` if its node answers."""
    try:
        done = subprocess.run(["sinfo", "--noheader", "--format=%t"], capture_output=True,
                              text=True, timeout=30)
    except FileNotFoundError:
        return "sinfo is not installed"
    except subprocess.TimeoutExpired:
        return "sinfo does not answer"
    states = done.stdout.split()
    if done.returncode != 0 or not states:
        return (done.stderr.strip().splitlines() or ["sinfo lists no node"])[0]
    if not {"idle", "mix", "alloc"} & set(states):
        return f"no node is up (sinfo: {' '.join(states)})"
    return None


@pytest.fixture(scope="module")
def cluster() -> None:
    reason = slurm_down()
    if reason is None:
        return
    message = f"SLURM is not running: start it with make slurm ({reason})"
    if os.environ.get("METAKNOT_SLURM") == "1":
        pytest.fail(message)
    pytest.skip(message)


def metaknot(*args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "metaknot.cli", "run", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout, env=ENV)


def best_values(study_dir: Path) -> dict[str, tuple]:
    runs = load_study(study_dir).runs
    assert runs.run_id.is_unique
    return {row.run_id: (row.status, row.best_f, row.rmse, row.n_control_points)
            for row in runs.itertuples()}


def test_a_study_on_slurm_stores_what_joblib_stores(cluster, tmp_path):
    """Every run of the small study is stored once, with the best values of the same study
    under joblib (which runs first: it also compiles the kernels, if no test has)."""
    local = metaknot("-m", "launcher=joblib", *STUDY, f"results_dir={tmp_path / 'joblib'}",
                     "study=small", cwd=tmp_path)
    assert local.returncode == 0, local.stderr
    started = time.monotonic()
    done = metaknot("-m", "launcher=slurm", *STUDY, f"results_dir={tmp_path / 'slurm'}",
                    "study=small", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert re.search(r"SLURM job \d+: 4 tasks", done.stderr), done.stderr
    assert "4 ok; 4 of 4 runs stored" in done.stderr, done.stderr
    expected = best_values(tmp_path / "joblib" / "small")
    assert len(expected) == 4 and all(status == "ok" for status, *_ in expected.values())
    assert best_values(tmp_path / "slurm" / "small") == expected
    print(f"4 runs on SLURM in {time.monotonic() - started:.1f} s")


def kill_wait() -> int:
    """KillWait of the cluster: seconds from scancel's SIGTERM to its SIGKILL."""
    shown = subprocess.run(["scontrol", "show", "config"], capture_output=True, text=True,
                           timeout=30).stdout
    found = re.search(r"^KillWait\s*=\s*(\d+)", shown, re.MULTILINE)
    assert found, "scontrol show config does not show KillWait"
    return int(found.group(1))


def running_task(name: str, timeout: float = 120) -> str:
    """The id of the first task of the job ``name`` that SLURM runs (``12_0``)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        listed = subprocess.run(["squeue", "--noheader", "--name", name, "--states=RUNNING",
                                 "--format=%i"], capture_output=True, text=True, timeout=30)
        tasks = listed.stdout.split()
        if tasks:
            return tasks[0]
        time.sleep(0.1)
    raise AssertionError(f"no task of {name} ran within {timeout:.0f} s")


def test_a_cancelled_task_is_one_line_and_the_same_command_computes_only_its_runs(
        cluster, tmp_path):
    """Three single-run tasks of a few seconds each on two CPUs; ``scancel`` of the first
    that runs, as soon as it runs (SLURM kills it 3 s later: KillWait in .ci/slurm, and the
    task needs more than that). The leader waits for the other two, names the cancelled
    task in one line and exits 1; the same command then computes its run alone: three runs
    stored, each once."""
    assert kill_wait() <= 5, "this test needs KillWait <= 5 s in slurm.conf (.ci/slurm sets 3)"
    name = f"metaknot-test-{os.getpid()}"
    args = ("-m", "launcher=slurm", f"hydra.launcher.name={name}", "optimizer=ga",
            "problem=archimedean", "seed=0,1,2", "budget=30000", "hydra.sweeper.runs_per_job=1",
            f"results_dir={tmp_path}", "study=cancel")
    sweep = subprocess.Popen([sys.executable, "-m", "metaknot.cli", "run", *args], cwd=tmp_path,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    try:
        task = running_task(name)
        subprocess.run(["scancel", task], check=True, timeout=30)
        _, err = sweep.communicate(timeout=600)
    finally:
        if sweep.poll() is None:
            sweep.kill()
            subprocess.run(["scancel", "--name", name], timeout=30)
    assert sweep.returncode == 1, err
    assert "Traceback" not in err and "UncompletedJobError" not in err, err
    lines = err.strip().splitlines()
    assert lines[-3] == f"study {tmp_path / 'cancel'}: 2 ok; 2 of 3 runs stored", err
    assert re.fullmatch(rf"  task {task} ended CANCELLED: its runs are not stored \(.*seed=\d"
                        r".*\)", lines[-2]), err
    assert lines[-1].startswith("  run the same command"), err
    first = best_values(tmp_path / "cancel")
    assert len(first) == 2

    again = metaknot(*args, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert "3 jobs, 1 to run, 2 already stored" in again.stderr, again.stderr
    assert "1 ok; 3 of 3 runs stored" in again.stderr, again.stderr
    runs = best_values(tmp_path / "cancel")
    assert len(runs) == 3 and all(status == "ok" for status, *_ in runs.values())
    assert {k: runs[k] for k in first} == first  # the stored runs were left as they were
    study = tmp_path / "cancel"
    assert len(list((study / "runs").iterdir())) == 3
    assert not (study / "failed").exists() or not list((study / "failed").iterdir())
    assert not (study / "tmp").exists() or not list((study / "tmp").iterdir())


def test_a_partition_the_cluster_lacks_is_one_line_before_anything_is_submitted(
        cluster, tmp_path):
    done = metaknot("-m", "launcher=slurm", "hydra.launcher.partition=nosuch", *STUDY,
                    f"results_dir={tmp_path}", "study=wrong", cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    assert re.fullmatch(r"metaknot run: error: hydra\.launcher\.partition=nosuch: no such "
                        r"partition on this cluster \(it has \w.*\)",
                        done.stderr.strip().splitlines()[-1]), done.stderr
    assert "Traceback" not in done.stderr and "SLURM job" not in done.stderr
