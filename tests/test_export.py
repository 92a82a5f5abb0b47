"""``metaknot export STUDY --format iohprofiler``: a real study's traces written as IOHanalyzer
loads them, compared with what IOHexperimenter's own logger (``ioh``'s Analyzer) writes when the
same runs are replayed through an ioh-wrapped problem."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import ioh
import iohinspector
import polars as pl
import pytest

from metaknot.cli import main
from metaknot.experiments.export import (
    FUNCTIONS_FILE,
    ExportedFunction,
    export_iohprofiler,
    function_ids,
    hashed_function_id,
    suite_function_id,
)
from metaknot.experiments.store import load_study

# one shared study or build for the module: keep its tests on one xdist worker
pytestmark = pytest.mark.xdist_group("export")


def _run(*args: str, cwd: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "metaknot.cli", "run", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr


@pytest.fixture(scope="session")  # kept if other modules run in between
def study(tmp_path_factory) -> Path:
    """Suite runs (two methods, two seeds, one instance and task) and one run on noisy
    non-suite data, in one study."""
    root = tmp_path_factory.mktemp("export")
    _run("-m", "problem=suite", "problem.instance=titanium", "problem.task=tolerance",
         "optimizer=ga,one_plus_one", "seed=0,1", "budget=60", "study=S",
         f"results_dir={root}", cwd=root)
    _run("optimizer=random_search", "budget=40", "seed=3", "problem.noise=0.01", "study=S",
         f"results_dir={root}", cwd=root)
    return root / "S"


@pytest.fixture(scope="module")
def budgets(tmp_path_factory) -> Path:
    """One method at two budgets (two seeds each) on one suite task, and a run on noisy
    non-suite data, in one study."""
    root = tmp_path_factory.mktemp("budgets")
    _run("-m", "problem=suite", "problem.instance=titanium", "problem.task=tolerance",
         "optimizer=ga", "seed=0,1", "budget=40,80", "study=B", f"results_dir={root}", cwd=root)
    _run("optimizer=random_search", "budget=30", "seed=2", "problem.noise=0.01", "study=B",
         f"results_dir={root}", cwd=root)
    return root / "B"


def _replay(study_dir: Path, out: Path, exported: Path) -> dict[int, int]:
    """Every run of the study replayed through ioh's Analyzer into ``out``: the objective
    returns the trace's best-so-far at its improvements and at the run's last evaluation (ioh
    logs that one), a worse value elsewhere, and the run's best candidate at its best
    evaluation. Returns ioh's function id -> ours."""
    study = load_study(study_dir)
    ours = {meta["function_name"]: meta["function_id"]
            for meta in (json.loads(p.read_text()) for p in exported.glob("*/*.json"))}
    improvements = study.trace[study.trace["improvement"].astype(bool)]
    ids, current = {}, {"y": 0.0}
    for label, runs in study.runs.groupby("label"):
        info = json.loads(next((exported / label).glob("*.json")).read_text())
        logger = ioh.logger.Analyzer(root=str(out), folder_name=label, algorithm_name=label,
                                     algorithm_info=info["algorithm"]["info"])
        for _, run in runs.sort_values(["seed", "run_id"]).iterrows():
            name = (f"{run['suite.instance']}__{run['suite.task']}"
                    if isinstance(run["suite.task"], str)
                    else f"{run['data']}__{run['problem']}__{run['objective']}")
            rows = improvements[improvements["run_id"] == run["run_id"]]
            values = dict(zip(rows["evaluations"], rows["best_f"], strict=True))
            config = json.loads(run["config"])
            instance = int(run["seed"]) if config["problem"]["noise"] else 1
            integer = all(isinstance(v, int) for v in run["best_x"])  # mask bits: int64
            problem = ioh.wrap_problem(
                lambda x: current["y"], name=name, dimension=int(run["n_var"]),
                instance=instance,
                problem_class=ioh.ProblemClass.INTEGER if integer else ioh.ProblemClass.REAL)
            ids[problem.meta_data.problem_id] = ours[name]
            problem.attach_logger(logger)
            best_at, worse = int(rows["evaluations"].iloc[-1]), float(rows["best_f"].max()) + 1
            n_evaluations = int(run["n_evaluations"])
            values.setdefault(n_evaluations, rows["best_f"].iloc[-1])  # not an improvement
            for evaluation in range(1, n_evaluations + 1):
                current["y"] = float(values.get(evaluation, worse))
                x = run["best_x"] if evaluation == best_at else [0] * int(run["n_var"])
                problem([v if integer else float(v) for v in x])
            problem.detach_logger()
        logger.close()
    return ids


def _files(folder: Path, ids: dict[int, int] | None = None) -> dict[str, str]:
    """Relative path -> text of every file under ``folder`` (ioh's function ids mapped to
    ours, in the names and the meta data)."""
    files = {}
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        name, text = path.relative_to(folder).as_posix(), path.read_text()
        for theirs, ours in (ids or {}).items():
            name = name.replace(f"f{theirs}_", f"f{ours}_")
            text = text.replace(f"f{theirs}_", f"f{ours}_").replace(
                f'"function_id": {theirs},', f'"function_id": {ours},')
        files[name] = text
    return files


def test_the_files_are_those_ioh_writes_for_the_same_runs(study, tmp_path) -> None:
    exported = tmp_path / "exported"
    written = export_iohprofiler(study, exported)
    ours = _files(exported)
    assert sorted(ours) == sorted(p.relative_to(exported).as_posix() for p in written)
    ids = _replay(study, tmp_path / "ioh", exported)
    theirs = _files(tmp_path / "ioh", ids)
    functions = ours.pop(FUNCTIONS_FILE)  # metaknot's own: the ids' instances and tasks
    assert sorted(ours) == sorted(theirs)
    for name, text in ours.items():
        if name.endswith(".dat"):
            assert text == theirs[name], name  # rows, headers, number format: the same text
        else:
            meta, expected = json.loads(text), json.loads(theirs[name])
            assert expected.pop("suite") == "unknown_suite" and meta.pop("suite") == "metaknot"
            assert meta == expected, name
    # one algorithm folder per method; the suite function named by instance and task
    assert {name.split("/")[0] for name in ours} == {"ga", "one_plus_one", "random_search"}
    fid = suite_function_id("titanium", "tolerance_1e-3")
    assert f"{fid},titanium__tolerance_1e-3,titanium,tolerance_1e-3," in functions
    suite_meta = json.loads(ours[f"ga/IOHprofiler_f{fid}_titanium__tolerance_1e-3.json"])
    assert [len(s["runs"]) for s in suite_meta["scenarios"]] == [2]
    assert suite_meta["scenarios"][0]["dimension"] == 47  # n_var: titanium's 47 masks bits
    noisy = next(t for n, t in ours.items() if n.startswith("random_search/") and
                 n.endswith(".json"))
    assert json.loads(noisy)["function_name"] == "epitrochoid__mask__paper"
    assert json.loads(noisy)["scenarios"][0]["runs"][0]["instance"] == 3  # the noise's seed


def test_only_improvements_are_written(study, tmp_path) -> None:
    export_iohprofiler(study, tmp_path / "out")
    trace = load_study(study).trace
    rows = [line for path in (tmp_path / "out").rglob("*.dat")
            for line in path.read_text().splitlines() if line != "evaluations raw_y"]
    runs = load_study(study).runs
    improvements = trace[trace["improvement"].astype(bool)]
    last = improvements.groupby("run_id")["evaluations"].max()
    # and a last row for each run whose final evaluation did not improve
    ends = sum(n > last[r] for r, n in zip(runs["run_id"], runs["n_evaluations"], strict=True))
    assert len(rows) == len(improvements) + ends < len(trace)


def test_function_ids_are_small_and_stable() -> None:
    # documented: 1 + 10 * the instance's place in the suite + the task's place
    assert suite_function_id("titanium", "tolerance_1e-3") == 166
    assert suite_function_id("titanium", "tolerance_1e-2") == 165
    assert suite_function_id("galvez_f1", "fixed_k_small.indices") == 1
    assert suite_function_id("titanium", "no_such_task") is None
    assert suite_function_id("titanium+noise0.01s7", "seed") is None  # not one of the suite's
    assert hashed_function_id("epitrochoid__mask__paper") == 29036  # 10000 + crc32 mod 50000
    # a collision moves the later name (by name order) to the next free id, the same each time
    names = sorted(f"d{i}__mask__paper" for i in range(2000))
    first = {}
    for name in names:
        first.setdefault(hashed_function_id(name), name)
    clash = next(n for n in names if first[hashed_function_id(n)] != n)
    functions = [ExportedFunction(n, "", "", n, "mask", "paper") for n in names]
    ids = function_ids(functions)
    assert ids == function_ids(reversed(functions))
    assert len(set(ids.values())) == len(names) and max(ids.values()) < 60_000
    assert ids[first[hashed_function_id(clash)]] == hashed_function_id(clash)
    assert ids[clash] != hashed_function_id(clash)
    suite = ExportedFunction("titanium__seed", "titanium", "seed", "titanium", "mask", "paper")
    assert function_ids([suite, *functions])["titanium__seed"] == 168


def test_the_command_refuses_a_folder_that_is_not_empty(study, tmp_path, capsys) -> None:
    out = tmp_path / "out"
    assert main(["export", str(study), "--format", "iohprofiler", "--out", str(out)]) == 0
    assert "files in" in capsys.readouterr().out
    assert main(["export", str(study), "--format", "iohprofiler", "--out", str(out)]) == 2
    assert "not empty" in capsys.readouterr().err
    assert main(["export", str(study), "--format", "iohprofiler", "--out", str(out),
                 "--force"]) == 0
    # the default folder sits beside the study
    assert main(["export", str(study), "--format", "iohprofiler"]) == 0
    assert (study.parent / "S-iohprofiler" / "ga").is_dir()


def test_a_study_without_runs_is_named(tmp_path) -> None:
    (tmp_path / "empty" / "runs").mkdir(parents=True)
    with pytest.raises(ValueError, match="no finished run"):
        export_iohprofiler(tmp_path / "empty", tmp_path / "out")


def test_iohinspector_loads_the_export(budgets, tmp_path) -> None:
    out = tmp_path / "out"
    export_iohprofiler(budgets, out)
    manager = iohinspector.DataManager()
    manager.add_folder(str(out))
    overview = manager.overview
    runs = load_study(budgets).runs
    assert len(overview) == len(runs) == 5
    # one algorithm per budget of the label "ga", its info naming that budget
    algorithm = {r: ("ga_budget=" + str(b) if o == "ga" else o) for r, o, b in
                 zip(runs["run_id"], runs["label"], runs["budget"], strict=True)}
    assert set(overview["algorithm_name"]) == {"ga_budget=40", "ga_budget=80", "random_search"}
    for name, info in zip(overview["algorithm_name"], overview["algorithm_info"], strict=True):
        assert name == "random_search" or f" budget={name.split('=')[1]} " in info
    expected = sorted((algorithm[r], n, f) for r, n, f in
                      zip(runs["run_id"], runs["n_evaluations"], runs["best_f"], strict=True))
    loaded = sorted(zip(overview["algorithm_name"], overview["evals"], overview["best_y"],
                        strict=True))
    assert loaded == expected  # best values with every digit
    # each run's rows read back as one run, ending at its best value
    last = manager.load(monotonic=False, include_meta_data=True).group_by("data_id").agg(
        *(pl.col(c).last() for c in ("algorithm_name", "raw_y")))
    assert sorted((a, round(y, 10)) for a, y in zip(last["algorithm_name"], last["raw_y"],
                                                    strict=True)) == \
        sorted((a, round(f, 10)) for a, _, f in expected)
    assert max(overview["function_id"]) < 60_000
    functions = (out / FUNCTIONS_FILE).read_text().splitlines()
    assert functions[1:] == [
        f"{suite_function_id('titanium', 'tolerance_1e-3')},titanium__tolerance_1e-3,titanium,"
        "tolerance_1e-3,titanium,mask,error_bounded",
        f"{hashed_function_id('epitrochoid__mask__paper')},epitrochoid__mask__paper,,,"
        "epitrochoid,mask,paper"]
    # a mask's bits are integers, as ioh writes an integer problem's candidates
    meta = json.loads(next((out / "ga_budget=40").glob("*.json")).read_text())
    assert all(type(v) is int for v in meta["scenarios"][0]["runs"][0]["best"]["x"])


def test_every_task_of_the_suite_has_its_own_small_function_id():
    from metaknot.experiments.export import suite_function_id
    from metaknot.suite import instances
    from metaknot.suite.tasks import tasks

    ids = [suite_function_id(instance.id, task.id) for instance in instances(plugins=False)
           for task in tasks(instance)]
    assert None not in ids and len(set(ids)) == len(ids) and max(ids) < 10_000
