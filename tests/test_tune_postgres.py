"""Distributed tuning on a real PostgreSQL server: two workers on one study, one killed with
SIGKILL in the middle of a trial.

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
    try:
        return optuna.load_study(study_name=study, storage=RDBStorage(url)).trials
    except KeyError:  # not created yet
        return []


def test_a_killed_worker_s_trial_fails_and_is_retried_once(postgres_url, tmp_path) -> None:
    n_trials = 10
    study = f"killed-{os.getpid()}"
    command = [sys.executable, "-m", "metaknot.cli", "tune", f"study={study}",
               f"storage={postgres_url}", f"results_dir={tmp_path}", f"n_trials={n_trials}",
               "evaluate=false", "pruner=none", "heartbeat_interval=1", "grace_period=3",
               "max_retry=1", "budget=3000", "train.seeds=3",
               "train.instances=[{curve: archimedean, noise: 0.0}, {curve: vivaldi, noise: 0.0}]"]
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    doomed = subprocess.Popen([*command, "worker_index=0"], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
    survivor = subprocess.Popen([*command, "worker_index=1"], env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
    try:
        deadline = time.monotonic() + 300
        while True:  # both workers inside a trial: the doomed one is mid-trial
            trials = trials_of(postgres_url, study)
            running = [t for t in trials if t.state == TrialState.RUNNING]
            if len(running) == 2 and any(t.state == TrialState.COMPLETE for t in trials):
                break
            assert time.monotonic() < deadline, "the workers never ran trials side by side"
            assert survivor.poll() is None and doomed.poll() is None, \
                (survivor.stdout.read() if survivor.poll() is not None else doomed.stdout.read())
            time.sleep(0.05)
        doomed.send_signal(signal.SIGKILL)
        doomed.wait(timeout=60)
        output, _ = survivor.communicate(timeout=600)
    finally:
        for process in (doomed, survivor):
            if process.poll() is None:
                process.kill()
    assert survivor.returncode == 0, output
    trials = trials_of(postgres_url, study)
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    failed = [t for t in trials if t.state == TrialState.FAIL]
    assert len(complete) == n_trials
    assert not [t for t in trials if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    (killed,) = failed  # the doomed worker's trial, failed by the heartbeat
    retries = [t for t in complete if t.system_attrs.get("failed_trial") == killed.number]
    assert len(retries) == 1  # retried once, counted once
    assert retries[0].params == killed.params
    assert len({t.number for t in trials}) == len(trials)
