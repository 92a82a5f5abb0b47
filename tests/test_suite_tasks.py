"""The suite's tasks, splits and studies: tasks resolved per instance, a fixed stratified split,
the ``suite`` config group in step with it, and ``metaknot run problem=suite``."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from metaknot.experiments.run import run_id
from metaknot.experiments.spec import ConfigError, run_spec
from metaknot.suite import base_instances, get_instance, instances
from metaknot.suite.splits import SPLITS, config_text, split
from metaknot.suite.tasks import fixed_k_sizes, get_task, tasks

CONF = Path(__file__).parents[1] / "experiments" / "conf"


def test_fixed_k_follows_its_rule() -> None:
    assert fixed_k_sizes(256, 252) == (8, 16)
    assert fixed_k_sizes(49, 45) == (3, 7)
    assert fixed_k_sizes(10, 3) == (2, 3)  # capped at what the data carry
    for instance in base_instances():
        problem = get_task(instance, "fixed_k_large.indices").problem()
        k = problem.n_knots
        assert k == min(max(fixed_k_sizes(problem.curve.n_points, 10**9)[0] + 1,
                            math.isqrt(problem.curve.n_points)), problem.curve.max_interior_knots)


def test_tolerance_tasks_follow_the_noise() -> None:
    clean, noisy = get_instance("humps"), get_instance("humps+noise0.03s0")
    assert [t.id for t in tasks(clean) if t.kind == "tolerance"] == ["tolerance_1e-2",
                                                                       "tolerance_1e-3"]
    (within,) = [t for t in tasks(noisy) if t.kind == "tolerance"]
    assert within.id == "tolerance_noise" == get_task(noisy, "tolerance").id
    assert get_task(clean, "tolerance").id == "tolerance_1e-3"
    # RMSE within 1.05 sigma, sigma being 3 % of the clean data's range
    y = clean.point_set().points
    sigma = 0.03 * (y.max() - y.min())
    assert within.objective == {"name": "error_bounded", "tolerance": pytest.approx(1.05 * sigma),
                                "metric": "rmse"}
    # the seed task's floor is the noise: an interpolating mask scores no better than a fit
    # within the noise
    seed = get_task(noisy, "seed").problem()
    everything = np.ones((1, seed.encoding.n_var), dtype=np.int64)
    everything[0, [0, -1]] = 0  # N - 4 knots: N control points, interpolation
    fit = seed.decode(everything[0]).metrics
    assert fit["rmse"] < sigma  # interpolation follows the noise ...
    floor_value = fit["n_control_points"] * sigma * np.sqrt(seed.data.n_points)
    assert seed.evaluate(everything)[0] == pytest.approx(floor_value, rel=1e-9)  # ... for nothing
    with pytest.raises(ValueError, match="has no task 'tolerance_noise'"):
        get_task(clean, "tolerance_noise")


def test_splits_are_stratified_and_keep_noisy_variants_with_their_base() -> None:
    train, test = set(split("train")), set(split("test"))
    assert not train & test and train | test == set(split("all"))
    assert len(split("all")) == len(instances(plugins=False))
    for family in {i.family for i in base_instances()}:
        ids = [i.id for i in base_instances() if i.family == family]
        in_test = [i for i in ids if i in test]
        assert len(in_test) == len(ids) // 3 and set(ids) - set(in_test) <= train
    for noisy in (i for i in instances(plugins=False) if i.noise):
        base = noisy.id.split("+")[0]
        assert (noisy.id in test) == (base in test)
    assert len(split("mini")) == len({i.family for i in base_instances()})
    with pytest.raises(ValueError, match="unknown suite split"):
        split("validation")


@pytest.mark.parametrize("name", SPLITS)
def test_suite_configs_are_in_step_with_the_splits(name: str) -> None:
    """experiments/conf/suite/<split>.yaml is what write_configs writes today (run
    ``python -c "from metaknot.suite.splits import write_configs;
    write_configs('experiments/conf/suite')"`` after changing the suite)."""
    assert (CONF / "suite" / f"{name}.yaml").read_text() == config_text(name)


def config(**problem):
    return {"study": "s", "results_dir": "results", "budget": 100, "seed": 0,
            "problem": {"curve": None, "points": None, "degree": 3,
                        "parameterization": "centripetal", **problem},
            "encoding": {"kind": "mask"}, "objective": {"name": "paper"},
            "optimizer": {"_name_": "random_search"}}


def test_a_task_sets_the_encoding_and_objective_of_a_run() -> None:
    spec = run_spec(config(instance="titanium", task="fixed_k_small.indices"))
    assert spec.config["encoding"] == {"kind": "indices", "n_knots": 3}
    assert spec.config["objective"] == {"name": "rmse"}
    assert spec.config["problem"]["name"] == "titanium"
    problem = spec.build_problem()
    expected = get_task("titanium", "fixed_k_small.indices").problem()
    np.testing.assert_array_equal(problem.points, expected.points)
    X = expected.sample(np.random.default_rng(0), 5)
    np.testing.assert_array_equal(problem.evaluate(X), expected.evaluate(X))
    # closedness comes from the instance; ids differ by instance and task
    assert run_spec(config(instance="digit_0")).config["problem"]["closed"] is True
    ids = {run_id(run_spec(config(instance=i, task=t)).config)
           for i in ("titanium", "humps") for t in ("seed", "tolerance")}
    assert len(ids) == 4


@pytest.mark.parametrize("problem, message", [
    ({"instance": "titanum"}, "Did you mean 'titanium'"),
    ({"instance": "titanium", "task": "fixed_k_huge"}, "has no task 'fixed_k_huge'"),
    ({"task": "seed", "curve": "archimedean"}, "needs a suite instance"),
    ({"instance": "titanium", "curve": "archimedean"}, "replaces problem.curve"),
])
def test_bad_suite_settings_are_named(problem, message) -> None:
    with pytest.raises(ConfigError, match=message):
        run_spec(config(**problem))


def test_a_suite_study_from_the_command_line(tmp_path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", "metaknot.cli", "run", "-m", "suite=mini", "problem.task=seed",
         "optimizer=random_search", "budget=30", "study=mini", f"results_dir={tmp_path}"],
        capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    from metaknot.experiments import load_study

    runs = load_study(tmp_path / "mini").runs
    assert sorted(runs["data"]) == sorted(split("mini"))
    tasks_seen = {json.loads(c)["problem"]["task"] for c in runs["config"]}
    assert tasks_seen == {"seed"} and set(runs["status"]) == {"ok"}
    # the records name the instance, its family and the task
    assert list(runs["suite.instance"]) == list(runs["data"])
    assert set(runs["suite.task"]) == {"seed"}
    assert sorted(runs["suite.family"]) == sorted(get_instance(i).family for i in split("mini"))


def test_the_knotbench_study_covers_the_suite(tmp_path) -> None:
    """experiment=knotbench sweeps every suite instance, its tolerance, seed and
    fixed_k_small.indices tasks and the six methods; a small slice of it runs."""
    from hydra import compose, initialize_config_dir

    from metaknot.experiments.app import register_hydra_plugins

    register_hydra_plugins()  # the study sweeper, as metaknot run registers it
    with initialize_config_dir(version_base="1.3", config_dir=str(CONF)):
        cfg = compose("config", overrides=["experiment=knotbench"], return_hydra_config=True)
    params = cfg.hydra.sweeper.params
    assert params["problem.instance"].split(",") == split("all")
    assert params["problem.task"] == "tolerance,seed,fixed_k_small.indices"
    assert len(params["optimizer"].split(",")) == 6 and params["seed"] == "range(0,10)"
    assert cfg.study == "knotbench" and cfg.budget == 3000
    done = subprocess.run(
        [sys.executable, "-m", "metaknot.cli", "run", "-m", "experiment=knotbench_free",
         "suite=mini", "problem.task=fixed_k_small.free", "seed=0", "budget=40",
         f"results_dir={tmp_path}"], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    from metaknot.experiments import load_study

    runs = load_study(tmp_path / "knotbench").runs
    assert len(runs) == 3 * len(split("mini"))
    assert set(runs["label"]) == {"nlopt-bobyqa", "nlopt-lbfgs", "varpro"}
    assert set(runs["suite.task"]) == {"fixed_k_small.free"} and set(runs["status"]) == {"ok"}
