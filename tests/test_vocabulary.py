"""One word per concept (:mod:`metaknot.compat`): the current spellings work, the former ones
still work with a deprecation note, and renaming changes no run id and no stored study."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from metaknot import compat
from metaknot.algorithms import NevergradOptimizer, NloptKnots, PymooOptimizer
from metaknot.experiments.preset import check_preset, expand_preset, preset_overrides
from metaknot.experiments.spec import run_spec
from metaknot.experiments.store import load_study

PREVIOUS = Path(__file__).parent / "data" / "previous-study"


@pytest.fixture(autouse=True)
def fresh_notes(monkeypatch):
    """Each test sees the notes of its own deprecated spellings (they are said once)."""
    monkeypatch.setattr(compat, "_NOTED", set())


def stored_configs() -> list[tuple[str, dict]]:
    runs = load_study(PREVIOUS).runs
    return [(row.run_id, json.loads(row.config)) for row in runs.itertuples()]


def test_stored_runs_keep_their_ids_under_either_spelling():
    configs = stored_configs()
    assert len(configs) == 5 and all("algorithm" in config for _, config in configs)
    for run_id, config in configs:
        legacy = run_spec({"study": "s", "results_dir": ".", **config}, check_build=False)
        current, renamed = compat.new_config(config)
        assert renamed == [("algorithm", "optimizer")] and "algorithm" not in current
        new = run_spec({"study": "s", "results_dir": ".", **current}, check_build=False)
        assert legacy.run_id == new.run_id == run_id
        assert new.config["optimizer"] == legacy.config["optimizer"] == current["optimizer"]


@pytest.mark.parametrize(("name", "old", "new", "value"), [
    ("nlopt", "algorithm", "variant", "LN_SBPLX"),
    ("nlopt", "local_algorithm", "local_variant", "LN_SBPLX"),
    ("pymoo", "algorithm", "variant", "DE"),
    ("nevergrad", "optimizer", "variant", "CMA"),
    ("free_front", "local_algorithm", "local_variant", "LN_SBPLX"),
])
def test_a_renamed_hyperparameter_hashes_under_its_former_name(name, old, new, value):
    base = {"study": "s", "results_dir": ".", "problem": {"curve": "archimedean"},
            "encoding": {"kind": "free"}, "objective": {"name": "paper"}, "budget": 100,
            "seed": 0}
    current = run_spec({**base, "optimizer": {"_name_": name, new: value}}, check_build=False)
    former = run_spec({**base, "algorithm": {"_name_": name, old: value}}, check_build=False)
    assert current.config["optimizer"][new] == value and old not in current.config["optimizer"]
    assert current.run_id == former.run_id
    # the id is the hash of the former names: what every stored run was identified by
    assert compat.legacy_config(current.config)["algorithm"][old] == value


def test_both_spellings_of_one_setting_are_refused():
    with pytest.raises(ValueError, match="algorithm and variant: the same setting twice"):
        compat.new_config({"optimizer": {"_name_": "nlopt", "algorithm": "A", "variant": "B"}})


def test_former_overrides_are_translated_and_noted_once(capsys):
    old = ["-m", "algorithm=ga,dolphin", "algorithm.population=30", "+algorithm.pp1=0.2",
           "~algorithm.loops", "algorithm.algorithm=LN_SBPLX", "algorithm.optimizer=CMA",
           "algorithm.local_algorithm=LN_SBPLX", "tune.algorithm=ga", "label=algorithm=x"]
    assert compat.new_overrides(old) == [
        "-m", "optimizer=ga,dolphin", "optimizer.population=30", "+optimizer.pp1=0.2",
        "~optimizer.loops", "optimizer.variant=LN_SBPLX", "optimizer.variant=CMA",
        "optimizer.local_variant=LN_SBPLX", "tune.optimizer=ga", "label=algorithm=x"]
    compat.new_overrides(["algorithm=ga"])
    err = capsys.readouterr().err.splitlines()
    assert err.count("metaknot: 'algorithm' is deprecated, write 'optimizer'") == 1
    assert "metaknot: 'algorithm.algorithm' is deprecated, write 'optimizer.variant'" in err
    new = ["optimizer=ga", "optimizer.population=30", "label=ga"]
    assert compat.new_overrides(new) == new and capsys.readouterr().err == ""


def test_a_preset_in_the_former_spelling_runs_as_the_current_one(tmp_path, capsys):
    old = tmp_path / "old.yaml"
    old.write_text("algorithm: {_name_: nlopt, algorithm: GN_CRS2_LM}\n"
                   "encoding: {kind: free}\n")
    new = {"optimizer": {"_name_": "nlopt", "variant": "GN_CRS2_LM"}, "encoding": {"kind": "free"}}
    assert expand_preset(["--preset", str(old), "seed=1"]) == [
        *preset_overrides(check_preset(new, "new")), "seed=1"]
    err = capsys.readouterr().err
    assert "metaknot: old.yaml: 'algorithm' is deprecated, write 'optimizer'" in err
    assert "'optimizer.algorithm' is deprecated, write 'optimizer.variant'" in err
    assert preset_overrides(check_preset(new, "new"))[:2] == ["optimizer=nlopt",
                                                              "++optimizer.variant='GN_CRS2_LM'"]


@pytest.mark.parametrize(("cls", "old", "new", "value"), [
    (NloptKnots, "algorithm", "variant", "LN_SBPLX"),
    (NloptKnots, "local_algorithm", "local_variant", "LN_SBPLX"),
    (PymooOptimizer, "algorithm", "variant", "DE"),
    (NevergradOptimizer, "optimizer", "variant", "CMA"),
])
def test_a_former_keyword_of_an_optimizer_warns_where_it_is_written(cls, old, new, value):
    with pytest.warns(DeprecationWarning, match=f"{old}= is deprecated, use {new}=") as caught:
        optimizer = cls(**{old: value})
    assert caught[0].filename == __file__  # the warning points at the caller
    assert getattr(optimizer, new) == value and optimizer.hyperparameters()[new] == value
    assert old not in optimizer.hyperparameters()


def test_a_stored_record_reads_under_the_current_names():
    row = {"run_id": "x", "algorithm": "nevergrad", "algorithm.optimizer": "CMA",
           "algorithm.batch_size": 4, "optimize_seconds": 1.0}
    assert compat.new_record(row) == {"run_id": "x", "optimizer": "nevergrad",
                                      "optimizer.variant": "CMA", "optimizer.batch_size": 4,
                                      "optimize_seconds": 1.0}
    runs = load_study(PREVIOUS).runs
    assert "algorithm" not in runs and not any(c.startswith("algorithm.") for c in runs)
    assert set(runs.optimizer) == {"ga", "random_search"}
    assert runs.loc[runs.optimizer == "ga", "optimizer.population"].eq(50).all()


def test_a_tuning_study_in_the_former_spelling_keeps_its_identity(tmp_path, capsys):
    from hydra import compose, initialize_config_dir

    from metaknot.experiments.spec import plain_config
    from metaknot.experiments.tuning import tune_spec
    from metaknot.experiments.tuning.app import CONFIG_DIR

    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        cfg = plain_config(compose("tuning", overrides=["tune=ga", f"results_dir={tmp_path}"]))
    current = tune_spec(cfg)
    cfg["tune"]["algorithm"] = cfg["tune"].pop("optimizer")
    former = tune_spec(cfg)
    assert "'tune.algorithm' is deprecated, write 'tune.optimizer'" in capsys.readouterr().err
    assert current.optimizer == former.optimizer == "ga"
    assert current.identity() == former.identity()
    assert current.identity()["tune"]["algorithm"] == "ga"  # as studies begun before stored it


@pytest.mark.parametrize(("old", "new"), sorted(compat.PROBLEM_NAMES.items()))
def test_a_former_problem_name_warns_at_the_line_that_names_it(old, new):
    import metaknot as mk

    options = {"points": "archimedean", **({} if new == "mask" else {"n_knots": 4})}
    assert mk.get_problem(new, **options).name == new
    with pytest.warns(DeprecationWarning, match=f"problem {old!r} is deprecated, use {new!r}") \
            as caught:
        problem = mk.get_problem(old, **options)
    assert problem.name == new and caught[0].filename == __file__
    with pytest.warns(DeprecationWarning) as caught:  # from deep inside minimize, too
        result = mk.minimize(old, "random_search", budget=20, seed=0, problem_kwargs=options)
    assert result.problem == new and caught[0].filename == __file__


def test_stored_records_name_their_problem_by_its_encoding():
    runs = load_study(PREVIOUS).runs
    assert set(runs.problem) == {"mask"} and set(runs.encoding) == {"binary"}


def test_hyperparameters_and_the_former_params():
    optimizer = NloptKnots(variant="LN_SBPLX", restarts=2)
    current = optimizer.hyperparameters()
    assert current["variant"] == "LN_SBPLX" and current["restarts"] == 2
    with pytest.warns(DeprecationWarning, match=r"use hyperparameters\(\)") as caught:
        assert optimizer.params() == current
    assert caught[0].filename == __file__

    class OldStyle(NloptKnots):  # a plugin written for the former name
        def params(self):
            return {"steps": 3}

    assert OldStyle().hyperparameters() == {"steps": 3}


def test_a_tolerance_is_tolerance_and_tol_still_works(tmp_path, capsys):
    import numpy as np

    import metaknot as mk
    from metaknot.cli import main

    x = np.linspace(0, 3, 60)
    points = np.column_stack([x, np.sin(2 * x)])
    current = mk.fit(points, tolerance=1e-3, method="removal")
    with pytest.warns(DeprecationWarning, match="fit: tol= is deprecated, use tolerance=") \
            as caught:
        former = mk.fit(points, tol=1e-3, method="removal")
    assert caught[0].filename == __file__
    assert current.n_control_points == former.n_control_points
    assert current.tolerance == former.tolerance == 1e-3
    np.savetxt(tmp_path / "sine.csv", points, delimiter=",")
    for option in ("--tolerance", "--tol"):
        assert main(["fit", str(tmp_path / "sine.csv"), option, "1e-3", "--method", "removal",
                     "--out", str(tmp_path / option.strip("-"))]) == 0
        saved = json.loads((tmp_path / option.strip("-") / "fit.json").read_text())
        assert saved["metrics"]["n_control_points"] == current.n_control_points


def test_metrics_is_a_dictionary_everywhere_and_calling_it_still_works():
    import metaknot as mk

    result = mk.minimize("mask", "random_search", budget=50, seed=0,
                         problem_kwargs={"points": "archimedean"})
    for metrics in (result.metrics, result.solution.metrics, result.solution.fit.metrics):
        assert isinstance(metrics, dict) and metrics["rmse"] == result.metrics["rmse"] > 0
    with pytest.warns(DeprecationWarning, match="metrics is a dictionary") as caught:
        assert result.solution.fit.metrics() == result.solution.fit.metrics
    assert caught[0].filename == __file__
    assert result.record()["rmse"] == result.metrics["rmse"]
