"""How the study sweeper hands runs to the launcher: seeds batched into jobs, the largest
jobs first, and the batch size chosen from the launcher's workers."""

from __future__ import annotations

import os
from types import SimpleNamespace

import pytest
from omegaconf import OmegaConf

from metaknot.experiments.spec import ConfigError
from metaknot.experiments.sweep import batch_jobs, launcher_workers, runs_per_job


def plan_of(jobs: list[tuple[str, int, int]]) -> list[tuple[list[str], SimpleNamespace]]:
    """(algorithm, seed, budget) -> the (overrides, spec) pairs of a plan."""
    return [([f"optimizer={a}", f"budget={b}", f"seed={s}"], SimpleNamespace(seed=s, budget=b))
            for a, s, b in jobs]


def test_one_run_per_job_keeps_every_job_and_puts_the_largest_first():
    plan = plan_of([("ga", 0, 100), ("ga", 1, 100), ("dolphin", 0, 900), ("ga", 2, 500)])
    assert batch_jobs(plan, 1) == [
        ["optimizer=dolphin", "budget=900", "seed=0"],
        ["optimizer=ga", "budget=500", "seed=2"],
        ["optimizer=ga", "budget=100", "seed=0"],
        ["optimizer=ga", "budget=100", "seed=1"],
    ]


def test_seeds_of_one_setting_go_together():
    plan = plan_of([("ga", s, 100) for s in range(5)] + [("dolphin", s, 100) for s in range(2)])
    jobs = batch_jobs(plan, 3)
    assert sorted(map(tuple, jobs)) == sorted([
        ("optimizer=ga", "budget=100", "seed=[0,1,2]"),
        ("optimizer=ga", "budget=100", "seed=[3,4]"),
        ("optimizer=dolphin", "budget=100", "seed=[0,1]"),
    ])
    # every run is in exactly one job
    runs = [(j[0], s) for j in jobs for s in j[-1][len("seed=["):-1].split(",")]
    assert sorted(runs) == sorted([(f"optimizer={a}", str(s)) for a, s, _ in
                                   [("ga", s, 0) for s in range(5)]
                                   + [("dolphin", s, 0) for s in range(2)]])
    # the heaviest job (three runs of 100) goes first
    assert jobs[0][-1] == "seed=[0,1,2]"


def test_a_job_without_a_seed_override_stays_alone():
    plan = [(["optimizer=ga"], SimpleNamespace(seed=0, budget=10)),
            (["optimizer=dolphin"], SimpleNamespace(seed=0, budget=10))]
    assert sorted(batch_jobs(plan, 4)) == [["optimizer=dolphin"], ["optimizer=ga"]]


@pytest.mark.parametrize(("setting", "n_runs", "workers", "expected"), [
    (1, 1000, 2, 1), (7, 3, 2, 7), ("auto", 40, 2, 5), ("auto", 1440, 2, 10),
    ("auto", 40, 64, 1), ("auto", 3, 1, 1), ("auto", 40, 1, 10),
])
def test_runs_per_job(setting, n_runs, workers, expected):
    assert runs_per_job(setting, n_runs, workers) == expected


@pytest.mark.parametrize("setting", [0, -1, 2.5, "many", True])
def test_runs_per_job_rejects_bad_settings(setting):
    with pytest.raises(ConfigError, match=r"hydra\.sweeper\.runs_per_job"):
        runs_per_job(setting, 10)


@pytest.mark.parametrize(("launcher", "expected"), [
    ({}, 1),
    ({"_target_": "hydra._internal.core_plugins.basic_launcher.BasicLauncher"}, 1),
    ({"_target_": "hydra_plugins.hydra_joblib_launcher.joblib_launcher.JoblibLauncher",
      "n_jobs": 3}, 3),
    ({"_target_": "hydra_plugins.hydra_joblib_launcher.joblib_launcher.JoblibLauncher",
      "n_jobs": -1}, os.cpu_count()),
])
def test_launcher_workers(launcher, expected):
    """(SLURM's count comes from sinfo: tests/test_slurm_checks.py.)"""
    assert launcher_workers(OmegaConf.create({"hydra": {"launcher": launcher}})) == expected


def test_the_progress_watcher_counts_records_and_failures(tmp_path):
    from metaknot.experiments.sweep import _Watcher

    specs = [SimpleNamespace(study_dir=tmp_path, run_id=f"{i:016x}") for i in range(4)]
    watcher = _Watcher(specs, interval=60)
    (tmp_path / "runs").mkdir()
    (tmp_path / "failed").mkdir()
    (tmp_path / "runs" / f"{0:016x}.parquet").touch()
    (tmp_path / "failed" / f"{1:016x}.20261130T000000Z.1.ab.parquet").touch()
    (tmp_path / "runs" / f"{99:016x}.parquet").touch()  # not one of this sweep's runs
    watcher._update()
    assert watcher.done == 2
    (tmp_path / "runs" / f"{3:016x}.parquet").touch()
    watcher.start()
    watcher.stop()
    assert watcher.done == 3
