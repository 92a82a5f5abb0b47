"""The results store: a run executed from its spec is stored once, atomically, never replaced,
and reads back (runs, trace, failures) exactly as a direct run of the same settings produced
it; files the store cannot read are named, files it does not own are ignored."""

from __future__ import annotations

import datetime as dt
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numba
import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import scipy

import metaknot as mk
import metaknot.algorithms  # built-in optimizers registered before the registry is copied
import metaknot.experiments.store as store_module
from metaknot import registry
from metaknot.experiments.app import execute
from metaknot.experiments.spec import ConfigError, run_id, run_spec
from metaknot.experiments.store import Store, StoreError, Study, load_study

#: Record fields that are wall-clock times (differ between two runs of the same settings).
TIMINGS = ("elapsed_seconds", "setup_seconds", "optimize_seconds", "decode_seconds")


def _config(results_dir, *, algorithm="ga", seed=0, budget=200, study="s", label=None,
            **params):
    return {"study": study, "results_dir": str(results_dir), "budget": budget, "seed": seed,
            "checkpoints_per_decade": 10, "threads": 1, "progress": False, "label": label,
            "problem": {"name": "archimedean", "curve": "archimedean", "points": None,
                        "params_column": None, "n_points": 60, "noise": 0.0,
                        "noise_seed": None, "degree": 3, "parameterization": "centripetal"},
            "encoding": {"kind": "mask", "density": 0.5},
            "objective": {"name": "paper", "error_floor": 1e-5},
            "optimizer": {"_name_": algorithm, **params}}


def _spec(results_dir, **kwargs):
    return run_spec(_config(results_dir, **kwargs))


def _direct(spec):
    """The run of ``spec`` made directly with ``metaknot.minimize`` (nothing stored)."""
    return mk.minimize(spec.build_problem(), spec.build_optimizer(), budget=spec.budget,
                       seed=spec.optimizer_seed(),
                       checkpoints_per_decade=spec.config["checkpoints_per_decade"])


def _same(stored, expected) -> bool:
    if expected is None:
        return stored is None
    if isinstance(expected, float) and np.isnan(expected):
        return isinstance(stored, float) and np.isnan(stored)
    return stored == expected


def _assert_trace(frame: pd.DataFrame, columns: dict[str, np.ndarray], *, dtypes=True):
    assert list(frame.columns) == ["run_id", *columns]
    assert len(frame) == len(columns["evaluations"])
    for name, values in columns.items():
        np.testing.assert_array_equal(frame[name].to_numpy(), values, err_msg=name)
        if dtypes:
            assert frame[name].dtype == values.dtype, name


def _files(directory):
    return sorted(p.name for p in directory.iterdir()) if directory.is_dir() else []


def _record(run_id, *, status="ok", timestamp="2024-01-01T00:00:00+00:00", **fields):
    """A minimal hand-made record for :meth:`Store.write`."""
    return {"run_id": run_id, "study": "s", "status": status, "timestamp": timestamp,
            "error": None if status == "ok" else "RuntimeError: boom", **fields}


RUN_A, RUN_B = "0123456789abcdef", "fedcba9876543210"


# --------------------------------------------------------------------------------------------
# a crashing optimizer, registered only for the test that uses it


class _Crash(mk.Optimizer):
    """Asks for ``batch`` random candidates and raises on ask number ``crash_at``."""

    def __init__(self, crash_at: int = 3, batch: int = 10) -> None:
        self.crash_at = crash_at
        self.batch = batch

    def setup(self, problem, rng):
        super().setup(problem, rng)
        self.asked = 0

    def ask(self):
        self.asked += 1
        if self.asked >= self.crash_at:
            raise RuntimeError("optimizer exploded")
        return self.problem.sample(self.rng, self.batch)

    def tell(self, X, F):
        pass


@pytest.fixture
def crash_optimizer(monkeypatch):
    """Register ``test_crash`` in a copy of the optimizer registry (restored afterwards)."""
    registry._load_builtin("optimizer")
    monkeypatch.setitem(registry._REGISTRY, "optimizer", dict(registry._REGISTRY["optimizer"]))
    mk.register("test_crash")(_Crash)
    return "test_crash"


def _crash_directly(spec):
    with pytest.raises(RuntimeError, match="optimizer exploded") as info:
        _direct(spec)
    return getattr(info.value, "partial_result", None)


# --------------------------------------------------------------------------------------------
# 1. round trip: execute -> load_study equals a direct run


def test_executed_run_reads_back_as_the_direct_run(tmp_path):
    spec = _spec(tmp_path)
    before = dt.datetime.now(dt.UTC).replace(microsecond=0)
    outcome = execute(spec)
    after = dt.datetime.now(dt.UTC)
    store = Store(tmp_path / "s")
    assert outcome == {"run_id": spec.run_id, "status": "ok",
                       "path": str(store.path(spec.run_id))}
    assert _files(store.runs_dir) == [f"{spec.run_id}.parquet"]
    assert _files(store.tmp_dir) == [] and not store.failed_dir.exists()

    study = load_study(tmp_path / "s")
    assert isinstance(study, Study) and study.name == "s" and study.path == tmp_path / "s"
    assert len(study.runs) == 1 and len(study.failures) == 0
    assert list(study.runs.columns[:2]) == ["run_id", "study"]
    row = study.runs.iloc[0]

    direct = _direct(spec)
    record = direct.record()
    for key, value in record.items():
        if key in TIMINGS:
            assert row[key] >= 0, key
        else:
            assert _same(row[key], value), (key, row[key], value)
    # the fields the brief names, spelled out
    assert row["best_f"] == direct.best_f and row["rmse"] == direct.solution.fit.rmse
    assert row["n_control_points"] == direct.solution.fit.n_control_points
    assert row["n_evaluations"] == direct.n_evaluations == spec.budget
    assert isinstance(row["best_x"], list) and row["best_x"] == direct.best_x.tolist()
    assert row["seed"] == spec.seed and row["seed_spawn_key"] == "1"
    for name, value in spec.config["optimizer"].items():
        if name != "_name_":
            assert _same(row[f"optimizer.{name}"], value), name
    assert row["optimizer"] == "ga"
    assert row["objective"] == "paper" and row["objective.error_floor"] == 1e-5
    assert row["data_fingerprint"] == record["data_fingerprint"]
    # study layer: identity, versions, time, config
    assert row["run_id"] == spec.run_id and row["study"] == "s"
    assert row["label"] == "ga" and row["status"] == "ok" and row["error"] is None
    assert row["metaknot_version"] == mk.__version__
    assert row["numpy_version"] == np.__version__
    assert row["scipy_version"] == scipy.__version__
    assert row["numba_version"] == numba.__version__
    assert row["python_version"] == platform.python_version()
    assert before <= dt.datetime.fromisoformat(row["timestamp"]) <= after
    assert json.loads(row["config"]) == spec.config

    trace = study.trace[study.trace.run_id == spec.run_id]
    assert len(trace) == len(study.trace) == len(direct.trace)
    _assert_trace(study.trace, direct.trace.columns())
    assert (study.trace.run_id == spec.run_id).all()
    assert repr(study) == f"Study('s': 1 runs, 1 ok, 0 failed attempts, {len(trace)} trace points)"


def test_label_is_stored_but_not_part_of_the_identity(tmp_path):
    spec = _spec(tmp_path, label="my-ga")
    assert execute(spec)["status"] == "ok"
    assert load_study(tmp_path / "s").runs.loc[0, "label"] == "my-ga"
    relabelled = _spec(tmp_path, label="other")
    assert relabelled.run_id == spec.run_id
    assert execute(relabelled)["status"] == "skipped"
    assert load_study(tmp_path / "s").runs.loc[0, "label"] == "my-ga"


@pytest.mark.parametrize("closed", [False, True])
def test_a_record_stores_the_fitted_spline(tmp_path, closed):
    """Knots, coefficients, degree and closedness of the best candidate's spline: the record
    alone gives the fitted curve, which :func:`stored_fit` turns back into the fit a decode
    of the stored candidate gives."""
    config = _config(tmp_path, budget=100)
    if closed:
        config["problem"].update(name="epitrochoid", curve="epitrochoid", closed=True)
    spec = run_spec(config)
    assert execute(spec)["status"] == "ok"
    row = load_study(tmp_path / "s").runs.iloc[0]
    fit = _direct(spec).solution.fit
    np.testing.assert_array_equal(row["spline.knots"], fit.spline.t)
    np.testing.assert_array_equal(np.array(row["spline.coefficients"]), fit.spline.c)
    assert (row["spline.degree"], row["spline.closed"]) == (3, closed)
    curve = spec.build_curve()
    stored = store_module.stored_fit(row, curve.params, curve.points)
    assert type(stored) is type(fit)
    np.testing.assert_array_equal(stored.interior_knots, fit.interior_knots)
    np.testing.assert_array_equal(stored.control_points, fit.control_points)
    assert stored.n_control_points == row["n_control_points"]
    assert stored.rmse == pytest.approx(row["rmse"], rel=1e-12)
    u = np.linspace(*curve.knot_bounds, 50, endpoint=not closed)
    np.testing.assert_allclose(stored.spline(u), fit.spline(u), rtol=0, atol=1e-12)


def test_a_record_without_a_spline_has_no_stored_fit():
    assert store_module.stored_fit({"run_id": RUN_A}, np.zeros(3), np.zeros((3, 2))) is None
    assert store_module.stored_fit({"spline.knots": np.nan}, np.zeros(3),
                                   np.zeros((3, 2))) is None


# --------------------------------------------------------------------------------------------
# 2. a stored run is skipped: no recompute, no rewrite


def test_re_executing_a_stored_run_skips_it_and_leaves_the_file_alone(tmp_path, monkeypatch):
    spec = _spec(tmp_path, budget=100)
    path = Store(spec.study_dir).path(spec.run_id)
    assert execute(spec)["path"] == str(path)
    content, stat = path.read_bytes(), path.stat()

    def no_run(*args, **kwargs):
        raise AssertionError("a stored run must not be computed again")

    monkeypatch.setattr(mk.runner, "minimize", no_run)
    again = execute(_spec(tmp_path, budget=100))
    assert again == {"run_id": spec.run_id, "status": "skipped", "path": str(path)}
    after = path.stat()
    assert path.read_bytes() == content
    assert (after.st_mtime_ns, after.st_ino, after.st_size) == (
        stat.st_mtime_ns, stat.st_ino, stat.st_size)
    assert _files(path.parent) == [path.name]
    assert _files(Store(spec.study_dir).tmp_dir) == []


# --------------------------------------------------------------------------------------------
# 3. atomic publish: never replace, failures each get a file


def test_write_never_replaces_an_ok_record(tmp_path):
    store = Store(tmp_path / "s")
    first = store.write(_record(RUN_A, seed=1), best_x=np.array([1, 0, 1]),
                        trace={"evaluations": np.array([1, 2]), "best_f": np.array([3.0, 2.0])})
    content, inode = first.read_bytes(), first.stat().st_ino
    second = store.write(_record(RUN_A, seed=2, label="intruder"), best_x=np.array([0, 0, 0]))
    assert second == first == store.path(RUN_A)
    assert first.read_bytes() == content and first.stat().st_ino == inode
    assert _files(store.runs_dir) == [f"{RUN_A}.parquet"]
    assert _files(store.tmp_dir) == []
    runs = load_study(store.study_dir).runs
    assert runs.loc[0, "seed"] == 1 and runs.loc[0, "best_x"] == [1, 0, 1]
    assert "label" not in runs.columns


def test_failed_records_get_a_new_file_each_and_never_touch_runs(tmp_path):
    store = Store(tmp_path / "s")
    paths = [store.write(_record(RUN_A, status="failed", error=f"RuntimeError: {i}"))
             for i in range(3)]
    assert len(set(paths)) == 3
    assert all(p.parent == store.failed_dir and p.is_file() for p in paths)
    assert all(store_module.FAILED_FILE.match(p.name) for p in paths)
    assert not store.runs_dir.exists() and not store.has(RUN_A)
    assert store.completed() == set()
    failures = load_study(store.study_dir).failures
    assert sorted(failures["error"]) == [f"RuntimeError: {i}" for i in range(3)]


def test_failed_records_are_kept_even_when_the_clock_does_not_move(tmp_path, monkeypatch):
    # two failures of one run in the same clock tick (a coarse clock, two threads) are two
    # attempts: neither may be dropped
    monkeypatch.setattr(store_module, "_now", lambda: "2024-01-01T00:00:00.000000Z")
    store = Store(tmp_path / "s")
    first = store.write(_record(RUN_A, status="failed", error="RuntimeError: first"))
    second = store.write(_record(RUN_A, status="failed", error="RuntimeError: second"))
    assert first != second
    assert len(_files(store.failed_dir)) == 2
    assert sorted(load_study(store.study_dir).failures["error"]) == [
        "RuntimeError: first", "RuntimeError: second"]


def test_write_without_hard_links_still_never_replaces(tmp_path, monkeypatch):
    def no_link(src, dst):
        raise PermissionError(1, "Operation not permitted", str(dst))

    monkeypatch.setattr(os, "link", no_link)
    store = Store(tmp_path / "s")
    path = store.write(_record(RUN_A, seed=1))
    content = path.read_bytes()
    assert store.write(_record(RUN_A, seed=2)) == path
    assert path.read_bytes() == content
    assert _files(store.tmp_dir) == []
    assert load_study(store.study_dir).runs.loc[0, "seed"] == 1


def test_write_rejects_a_bad_run_id_before_touching_the_disk(tmp_path):
    store = Store(tmp_path / "s")
    for bad in ("0123456789ABCDEF", "0123", "../../etc/passwd", "0123456789abcdef0", None):
        with pytest.raises(ValueError, match="16 hex digits"):
            store.write(_record(bad))
    assert not store.study_dir.exists()


def test_an_interrupted_write_publishes_nothing(tmp_path, monkeypatch):
    def half_written(table, where, **kwargs):
        where.write(b"PAR1 half a file")
        raise OSError("No space left on device")

    monkeypatch.setattr(store_module.pq, "write_table", half_written)
    store = Store(tmp_path / "s")
    with pytest.raises(OSError, match="No space left"):
        store.write(_record(RUN_A))
    assert not store.has(RUN_A) and _files(store.runs_dir) == []
    monkeypatch.undo()
    study = load_study(store.study_dir)
    assert len(study.runs) == 0 and len(study.trace) == 0


def _pyarrow_table(record, best_x, trace) -> pa.Table:
    """The record table as pyarrow converts Python objects (the reference of the store's own
    columns built from buffers)."""
    columns = {}
    for key, value in record.items():
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, np.ndarray):
            columns[key] = pa.array([value.tolist()])
            continue
        if isinstance(value, dict | list | tuple):
            value = json.dumps(value, sort_keys=True, default=str)
        columns[key] = pa.array([value])
    x = None if best_x is None else np.asarray(best_x)
    if x is not None and x.dtype.kind in "iub":
        columns["best_x"] = pa.array([x.astype(np.int64)], type=pa.list_(pa.int64()))
    else:
        columns["best_x"] = pa.array([None if x is None else x.astype(np.float64)],
                                     type=pa.list_(pa.float64()))
    for key, values in (trace or {}).items():
        values = np.asarray(values)
        kind = pa.bool_() if values.dtype == bool else (
            pa.int64() if values.dtype.kind in "iu" else pa.float64())
        columns[store_module.TRACE_PREFIX + key] = pa.array([values], type=pa.list_(kind))
    return pa.table(columns).replace_schema_metadata(
        {b"metaknot": store_module.STORE_FORMAT.encode()})


def _parquet(table: pa.Table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


@pytest.mark.parametrize("best_x", [None, np.array([3, 1]), np.array([True, False]),
                                    np.array([0.5, np.nan]), np.array([], dtype=np.int64),
                                    np.array([])])
def test_a_record_file_is_what_pyarrow_writes_for_the_same_values(best_x):
    """The store builds a record's columns from buffers (pyarrow's conversion of Python
    objects imports pandas); the file is the same, byte for byte, as with that conversion,
    for every kind of value a record holds."""
    record = {"run_id": "0123456789abcdef", "none": None, "yes": True, "no": np.bool_(False),
              "small": 7, "int": np.int64(-3), "large": 2**63 - 1, "low": -2**63,
              "x": 0.25, "nan": float("nan"), "inf": -np.inf, "float32": np.float32(1.5),
              "text": "épure", "empty_text": "", "options": {"b": 1, "a": [1, 2]},
              "pair": (1, 2), "floats": np.array([1.0, np.nan]), "ints": np.arange(3),
              "bytes": np.arange(3, dtype=np.uint8), "flags": np.array([True, False]),
              "single": np.array([0.5], dtype=np.float32), "nothing": np.array([]),
              "grid": np.arange(6.0).reshape(2, 3), "rows": np.zeros((0, 3)),
              "columns": np.zeros((3, 0)), "words": np.array(["a", "b"]),
              "unsigned": np.array([5], dtype=np.uint64)}
    trace = {"evaluations": np.array([1, 5], dtype=np.int32), "best_f": np.array([2.0, 1.0]),
             "improvement": np.array([True, False]), "empty": np.array([], dtype=bool),
             "nothing": np.array([])}
    for trace_case in (trace, None, {}):
        ours = store_module._to_table(record, best_x, trace_case)
        reference = _pyarrow_table(record, best_x, trace_case)
        assert ours.schema.equals(reference.schema, check_metadata=True)
        assert _parquet(ours) == _parquet(reference)


def test_a_run_writes_its_record_without_pandas(tmp_path):
    """A run worker writes its record without importing pandas (about 0.3 s of a single
    ``metaknot run``): pyarrow's conversion of Python objects would import it."""
    code = textwrap.dedent(f"""
        import sys
        import numpy as np
        import metaknot as mk
        from metaknot.experiments.store import Store
        from metaknot.problems import KnotSelection
        result = mk.minimize(KnotSelection("archimedean"), "ga", budget=60, seed=0)
        record = {{"study": "s", "status": "ok", **result.record(), "run_id": "0" * 16}}
        Store({str(tmp_path / "s")!r}).write(record, best_x=np.asarray(result.best_x),
                                            trace=result.trace.columns())
        assert "pandas" not in sys.modules, "pandas imported"
        """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert len(list((tmp_path / "s" / "runs").iterdir())) == 1


def test_write_stores_plain_values(tmp_path):
    store = Store(tmp_path / "s")
    store.write(_record(RUN_A, n=np.int64(7), x=np.float64(0.25), flag=np.bool_(True),
                        options={"b": 1, "a": [1, 2]}, pair=(1, 2)),
                best_x=np.array([0.5, 1.5]),
                trace={"evaluations": np.array([1, 5]), "best_f": np.array([2.0, 1.0]),
                       "improvement": np.array([True, True])})
    store.write(_record(RUN_B), best_x=np.array([True, False]),
                trace={"evaluations": np.array([3]), "best_f": np.array([4.0]),
                       "improvement": np.array([False])})
    study = load_study(store.study_dir)
    a = study.runs.set_index("run_id").loc[RUN_A]
    assert a["n"] == 7 and a["x"] == 0.25 and bool(a["flag"]) is True
    assert json.loads(a["options"]) == {"a": [1, 2], "b": 1}
    assert json.loads(a["pair"]) == [1, 2]
    assert a["best_x"] == [0.5, 1.5]
    b = study.runs.set_index("run_id").loc[RUN_B]
    assert b["best_x"] == [1, 0] and all(isinstance(v, int) for v in b["best_x"])
    _assert_trace(study.trace.sort_values(["run_id", "evaluations"], ignore_index=True),
                  {"evaluations": np.array([1, 5, 3]), "best_f": np.array([2.0, 1.0, 4.0]),
                   "improvement": np.array([True, True, False])})


# --------------------------------------------------------------------------------------------
# 4. failures


def test_a_run_that_crashes_after_evaluating_is_stored_with_its_partial_best(
        tmp_path, crash_optimizer):
    spec = _spec(tmp_path, algorithm=crash_optimizer, crash_at=3, batch=10)
    outcome = execute(spec)
    store = Store(spec.study_dir)
    assert outcome["status"] == "failed" and outcome["run_id"] == spec.run_id
    assert os.path.dirname(outcome["path"]) == str(store.failed_dir)
    assert _files(store.runs_dir) == [] and not store.has(spec.run_id)

    partial = _crash_directly(spec)
    assert partial is not None and partial.n_evaluations == 20
    study = load_study(spec.study_dir)
    assert len(study.runs) == 1 and len(study.failures) == 1
    row = study.runs.iloc[0]
    assert row["run_id"] == spec.run_id and row["status"] == "failed"
    assert row["error"] == "RuntimeError: optimizer exploded"
    assert row["n_evaluations"] == 20
    assert row["best_f"] == partial.best_f and row["best_x"] == partial.best_x.tolist()
    assert row["rmse"] == partial.record()["rmse"]
    assert row["optimizer"] == "test_crash" and row["optimizer.crash_at"] == 3
    assert json.loads(row["config"]) == spec.config
    failure = study.failures.iloc[0]
    assert failure["run_id"] == spec.run_id and failure["error"] == row["error"]
    assert not any(c.startswith("trace.") for c in study.failures.columns)
    _assert_trace(study.trace, partial.trace.columns())
    assert repr(study).startswith("Study('s': 1 runs, 0 ok, 1 failed attempts")


def test_a_run_that_crashes_before_evaluating_is_stored_with_its_settings(
        tmp_path, crash_optimizer):
    spec = _spec(tmp_path, algorithm=crash_optimizer, crash_at=1)
    assert _crash_directly(spec) is None
    assert execute(spec)["status"] == "failed"
    study = load_study(spec.study_dir)
    row = study.runs.iloc[0]
    assert row["status"] == "failed" and row["error"] == "RuntimeError: optimizer exploded"
    assert row["n_evaluations"] == 0 and row["best_x"] is None
    assert (row["problem"], row["encoding"], row["data"]) == (
        "mask", "binary", "archimedean")
    assert (row["optimizer"], row["optimizer.crash_at"], row["optimizer.batch"]) == (
        "test_crash", 1, 10)
    assert row["objective"] == "paper" and row["objective.error_floor"] == 1e-5
    assert (row["seed"], row["budget"], row["label"]) == (0, spec.budget, "test_crash")
    assert len(study.trace) == 0 and len(study.failures) == 1


def test_a_run_that_fails_before_evaluating_has_the_fields_of_a_finished_run(
        tmp_path, crash_optimizer):
    """Its record is built as every run's is: each setting of the problem, the seed and the
    budget has the value a finished run of the same problem records, and no field of a
    finished run is missing but those of its outcome (the spline, the timings, the trace's
    metrics)."""
    finished = _spec(tmp_path, algorithm="random_search", budget=50)
    crashed = _spec(tmp_path, algorithm=crash_optimizer, crash_at=1, budget=50)
    assert execute(finished)["status"] == "ok"
    failed_path = execute(crashed)["path"]
    ok = store_module.read_record(Store(finished.study_dir).path(finished.run_id))
    failed = store_module.read_record(failed_path)
    settings = [*crashed.build_problem().describe(), "problem", "seed", "seed_spawn_key",
                "budget", "study", "kernel_threads"]
    assert {key: failed.get(key, "missing") for key in settings} == \
        {key: ok[key] for key in settings}
    outcome = {*store_module.SPLINE_FIELDS, *TIMINGS}
    missing = {key for key in set(ok) - set(failed)  # the optimizers differ, and the trace
               if not key.startswith(("optimizer.", store_module.TRACE_PREFIX))}
    assert missing <= outcome, missing - outcome
    assert (failed["status"], failed["n_evaluations"], failed["best_x"]) == ("failed", 0, None)
    assert (failed["optimizer"], failed["optimizer.crash_at"]) == ("test_crash", 1)


def test_every_attempt_of_a_failing_run_is_kept(tmp_path, crash_optimizer):
    spec = _spec(tmp_path, algorithm=crash_optimizer)
    first, second = execute(spec), execute(spec)  # a failed run is not "stored": it reruns
    assert first["status"] == second["status"] == "failed"
    assert first["path"] != second["path"]
    store = Store(spec.study_dir)
    assert len(_files(store.failed_dir)) == 2 and _files(store.runs_dir) == []
    study = load_study(spec.study_dir)
    assert len(study.runs) == 1 and len(study.failures) == 2
    assert set(study.failures.run_id) == {spec.run_id}


def test_a_run_without_a_trace_leaves_the_trace_types_alone(tmp_path, crash_optimizer):
    # a run that failed before evaluating has no trace; the other runs' traces keep their
    # integer evaluation counts and boolean flags
    ok = _spec(tmp_path, budget=100)
    crashed = _spec(tmp_path, algorithm=crash_optimizer, crash_at=1)
    assert execute(ok)["status"] == "ok" and execute(crashed)["status"] == "failed"
    study = load_study(tmp_path / "s")
    assert len(study.runs) == 2 and set(study.trace.run_id) == {ok.run_id}
    _assert_trace(study.trace, _direct(ok).trace.columns())


def test_raise_errors_re_raises_and_stores_no_record(tmp_path, crash_optimizer):
    spec = _spec(tmp_path, algorithm=crash_optimizer)
    with pytest.raises(RuntimeError, match="optimizer exploded"):
        execute(spec, raise_errors=True)
    assert not Store(spec.study_dir).has(spec.run_id)


def test_an_incompatible_run_is_a_config_error_and_stores_nothing(tmp_path):
    spec = _spec(tmp_path, algorithm="nlopt")  # nlopt handles continuous encodings only
    with pytest.raises(ConfigError, match="nlopt"):
        execute(spec)
    assert not (tmp_path / "s").exists()


def test_the_latest_failure_shows_until_an_ok_record_supersedes_it(tmp_path):
    store = Store(tmp_path / "s")
    # written out of time order: the latest is chosen by time stamp, not by file
    store.write(_record(RUN_B, status="failed", timestamp="2024-01-02T00:00:00+00:00",
                        error="RuntimeError: later"))
    store.write(_record(RUN_B, status="failed", timestamp="2024-01-01T00:00:00+00:00",
                        error="RuntimeError: earlier"))
    store.write(_record(RUN_A, status="failed", error="RuntimeError: flaky"))
    study = load_study(store.study_dir)
    runs = study.runs.set_index("run_id")
    assert sorted(runs.index) == [RUN_A, RUN_B]
    assert runs.loc[RUN_B, "error"] == "RuntimeError: later"
    assert (runs["status"] == "failed").all() and len(study.failures) == 3

    store.write(_record(RUN_A, timestamp="2024-01-03T00:00:00+00:00"))
    study = load_study(store.study_dir)
    runs = study.runs.set_index("run_id")
    assert len(runs) == 2
    assert runs.loc[RUN_A, "status"] == "ok" and pd.isna(runs.loc[RUN_A, "error"])
    assert runs.loc[RUN_B, "status"] == "failed"
    assert len(study.failures) == 3  # the superseded attempt stays in the failures
    assert sorted(study.failures.error) == ["RuntimeError: earlier", "RuntimeError: flaky",
                                            "RuntimeError: later"]


# --------------------------------------------------------------------------------------------
# 5. files the store cannot read are named; files it does not own are ignored


@pytest.fixture
def one_run(tmp_path):
    """A study directory with one complete record (hand-made, no optimisation)."""
    store = Store(tmp_path / "s")
    store.write(_record(RUN_A), best_x=np.array([1, 0]),
                trace={"evaluations": np.array([1]), "best_f": np.array([1.0])})
    return store


def _error_names(path):
    return pytest.raises(StoreError, match=re.escape(str(path)))


def test_a_foreign_file_in_runs_is_named(one_run):
    notes = one_run.runs_dir / "notes.txt"
    notes.write_text("remember the milk\n")
    with _error_names(notes):
        load_study(one_run.study_dir)
    with _error_names(notes):
        one_run.completed()


def test_a_corrupt_record_is_named(one_run):
    corrupt = one_run.runs_dir / f"{RUN_B}.parquet"
    corrupt.write_bytes(np.random.default_rng(0).bytes(2048))
    with _error_names(corrupt):
        load_study(one_run.study_dir)


def test_an_empty_record_file_is_named(one_run):
    empty = one_run.runs_dir / f"{RUN_B}.parquet"
    empty.touch()
    with _error_names(empty):
        load_study(one_run.study_dir)


def test_a_parquet_file_that_is_not_a_record_is_named(one_run):
    foreign = one_run.runs_dir / f"{RUN_B}.parquet"
    pq.write_table(pa.table({"run_id": [RUN_B], "status": ["ok"]}), foreign)
    with _error_names(foreign):
        load_study(one_run.study_dir)


def test_a_record_file_with_several_rows_is_named(one_run):
    double = one_run.runs_dir / f"{RUN_B}.parquet"
    table = pa.table({"run_id": [RUN_B, RUN_B], "status": ["ok", "ok"]})
    pq.write_table(table.replace_schema_metadata(
        {b"metaknot": store_module.STORE_FORMAT.encode()}), double)
    with _error_names(double):
        load_study(one_run.study_dir)


def test_a_record_under_another_run_id_is_named(one_run):
    moved = one_run.runs_dir / f"{RUN_B}.parquet"
    os.rename(one_run.path(RUN_A), moved)
    with _error_names(moved):
        load_study(one_run.study_dir)


def test_a_foreign_file_in_failed_is_named(one_run):
    one_run.failed_dir.mkdir()
    stray = one_run.failed_dir / "crash.log"
    stray.write_text("Traceback ...\n")
    with _error_names(stray):
        load_study(one_run.study_dir)


def test_a_missing_study_directory_is_named(tmp_path):
    missing = tmp_path / "no-such-study"
    with _error_names(missing):
        load_study(missing)
    (tmp_path / "a-file").write_text("")
    with _error_names(tmp_path / "a-file"):
        load_study(tmp_path / "a-file")


def test_files_the_store_does_not_own_are_ignored(one_run):
    garbage = np.random.default_rng(1).bytes(512)
    root = one_run.study_dir
    (root / "README.md").write_text("my study\n")
    (root / f"{RUN_B}.parquet").write_bytes(garbage)
    (root / "hydra" / "0").mkdir(parents=True)
    (root / "hydra" / "multirun.yaml").write_text("hydra: {}\n")
    (root / "hydra" / "0" / f"{RUN_B}.parquet").write_bytes(garbage)
    one_run.tmp_dir.mkdir(exist_ok=True)
    (one_run.tmp_dir / f"{RUN_B}.123.deadbeef.parquet").write_bytes(garbage)
    (one_run.tmp_dir / "junk.txt").write_text("junk")
    (one_run.runs_dir / ".DS_Store").write_bytes(garbage)
    (one_run.runs_dir / f".{RUN_B}.parquet").write_bytes(garbage)
    one_run.failed_dir.mkdir()
    (one_run.failed_dir / ".nfs0001").write_bytes(garbage)
    study = load_study(root)
    assert list(study.runs.run_id) == [RUN_A] and len(study.failures) == 0
    assert one_run.completed() == {RUN_A}


def test_an_empty_study_loads_empty(tmp_path):
    (tmp_path / "s").mkdir()
    study = load_study(tmp_path / "s")
    assert len(study.runs) == len(study.trace) == len(study.failures) == 0
    assert {"run_id", "status"} <= set(study.runs.columns)
    assert {"run_id", "evaluations", "best_f"} <= set(study.trace.columns)
    assert repr(study) == "Study('s': 0 runs, 0 ok, 0 failed attempts, 0 trace points)"


# --------------------------------------------------------------------------------------------
# 6. partial studies


def test_a_partial_study_loads_its_complete_runs(tmp_path):
    specs = [_spec(tmp_path, seed=seed, budget=100) for seed in (0, 1)]
    for spec in specs:
        assert execute(spec)["status"] == "ok"
    store = Store(tmp_path / "s")
    # a run killed while writing: its temp file (a truncated copy of a real record) stays
    killed = _spec(tmp_path, seed=2, budget=100)
    content = store.path(specs[0].run_id).read_bytes()
    (store.tmp_dir / f"{killed.run_id}.4242.0badc0de.parquet").write_bytes(
        content[: len(content) // 2])
    study = load_study(store.study_dir)
    assert sorted(study.runs.run_id) == sorted(s.run_id for s in specs)
    assert set(study.trace.run_id) == {s.run_id for s in specs}
    assert not store.has(killed.run_id)
    # the sweep resumes: the killed run is computed, the others skipped
    assert [execute(s)["status"] for s in [*specs, killed]] == ["skipped", "skipped", "ok"]
    assert len(load_study(store.study_dir).runs) == 3


# --------------------------------------------------------------------------------------------
# 7. several runs


def test_several_runs_load_one_row_each_sorted_with_their_traces(tmp_path):
    specs = [_spec(tmp_path, algorithm=algorithm, seed=seed, budget=budget)
             for algorithm, budget in (("random_search", 100), ("ga", 150))
             for seed in (1, 0)]
    assert len({s.run_id for s in specs}) == 4
    for spec in specs:
        assert execute(spec)["status"] == "ok"
    study = load_study(tmp_path / "s")
    runs = study.runs
    assert len(runs) == 4 and runs.run_id.is_unique
    assert set(runs.run_id) == {s.run_id for s in specs}
    assert list(zip(runs.optimizer, runs.budget, runs.seed, strict=True)) == sorted(
        (s.optimizer, s.budget, s.seed) for s in specs)
    assert list(runs.index) == list(range(4))
    joined = study.trace.merge(runs[["run_id", "optimizer", "seed"]], on="run_id",
                               how="left", validate="many_to_one")
    assert len(joined) == len(study.trace) and joined.optimizer.notna().all()
    for spec in specs:
        direct = _direct(spec)
        row = runs[runs.run_id == spec.run_id].iloc[0]
        assert (row.optimizer, row.seed, row.budget) == (spec.optimizer, spec.seed, spec.budget)
        assert row.best_f == direct.best_f and row.best_x == direct.best_x.tolist()
        trace = study.trace[study.trace.run_id == spec.run_id].reset_index(drop=True)
        assert len(trace) == len(direct.trace)
        _assert_trace(trace, direct.trace.columns(), dtypes=False)
        assert trace.evaluations.iloc[-1] == row.n_evaluations
        assert trace.best_f.iloc[-1] == row.best_f


# --------------------------------------------------------------------------------------------
# 8. concurrency


def test_losing_the_race_keeps_the_first_record(tmp_path, monkeypatch):
    # both workers found no record and computed the run; the second to publish keeps the first
    spec = _spec(tmp_path, budget=100)
    monkeypatch.setattr(Store, "has", lambda self, run_id: False)
    first = execute(spec)
    path = Store(spec.study_dir).path(spec.run_id)
    content, inode = path.read_bytes(), path.stat().st_ino
    second = execute(spec)
    assert first == second == {"run_id": spec.run_id, "status": "ok", "path": str(path)}
    assert path.read_bytes() == content and path.stat().st_ino == inode
    assert _files(path.parent) == [path.name]
    assert _files(Store(spec.study_dir).tmp_dir) == []


WORKER = textwrap.dedent("""
    import json, sys, time
    from pathlib import Path

    import metaknot as mk
    from metaknot.experiments.app import execute
    from metaknot.experiments.spec import run_spec

    cfg, ready, me = json.loads(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
    spec = run_spec(cfg)
    # warm up (compile) so that both workers reach the store at about the same time
    mk.minimize(spec.build_problem(), spec.build_optimizer(), budget=10, seed=0)
    (ready / me).touch()
    deadline = time.monotonic() + 60
    while len(list(ready.iterdir())) < 2 and time.monotonic() < deadline:
        time.sleep(0.001)
    print(json.dumps(execute(spec)))
""")


def test_two_processes_executing_the_same_run_store_it_once(tmp_path):
    cfg = _config(tmp_path / "results", budget=100)
    spec = run_spec(cfg)
    ready = tmp_path / "ready"
    ready.mkdir()
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    workers = [subprocess.Popen([sys.executable, "-c", WORKER, json.dumps(cfg), str(ready),
                                 str(i)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, cwd=tmp_path, env=env) for i in range(2)]
    outcomes = []
    for worker in workers:
        out, err = worker.communicate(timeout=120)
        assert worker.returncode == 0, err
        outcomes.append(json.loads(out.strip().splitlines()[-1]))
    store = Store(spec.study_dir)
    path = str(store.path(spec.run_id))
    for outcome in outcomes:
        assert outcome["run_id"] == spec.run_id and outcome["path"] == path
        assert outcome["status"] in ("ok", "skipped")
    assert "ok" in {o["status"] for o in outcomes}
    assert _files(store.runs_dir) == [f"{spec.run_id}.parquet"]
    assert _files(store.tmp_dir) == [] and not store.failed_dir.exists()
    study = load_study(store.study_dir)
    assert len(study.runs) == 1
    assert study.runs.loc[0, "best_f"] == _direct(spec).best_f


# --------------------------------------------------------------------------------------------
# 9. damaged records: checked when counted as stored, moved aside (never deleted), named


def _truncate(path):
    content = path.read_bytes()
    path.write_bytes(content[: len(content) // 2])
    return path.read_bytes()


def _bad_files(store):
    return {p.name: p.read_bytes() for p in store.bad_dir.iterdir()} if store.bad_dir.is_dir() \
        else {}


def test_a_truncated_record_is_moved_aside_and_its_run_computed_again(tmp_path, capsys):
    spec = _spec(tmp_path, budget=100)
    store = Store(spec.study_dir)
    assert execute(spec)["status"] == "ok"
    damaged = _truncate(store.path(spec.run_id))
    with _error_names(store.path(spec.run_id)):  # reading names it and changes nothing
        load_study(store.study_dir)
    assert store.path(spec.run_id).read_bytes() == damaged and not store.bad_dir.exists()

    outcome = execute(spec)
    assert outcome["status"] == "ok"  # computed again, not "skipped"
    assert list(_bad_files(store).values()) == [damaged]  # kept, byte for byte
    (aside,) = store.bad_dir.iterdir()
    message = capsys.readouterr().err.strip()
    assert message.startswith(f"metaknot: {store.path(spec.run_id)}: cannot be read as a "
                              "Parquet run record (")
    assert message.endswith(f"); moved to {aside} (the run will be computed again)")
    assert len(message.splitlines()) == 1
    study = load_study(store.study_dir)
    assert list(study.runs.run_id) == [spec.run_id]
    assert study.runs.loc[0, "best_f"] == _direct(spec).best_f


def _two_rows(path):
    table = pa.table({"run_id": [RUN_B, RUN_B], "status": ["ok", "ok"]})
    pq.write_table(table.replace_schema_metadata(
        {b"metaknot": store_module.STORE_FORMAT.encode()}), path)


BAD_RECORDS = {
    "truncated": (lambda store, path: _truncate(store.write(_record(RUN_B))),
                  "cannot be read as a Parquet run record"),
    "string best_f": (lambda store, path: store.write(_record(RUN_B, best_f="0.5")),
                      "'best_f' must be a number; it is string"),
    "boolean seed": (lambda store, path: store.write(_record(RUN_B, seed=True)),
                     "'seed' must be a number; it is bool"),
    "numeric status": (lambda store, path: store.write(_record(RUN_B, status=1)),
                       "'status' must be text; it is int64"),
    "no format mark": (lambda store, path: pq.write_table(
        pa.table({"run_id": [RUN_B], "status": ["ok"]}), path),
        "a Parquet file that is not a metaknot run record"),
    "two rows": (lambda store, path: _two_rows(path), "a run record holds one row; this file "
                                                      "has 2"),
}


@pytest.mark.parametrize("case", BAD_RECORDS)
def test_a_bad_record_is_named_on_load_and_moved_aside_when_counted(one_run, capsys, case):
    make, problem = BAD_RECORDS[case]
    path = one_run.path(RUN_B)
    if case == "numeric status":  # the store routes by status: place the file by hand
        make(Store(one_run.study_dir.parent / "elsewhere"), None)
        path.write_bytes(next((one_run.study_dir.parent / "elsewhere").rglob(
            "*.parquet")).read_bytes())
    else:
        make(one_run, path)
    content = path.read_bytes()
    with pytest.raises(StoreError, match=re.escape(str(path)) + ".*" + re.escape(problem)):
        load_study(one_run.study_dir)
    assert path.read_bytes() == content  # reading changes nothing

    assert one_run.completed() == {RUN_A}
    assert not path.exists() and list(_bad_files(one_run).values()) == [content]
    err = capsys.readouterr().err
    assert err.startswith(f"metaknot: {path}: ") and problem in err and "moved to" in err
    assert not one_run.has(RUN_B)
    assert list(load_study(one_run.study_dir).runs.run_id) == [RUN_A]


def test_two_processes_moving_the_same_bad_record_keep_one_copy(one_run, monkeypatch):
    # the second mover finds the file gone: no error, nothing lost
    path = one_run.path(RUN_B)
    content = _truncate(one_run.write(_record(RUN_B)))
    rename = os.rename

    def first_mover_wins(src, dst):
        rename(src, dst)
        raise FileNotFoundError(2, "No such file or directory", str(src))

    monkeypatch.setattr(os, "rename", first_mover_wins)
    assert not one_run.has(RUN_B)
    monkeypatch.undo()
    assert not path.exists() and list(_bad_files(one_run).values()) == [content]


def test_a_file_name_with_a_trailing_newline_is_not_a_record(one_run):
    odd = one_run.runs_dir / f"{RUN_B}.parquet\n"
    odd.write_bytes(one_run.path(RUN_A).read_bytes())
    with _error_names(odd):
        one_run.completed()
    with _error_names(odd):
        load_study(one_run.study_dir)


def test_a_study_name_with_a_trailing_newline_is_rejected(tmp_path):
    with pytest.raises(ConfigError, match="study: a name of letters"):
        _spec(tmp_path, study="s\n")


def test_a_results_folder_is_named_with_its_studies(tmp_path):
    for name in ("beta", "alpha"):
        Store(tmp_path / name).write(_record(RUN_A))
    (tmp_path / "alpha-report").mkdir()  # not a study
    with pytest.raises(StoreError, match=re.escape(
            f"{tmp_path}: a results folder, not a study; its studies: alpha, beta")):
        load_study(tmp_path)


# --------------------------------------------------------------------------------------------
# 10. durability and a full disk


def test_write_syncs_the_file_before_linking_and_the_folder_after(tmp_path, monkeypatch):
    events = []
    fsync, link = os.fsync, os.link

    def recording_fsync(fd):
        kind = "folder" if os.path.isdir(os.readlink(f"/proc/self/fd/{fd}")) else "file"
        events.append(("fsync", kind, os.path.basename(os.readlink(f"/proc/self/fd/{fd}"))))
        fsync(fd)

    def recording_link(src, dst):
        events.append(("link", os.path.basename(src), os.path.basename(dst)))
        link(src, dst)

    monkeypatch.setattr(os, "fsync", recording_fsync)
    monkeypatch.setattr(os, "link", recording_link)
    store = Store(tmp_path / "s")
    path = store.write(_record(RUN_A))
    (tmp_name,) = {e[1] for e in events if e[0] == "link"}
    assert events == [("fsync", "file", tmp_name), ("link", tmp_name, path.name),
                      ("fsync", "folder", "runs")]
    events.clear()
    failed = store.write(_record(RUN_A, status="failed"))
    assert [e[:2] for e in events] == [("fsync", "file"), ("link", events[1][1]),
                                       ("fsync", "folder")]
    assert events[2][2] == "failed" and events[1][2] == failed.name


def _free_space(monkeypatch, free):
    usage = store_module.shutil.disk_usage

    def disk_usage(path):
        return usage(path)._replace(free=free)

    monkeypatch.setattr(store_module.shutil, "disk_usage", disk_usage)


def test_a_run_does_not_start_without_room_for_its_record(tmp_path, monkeypatch):
    spec = _spec(tmp_path, budget=100)
    _free_space(monkeypatch, store_module.MIN_FREE_BYTES - 1)

    def no_run(*args, **kwargs):
        raise AssertionError("a run that cannot be stored must not be computed")

    monkeypatch.setattr(mk.runner, "minimize", no_run)
    outcome = execute(spec)
    assert outcome["status"] == "not_run" and outcome["path"] is None
    assert outcome["error"] == "No space left on device"
    assert "255 KiB free, a run needs 256 KiB" in outcome["detail"]
    assert not (tmp_path / "s").exists()
    _free_space(monkeypatch, store_module.MIN_FREE_BYTES)
    monkeypatch.undo()
    assert execute(spec)["status"] == "ok"


def _disk_full_for(monkeypatch, study_dir):
    """Every write into ``study_dir`` fails as on a full disk; other studies are written."""
    write = Store.write

    def full(self, record, **kwargs):
        if self.study_dir == study_dir:
            raise OSError(28, "No space left on device", str(self.tmp_dir / "x.parquet"))
        return write(self, record, **kwargs)

    monkeypatch.setattr(Store, "write", full)


def test_a_computed_run_the_study_cannot_take_is_kept_elsewhere(tmp_path, monkeypatch):
    spec = _spec(tmp_path / "results", budget=100)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "spare"))
    _disk_full_for(monkeypatch, spec.study_dir)
    outcome = execute(spec)
    kept = tmp_path / "spare" / "metaknot-unsaved" / "s" / "runs" / f"{spec.run_id}.parquet"
    assert outcome == {"run_id": spec.run_id, "status": "not_stored", "path": str(kept),
                       "error": "No space left on device",
                       "detail": f"[Errno 28] No space left on device: "
                                 f"'{spec.study_dir / 'tmp' / 'x.parquet'}'"}
    assert not Store(spec.study_dir).has(spec.run_id)
    # the kept record is a record of the study: moved into runs/, the study has the run
    monkeypatch.undo()
    Store(spec.study_dir).runs_dir.mkdir(parents=True)
    os.rename(kept, Store(spec.study_dir).path(spec.run_id))
    assert execute(spec)["status"] == "skipped"
    assert load_study(spec.study_dir).runs.loc[0, "best_f"] == _direct(spec).best_f


def test_a_result_that_cannot_be_kept_anywhere_is_reported_lost(tmp_path, monkeypatch):
    spec = _spec(tmp_path, budget=100)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "spare"))
    write = Store.write

    def full(self, record, **kwargs):
        raise OSError(28, "No space left on device", str(self.tmp_dir / "x.parquet"))

    monkeypatch.setattr(Store, "write", full)
    outcome = execute(spec)
    assert outcome["status"] == "not_stored" and outcome["path"] is None
    assert outcome["error"] == "No space left on device"
    monkeypatch.setattr(Store, "write", write)
    assert execute(spec)["status"] == "ok"  # nothing was stored: the run is computed again


@pytest.mark.parametrize("edited", [-1e308, float("nan"), 0.5])
def test_a_record_edited_after_its_run_is_named_on_load(tmp_path, edited):
    """best_f changed in a stored record (its format mark kept): a value that is not the best
    of the record's own trace, or not a number, is refused by name (a report used it: a NaN
    was dropped silently, -1e308 gave a mean of -1.25e307)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    store = Store(tmp_path / "s")
    path = store.write(_record(RUN_A, seed=1, best_f=2.0), best_x=np.array([1, 0, 1]),
                       trace={"evaluations": np.array([1, 2]), "best_f": np.array([3.0, 2.0])})
    assert len(load_study(store.study_dir).runs) == 1
    table = pq.read_table(path)
    column = table.schema.get_field_index("best_f")
    table = table.set_column(column, "best_f", pa.array([edited]))
    pq.write_table(table, path)
    with pytest.raises(StoreError, match=rf"{RUN_A}\.parquet: its best value .*changed after "
                                         "its run"):
        load_study(store.study_dir)


def test_a_record_copied_from_another_study_is_named_on_load(tmp_path):
    """A record of study 'b' copied into study 'a' (a report called the design paired with an
    unpaired seed) is refused by name; a study folder renamed as a whole still loads."""
    import shutil

    first, second = Store(tmp_path / "a"), Store(tmp_path / "b")
    trace = {"evaluations": np.array([1]), "best_f": np.array([2.0])}
    first.write({**_record(RUN_A, seed=1, best_f=2.0), "study": "a"}, best_x=np.array([1]),
                trace=trace)
    copied = second.write({**_record(RUN_B, seed=1, best_f=2.0), "study": "b"},
                          best_x=np.array([1]), trace=trace)
    shutil.copy(copied, first.runs_dir / copied.name)
    with pytest.raises(StoreError, match=rf"{RUN_B}\.parquet: the record of a run of study "
                                         r"'b', not of 'a' as 1 other record\(s\) here"):
        load_study(first.study_dir)
    (first.runs_dir / copied.name).unlink()
    (tmp_path / "a").rename(tmp_path / "renamed")
    assert len(load_study(tmp_path / "renamed").runs) == 1


#: A study written by this version of the store (format 2) at commit 8d4f927, by::
#:
#:     metaknot run -m problem=archimedean optimizer=ga,random_search seed=0,1 budget=100
#:     metaknot run problem=suite problem.instance=titanium problem.task=fixed_k_small.free \
#:         method=bobyqa_free budget=100
#:     metaknot run problem=suite problem.instance=cardioid problem.task=front \
#:         method=nsga2_mask budget=200
#:     metaknot run problem=archimedean encoding=indices encoding.max_multiplicity=2 \
#:         optimizer=local_search label=mine budget=100
#:
#: each with ``study=current-study``: open, closed and function data, mask, index (with
#: repeats) and free encodings, a suite task, a Pareto front, a label. Its Hydra folder was
#: left out.
CURRENT_STUDY = Path(__file__).parent / "data" / "current-study"


def test_a_study_written_by_this_version_loads_as_it_was_written():
    """Every record of a stored study of the current format passes the checks on load (its
    settings give its run id; its seed and budget are its settings')."""
    study = load_study(CURRENT_STUDY)
    names = {p.stem for p in (CURRENT_STUDY / "runs").glob("*.parquet")}
    assert set(study.runs.run_id) == names and len(names) == 7
    assert (study.runs.status == "ok").all()
    for _, row in study.runs.iterrows():
        config = json.loads(row["config"])
        assert run_id(config) == row["run_id"]
        assert (row["seed"], row["budget"]) == (config["seed"], config["budget"])


def _edit_config(config: dict) -> dict:
    return {**config, "seed": config["seed"] + 1}


@pytest.mark.parametrize(("column", "edit", "message"), [
    ("config", lambda text: json.dumps(_edit_config(json.loads(text)), sort_keys=True),
     r"its settings give the run id [0-9a-f]{16}, not {run}"),
    ("config", lambda text: json.dumps({**json.loads(text), "budget": 10 ** 6}),
     r"its settings give the run id [0-9a-f]{16}, not {run}"),
    ("config", lambda text: text[:-1], r"its settings cannot be read \(.*\)"),
    ("seed", lambda seed: seed + 1, r"its seed 1 is not that of its settings \(0\)"),
    ("budget", lambda budget: 10 * budget, r"its budget 1000 is not that of its settings "
                                            r"\(100\)"),
], ids=["seed in its settings", "budget in its settings", "settings cut short", "seed field",
        "budget field"])
def test_a_record_whose_settings_were_edited_is_named_on_load(tmp_path, column, edit,
                                                              message):
    """A record whose stored settings, or the seed or budget fields that copy them, were
    edited after its run (a report would pair or group it as another run) is refused by name:
    its settings must give its run id, by the function that named the run."""
    import shutil

    study_dir = tmp_path / "current-study"
    shutil.copytree(CURRENT_STUDY, study_dir)
    path = study_dir / "runs" / "bf351629f0a297c7.parquet"  # ga, seed 0, budget 100
    table = pq.read_table(path)
    index = table.schema.get_field_index(column)
    value = edit(table.column(column)[0].as_py())
    table = table.set_column(index, column, pa.array([value], type=table.schema.field(
        index).type))
    pq.write_table(table, path)
    problem = message.replace("{run}", path.stem)
    pattern = rf"{re.escape(str(path))}: {problem}: the record was changed after its run; " \
              "move it out of the study"
    with pytest.raises(StoreError, match=pattern):
        load_study(study_dir)


def _tampered(tmp_path, name: str, **columns) -> Path:
    """A copy of :data:`CURRENT_STUDY` in ``tmp_path`` whose record of run ``name`` has the
    ``columns`` given: a value each, or a function of the stored value (its type kept; None:
    the column removed). Returns the record's path."""
    import shutil

    study_dir = tmp_path / "current-study"
    if not study_dir.exists():
        shutil.copytree(CURRENT_STUDY, study_dir)
    path = study_dir / "runs" / f"{name}.parquet"
    table = pq.read_table(path)
    for column, edit in columns.items():
        index = table.schema.get_field_index(column)
        if edit is None:
            table = table.remove_column(index)
            continue
        value = edit(table.column(column)[0].as_py()) if callable(edit) else edit
        kind = table.schema.field(index).type  # a column of nulls takes the value's type
        array = pa.array([value]) if pa.types.is_null(kind) else pa.array([value], type=kind)
        table = table.set_column(index, column, array)
    pq.write_table(table, path)
    return path


def _last(value):
    """A trace edit: its last best value replaced by ``value`` (a consistent edit: the best
    value is the best of the trace)."""
    return lambda trace: [*trace[:-1], value]


def _changed_message(path: Path, problem: str) -> str:
    return rf"{re.escape(str(path))}: {problem}: the record was changed after its run; " \
        "move it out of the study"


PAPER_RUN, RMSE_RUN, PARETO_RUN = "bf351629f0a297c7", "140fe0c6478e1709", "5a2022cff40b22ce"


def _fixture_record(name: str) -> dict:
    return store_module.read_record(CURRENT_STUDY / "runs" / f"{name}.parquet")


def _outcome_edits():
    """(run, columns, message) of records whose outcome was edited consistently: the best
    value with its trace, or a field with what it must agree with left alone."""
    paper, rmse, pareto = (_fixture_record(name) for name in (PAPER_RUN, RMSE_RUN,
                                                              PARETO_RUN))
    below = 0.5 * paper["n_control_points"] * paper["sse"] ** 0.5
    return {
        "-1e308 with its trace": (PAPER_RUN, {"best_f": -1e308, "trace.best_f": _last(-1e308)},
                                  r"its best value -1e\+308 is below what its paper objective "
                                  r"gives for its own fit \(.*\)"),
        "-inf with its trace": (PAPER_RUN, {"best_f": -np.inf,
                                            "trace.best_f": _last(-np.inf)},
                                r"its best value is -inf"),
        "paper below its fit": (PAPER_RUN, {"best_f": below, "trace.best_f": _last(below)},
                                r"its best value .* is below what its paper objective gives "
                                r"for its own fit \(0\.00401072\d*\)"),
        "rmse halved": (RMSE_RUN, {"best_f": rmse["best_f"] / 2,
                                   "trace.best_f": _last(rmse["best_f"] / 2)},
                        r"its best value .* is not its rmse \(0\.1048866941593990\d*\), which "
                        "the run minimised"),
        "pareto below 0": (PARETO_RUN, {"best_f": -0.5, "trace.best_f": _last(-0.5)},
                           r"its best value -0\.5 \(a hypervolume gap\) is not within \[0, 1\]"),
        "pareto lowered": (PARETO_RUN, {"best_f": pareto["best_f"] / 2,
                                        "trace.best_f": _last(pareto["best_f"] / 2)},
                           r"its hypervolume 0\.907.* is not 1 - its best value \(0\.95.*\)"),
        "trace rises": (PAPER_RUN, {"trace.best_f": lambda t: [t[0], 2 * t[0], *t[2:]]},
                        r"its trace's best so far rises \(point 1: .*\)"),
        "trace evaluations": (PAPER_RUN, {"trace.evaluations": lambda e: [*e[:-1], 1000]},
                              r"its trace reaches 1000 evaluations, beyond its n_evaluations "
                              "100"),
        "trace evaluations fall": (PAPER_RUN, {"trace.evaluations": lambda e: e[::-1]},
                                   r"its trace's evaluation counts do not rise from 1"),
        "beyond its budget": (PAPER_RUN, {"n_evaluations": 1000},
                              r"its n_evaluations 1000 exceed its budget 100"),
        "rmse field": (PAPER_RUN, {"rmse": lambda value: value / 2},
                       r"its rmse .* is not sqrt\(sse / n_points\) \(.*\)"),
        "sse below 0": (PAPER_RUN, {"sse": -1.0}, r"its sse -1\.0 is not a finite value >= 0"),
        "euclidean distance": (PAPER_RUN, {"euclidean_distance": 1.0},
                               r"its euclidean_distance 1\.0 is not sqrt\(sse\) \(9\.3272.*\)"),
        "max deviation": (PAPER_RUN, {"max_deviation": 1e-9},
                          r"its max_deviation 1e-09 is below its rmse \(9\.3272.*\)"),
        "control points": (PAPER_RUN, {"n_control_points": 40},
                           r"its n_control_points 40 are not its spline's \(43\)"),
        "spline knots": (PAPER_RUN, {"spline.knots": lambda knots: knots[1:]},
                         r"its spline has 46 knots for 43 coefficients of degree 3"),
    }


OUTCOME_EDITS = _outcome_edits()


@pytest.mark.parametrize("case", list(OUTCOME_EDITS))
def test_a_record_whose_outcome_was_edited_consistently_is_named_on_load(tmp_path, case):
    """A best value edited with its trace (still the best of it) or a fit metric edited alone
    is refused by name when it is out of what the run could reach: below what its objective
    gives for the record's own fit (an RMSE objective: the RMSE itself; a Pareto front: a gap
    in [0, 1]), a trace that rises or runs beyond the run's evaluations, evaluations beyond
    the budget, metrics that disagree with each other or with the stored spline."""
    run, columns, message = OUTCOME_EDITS[case]
    path = _tampered(tmp_path, run, **columns)
    with pytest.raises(StoreError, match=_changed_message(path, message)):
        load_study(path.parent.parent)


def test_the_outcome_checks_keep_every_record_of_the_current_study():
    """Every record of the study written by this version passes every check of its outcome
    (pareto, paper and rmse objectives; open and closed curves; mask, index and free
    encodings)."""
    for path in sorted((CURRENT_STUDY / "runs").glob("*.parquet")):
        assert store_module._outcome_changed(store_module.read_record(path)) is None, path


def _as_failed(tmp_path, name: str, file_run: str | None = None, **columns) -> Path:
    """The record of run ``name`` of a copy of :data:`CURRENT_STUDY`, made a failed attempt
    (status ``failed``, with ``columns``) and moved to ``failed/`` under the run id
    ``file_run`` (its own by default)."""
    path = _tampered(tmp_path, name, **{"status": "failed", "error": "RuntimeError: boom",
                                        **columns})
    failed = path.parent.parent / "failed"
    failed.mkdir(exist_ok=True)
    target = failed / f"{file_run or name}.20260101T000000000000Z.1.abcd1234.parquet"
    path.rename(target)
    return target


def test_a_failed_attempt_of_this_version_loads(tmp_path):
    """A failed attempt (its record as a run's, status ``failed``) passes the checks."""
    target = _as_failed(tmp_path, PAPER_RUN)
    study = load_study(target.parent.parent)
    assert len(study.failures) == 1 and len(study.runs) == 7
    assert study.runs.set_index("run_id").loc[PAPER_RUN, "status"] == "failed"


@pytest.mark.parametrize(("file_run", "columns", "message"), [
    (RUN_A, {}, rf"holds the record of run '{PAPER_RUN}', not of '{RUN_A}'"),
    (None, {"seed": 1}, _changed_message(Path("x"), r"its seed 1 is not that of its settings "
                                                    r"\(0\)").split(": ", 1)[1]),
    (None, {"best_f": float("nan")}, r"its best value is not a number: the record was "
                                     "changed"),
    (None, {"best_f": -1e308, "trace.best_f": _last(-1e308)},
     r"its best value -1e\+308 is below what its paper objective gives"),
    (None, {"status": "ok"}, r"its status 'ok' is not that of its folder \(failed/ holds the "
                             r"attempts that failed\)"),
    (None, {"study": "another"}, r"the record of a run of study 'another', not of "
                                 "'current-study'"),
], ids=["named for another run", "seed edited", "NaN", "-1e308 with its trace", "status ok",
        "another study"])
def test_a_failed_attempt_is_checked_as_a_run_is(tmp_path, file_run, columns, message):
    """A record under ``failed/`` (shown as its run when no complete record supersedes it) is
    checked as one under ``runs/``: its file's run id, its settings, its outcome, its study,
    and a status of a failed attempt."""
    target = _as_failed(tmp_path, PAPER_RUN, file_run, **columns)
    with pytest.raises(StoreError, match=rf"{re.escape(str(target))}: {message}"):
        load_study(target.parent.parent)


def test_a_complete_record_with_the_status_of_a_failure_is_named(tmp_path):
    path = _tampered(tmp_path, PAPER_RUN, status="failed")
    with pytest.raises(StoreError, match=rf"{re.escape(str(path))}: its status 'failed' is not "
                                         r"that of its folder \(runs/ holds the records of "
                                         r"complete runs\)"):
        load_study(path.parent.parent)


def test_a_record_whose_settings_were_removed_is_named_on_load(tmp_path):
    """A record without settings (``config``) among records that have them cannot have its run
    id checked: it is refused by name (a study of hand-made records without settings loads)."""
    path = _tampered(tmp_path, PAPER_RUN, config=None)
    with pytest.raises(StoreError, match=rf"{re.escape(str(path))}: the record has no settings "
                                         r"\('config'\), as 6 other record\(s\) here have"):
        load_study(path.parent.parent)


@pytest.mark.parametrize(("objective", "closed"), [("bic", False), ("bic", True),
                                                   ("error_bounded", False)])
def test_the_bounds_of_the_objectives_the_fixture_lacks_are_checked(objective, closed):
    """The BIC (the objective's own formula on the record's SSE) and error-bounded bounds: a
    run's record passes; its best value lowered by 1 (below the formula, below the
    control points) are named."""
    import metaknot as mk
    from metaknot.problems import KnotSelection, get_curve

    problem = KnotSelection(get_curve("epitrochoid" if closed else "archimedean"),
                            objective=objective, closed=closed)
    record = mk.minimize(problem, mk.get_optimizer("random_search"), budget=50, seed=0).record()
    assert store_module._outcome_changed(record) is None
    lowered = {**record, "best_f": record["best_f"] - 1.0}  # (a run's record holds no trace)
    assert (store_module._outcome_changed(lowered) or "").startswith(
        f"its best value {lowered['best_f']!r} is below what its {objective} objective gives "
        "for its own fit")
