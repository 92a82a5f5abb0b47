"""``metaknot run`` end to end, as a user runs it: single runs, sweeps, resume after a kill,
the launchers, and errors before anything runs."""

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
import pytest
import yaml

from metaknot.experiments.store import load_study

ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}
#: Fields every stored run has (the studies issue's list), beyond problem-specific settings.
RECORD_FIELDS = {
    "run_id", "study", "label", "problem", "data", "data_fingerprint", "n_points", "dim",
    "noise", "noise_seed", "density", "degree", "parameterization", "encoding", "objective",
    "objective.error_floor", "optimizer", "seed", "seed_spawn_key", "budget",
    "n_evaluations", "best_f", "rmse", "euclidean_distance", "max_deviation",
    "n_control_points", "setup_seconds", "optimize_seconds", "decode_seconds",
    "elapsed_seconds", "external_fits", "status", "error", "metaknot_version",
    "python_version", "numpy_version", "scipy_version", "numba_version", "git_commit",
    "timestamp", "config", "best_x", "kernel_threads",
}


def metaknot(*args: str, cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "metaknot.cli", "run", *args], cwd=cwd,
                          capture_output=True, text=True, timeout=timeout, env=ENV)


def plan_line(stderr: str) -> dict[str, int]:
    """Counts of the sweeper's plan line ('study ...: N jobs, X to run, Y already stored')."""
    line = next(ln for ln in stderr.splitlines() if " jobs, " in ln)
    counts = {"jobs": int(re.search(r"(\d+) jobs", line).group(1))}
    for key, pattern in (("to_run", r"(\d+) to run"), ("stored", r"(\d+) already stored"),
                         ("skipped", r"(\d+) skipped")):
        found = re.search(pattern, line)
        counts[key] = int(found.group(1)) if found else 0
    return counts


def snapshot(runs_dir: Path) -> dict[str, tuple[int, int, bytes]]:
    return {p.name: (p.stat().st_ino, p.stat().st_mtime_ns, p.read_bytes())
            for p in runs_dir.glob("*.parquet")}


def test_single_run_from_the_command_line(tmp_path):
    done = metaknot("optimizer=ga", "problem=vivaldi", "seed=3", "budget=400",
                    f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    study = load_study(tmp_path / "default")
    (row,) = study.runs.to_dict("records")
    assert row["optimizer"] == "ga" and row["data"] == "vivaldi" and row["seed"] == 3
    assert row["n_evaluations"] == 400 and row["status"] == "ok"
    # the outcome: objective, RMSE, the control points (the first and last twelve of many)
    lines = done.stdout.splitlines()
    assert lines[0] == f"run {row['run_id']}: ok, 400 of 400 evaluations"
    assert lines[1] == (f"  objective (paper) {row['best_f']:.6g}, RMSE {row['rmse']:.4g}, "
                        f"max deviation {row['max_deviation']:.4g}, "
                        f"{row['n_control_points']} control points")
    control = np.asarray(row["spline.coefficients"])[: row["n_control_points"]]
    assert row["n_control_points"] > 24 and lines[2] == "  control points:"
    shown = [[float(v) for v in line.split()] for line in lines[3:15] + lines[16:28]]
    np.testing.assert_allclose(shown, np.vstack((control[:12], control[-12:])), rtol=1e-5)
    assert lines[15] == f"    ... {len(control) - 24} more ..."
    assert lines[28:] == [f"  record: {tmp_path / 'default' / 'runs' / row['run_id']}.parquet"]
    again = metaknot("optimizer=ga", "problem=vivaldi", "seed=3", "budget=400",
                     f"results_dir={tmp_path}", cwd=tmp_path)
    assert again.returncode == 0 and "already stored" in again.stdout
    # a single run uses every kernel thread (threads=auto); threads=1 pins one
    import numba

    assert row["kernel_threads"] == numba.config.NUMBA_NUM_THREADS
    one = metaknot("optimizer=ga", "problem=vivaldi", "seed=4", "budget=100", "threads=1",
                   f"results_dir={tmp_path}", cwd=tmp_path)
    assert one.returncode == 0, one.stderr
    runs = load_study(tmp_path / "default").runs
    assert int(runs.loc[runs.seed == 4, "kernel_threads"].iloc[0]) == 1


@pytest.mark.parametrize(("override", "key"), [
    ("optimizer.population=abc", "optimizer.population"),
    ("budget=0", "budget"),
    ("problem.degree=9", "problem.degree"),
    ("encoding.density=1.5", "encoding.density"),
])
def test_a_bad_value_fails_before_anything_runs(tmp_path, override, key):
    done = metaknot(override, f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("metaknot run: error: ") and key in line
    assert not (tmp_path / "default").exists()


def test_a_bad_value_in_a_sweep_fails_before_any_run(tmp_path):
    done = metaknot("-m", "optimizer=ga", "optimizer.population=30,abc", "seed=0,1",
                    "budget=100", f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("metaknot run: error: optimizer.population: expected an integer, "
                           "got 'abc' (in the job optimizer=ga optimizer.population=abc "
                           "seed=0"), line
    assert not (tmp_path / "default" / "runs").exists()


#: A bad command line, single run and sweep alike: one line naming the setting, exit status 2,
#: no Hydra advice ("+optimizer.populaton=30", HYDRA_FULL_ERROR).
BAD_COMMAND_LINES = [
    (["optimizer=ga", "optimizer.populaton=30"],
     r"optimizer\.populaton: unknown setting \(known: crossover, .*\bpopulation\b.*\)"),
    (["-m", "optimizer=ga", "optimizer.populaton=30"],
     r"optimizer\.populaton: unknown setting \(known: .*\bpopulation\b.*\) \(in the job "
     r"optimizer=ga optimizer\.populaton=30 "),
    (["-m", "optimizer=ga,nlopt", "encoding=free", "optimizer.population=30"],
     r"optimizer\.population: unknown setting \(known: box_map, .*\) \(in the job "
     r"optimizer=nlopt "),
    (["objective.tolerence=0.1"], r"objective\.tolerence: unknown setting \(known: error_floor\)"),
    (["-m", "objective=error_bounded", "objective.tolerence=0.1"],
     r"objective\.tolerence: unknown setting \(known: .*\btolerance\b"),
    (["launcher.n_jobs=2"], r"launcher\.n_jobs: unknown setting; launcher is a choice of "
                            r"config \(launcher=basic, joblib, "),
    (["-m", "seed=range(0,x)"], r"seed: cannot read 'seed=range\(0,x\)': TypeError while "
                                r"evaluating 'range\(0,x\)'"),
    (["-m", "seed=range(0,3"], r"seed: cannot read 'seed=range\(0,3': no viable alternative"),
    (["seed=range(0,3"], r"seed: cannot read 'seed=range\(0,3': "),
    (["-m", "problem=archimedean", "suite=mini"],
     r"problem=archimedean: a suite sweeps the suite's instances \(problem=suite\)"),
    (["-m", "budget=abc"], r"budget: expected an integer, got 'abc' \(in the job budget=abc "),
    (["-m", "optimizer=gaa"], r"optimizer=gaa: unknown optimizer 'gaa'\. Did you mean 'ga'\?"),
]


@pytest.mark.parametrize(("args", "message"), BAD_COMMAND_LINES,
                         ids=[" ".join(args) for args, _ in BAD_COMMAND_LINES])
def test_a_bad_command_line_is_one_line_naming_the_setting_and_exit_status_2(tmp_path, args,
                                                                              message):
    done = metaknot(*args, f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert re.match(rf"metaknot run: error: {message}", line), line
    assert "HYDRA_FULL_ERROR" not in done.stderr and "+optimizer" not in done.stderr
    assert not (tmp_path / "default").exists()


def test_hydra_options_and_their_values_are_not_settings(tmp_path):
    done = metaknot("optimizer=ga", "optimizer.population=30", f"results_dir={tmp_path}",
                    "--cfg", "job", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    shown = yaml.safe_load(done.stdout)
    assert shown["optimizer"]["_name_"] == "ga" and shown["optimizer"]["population"] == 30
    assert shown["optimizer"]["tournament_size"] == 2  # the signature's default
    assert not (tmp_path / "default").exists()


def test_a_sweep_whose_every_job_is_skipped_says_why_and_fails(tmp_path):
    done = metaknot("-m", "optimizer=nlopt", "encoding=mask", "seed=0,1", "budget=50",
                    f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 2
    (line,) = done.stderr.strip().splitlines()
    assert line == ("metaknot run: error: no job of the sweep can run: optimizer 'nlopt' handles "
                    "continuous encodings; encoding 'mask' is binary (2 jobs)")
    assert not (tmp_path / "default").exists()


def test_an_algorithm_that_cannot_work_on_an_encoding(tmp_path):
    single = metaknot("optimizer=nlopt", "encoding=mask", f"results_dir={tmp_path}",
                      cwd=tmp_path)
    assert single.returncode == 2 and "nlopt" in single.stderr and "mask" in single.stderr
    sweep = metaknot("-m", "optimizer=nlopt,random_search", "encoding=mask,free",
                     "problem=archimedean", "budget=60", f"results_dir={tmp_path}",
                     cwd=tmp_path)
    assert sweep.returncode == 0, sweep.stderr
    counts = plan_line(sweep.stderr)
    assert counts == {"jobs": 4, "to_run": 3, "stored": 0, "skipped": 1}
    assert "skipped 1 job(s): optimizer 'nlopt'" in sweep.stderr
    study = load_study(tmp_path / "default")
    assert sorted(zip(study.runs.optimizer, study.runs.encoding, strict=True)) == [
        ("nlopt", "continuous"), ("random_search", "binary"), ("random_search", "continuous")]


def test_smoke_study_has_every_field_and_paired_replicates(tmp_path):
    # the demo study as `make demo` runs it, on three of its eight seeds
    done = metaknot("-m", "experiment=smoke", "seed=range(0,3)", f"results_dir={tmp_path}",
                    cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    study = load_study(tmp_path / "smoke")
    runs = study.runs
    assert len(runs) == 3 * 6 * 2 * 3 and (runs.status == "ok").all()
    assert RECORD_FIELDS <= set(runs.columns), RECORD_FIELDS - set(runs.columns)
    assert runs.run_id.is_unique
    assert set(runs.optimizer) == {"dolphin", "ga", "random_search", "one_plus_one",
                                   "averaging", "local_search"}
    assert set(runs.budget) == {500, 1500} and set(runs.seed) == set(range(3))
    searches = runs.optimizer.isin(["dolphin", "ga", "random_search", "one_plus_one"])
    assert (runs.n_evaluations[searches] == runs.budget[searches]).all()
    assert (runs.n_evaluations <= runs.budget).all()  # the averaging scan and local search stop
    # replicate r of every algorithm saw the same data: same fingerprint per (curve, seed)
    assert (runs.groupby(["data", "seed"]).data_fingerprint.nunique() == 1).all()
    # the trace: checkpoints shared across runs, the last one at the run's end
    trace = study.trace
    assert set(trace.run_id) == set(runs.run_id)
    for run_id, points in trace.groupby("run_id"):
        used = int(runs.loc[runs.run_id == run_id, "n_evaluations"].iloc[0])
        assert points.evaluations.is_monotonic_increasing
        assert points.evaluations.iloc[-1] == used and points.checkpoint.iloc[-1]
        assert {e for e in (1, 10, 100) if e <= used} <= set(
            points.evaluations[points.checkpoint])
        assert (np.diff(points.best_f.to_numpy()) <= 0).all()
        best = float(runs.loc[runs.run_id == run_id, "best_f"].iloc[0])
        assert points.best_f.iloc[-1] == best
    config = json.loads(runs.config.iloc[0])
    assert config["budget"] == int(runs.budget.iloc[0])


def test_sweep_resumes_after_a_kill(tmp_path):
    """SIGKILL a sweep part-way; the same command again runs exactly the rest."""
    args = ("-m", "experiment=smoke", "optimizer=dolphin,ga,random_search", "seed=0,1",
            "budget=3000", f"results_dir={tmp_path}")
    runs_dir = tmp_path / "smoke" / "runs"
    proc = subprocess.Popen([sys.executable, "-m", "metaknot.cli", "run", *args], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=ENV,
                            start_new_session=True)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and len(list(runs_dir.glob("*.parquet"))) < 4:
        assert proc.poll() is None, "the sweep ended before it could be killed"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=60)
    before = snapshot(runs_dir)
    assert 4 <= len(before) < 18, len(before)
    done = metaknot(*args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    counts = plan_line(done.stderr)
    assert counts["jobs"] == 18 and counts["stored"] == len(before)
    assert counts["to_run"] == 18 - len(before)
    assert f"{18 - len(before)} ok" in done.stderr  # only the rest was computed
    after = snapshot(runs_dir)
    assert len(after) == 18
    for name, state in before.items():
        assert after[name] == state, f"{name} was rewritten"
    study = load_study(tmp_path / "smoke")
    assert len(study.runs) == 18 and study.runs.run_id.is_unique
    assert (study.runs.status == "ok").all() and len(study.failures) == 0
    # a third time: nothing left to do
    again = metaknot(*args, cwd=tmp_path)
    assert plan_line(again.stderr) == {"jobs": 18, "to_run": 0, "stored": 18, "skipped": 0}
    assert snapshot(runs_dir) == after


def test_joblib_workers_run_the_kernel_on_one_thread(tmp_path):
    done = metaknot("-m", "launcher=joblib", "hydra.launcher.n_jobs=2",
                    "optimizer=ga,random_search", "problem=archimedean,vivaldi", "seed=0,1",
                    "budget=300", f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    runs = load_study(tmp_path / "default").runs
    assert len(runs) == 8 and (runs.status == "ok").all()
    assert (runs.kernel_threads == 1).all()


@pytest.mark.slow
def test_submitit_local_launcher(tmp_path):
    """The same code path as SLURM, on this machine."""
    done = metaknot("-m", "launcher=submitit_local", "optimizer=ga,random_search",
                    "problem=archimedean", "budget=200", f"results_dir={tmp_path}",
                    cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    runs = load_study(tmp_path / "default").runs
    assert sorted(runs.optimizer) == ["ga", "random_search"]
    assert (runs.status == "ok").all() and (runs.kernel_threads == 1).all()


def test_user_points_file(tmp_path):
    t = np.linspace(0, 2 * np.pi, 80)
    points = tmp_path / "outline.csv"
    np.savetxt(points, np.column_stack((np.cos(t), np.sin(2 * t))), delimiter=",",
               header="x,y", comments="")
    done = metaknot("problem=points", f"problem.points={points}", "optimizer=ga",
                    "budget=200", f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    (row,) = load_study(tmp_path / "default").runs.to_dict("records")
    assert row["data"] == "outline" and row["n_points"] == 80


def test_batching_seeds_into_jobs_changes_no_result(tmp_path):
    """Seeds batched three to a job are stored as separate runs, identical to one per job."""
    common = ("-m", "optimizer=ga,random_search", "problem=archimedean", "seed=range(0,5)",
              "budget=150")
    one = metaknot(*common, "hydra.sweeper.runs_per_job=1", f"results_dir={tmp_path / 'a'}",
                   cwd=tmp_path)
    three = metaknot(*common, "hydra.sweeper.runs_per_job=3", f"results_dir={tmp_path / 'b'}",
                     cwd=tmp_path)
    assert one.returncode == 0 and three.returncode == 0, one.stderr + three.stderr
    assert "10 ok" in one.stderr and "10 ok" in three.stderr
    a = load_study(tmp_path / "a" / "default").runs.set_index("run_id")
    b = load_study(tmp_path / "b" / "default").runs.set_index("run_id")
    assert sorted(a.index) == sorted(b.index) and len(a) == 10
    for column in ("seed", "optimizer", "best_f", "rmse", "n_control_points"):
        assert (a[column] == b.loc[a.index, column]).all(), column
    bad = metaknot(*common, "hydra.sweeper.runs_per_job=0", f"results_dir={tmp_path / 'c'}",
                   cwd=tmp_path)
    assert bad.returncode != 0 and "hydra.sweeper.runs_per_job" in bad.stderr



def test_runs_in_processes_with_different_string_hashing_store_the_same_records(tmp_path):
    """Same seed, same records, whatever the interpreter's string hashing: every stored field
    but the timings and the host is equal (traces and their metric columns included)."""
    import pyarrow.parquet as pq

    sweep = ("-m", "optimizer=one_plus_one,ga", "objective=paper,error_bounded",
             "problem=archimedean", "seed=0", "budget=200")
    for hash_seed in ("1", "7"):
        done = subprocess.run(
            [sys.executable, "-m", "metaknot.cli", "run", *sweep,
             f"results_dir={tmp_path / hash_seed}"], cwd=tmp_path, capture_output=True,
            text=True, timeout=600, env={**ENV, "PYTHONHASHSEED": hash_seed})
        assert done.returncode == 0 and "4 ok" in done.stderr, done.stderr
    timings = {"timestamp", "host", "elapsed_seconds", "setup_seconds", "optimize_seconds",
               "decode_seconds"}
    records = sorted((tmp_path / "1" / "default" / "runs").glob("*.parquet"))
    assert len(records) == 4
    for record in records:
        one, other = (pq.read_table(tmp_path / h / "default" / "runs" / record.name)
                      for h in ("1", "7"))
        assert one.column_names == other.column_names
        kept = [name for name in one.column_names if name not in timings]
        assert one.select(kept).equals(other.select(kept)), record.name
        assert one.schema.metadata == other.schema.metadata

# --- method presets: data, never code ---------------------------------------------------------

#: A preset that, loaded as a Hydra config (``--config-dir``), would run a Python callable when
#: the job starts: a Hydra callback whose ``_target_`` opens (creates) a file.
CALLBACK_PRESET = """\
# @package _global_
optimizer: {_name_: ga, population: 20}
hydra:
  callbacks:
    evil: {_target_: builtins.open, _args_: ["{marker}", "w"]}
"""


def test_a_preset_runs_as_its_overrides_and_the_command_line_wins(tmp_path):
    preset = tmp_path / "ga_tuned.yaml"
    preset.write_text("# tuned\noptimizer: {_name_: ga, population: 20, mutation_rate: 0.05}\n"
                      "encoding: {kind: indices, n_knots: 12}\nlabel: ga-tuned\n")
    common = ("problem=vivaldi", "budget=150", f"results_dir={tmp_path}")
    by_preset = metaknot("--preset", str(preset), *common, "seed=1", "optimizer.population=30",
                         cwd=tmp_path)
    assert by_preset.returncode == 0, by_preset.stderr
    by_hand = metaknot("optimizer=ga", "optimizer.population=30", "optimizer.mutation_rate=0.05",
                       "encoding=indices", "encoding.n_knots=12", "label=ga-tuned", *common,
                       "seed=1", cwd=tmp_path)
    assert "already stored" in by_hand.stdout  # the very same run
    sweep = metaknot("-m", f"--preset={preset}", *common, "seed=2,3", cwd=tmp_path)
    assert sweep.returncode == 0, sweep.stderr
    runs = load_study(tmp_path / "default").runs.set_index("seed")
    assert list(runs.loc[[2, 3], "optimizer.population"]) == [20, 20]
    assert runs.loc[1, "optimizer.population"] == 30
    assert set(runs.label) == {"ga-tuned"} and set(runs.encoding) == {"integer"}


@pytest.mark.parametrize(("body", "key"), [
    (CALLBACK_PRESET, "hydra"),
    ('optimizer: {_name_: ga}\n"hydra.callbacks.evil._target_": builtins.open\n',
     "hydra.callbacks.evil._target_"),
    ("optimizer: {_name_: ga, _target_: builtins.open}\n", "optimizer._target_"),
    ("defaults: [{override /optimizer: ga}]\noptimizer: {population: 20}\n", "defaults"),
    ("optimizer: {_name_: ga}\nproblem: {curve: vivaldi}\n", "problem: unknown setting"),
    ("optimizer: {_name_: ga, speed: 3}\n", "optimizer.speed: unknown setting"),
    ("{1: 2, speed: 3, optimizer: {_name_: ga}}\n", "1: unknown setting"),
    ("optimizer: {_name_: ga, population: [10, 20]}\n", "optimizer.population"),
    ("optimizer: {_name_: ga}\nlabel: '${oc.env:HOME}'\n", "label"),
    ("optimizer: {_name_: warp}\n", "optimizer._name_"),
    ("optimizer: {_name_: ga}\nencoding: {kind: warp}\n", "encoding.kind"),
    ("encoding: {kind: mask}\n", "optimizer: required"),
    ("optimizer: {_name_: ga\n", "not valid YAML"),
])
def test_a_preset_is_read_as_data_and_anything_else_is_refused(tmp_path, capsys, body, key):
    from metaknot.experiments.app import main

    marker = tmp_path / "pwned"
    preset = tmp_path / "preset.yaml"
    preset.write_text(body.replace("{marker}", str(marker)))
    assert main(["--preset", str(preset), "problem=vivaldi", "budget=100",
                 f"results_dir={tmp_path}"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"metaknot run: error: {preset}: ") and key in line, line
    assert not marker.exists() and not (tmp_path / "default").exists()


def test_a_missing_or_repeated_preset_is_one_line(tmp_path, capsys):
    from metaknot.experiments.app import main

    for args, message in ((["--preset", str(tmp_path / "none.yaml")], "no such file"),
                          (["--preset"], "give the preset file"),
                          (["--preset=a.yaml", "--preset=b.yaml"], "given twice")):
        assert main([f"results_dir={tmp_path}", *args]) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert line.startswith("metaknot run: error: --preset: ") and message in line


@pytest.mark.parametrize("args", [["method=dolphin_indice"],
                                  ["-m", "method=ga_indices,dolphin_indice", "seed=0,1"]])
def test_a_mistyped_config_choice_is_one_line_with_the_closest_names(tmp_path, capsys, args):
    from metaknot.experiments.app import main

    assert main([*args, f"results_dir={tmp_path}"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("metaknot run: error: method=dolphin_indice: ") and \
        "did you mean dolphin_indices" in line, line
    assert not (tmp_path / "default").exists()


@pytest.mark.parametrize("command", ["run", "tune"])
def test_a_bare_word_is_named_as_not_a_setting(tmp_path, capsys, command):
    """A file name where a setting belongs (``metaknot run spec.yaml``) got Hydra's "missing
    EQUAL at '<EOF>'" and a stack-trace hint; it is one line with an example now."""
    from metaknot.experiments.app import main as run_main
    from metaknot.experiments.tuning.app import main as tune_main

    main = run_main if command == "run" else tune_main
    assert main(["spec.yaml", f"results_dir={tmp_path}"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"metaknot {command}: error: 'spec.yaml' is not a setting: settings "
                           "are key=value, e.g. "), line
    assert not (tmp_path / "default").exists()


@pytest.mark.parametrize("args", [["method=null"], ["-m", "method=null,ga_indices"]])
def test_a_method_set_to_null_is_one_line_naming_the_default_method(tmp_path, capsys, args):
    from metaknot.experiments.app import main

    assert main([*args, f"results_dir={tmp_path}"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("metaknot run: error: method=null: ") and \
        "method=default,NAME" in line, line
    assert not (tmp_path / "default").exists()


@pytest.mark.parametrize(("args", "key"), [
    (["optimizer=dolphn"], "optimizer"), (["-m", "optimizer=ga,dolphn"], "optimizer"),
    (["optimizer._name_=dolphn"], "optimizer._name_"),
    (["-m", "optimizer._name_=ga,dolphn", "seed=0,1"], "optimizer._name_"),
])
def test_a_mistyped_optimizer_is_one_line_from_the_optimizer_registry(tmp_path, capsys, args,
                                                                       key):
    from metaknot.experiments.app import main

    assert main([*args, f"results_dir={tmp_path}"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"metaknot run: error: {key}=dolphn: unknown optimizer 'dolphn'. "
                           "Did you mean 'dolphin'? Available: "), line
    assert not (tmp_path / "default").exists()


def test_a_sweep_compares_a_method_with_the_defaults(tmp_path):
    done = metaknot("-m", "method=default,ga_indices", "problem=archimedean", "budget=60",
                    f"results_dir={tmp_path}", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    runs = load_study(tmp_path / "default").runs
    assert sorted(zip(runs.label, runs.optimizer, runs.encoding, strict=True)) == [
        ("dolphin", "dolphin", "binary"), ("ga", "ga", "integer")]


NOTE = "metaknot run: note: these runs go to the default study "


def test_runs_into_the_default_study_say_so(tmp_path):
    """A single run or a sweep without study= prints one note naming the default study; one
    with a study of its own, or with nothing left to run, does not."""
    for args, study in ((["optimizer=ga"], "default"), (["-m", "seed=1,2"], "default"),
                        (["optimizer=ga", "study=mine"], "mine"),
                        (["-m", "seed=1,2", "study=mine"], "mine"), (["-m", "seed=1,2"], None)):
        done = metaknot(*args, "problem=archimedean", "budget=40", f"results_dir={tmp_path}",
                        cwd=tmp_path)
        assert done.returncode == 0, done.stderr
        notes = [line for line in done.stderr.splitlines() if line.startswith(NOTE)]
        if study == "default":
            assert notes == [f"{NOTE}{tmp_path / 'default'}, which every run made without "
                             "study= shares; give study=NAME to keep an experiment apart"], args
        else:
            assert notes == [], args
        assert (tmp_path / (study or "default") / "runs").is_dir()


# --------------------------------------------------------------------------------------------
# Ctrl-C and kill: the workers stop, every record stays, one line, exit 130/143, resume

INTERRUPTED = re.compile(r"interrupted: (\d+) of (\d+) runs stored; run the same command to "
                         r"resume")


def living_processes(group: int) -> list[str]:
    """Processes of the process group ``group`` that are neither gone nor zombies."""
    alive = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[2]) == group and fields[0] != "Z":
                alive.append(f"{entry.name}: {(entry / 'cmdline').read_bytes()[:80]!r}")
    return alive


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupted_joblib_sweep_stops_its_workers_and_resumes(tmp_path, signum):
    """SIGINT to the whole process group (Ctrl-C) or SIGTERM to the leader (kill) once three
    records exist: no worker goes on, one line says what is stored, the same command
    finishes the study with the results a direct run gives."""
    args = ("-m", "launcher=joblib", "hydra.launcher.n_jobs=2", "optimizer=ga,random_search",
            "problem=archimedean", "seed=range(0,6)", "budget=2000", f"results_dir={tmp_path}")
    runs_dir = tmp_path / "default" / "runs"
    # files, not pipes: a worker left alive would hold a pipe open
    with open(tmp_path / "stderr", "w") as err:
        proc = subprocess.Popen([sys.executable, "-m", "metaknot.cli", "run", *args],
                                cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=err, env=ENV,
                                start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and len(list(runs_dir.glob("*.parquet"))) < 3:
            assert proc.poll() is None, "the sweep ended before it could be interrupted"
            time.sleep(0.02)
        if signum == signal.SIGINT:
            os.killpg(proc.pid, signum)
        else:
            os.kill(proc.pid, signum)
        assert proc.wait(timeout=60) == 128 + signum
        deadline = time.monotonic() + 5
        while living_processes(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert living_processes(proc.pid) == []
    finally:
        if living_processes(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)
    stderr = (tmp_path / "stderr").read_text()
    assert "Traceback" not in stderr and "Error" not in stderr, stderr
    lines = stderr.strip().splitlines()
    assert plan_line(lines[0])["to_run"] == 12 and len(lines) == 3, stderr
    assert lines[1].startswith(NOTE)  # no study=: the default study
    stored, total = map(int, INTERRUPTED.fullmatch(lines[2]).groups())
    before = snapshot(runs_dir)
    assert 3 <= stored == len(before) < total == 12
    assert list((tmp_path / "default" / "tmp").iterdir()) == []

    done = metaknot(*args, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert plan_line(done.stderr)["stored"] == stored and f"{12 - stored} ok" in done.stderr
    after = snapshot(runs_dir)
    assert len(after) == 12 and all(after[name] == state for name, state in before.items())
    runs = load_study(tmp_path / "default").runs
    assert (runs.status == "ok").all() and runs.run_id.is_unique
    import metaknot as mk
    from metaknot.experiments.spec import run_spec

    for row in runs.itertuples():
        spec = run_spec({**json.loads(row.config), "study": "direct", "results_dir": "."})
        assert spec.run_id == row.run_id
        direct = mk.minimize(spec.build_problem(), spec.build_optimizer(), budget=spec.budget,
                             seed=spec.optimizer_seed(),
                             checkpoints_per_decade=spec.config["checkpoints_per_decade"])
        assert row.best_f == direct.best_f and row.best_x == direct.best_x.tolist()


SIGNAL_IN_RUN = """
import os, signal, sys
import metaknot.runner
from metaknot.experiments.app import main

minimize = metaknot.runner.minimize

def signalled(*args, **kwargs):  # the signal arrives while the run computes
    os.kill(os.getpid(), signal.SIGTERM)
    return minimize(*args, **kwargs)

metaknot.runner.minimize = signalled
sys.exit(main(sys.argv[1:]))
"""


def test_an_interrupted_single_run_says_nothing_is_stored(tmp_path):
    done = subprocess.run([sys.executable, "-c", SIGNAL_IN_RUN, "optimizer=ga", "budget=3000",
                           f"results_dir={tmp_path}"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300, env=ENV)
    assert done.returncode == 143
    assert done.stderr.strip() == ("interrupted: 0 of 1 runs stored; run the same command to "
                                   "resume")
    assert not list((tmp_path / "default").glob("*/*.parquet"))


# --------------------------------------------------------------------------------------------
# a full disk: every run is accounted for, nothing computed is lost, one line per kind

DISK_FILLS_UP = """
import errno, shutil, sys
from metaknot.experiments import store
from metaknot.experiments.app import main

room, results = int(sys.argv[1]), sys.argv[2]
write, usage = store.Store.write, shutil.disk_usage
full = []

def write_until_full(self, record, **kwargs):  # the disk takes `room` records
    if str(self.study_dir).startswith(results):
        if len(full) or room == 0:
            full.append(1)
            raise OSError(errno.ENOSPC, "No space left on device", str(self.tmp_dir))
        globals()["room"] -= 1
    return write(self, record, **kwargs)

def free_space(path):  # once a write has failed, the disk says so
    found = usage(path)
    return found._replace(free=0) if full and str(path).startswith(results) else found

store.Store.write = write_until_full
store.shutil.disk_usage = free_space
sys.exit(main(sys.argv[3:]))
"""


def test_a_sweep_on_a_disk_that_fills_up_accounts_for_every_run(tmp_path):
    """Seeds batched three to a job; the disk takes four records. The fifth run is computed
    and kept elsewhere, the rest (also the rest of its job) are not started; one line each,
    exit 1; once there is space, the same command computes exactly the missing runs."""
    results, spare = tmp_path / "results", tmp_path / "spare"
    spare.mkdir()
    args = ["-m", "optimizer=ga,random_search", "problem=archimedean", "seed=range(0,5)",
            "budget=200", "hydra.sweep.dir=" + str(tmp_path / "sweep"),
            "hydra.sweeper.runs_per_job=3", f"results_dir={results}"]
    done = subprocess.run([sys.executable, "-c", DISK_FILLS_UP, "4", str(results), *args],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600,
                          env={**ENV, "TMPDIR": str(spare)})
    assert done.returncode == 1, done.stderr
    study, kept = results / "default", spare / "metaknot-unsaved" / "default"
    lines = done.stderr.strip().splitlines()
    assert "Traceback" not in done.stderr and plan_line(lines[0])["to_run"] == 10
    assert lines[1].startswith(NOTE)  # no study=: the default study
    assert lines[2:] == [
        f"study {study}: 4 ok, 5 not run, 1 not stored; 4 of 10 runs stored",
        f"  5 not run: [Errno 28] No space left on device (0 KiB free, a run needs 256 KiB): "
        f"'{study}'",
        f"  1 computed but not stored (No space left on device): their records are kept in "
        f"{kept / 'runs'}: move them into {study / 'runs'}/ once there is space",
        "  run the same command to compute the missing runs once the cause is fixed",
    ]
    assert len(list((study / "runs").iterdir())) == 4 and not list((study / "tmp").iterdir())
    (saved,) = load_study(kept).runs.to_dict("records")

    again = metaknot(*args, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert plan_line(again.stderr)["stored"] == 4
    assert f"study {study}: 6 ok; 10 of 10 runs stored" in again.stderr
    runs = load_study(study).runs.set_index("run_id")
    assert len(runs) == 10 and (runs.status == "ok").all()
    assert runs.loc[saved["run_id"], "best_f"] == saved["best_f"]  # the kept record was right


def test_a_single_run_the_disk_cannot_take_is_kept_and_named(tmp_path):
    results, spare = tmp_path / "results", tmp_path / "spare"
    spare.mkdir()
    done = subprocess.run([sys.executable, "-c", DISK_FILLS_UP, "0", str(results),
                           "optimizer=ga", "budget=200", f"results_dir={results}"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=600,
                          env={**ENV, "TMPDIR": str(spare)})
    assert done.returncode == 1 and done.stdout == ""
    (kept,) = (spare / "metaknot-unsaved" / "default" / "runs").iterdir()
    assert done.stderr.strip() == (
        f"metaknot run: error: run {kept.stem} computed but not stored (No space left on "
        f"device); its record is kept in {kept}: move it into {results / 'default' / 'runs'}/ "
        "once there is space")


def test_a_sweep_on_a_real_full_disk(tmp_path):
    """The same on a real small file system (a tmpfs: needs root, skipped where mounting is
    not allowed): the runs that fit are stored, the others not started; resumed once the
    file system is larger."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=600k", "tmpfs", str(disk)],
                             capture_output=True, text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.strip()[:80]}")
    try:
        args = ("-m", "optimizer=ga,random_search", "problem=archimedean", "seed=range(0,15)",
                "budget=500", f"results_dir={disk}")
        done = metaknot(*args, cwd=tmp_path)
        assert done.returncode == 1 and "Traceback" not in done.stderr, done.stderr
        runs_dir = disk / "default" / "runs"
        stored = len(list(runs_dir.iterdir())) if runs_dir.is_dir() else 0
        assert 0 < stored < 30, done.stderr
        assert f"; {stored} of 30 runs stored" in done.stderr
        assert f"  {30 - stored} not run: [Errno 28] No space left on device" in done.stderr
        assert not list((disk / "default" / "tmp").iterdir())
        subprocess.run(["mount", "-o", "remount,size=16m", str(disk)], check=True)
        again = metaknot(*args, cwd=tmp_path)
        assert again.returncode == 0 and "30 of 30 runs stored" in again.stderr, again.stderr
        runs = load_study(disk / "default").runs
        assert len(runs) == 30 and runs.run_id.is_unique and (runs.status == "ok").all()
    finally:
        if subprocess.run(["umount", str(disk)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(disk)], check=True)


def test_sweeps_started_in_the_same_second_keep_their_own_folder(tmp_path):
    """Two sweeps of a study whose configured Hydra folder is the same (as when they start in
    the same second) each keep their multirun.yaml."""
    common = ("-m", "optimizer=random_search", "problem=archimedean", "budget=50",
              f"hydra.sweep.dir={tmp_path / 'sweep'}", f"results_dir={tmp_path}")
    for seed in (0, 1):
        done = metaknot(*common, f"seed={seed},{seed + 10}", cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    first = (tmp_path / "sweep" / "multirun.yaml").read_text()
    second = (tmp_path / "sweep-2" / "multirun.yaml").read_text()
    assert "seed=0,10" in first and "seed=1,11" in second


SIGNAL_IN_PLAN = """
import os, signal, sys
import metaknot.experiments.sweep as sweep
from metaknot.experiments.app import main

plan = sweep.plan

def signalled(*args, **kwargs):  # the signal arrives while the sweep is validated
    os.kill(os.getpid(), signal.SIGTERM)
    return plan(*args, **kwargs)

sweep.plan = signalled
sys.exit(main(sys.argv[1:]))
"""


def test_a_signal_while_the_sweep_is_planned_stops_it_before_any_run(tmp_path):
    with open(tmp_path / "stderr", "w") as err:
        proc = subprocess.Popen(
            [sys.executable, "-c", SIGNAL_IN_PLAN, "-m", "launcher=joblib",
             "hydra.launcher.n_jobs=2", "optimizer=ga", "seed=0,1", "budget=100",
             f"results_dir={tmp_path}"], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=err,
            env=ENV, start_new_session=True)
    try:
        assert proc.wait(timeout=300) == 143
        deadline = time.monotonic() + 5
        while living_processes(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert living_processes(proc.pid) == []  # the warm-up workers too
    finally:
        if living_processes(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)
    assert (tmp_path / "stderr").read_text().strip() == (
        "interrupted before any run started; run the same command to start again")
    assert not (tmp_path / "default" / "runs").exists()


def test_a_results_dir_that_cannot_be_used_is_one_line_before_anything_runs(tmp_path):
    """A loop of symbolic links (a traceback from Hydra's folder before), a file, and a path
    beyond ASCII unquoted (Hydra's lexer error before, without the fix); the report of a
    study behind a loop says why it cannot be read (it said "no such study directory")."""
    loop = tmp_path / "loop"
    loop.symlink_to(loop)
    afile = tmp_path / "afile"
    afile.write_text("")
    for value, message in ((str(loop), "cannot be used: Too many levels of symbolic links"),
                           (str(afile), "is not a folder"),
                           (str(tmp_path / "résultats"),
                            "a value with characters beyond ASCII is read only in quotes: "
                            "results_dir='")):
        for sweep in ((), ("-m",)):
            done = metaknot(*sweep, f"results_dir={value}", "budget=5", cwd=tmp_path)
            assert done.returncode != 0
            (line,) = done.stderr.strip().splitlines()
            assert line.startswith("metaknot run: error: results_dir: ") and message in line, \
                line
    done = metaknot(f"results_dir='{tmp_path / 'résultats'}'", "budget=5",
                    "problem.n_points=30", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert list((tmp_path / "résultats" / "default" / "runs").glob("*.parquet"))
    report = subprocess.run([sys.executable, "-m", "metaknot.cli", "report",
                             str(loop / "default")], capture_output=True, text=True)
    assert report.returncode != 0
    assert "Too many levels of symbolic links" in report.stderr.strip().splitlines()[-1]


def test_a_results_dir_that_cannot_be_written_is_one_line_before_any_run(tmp_path):
    """A results folder nothing can be written into (sysfs refuses new files even to root:
    the same refusal as a read-only file system's): one line naming it, exit status 2, and no
    run computed (before, a single run ended in Hydra's traceback and a sweep computed every
    run and then could not store it)."""
    folder = "/sys/kernel/metaknot-results"
    for sweep in ((), ("-m",)):
        done = metaknot(*sweep, f"results_dir={folder}", "budget=5", cwd=tmp_path)
        assert done.returncode == 2, done.stderr
        (line,) = done.stderr.strip().splitlines()
        assert line == ("metaknot run: error: results_dir: cannot write into /sys/kernel "
                        "(Permission denied); nothing was run")
