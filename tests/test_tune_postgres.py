"""Distributed tuning on a real PostgreSQL server: two workers on one study, one killed with
SIGKILL inside a trial at a known point (it holds there, ``METAKNOT_TUNE_HOLD_WORKER``).

The server is the one ``.ci/run`` starts (``METAKNOT_TEST_POSTGRES_URL``) or, without it, a
private one this module starts on 127.0.0.1 with ``.ci/postgres`` (Debian's ``postgresql``
package) and stops at the end.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import optuna
import pytest
from optuna.storages import RDBStorage
from optuna.trial import TrialState

from metaknot.experiments.tuning.runner import HOLD_WORKER_ENV
from tests.test_tune import wait_until_held

ROOT = Path(__file__).resolve().parent.parent
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("postgres")]


@pytest.fixture(scope="module")
def postgres_url():
    url = os.environ.get("METAKNOT_TEST_POSTGRES_URL")
    if url:
        yield url
        return
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    folder = tempfile.mkdtemp(prefix="metaknot-pg-", dir="/tmp")
    started = subprocess.run([str(ROOT / ".ci" / "postgres"), "start", folder, str(port)],
                             capture_output=True, text=True, timeout=120)
    assert started.returncode == 0, f"PostgreSQL did not start: {started.stderr}"
    try:
        yield started.stdout.strip()
    finally:
        subprocess.run([str(ROOT / ".ci" / "postgres"), "stop", folder], timeout=120)


def trials_of(url: str, study: str) -> list[optuna.trial.FrozenTrial]:
    return optuna.load_study(study_name=study, storage=RDBStorage(url)).trials


def test_a_killed_worker_s_trial_is_failed_and_retried_even_after_the_study_ends(
        postgres_url, tmp_path) -> None:
    """Two workers on one study; one is killed inside a trial at a known point (it holds there
    and says so), the other runs the study to its end, usually within the grace period. The
    survivor must not leave the dead trial RUNNING: it fails it once its heartbeat is
    ``grace_period`` old and runs the retry."""
    n_trials = 3
    study = f"killed-{os.getpid()}"
    command = [sys.executable, "-m", "metaknot.cli", "tune", f"study={study}",
               f"storage={postgres_url}", f"results_dir={tmp_path}", f"n_trials={n_trials}",
               "evaluate=false", "pruner=none", "heartbeat_interval=1", "grace_period=6",
               "max_retry=1", "budget=300", "train.seeds=1",
               "train.instances=[{curve: archimedean, noise: 0.0}, {curve: vivaldi, noise: 0.0}]"]
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    doomed = subprocess.Popen([*command, "worker_index=0"], env={**env, HOLD_WORKER_ENV: "0"},
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    survivor = subprocess.Popen([*command, "worker_index=1"], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
    try:
        held = wait_until_held(tmp_path / study, 0, doomed)
        doomed.send_signal(signal.SIGKILL)
        doomed.wait(timeout=60)
        output, _ = survivor.communicate(timeout=300)
    finally:
        for process in (doomed, survivor):
            if process.poll() is None:
                process.kill()
    assert survivor.returncode == 0, output
    trials = trials_of(postgres_url, study)
    assert not [t for t in trials if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    failed = [t for t in trials if t.state == TrialState.FAIL]
    assert [t.number for t in failed] == [held["trial"]]
    assert failed[0].user_attrs["worker"] == f"{socket.gethostname()}:{doomed.pid}"
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    # the retry counts towards n_trials, or runs after them when the study ended first
    assert n_trials <= len(complete) <= n_trials + 1
    retries = [t for t in complete if t.system_attrs.get("failed_trial") == held["trial"]]
    assert len(retries) == 1 and retries[0].params == failed[0].params
    assert set(failed[0].params) >= {"population", "pp1", "power"}  # sampled before the kill
    assert len({t.number for t in trials}) == len(trials)


OPEN_STORAGE = """
import pathlib, sys, time, types
from metaknot.experiments.tuning.runner import open_storage
spec = types.SimpleNamespace(study_dir=pathlib.Path(sys.argv[2]), storage=sys.argv[1],
                             workers=2, heartbeat_interval=1, grace_period=6, max_retry=1)
time.sleep(max(0.0, float(sys.argv[3]) - time.time()))
open_storage(spec)
"""


def test_workers_opening_a_new_database_at_once_all_get_the_storage(postgres_url, tmp_path):
    """Workers started together on a database without Optuna's tables all create them at
    once; PostgreSQL then refuses all but one (a duplicate key in its catalogue). Each worker
    must still open the storage."""
    import psycopg

    server = postgres_url.replace("+psycopg", "")
    name = f"fresh_{os.getpid()}_{time.monotonic_ns()}"
    with psycopg.connect(server, autocommit=True) as connection:
        connection.execute(f"CREATE DATABASE {name}")
    fresh = postgres_url.rsplit("/", 1)[0] + f"/{name}"
    try:
        start = time.time() + 8  # every worker imports Optuna first, then they start together
        workers = [subprocess.Popen([sys.executable, "-c", OPEN_STORAGE, fresh, str(tmp_path),
                                     str(start)], stdout=subprocess.PIPE,
                                    stderr=subprocess.STDOUT, text=True) for _ in range(6)]
        outputs = [worker.communicate(timeout=120)[0] for worker in workers]
        assert [w.returncode for w in workers] == [0] * 6, "\n".join(outputs)
        assert optuna.get_all_study_summaries(RDBStorage(fresh)) == []  # the tables are there
    finally:
        with psycopg.connect(server, autocommit=True) as connection:
            connection.execute(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)")
