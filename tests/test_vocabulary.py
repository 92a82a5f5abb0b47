"""One word per concept: the current names work, and a name that is not current is refused as
any misspelled name is (never translated), on every surface: configurations, presets, tuning
configurations, command lines, Python keywords, registered names. Run ids hash the current
names."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

import metaknot as mk
from metaknot.algorithms import FreeKnotFront, NevergradOptimizer, NloptKnots, PymooOptimizer
from metaknot.bspline.fitpack import fewest_within
from metaknot.experiments.app import check_choices
from metaknot.experiments.preset import check_preset
from metaknot.experiments.run import run_id
from metaknot.experiments.spec import ConfigError, run_spec

BASE = {"study": "s", "results_dir": ".", "problem": {"curve": "archimedean"},
        "encoding": {"kind": "free"}, "objective": {"name": "paper"}, "budget": 100, "seed": 0}


def test_a_run_id_is_the_hash_of_the_current_names():
    spec = run_spec({**BASE, "optimizer": {"_name_": "nlopt", "variant": "LN_SBPLX"}},
                    check_build=False)
    assert spec.config["optimizer"]["variant"] == "LN_SBPLX"
    settings = {k: spec.config[k] for k in ("problem", "encoding", "objective", "optimizer",
                                            "budget", "seed", "checkpoints_per_decade")}
    text = json.dumps(settings, sort_keys=True, default=str, separators=(",", ":"))
    assert spec.run_id == run_id(spec.config) == hashlib.sha256(text.encode()).hexdigest()[:16]


def test_the_optimizer_group_has_one_name():
    with pytest.raises(ConfigError, match=r"^algorithm: unknown setting \(known: budget, "):
        run_spec({**BASE, "algorithm": {"_name_": "nlopt"}}, check_build=False)


@pytest.mark.parametrize(("name", "word"), [
    ("nlopt", "algorithm"), ("nlopt", "local_algorithm"), ("pymoo", "algorithm"),
    ("nevergrad", "optimizer"), ("free_front", "local_algorithm"),
])
def test_a_hyperparameter_has_one_name(name, word):
    with pytest.raises(ConfigError, match=rf"^optimizer\.{word}: unknown setting \(known: .*"
                                          r"variant"):
        run_spec({**BASE, "optimizer": {"_name_": name, word: "X"}}, check_build=False)


@pytest.mark.parametrize(("cls", "word"), [
    (NloptKnots, "algorithm"), (NloptKnots, "local_algorithm"), (PymooOptimizer, "algorithm"),
    (NevergradOptimizer, "optimizer"), (FreeKnotFront, "local_algorithm"),
])
def test_an_optimizer_takes_its_current_keywords_only(cls, word):
    with pytest.raises(TypeError, match=f"unexpected keyword argument '{word}'"):
        cls(**{word: "LN_SBPLX"})


@pytest.mark.parametrize("args", [["algorithm=ga"], ["-m", "algorithm=ga,dolphin"],
                                  ["algorithm.population=30"]])
def test_a_command_line_names_the_setting_it_does_not_know(args):
    error = check_choices(args)
    assert error is not None and error.startswith("algorithm: unknown setting (known: ")
    assert "optimizer" in error
    assert check_choices(["optimiser=ga"]).startswith(
        "optimiser: unknown setting; did you mean optimizer? (known: ")
    assert check_choices(["optimizer=ga", "+label=x", "budget=10"]) is None


def test_a_preset_has_one_name_for_its_optimizer():
    assert check_preset({"optimizer": {"_name_": "ga"}}, "p.yaml")["optimizer"]["_name_"] == "ga"
    with pytest.raises(ConfigError, match=r"^p\.yaml: algorithm: unknown setting"):
        check_preset({"algorithm": {"_name_": "ga"}}, "p.yaml")


def test_a_tuning_configuration_has_one_name_for_its_optimizer(tmp_path):
    from hydra import compose, initialize_config_dir

    from metaknot.experiments.spec import plain_config
    from metaknot.experiments.tuning import tune_spec
    from metaknot.experiments.tuning.app import CONFIG_DIR

    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        cfg = plain_config(compose("tuning", overrides=["tune=ga", f"results_dir={tmp_path}"]))
    assert tune_spec(cfg).identity()["tune"]["optimizer"] == "ga"
    cfg["tune"]["algorithm"] = cfg["tune"].pop("optimizer")
    with pytest.raises(ConfigError, match=r"^tune\.algorithm: unknown setting"):
        tune_spec(cfg)


@pytest.mark.parametrize("word", ["knot_selection", "knot_indices", "free_knots"])
def test_a_problem_is_named_by_its_encoding(word):
    with pytest.raises(ValueError, match=f"^unknown problem '{word}'.* Available: free, "
                                         "indices, mask$"):
        mk.get_problem(word, points="archimedean")


def test_a_tolerance_is_tolerance():
    x = np.linspace(0, 3, 60)
    points = np.column_stack([x, np.sin(2 * x)])
    assert mk.fit(points, tolerance=1e-3, method="removal").tolerance == 1e-3
    with pytest.raises(TypeError, match="unexpected keyword argument 'tol'"):
        mk.fit(points, tol=1e-3, method="removal")
    with pytest.raises(TypeError, match="unexpected keyword argument 'tol'"):
        fewest_within(x / 3, points, 3, tol=1e-3, metric="rmse")


def test_metrics_are_plain_dictionaries_and_hyperparameters_have_one_name():
    result = mk.minimize("mask", "random_search", budget=50, seed=0,
                         problem_kwargs={"points": "archimedean"})
    for metrics in (result.metrics, result.solution.metrics, result.solution.fit.metrics):
        assert type(metrics) is dict and metrics["rmse"] == result.metrics["rmse"] > 0
    assert result.record()["rmse"] == result.metrics["rmse"]
    optimizer = NloptKnots(variant="LN_SBPLX", restarts=2)
    assert optimizer.hyperparameters()["variant"] == "LN_SBPLX"
    assert not hasattr(optimizer, "params")

    class Custom(NloptKnots):
        def params(self):  # a method of its own, not the optimizer's hyperparameters
            return {"steps": 3}

    assert Custom().hyperparameters()["variant"] == "LN_BOBYQA"
