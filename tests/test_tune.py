"""``metaknot tune``: search spaces, trials on training instances, resume, outputs, held-out
evaluation, several workers and bad configurations."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import optuna
import pytest
import yaml
from optuna.trial import TrialState

from metaknot.experiments.spec import ConfigError, run_spec
from metaknot.experiments.store import load_study
from metaknot.experiments.tuning import TRAIN_SEED_OFFSET, tune, tune_spec
from metaknot.experiments.tuning.app import CONFIG_DIR
from metaknot.experiments.tuning.runner import (
    HOLD_WORKER_ENV,
    evaluate_setting,
    open_storage,
    open_study,
    references,
    trial_objective,
)
from metaknot.experiments.tuning.space import SearchSpace

#: A small study: two training instances, one seed, 300 evaluations per run.
SMALL = ["budget=300", "train.seeds=1", "test.seeds=2",
         "train.instances=[{curve: archimedean, noise: 0.0}, {curve: vivaldi, noise: 0.0}]",
         "test.instances=[{curve: epitrochoid, noise: 0.0}]"]


def compose(tmp_path: Path, *overrides: str):
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        return hydra_compose("tuning", overrides=[f"results_dir={tmp_path}", *SMALL,
                                                  *overrides])


def spec_of(tmp_path: Path, *overrides: str):
    return tune_spec(compose(tmp_path, *overrides))


def stored_trials(spec):
    return optuna.load_study(study_name=spec.study, storage=open_storage(spec)).trials


def wait_until_held(study_dir: Path, worker_index: int | str, process: subprocess.Popen,
                    timeout: float = 300) -> dict:
    """The trial and pid of the worker ``worker_index`` once it holds inside a trial
    (``HOLD_WORKER_ENV``), or the pid of the command held in its reference runs
    (``worker_index="references"``); fails if ``process`` (the command that runs it) ends
    first."""
    marker = study_dir / ("references.held" if worker_index == "references"
                          else f"worker-{worker_index}.held")
    deadline = time.monotonic() + timeout
    while not marker.exists():
        assert process.poll() is None, f"worker {worker_index} ended before it held:\n" \
                                       f"{process.stdout.read()}"
        assert time.monotonic() < deadline, f"worker {worker_index} never held"
        time.sleep(0.05)
    return json.loads(marker.read_text())


def stop(process: subprocess.Popen, sig: int) -> str:
    """Send ``sig`` to ``process`` (SIGINT to its process group, as Ctrl-C does) and return
    its stderr once it has ended; kills its group if it has not ended within 120 s."""
    try:
        if sig == signal.SIGINT:
            os.killpg(process.pid, sig)
        else:
            os.kill(process.pid, sig)
        _, stderr = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    return stderr


def stop_a_held_tune(tmp_path: Path, how: str, study: str, *overrides: str,
                     multirun: bool = False) -> None:
    """Start ``metaknot tune [-m] ... workers=2`` (``overrides`` added), hold its spawned
    worker inside a trial of ``study``, signal it as ``how`` says and check what a stopped tune
    leaves: the worker stopped, no trial RUNNING (the held one FAIL), trials.csv written, one
    line on stderr, exit 128 + the signal."""
    sig = signal.SIGTERM if how.startswith("SIGTERM") else signal.SIGINT
    command = [sys.executable, "-m", "metaknot.cli", "tune", *(["-m"] if multirun else []),
               f"results_dir={tmp_path}", *SMALL, "n_trials=40", "workers=2", "evaluate=false",
               "pruner=none", *overrides]
    parent = subprocess.Popen(command, env={**os.environ, HOLD_WORKER_ENV: "1"},
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              start_new_session=True)
    try:
        held = wait_until_held(tmp_path / study, 1, parent)
    except BaseException:
        os.killpg(parent.pid, signal.SIGKILL)
        raise
    stderr = stop(parent, sig)
    assert parent.returncode == 128 + sig, stderr
    (line,) = stderr.strip().splitlines()
    assert re.fullmatch(rf"tune {study}: added \d+ trials? \(.*\d+ fail.*\); the study holds "
                        rf"\d+; interrupted \({signal.Signals(sig).name}\): its running trials "
                        r"marked FAIL; run the same command to resume", line), line
    with pytest.raises(ProcessLookupError):
        os.kill(held["pid"], 0)  # the spawned worker has ended
    trials = stored_trials(spec_of(tmp_path, "workers=2", f"study={study}"))
    assert not [t for t in trials if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    assert [t.state for t in trials if t.number == held["trial"]] == [TrialState.FAIL]
    assert (tmp_path / study / "trials.csv").exists()


# --- search spaces ------------------------------------------------------------------------

NAMES = {"population", "pp1", "power", "re", "epsilon", "fitness", "loops"}


@pytest.mark.parametrize(("space", "message"), [
    ({}, "empty"),
    ({"pp1": {"type": "float", "low": 0.5, "high": 0.5}}, "low must be below high"),
    ({"pp1": {"type": "float", "low": 0.6, "high": 0.1}}, "empty range"),
    ({"speed": {"type": "float", "low": 0, "high": 1}}, "no such hyperparameter"),
    ({"pp1": {"type": "float", "low": 0.0, "high": 1, "log": True}}, "log scale needs low > 0"),
    ({"fitness": {"type": "categorical", "choices": []}}, "non-empty list"),
    ({"fitness": {"type": "categorical", "choices": ["rank", "rank"]}}, "repeated"),
    ({"population": {"type": "int", "low": 1.5, "high": 9}}, "integer for type int"),
    ({"pp1": {"type": "uniform", "low": 0, "high": 1}}, "int, float or categorical"),
    ({"pp1": {"type": "float", "low": 0, "high": 1, "when": {"encoding": "mask"}}},
     "not a categorical parameter listed before"),
    ({"encoding": {"type": "categorical", "choices": ["mask"]},
      "re": {"type": "int", "low": 1, "high": 3, "when": {"encoding": "indices"}}},
     "never be sampled"),
    ({"encoding": {"type": "categorical", "choices": ["mask", "free"]}}, "choices among"),
    ({"encoding": {"type": "categorical", "choices": ["mask", "indices"]},
      "n_knots": {"type": "int", "low": 4, "high": 9}}, "when: {encoding: indices}"),
])
def test_bad_search_spaces_are_named(space, message) -> None:
    with pytest.raises(ConfigError, match=message):
        SearchSpace(space, NAMES, "dolphin")


def test_conditional_parameters_are_sampled_only_when_they_apply() -> None:
    space = SearchSpace({
        "encoding": {"type": "categorical", "choices": ["mask", "indices"]},
        "n_knots": {"type": "int", "low": 4, "high": 40, "log": True,
                    "when": {"encoding": "indices"}},
        "pp1": {"type": "float", "low": 0.05, "high": 0.5},
    }, NAMES, "dolphin")
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=1))
    seen = set()
    for _ in range(40):
        trial = study.ask()
        values = space.suggest(trial)
        assert ("n_knots" in values) == (values["encoding"] == "indices")
        assert 0.05 <= values["pp1"] <= 0.5
        if "n_knots" in values:
            assert 4 <= values["n_knots"] <= 40 and isinstance(values["n_knots"], int)
        seen.add(values["encoding"])
        study.tell(trial, 0.0)
    assert seen == {"mask", "indices"}


def test_trial_setting_turns_space_values_into_a_problem(tmp_path) -> None:
    spec = spec_of(tmp_path)
    params, encoding = spec.trial_setting({"encoding": "indices", "n_knots": 12, "pp1": 0.2})
    assert encoding == {"kind": "indices", "n_knots": 12}
    assert params == {"pp1": 0.2}
    params, encoding = spec.trial_setting({"encoding": "mask", "population": 30})
    assert encoding == {"kind": "mask", "density": 0.5} and params == {"population": 30}


# --- bad configurations: one line, before any trial ----------------------------------------

@pytest.mark.parametrize(("override", "message"), [
    ("n_trials=0", "n_trials"),
    ("~tune.space", "empty"),
    ("+tune.space.speed={type: float, low: 0, high: 1}", "no such hyperparameter"),
    ("+tune.fixed.pp1=0.2", "fixed and searched at once"),
    ("test.instances=[{curve: vivaldi, noise: 0.0}]", "also a training instance"),
    ("train.instances=[]", "non-empty list"),
    ("sampler=cmaes", "sampler"),
    ("reference=nothing", "reference: unknown optimizer 'nothing'"),
    ("compare_with=[ga,gaa]", "compare_with: unknown optimizer 'gaa'. Did you mean 'ga'?"),
    ("tune.optimizer=dolfin", "tune.optimizer: unknown optimizer 'dolfin'"),
    ("workers=2|storage=sqlite:///x.db", "not safe for several workers"),
    ("grace_period=5", "grace_period: must be >= 11, got 5"),
])
def test_bad_configurations_are_refused_before_a_trial(tmp_path, override, message) -> None:
    done = subprocess.run([sys.executable, "-m", "metaknot.cli", "tune",
                           f"results_dir={tmp_path}", *SMALL, *override.split("|")],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("metaknot tune: error:") and message in line
    assert not (tmp_path / "tune-dolphin" / "optuna.db").exists()


def test_an_unreachable_storage_is_one_line_and_nothing_runs(tmp_path) -> None:
    url = "postgresql+psycopg://nobody@127.0.0.1:9/none"
    done = subprocess.run([sys.executable, "-m", "metaknot.cli", "tune", f"storage={url}",
                           f"results_dir={tmp_path}", *SMALL], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert "storage: cannot open postgresql+psycopg://nobody@127.0.0.1:9/none" in line
    assert not list(tmp_path.glob("*/runs"))


# --- trials ----------------------------------------------------------------------------------

def test_training_and_test_seeds_are_disjoint(tmp_path) -> None:
    spec = spec_of(tmp_path, "train.seeds=5", "test.seeds=30")
    assert spec.train_seeds == tuple(range(TRAIN_SEED_OFFSET, TRAIN_SEED_OFFSET + 5))
    assert spec.test_seeds == tuple(range(30))
    with pytest.raises(ConfigError, match=r"test\.seeds"):
        spec_of(tmp_path, f"test.seeds={TRAIN_SEED_OFFSET + 1}")


def test_a_trial_is_the_mean_ratio_to_the_reference_on_the_training_instances(tmp_path):
    from metaknot.runner import minimize

    spec = spec_of(tmp_path, "train.seeds=2", "n_trials=3", "evaluate=false")
    tune(spec, progress=False)
    trials = stored_trials(spec)
    assert [t.state for t in trials] == [TrialState.COMPLETE] * 3
    study = optuna.load_study(study_name=spec.study, storage=open_storage(spec))
    for trial in trials:
        params, encoding = spec.trial_setting(trial.params)
        ratios = []
        for instance in spec.train:
            # the runs, redone by hand with the training seeds
            values = []
            for seed in spec.train_seeds:
                run = run_spec(spec.run_config(instance, seed, params=params,
                                               encoding=encoding))
                values.append(minimize(run.build_problem(), run.build_optimizer(),
                                       budget=300, seed=np.random.SeedSequence(seed, spawn_key=(1,))
                                       ).best_f)
            assert trial.user_attrs[f"best_f:{instance.key}"] == values
            reference = np.median(evaluate_setting(spec, instance, spec.train_seeds,
                                                   optimizer="averaging", params={}))
            assert study.user_attrs[f"reference:{instance.key}"] == reference
            ratios.append(np.median(values) / reference)
        assert trial.value == pytest.approx(np.mean(ratios), rel=1e-12)
        # intermediate values: the running mean after each instance (what the pruner sees)
        running = np.cumsum(ratios) / np.arange(1, len(ratios) + 1)
        assert [trial.intermediate_values[i] for i in range(len(ratios))] == \
            pytest.approx(running)


def test_a_pruned_trial_stops_after_the_instance_it_was_pruned_at(tmp_path) -> None:
    spec = spec_of(tmp_path, "evaluate=false")
    storage = open_storage(spec)
    study = open_study(spec, storage)
    study.pruner = optuna.pruners.ThresholdPruner(upper=0.0)  # prunes at the first report
    study.optimize(trial_objective(spec, references(spec, study)), n_trials=2)
    for trial in study.trials:
        assert trial.state == TrialState.PRUNED
        assert [k for k in trial.user_attrs if k.startswith("ratio:")] == \
            [f"ratio:{spec.train[0].key}"]


def test_resuming_adds_trials_and_keeps_the_earlier_ones(tmp_path, capsys) -> None:
    def added() -> list[str]:  # the line saying how many trials were added
        return [line for line in capsys.readouterr().out.splitlines() if ": added " in line]

    spec = spec_of(tmp_path, "n_trials=3", "evaluate=false", "pruner=none")
    tune(spec, progress=False)
    assert added() == ["tune tune-dolphin: added 3 trials (3 complete); the study holds 3"]
    before = [(t.number, t.params, t.value) for t in stored_trials(spec)]
    tune(spec_of(tmp_path, "n_trials=5", "evaluate=false", "pruner=none"), progress=False)
    assert added() == ["tune tune-dolphin: added 2 trials (2 complete); the study holds 5"]
    after = [(t.number, t.params, t.value) for t in stored_trials(spec)]
    assert len(after) == 5 and after[:3] == before
    tune(spec_of(tmp_path, "n_trials=5", "evaluate=false", "pruner=none"), progress=False)
    assert len(stored_trials(spec)) == 5  # already there: nothing added
    assert added() == ["tune tune-dolphin: added no trials; the study holds 5"]


def test_a_study_with_other_settings_is_refused_and_kept(tmp_path) -> None:
    spec = spec_of(tmp_path, "n_trials=2", "evaluate=false")
    tune(spec, progress=False)
    db = (tmp_path / "tune-dolphin" / "optuna.db").read_bytes()
    with pytest.raises(ConfigError, match=r"already exists .* \(budget\)"):
        tune(spec_of(tmp_path, "n_trials=2", "evaluate=false", "budget=400"), progress=False)
    assert (tmp_path / "tune-dolphin" / "optuna.db").read_bytes() == db
    assert len(stored_trials(spec)) == 2


def test_same_seed_same_study(tmp_path) -> None:
    studies = []
    for name in ("a", "b"):
        spec = spec_of(tmp_path, f"study={name}", "n_trials=4", "evaluate=false")
        tune(spec, progress=False)
        studies.append([(t.params, t.value) for t in stored_trials(spec)])
    assert studies[0] == studies[1]


# --- outputs and the held-out judgement ------------------------------------------------------

def test_outputs_and_held_out_study(tmp_path, capsys) -> None:
    spec = spec_of(tmp_path, "n_trials=4", "pruner=none")
    written = tune(spec, progress=False)
    printed = capsys.readouterr().out
    study_dir = tmp_path / "tune-dolphin"
    import pandas as pd

    trials = pd.read_csv(study_dir / "trials.csv")
    assert len(trials) == 4 and set(trials.state) == {"COMPLETE"}
    assert pd.read_parquet(study_dir / "trials.parquet").shape[0] == 4
    for name in ("history", "importances", "slice"):
        assert (study_dir / "figures" / f"{name}.png").stat().st_size > 1000
    report = (study_dir / "report.md").read_text()
    assert "## Best configuration" in report and "figures/history.png" in report
    assert "| best_f | dolphin | 2 |" in report and "| rmse | ga | 2 |" in report
    # the held-out study: tuned, default and GA on the test instances and test seeds only
    runs = load_study(written["test_study"]).runs
    assert sorted(runs.label.unique()) == ["dolphin", "dolphin-tuned", "ga"]
    assert set(runs.seed) == set(spec.test_seeds) and set(runs.data) == {"epitrochoid"}
    tuned = runs[runs.label == "dolphin-tuned"].iloc[0]
    best = written["best_params"]
    assert tuned["optimizer.population"] == best["population"]
    # the preset is data, named with the command that runs it; it gives the same record as the
    # held-out run
    preset = study_dir / "dolphin_tuned.yaml"
    assert written["best_config"] == preset and not (study_dir / "conf").exists()
    assert set(yaml.safe_load(preset.read_text())) == {"optimizer", "encoding", "label"}
    for text in (preset.read_text(), report, printed):
        assert f"metaknot run --preset {preset} " in text and "--config-dir" not in text
    done = subprocess.run(
        [sys.executable, "-m", "metaknot.cli", "run", "--preset", str(preset),
         "problem=epitrochoid", "seed=0", "budget=300", f"results_dir={tmp_path}",
         "study=again"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    again = load_study(tmp_path / "again").runs.iloc[0]
    first = runs[(runs.label == "dolphin-tuned") & (runs.seed == 0)].iloc[0]
    assert again.label == "dolphin-tuned" and again.run_id == first.run_id
    assert again.best_f == first.best_f


@pytest.mark.slow
def test_two_workers_on_a_journal_storage(tmp_path) -> None:
    spec = spec_of(tmp_path, "n_trials=8", "workers=2", "evaluate=false", "pruner=none")
    tune(spec, progress=False)
    trials = stored_trials(spec)
    assert (tmp_path / "tune-dolphin" / "optuna.journal").exists()
    finished = [t for t in trials if t.state == TrialState.COMPLETE]
    assert 8 <= len(finished) <= 9  # the other worker may finish the trial it was running
    assert len({t.number for t in trials}) == len(trials)


@pytest.mark.slow
def test_a_killed_worker_s_trial_is_failed_by_the_parent_on_a_journal_storage(tmp_path):
    """The journal storage has no heartbeat: the parent, which knows which worker died, marks
    that worker's trial FAIL and says so."""
    command = [sys.executable, "-m", "metaknot.cli", "tune", f"results_dir={tmp_path}", *SMALL,
               "n_trials=3", "workers=2", "evaluate=false", "pruner=none"]
    parent = subprocess.Popen(command, env={**os.environ, HOLD_WORKER_ENV: "1"},
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    held = {}
    try:
        held = wait_until_held(tmp_path / "tune-dolphin", 1, parent)
        os.kill(held["pid"], signal.SIGKILL)
        output, _ = parent.communicate(timeout=300)
    finally:
        if parent.poll() is None:
            parent.kill()
    assert parent.returncode == 0, output
    trials = stored_trials(spec_of(tmp_path, "workers=2"))
    assert not [t for t in trials if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    (failed,) = [t for t in trials if t.state == TrialState.FAIL]
    assert failed.number == held["trial"]
    assert len([t for t in trials if t.state == TrialState.COMPLETE]) == 3
    assert re.search(rf"worker 1 \(pid {held['pid']}\) was killed by SIGKILL.* trial "
                     rf"{held['trial']}\b.*FAIL", output), output
    assert "retried by the heartbeat" not in output


@pytest.mark.slow
def test_resuming_fails_and_retries_a_dead_worker_s_trial(tmp_path) -> None:
    """A study holds its n_trials finished trials and one that a worker killed inside it left
    RUNNING. Re-running the study fails that trial once its heartbeat is grace_period old and
    runs the retry, instead of returning at once."""
    settings = ["evaluate=false", "pruner=none", "heartbeat_interval=1", "grace_period=2"]
    tune(spec_of(tmp_path, "n_trials=2", *settings), progress=False)
    doomed = subprocess.Popen(
        [sys.executable, "-m", "metaknot.cli", "tune", f"results_dir={tmp_path}", *SMALL,
         "n_trials=3", *settings], env={**os.environ, HOLD_WORKER_ENV: "0"},
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        held = wait_until_held(tmp_path / "tune-dolphin", 0, doomed)
    finally:
        doomed.kill()
        doomed.wait(timeout=60)
    time.sleep(3)  # the grace period passes before the study is resumed
    spec = spec_of(tmp_path, "n_trials=2", *settings)
    tune(spec, progress=False)
    trials = stored_trials(spec)
    assert not [t for t in trials if t.state in (TrialState.RUNNING, TrialState.WAITING)]
    (failed,) = [t for t in trials if t.state == TrialState.FAIL]
    assert failed.number == held["trial"] == 2
    complete = [t for t in trials if t.state == TrialState.COMPLETE]
    (retry,) = [t for t in complete if t.system_attrs.get("failed_trial") == failed.number]
    assert retry.params == failed.params and len(complete) == 3


@pytest.mark.parametrize("pruner", ["median", "percentile", "successive_halving", "hyperband",
                                    "none"])
def test_every_pruner_runs_a_study(tmp_path, pruner) -> None:
    spec = spec_of(tmp_path, f"pruner={pruner}", "n_trials=7", "evaluate=false")
    tune(spec, progress=False)
    study = optuna.load_study(study_name=spec.study, storage=open_storage(spec))
    expected = {"median": optuna.pruners.MedianPruner, "none": optuna.pruners.NopPruner,
                "percentile": optuna.pruners.PercentilePruner,
                "successive_halving": optuna.pruners.SuccessiveHalvingPruner,
                "hyperband": optuna.pruners.HyperbandPruner}[pruner]
    assert isinstance(open_study(spec, open_storage(spec)).pruner, expected)
    finished = [t for t in study.trials
                if t.state in (TrialState.COMPLETE, TrialState.PRUNED)]
    assert len(finished) == 7
    for trial in finished:
        ran = [k for k in trial.user_attrs if k.startswith("ratio:")]
        if trial.state == TrialState.COMPLETE:  # a complete trial ran every instance
            assert len(ran) == 2
        else:  # a pruned one stopped at the instance its last intermediate value is from
            assert pruner != "none" and len(ran) == max(trial.intermediate_values) + 1


def test_a_run_that_fails_its_budget_audit_fails_the_trial(tmp_path, monkeypatch) -> None:
    import gc

    import metaknot as mk
    from metaknot import registry
    from metaknot.problems import KnotProblem

    monkeypatch.setitem(registry._REGISTRY, "optimizer", dict(registry._REGISTRY["optimizer"]))

    @mk.register("peeking_search")
    class PeekingSearch(mk.Optimizer):
        """Scores extra candidates on the problem it finds among all objects."""

        def ask(self):
            X = self.problem.sample(self.rng, 10)
            if not hasattr(self, "found"):  # the run's own problem, looked up once
                self.found = next(o for o in gc.get_objects() if isinstance(o, KnotProblem)
                                  and o.encoding is self.problem.encoding)
            self.found.evaluate(X)
            return X[:2]

        def tell(self, X, F):
            pass

    spec = spec_of(tmp_path)
    instance = spec.train[0]
    assert len(evaluate_setting(spec, instance, (0,), optimizer="random_search", params={})) == 1
    with pytest.raises(ValueError, match=r"peeking_search on .*budget violation"):
        evaluate_setting(spec, instance, (0,), optimizer="peeking_search", params={})


# --- the benchmark suite's instances --------------------------------------------------------

def test_tuning_on_suite_instances_with_their_task(tmp_path) -> None:
    """Training and test instances from the suite (a split by name, or ids), each scored by
    its own task's objective: the seed task's error floor is the noise on a noisy instance."""
    from metaknot.runner import minimize
    from metaknot.suite.splits import split
    from metaknot.suite.tasks import get_task

    spec = spec_of(tmp_path, "train.instances=[{suite: titanium}, {suite: humps+noise0.03s0}]",
                   "test.instances=suite:mini", "~objective.name", "~objective.error_floor",
                   "+objective.task=seed",
                   "n_trials=2", "evaluate=false", "budget=200")
    assert [i.key for i in spec.train] == ["titanium", "humps+noise0.03s0"]
    assert [i.key for i in spec.test] == split("mini")
    config = spec.run_config(spec.train[1], spec.train_seeds[0])
    assert config["objective"] == get_task("humps+noise0.03s0", "seed").objective
    assert config["problem"]["instance"] == "humps+noise0.03s0"
    tune(spec, progress=False)
    (first, _) = stored_trials(spec)
    params, encoding = spec.trial_setting(first.params)
    run = run_spec(spec.run_config(spec.train[1], spec.train_seeds[0], params=params,
                                   encoding=encoding))
    expected = minimize(run.build_problem(), run.build_optimizer(), budget=200,
                        seed=np.random.SeedSequence(spec.train_seeds[0], spawn_key=(1,)))
    assert first.user_attrs["best_f:humps+noise0.03s0"][0] == expected.best_f


@pytest.mark.parametrize(("override", "message"), [
    ("test.instances=[{suite: titanium+noise0.01s0}]", "training instance with other noise"),
    ("test.instances=suite:validation", "unknown suite split"),
    ("test.instances=[{suite: titanum}]", "Did you mean 'titanium'"),
    ("+objective.task=seed", "not one"),
])
def test_bad_suite_instances_in_a_tuning_study(tmp_path, override, message) -> None:
    overrides = ["train.instances=[{suite: titanium}]", override]
    if "objective.task" in override:
        overrides = ["train.instances=[{suite: titanium}]", "~objective.name",
                     "~objective.error_floor", override]
    with pytest.raises(ConfigError, match=message):
        spec_of(tmp_path, *overrides)


def test_the_trials_added_are_those_of_this_commands_workers(tmp_path) -> None:
    """Several tune commands on one study: each says how many trials its own workers ran,
    and how many the others added meanwhile (it used to count them all as its own)."""
    from metaknot.experiments.tuning.app import trials_added

    spec = spec_of(tmp_path, "n_trials=3", "evaluate=false", "pruner=none")
    tune(spec, progress=False)
    study = open_study(spec, open_storage(spec))
    trials = study.get_trials(deepcopy=False)
    workers = {t.user_attrs["worker"] for t in trials}
    assert len(workers) == 1
    assert trials_added(spec, study, 0, workers) == \
        "tune tune-dolphin: added 3 trials (3 complete); the study holds 3"
    assert trials_added(spec, study, 0, {"elsewhere:1"}) == \
        "tune tune-dolphin: added no trials; other workers added 3; the study holds 3"
    assert trials_added(spec, study, 1, {"elsewhere:1"}).endswith(
        "other workers added 2; the study holds 3")


def test_two_commands_creating_a_sqlite_study_at_once_retry_instead_of_failing() -> None:
    """SQLite's errors when another command creates Optuna's tables at the same moment are
    retried, as PostgreSQL's are; other errors are not."""
    import sqlite3

    from sqlalchemy.exc import IntegrityError, OperationalError

    from metaknot.experiments.tuning.runner import _schema_race

    for text in ("table studies already exists", "database is locked"):
        error = OperationalError("CREATE TABLE studies (...)", {}, sqlite3.OperationalError(text))
        assert _schema_race(error), text
    version = IntegrityError("INSERT INTO alembic_version ...", {}, sqlite3.IntegrityError(
        "UNIQUE constraint failed: alembic_version.version_num"))
    assert _schema_race(version)
    other = OperationalError("SELECT 1", {}, sqlite3.OperationalError("unable to open database"))
    assert not _schema_race(other)
    assert not _schema_race(RuntimeError("table studies already exists"))


@pytest.mark.slow
@pytest.mark.parametrize("how", ["SIGTERM to the command", "Ctrl-C to its process group"])
def test_a_stopped_tune_stops_its_workers_fails_their_trials_in_one_line(tmp_path, how):
    """SIGTERM to ``metaknot tune workers=2`` (its spawned worker held inside a trial) or
    Ctrl-C to the terminal's process group: the spawned worker is stopped, no trial is left
    RUNNING (the held one FAIL), trials.csv is written, one line on stderr, exit 128 + the
    signal. Before, SIGTERM orphaned the worker and left the parent's trial RUNNING; Ctrl-C
    printed 99 lines of tracebacks and no trials.csv."""
    stop_a_held_tune(tmp_path, how, "tune-dolphin")


@pytest.mark.slow
@pytest.mark.parametrize("how", ["SIGTERM to the command", "Ctrl-C to its process group"])
def test_a_stopped_tune_sweep_stops_as_a_single_tune_does(tmp_path, how):
    """``metaknot tune -m study=a,b workers=2`` stopped while study a's spawned worker holds
    inside a trial: as a single tune, the worker is stopped, no trial is left RUNNING (the
    held one FAIL), trials.csv is written, one line on stderr, exit 128 + the signal; study b
    is not started. Before, SIGTERM killed the command alone (the worker went on, both trials
    RUNNING for ever on the journal, no trials.csv) and Ctrl-C printed a traceback."""
    stop_a_held_tune(tmp_path, how, "a", "study=a,b", multirun=True)
    assert not (tmp_path / "b").exists()


@pytest.mark.slow
@pytest.mark.parametrize("form", ["tune", "tune -m"])
@pytest.mark.parametrize("how", ["SIGTERM to the command", "Ctrl-C to its process group"])
def test_a_tune_stopped_while_its_reference_method_runs_stops_at_once(tmp_path, how, form):
    """SIGTERM or Ctrl-C while the reference method runs (held inside its first run): the
    command stops at once with one line, exit 128 + the signal, and no trial in the study.
    Before, the signal waited for every reference run to end (for ever here), then a trial
    was started only to fail."""
    sig = signal.SIGTERM if how.startswith("SIGTERM") else signal.SIGINT
    sweep = ["-m", "study=a,b"] if form.endswith("-m") else ["study=a"]
    command = [sys.executable, "-m", "metaknot.cli", "tune", *sweep, f"results_dir={tmp_path}",
               *SMALL, "n_trials=40", "evaluate=false", "pruner=none"]
    parent = subprocess.Popen(command, env={**os.environ, HOLD_WORKER_ENV: "references"},
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                              start_new_session=True)
    held = wait_until_held(tmp_path / "a", "references", parent)
    assert held["pid"] == parent.pid
    stderr = stop(parent, sig)
    assert parent.returncode == 128 + sig, stderr
    assert stderr.strip().splitlines() == [
        f"tune a: interrupted ({signal.Signals(sig).name}) while the reference method ran, "
        "before any trial; run the same command to resume"]
    study = optuna.load_study(study_name="a", storage=open_storage(spec_of(tmp_path, "study=a")))
    assert study.trials == [] and not [k for k in study.user_attrs if k.startswith("reference")]
    assert not (tmp_path / "b").exists()


def test_a_results_dir_that_cannot_be_used_is_one_line_before_a_tune(tmp_path):
    """As for metaknot run: a loop of symbolic links, a file, a path beyond ASCII unquoted and
    a folder nothing can be written into (sysfs refuses new files even to root) are one line
    naming results_dir, exit status 2, for a tune and a sweep of them. Before, Hydra's lexer
    error (beyond ASCII), a traceback from Hydra's sweep folder (a loop under -m) and a
    PermissionError traceback (unwritable); quoted, the path beyond ASCII works."""
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    afile = tmp_path / "afile"
    afile.write_text("")
    cases = ((str(loop), "cannot be used: Too many levels of symbolic links"),
             (str(afile), "is not a folder"),
             (str(tmp_path / "résultats"), "a value with characters beyond ASCII is read only "
                                           "in quotes: results_dir='"),
             ("/sys/kernel/metaknot-results", "cannot write into /sys/kernel (Permission "
                                              "denied); nothing was run"))
    for value, message in cases:
        for sweep in ((), ("-m",), ("-m", "study=a,b")):
            done = subprocess.run([sys.executable, "-m", "metaknot.cli", "tune", *sweep,
                                   f"results_dir={value}", *SMALL, "n_trials=1"],
                                  capture_output=True, text=True, cwd=tmp_path, timeout=300)
            assert done.returncode == 2, done.stderr
            (line,) = done.stderr.strip().splitlines()
            assert line.startswith("metaknot tune: error: results_dir: ") and message in line, \
                (sweep, line)
    assert not list(tmp_path.glob("*/tune-dolphin"))
    done = subprocess.run([sys.executable, "-m", "metaknot.cli", "tune",
                           f"results_dir='{tmp_path / 'résultats'}'", *SMALL, "n_trials=1",
                           "evaluate=false"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "résultats" / "tune-dolphin" / "trials.csv").exists()
