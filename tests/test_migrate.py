"""``metaknot migrate STUDY``: a study stored in the earlier record format is carried over, in
place, to the current names and run ids; until then the store refuses it, naming the command.

``tests/data/study-0.1.0`` was written by metaknot 0.1.0 before run ids were hashed from the
current names, by::

    metaknot run -m problem=archimedean optimizer=ga,random_search seed=0,1 budget=100 \\
        study=study-0.1.0
    metaknot run problem=archimedean encoding=free optimizer=nlopt optimizer.variant=LN_SBPLX \\
        seed=0 budget=100 study=study-0.1.0
    metaknot run problem=archimedean encoding=free optimizer=pymoo seed=0 budget=100 \\
        study=study-0.1.0

plus :data:`FAILED_CONFIG` run by ``execute`` with an optimizer that raised before its first
evaluation (its record, under ``failed/``). The Hydra folder was left out.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from metaknot.cli import main
from metaknot.experiments.migrate import migrate_study
from metaknot.experiments.store import (
    STORE_FORMAT,
    Store,
    StoreError,
    load_study,
    record_format,
)

DATA = Path(__file__).parent / "data" / "study-0.1.0"
FORMER_IDS = {"0de33c3ab98da6b6", "3d286300e2f94ba9", "8f2b44145ba0dc23", "b2bce6bcb526ac6b",
              "d6e030204788fd60", "e0ebcbd9df9d191b"}
FORMER_FAILED_ID = "3097bbf96760541b"
#: The command lines (Hydra overrides) of the stored complete runs.
RUNS = [[f"optimizer={name}", f"seed={seed}"] for name in ("ga", "random_search")
        for seed in (0, 1)] + [["encoding=free", "optimizer=nlopt", "optimizer.variant=LN_SBPLX",
                                "seed=0"], ["encoding=free", "optimizer=pymoo", "seed=0"]]
FAILED_CONFIG = {"problem": {"curve": "archimedean"}, "encoding": {"kind": "free"},
                 "optimizer": {"_name_": "nlopt", "variant": "LN_SBPLX"},
                 "objective": {"name": "paper"}, "budget": 100, "seed": 7}


@pytest.fixture
def study(tmp_path: Path) -> Path:
    """A copy of the study in a results folder (migrating changes it)."""
    shutil.copytree(DATA, tmp_path / "results" / "study-0.1.0")
    return tmp_path / "results" / "study-0.1.0"


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*.parquet"))}


def specs(study: Path) -> list:
    """Today's :class:`RunSpec` of the stored runs, composed from their command lines."""
    from hydra import compose, initialize_config_dir

    from metaknot.experiments.app import CONFIG_DIR, register_hydra_plugins
    from metaknot.experiments.spec import run_spec

    register_hydra_plugins()
    common = ["problem=archimedean", "budget=100", f"study={study.name}",
              f"results_dir={study.parent}"]
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        return [run_spec(compose("config", overrides=[*common, *args]), check_build=False)
                for args in RUNS]


def test_the_store_refuses_a_study_of_the_earlier_format_naming_the_command(study):
    before = snapshot(study)
    with pytest.raises(StoreError, match=r"earlier format 'metaknot-run-record/1'.*carry the "
                                         rf"study over with: metaknot migrate {study}$"):
        load_study(study)
    with pytest.raises(StoreError, match="metaknot migrate"):
        Store(study).completed()  # as a sweep plans: refused, not moved aside as damaged
    with pytest.raises(StoreError, match="metaknot migrate"):
        Store(study).check_format()
    assert snapshot(study) == before and not (study / "bad").exists()


def test_a_run_into_a_study_to_migrate_is_refused_before_it_starts(study, capsys):
    from metaknot.experiments.app import main as run_main

    before = snapshot(study)
    assert run_main(["problem=archimedean", "optimizer=ga", "budget=100", f"study={study.name}",
                     f"results_dir={study.parent}"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("metaknot run: error: ") and \
        err.rstrip().endswith(f"carry the study over with: metaknot migrate {study}")
    assert snapshot(study) == before
    migrate_study(study)
    Store(study).check_format()  # current: nothing to say


def test_migrate_gives_the_run_ids_of_todays_configurations(study):
    done = migrate_study(study)
    expected = {spec.run_id for spec in specs(study)}
    assert len(expected) == 6 and not expected & FORMER_IDS
    assert {p.stem for p in (study / "runs").iterdir()} == expected
    assert set(done.run_ids) == FORMER_IDS | {FORMER_FAILED_ID}
    assert set(done.run_ids.values()) - expected == {done.run_ids[FORMER_FAILED_ID]}
    assert done.current == 0 and done.set_aside == []
    for path in study.rglob("*.parquet"):
        assert record_format(pq.read_schema(path)) == STORE_FORMAT
    assert sorted(p.name for p in (study / "tmp").iterdir()) == []

    loaded = load_study(study)
    ok = loaded.runs[loaded.runs.status == "ok"]
    assert set(ok.run_id) == expected and set(loaded.trace.run_id) == expected
    assert sorted(ok.optimizer) == ["ga", "ga", "nlopt", "pymoo", "random_search",
                                    "random_search"]
    assert set(ok.problem) == {"mask", "free"} and (ok.n_evaluations == 100).all()
    assert ok.loc[ok.optimizer == "nlopt", "optimizer.variant"].tolist() == ["LN_SBPLX"]
    (failed,) = loaded.failures.to_dict("records")
    assert failed["error"] == "RuntimeError: could not start"
    assert failed["run_id"] == done.run_ids[FORMER_FAILED_ID]


def test_a_migrated_study_resumes_and_reports(study, tmp_path):
    from metaknot.experiments.app import execute
    from metaknot.experiments.report import build
    from metaknot.experiments.spec import run_spec

    migrate_study(study)
    before = snapshot(study)
    for spec in specs(study):  # every run is found stored: none is computed again
        assert execute(spec)["status"] == "skipped"
    failed = run_spec({"study": study.name, "results_dir": str(study.parent), **FAILED_CONFIG},
                      check_build=False)
    (path,) = (study / "failed").iterdir()
    assert path.name.startswith(f"{failed.run_id}.")  # the failed attempt keeps its run
    assert snapshot(study) == before
    build(study, tmp_path / "report", figures=False, log=None)
    text = (tmp_path / "report" / "report.md").read_text()
    assert "1 run(s) failed and are left out" in text
    assert snapshot(study) == before


def test_migrate_on_the_command_line_then_again_changes_nothing(study, capsys):
    assert main(["migrate", str(study)]) == 0
    assert f"metaknot migrate: {study}: 7 record(s) carried over to new run ids, 0 already " \
           "current" in capsys.readouterr().err
    after = snapshot(study)
    assert main(["migrate", str(study)]) == 0
    assert "0 record(s) carried over to new run ids, 7 already current" in \
        capsys.readouterr().err
    assert snapshot(study) == after


def test_a_stopped_migration_completes_when_run_again(study):
    done = migrate_study(study)
    after = snapshot(study)
    former = next(iter(FORMER_IDS))
    shutil.copy(DATA / "runs" / f"{former}.parquet", study / "runs")  # not yet removed
    again = migrate_study(study)
    assert again.run_ids == {former: done.run_ids[former]} and again.current == 7
    assert again.set_aside == [] and snapshot(study) == after


@pytest.mark.parametrize("where", ["missing", "empty", "results"])
def test_migrate_refuses_a_folder_that_is_not_a_study(study, tmp_path, capsys, where):
    folder = {"missing": tmp_path / "nothing", "empty": tmp_path / "empty",
              "results": study.parent}[where]
    if where == "empty":
        folder.mkdir()
        (folder / "notes.txt").write_text("x")
    before = snapshot(tmp_path)
    assert main(["migrate", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"metaknot: error: {folder}: ")
    assert {"missing": "no such study directory",
            "empty": "not a metaknot study (it has no runs/ or failed/ folder and no tuning "
                     "storage); nothing was changed",
            "results": "a results folder, not a study; migrate each of its studies: "
                       "study-0.1.0"}[where] in err
    assert snapshot(tmp_path) == before


def test_a_tuning_study_begun_before_resumes_once_migrated(tmp_path, capsys):
    import json

    import optuna
    from hydra import compose, initialize_config_dir

    from metaknot.experiments.spec import ConfigError, plain_config
    from metaknot.experiments.tuning import tune_spec
    from metaknot.experiments.tuning.app import CONFIG_DIR
    from metaknot.experiments.tuning.runner import open_storage, open_study

    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        cfg = plain_config(compose("tuning", overrides=["tune=ga", f"results_dir={tmp_path}",
                                                        "study=t"]))
    spec = tune_spec(cfg)
    former = spec.identity()
    former["tune"]["algorithm"] = former["tune"].pop("optimizer")  # as 0.1.0 stored it
    study = optuna.create_study(study_name="t", storage=open_storage(spec))
    study.set_user_attr("metaknot_identity", json.dumps(former, sort_keys=True))
    with pytest.raises(ConfigError, match=r"already exists .* with other settings \(tune\)"):
        open_study(spec, open_storage(spec))
    assert main(["migrate", str(spec.study_dir)]) == 0
    assert "tuning study 't' carried over" in capsys.readouterr().err
    assert open_study(spec, open_storage(spec)).study_name == "t"  # resumes
    assert migrate_study(spec.study_dir).tuning == []


def test_migrate_changes_nothing_if_one_record_does_not_hold_its_run(study):
    shutil.copy(study / "runs" / "0de33c3ab98da6b6.parquet",
                study / "runs" / "0123456789abcdef.parquet")
    before = snapshot(study)
    with pytest.raises(StoreError, match=r"0123456789abcdef\.parquet: holds the record of run "
                                         "'0de33c3ab98da6b6'"):
        migrate_study(study)
    assert snapshot(study) == before
