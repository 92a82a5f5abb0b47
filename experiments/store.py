"""The results store: one Parquet file per run, written atomically, read back as tidy tables.

Layout of a study directory ``<results_dir>/<study>/``::

    runs/<run_id>.parquet        the complete record of a run that finished (ok)
    failed/<run_id>.<time>.<pid>.parquet   a run that raised (kept, never overwritten)
    tmp/                         files being written (a killed run leaves its temp file here)
    hydra/                       Hydra's logs and multirun.yaml (ignored by the store)

A record file holds one row: every field of the run record (settings, seeds, outcome, timings,
versions), the run's best candidate ``best_x`` and its trace as list columns ``trace.*``. A file
appears under ``runs/`` only once it is complete (written under ``tmp/``, then hard-linked into
place), so a killed run never leaves a partial record, and a record is never replaced: a run
whose id already has a record is skipped, which is how an interrupted study resumes.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import re
import uuid
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

if TYPE_CHECKING:  # pandas loads only when a study is read (run workers do not need it)
    import pandas as pd

__all__ = ["STORE_FORMAT", "Store", "StoreError", "Study", "load_study"]

#: Written into every record file's Parquet metadata; files without it are foreign.
STORE_FORMAT = "metaknot-run-record/1"
_META_KEY = b"metaknot"
RUN_FILE = re.compile(r"^(?P<run_id>[0-9a-f]{16})\.parquet$")
FAILED_FILE = re.compile(r"^(?P<run_id>[0-9a-f]{16})\.[0-9TZ]+\.[0-9]+(\.[0-9a-f]+)?\.parquet$")
TRACE_PREFIX = "trace."


class StoreError(ValueError):
    """A results directory holds something the store cannot read; the message names the file."""


def _now() -> str:
    return _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


class Store:
    """The records of one study directory.

    Parameters
    ----------
    study_dir
        ``<results_dir>/<study>``; created on the first write.
    """

    def __init__(self, study_dir: str | os.PathLike) -> None:
        self.study_dir = Path(study_dir)
        self.runs_dir = self.study_dir / "runs"
        self.failed_dir = self.study_dir / "failed"
        self.tmp_dir = self.study_dir / "tmp"

    def path(self, run_id: str) -> Path:
        """Where the record of ``run_id`` lives once complete."""
        return self.runs_dir / f"{run_id}.parquet"

    def has(self, run_id: str) -> bool:
        """True if ``run_id`` has a complete record (then the run is skipped)."""
        return self.path(run_id).is_file()

    def completed(self) -> set[str]:
        """Run ids with a complete record.

        Raises
        ------
        StoreError
            If ``runs/`` holds a file that is not a record file (named by the store).
        """
        done = set()
        for entry in _entries(self.runs_dir):
            match = RUN_FILE.match(entry.name)
            if not match:
                raise StoreError(f"{entry}: not a metaknot run record (the store writes only "
                                 "<run id>.parquet files in runs/); move it out of the study")
            done.add(match.group("run_id"))
        return done

    def remove_temp_files(self, pids: Iterable[int]) -> None:
        """Remove the temp files of writes by the processes ``pids`` (stopped mid-write)."""
        for pid in pids:
            for path in self.tmp_dir.glob(f"*.{pid}.*.parquet"):
                path.unlink(missing_ok=True)

    def write(self, record: Mapping[str, Any], *, best_x: np.ndarray | None = None,
              trace: Mapping[str, np.ndarray] | None = None) -> Path:
        """Store a run record atomically and return its path.

        A record with ``status == "ok"`` goes to ``runs/<run_id>.parquet``; if that file exists
        already (another worker finished the same run first), it is kept and returned. Any other
        status goes to a new file under ``failed/``. Nothing is ever overwritten.
        """
        run_id = record["run_id"]
        if not re.fullmatch(r"[0-9a-f]{16}", str(run_id)):
            raise ValueError(f"run_id must be 16 hex digits; got {run_id!r}")
        table = _to_table(record, best_x, trace)
        self.tmp_dir.mkdir(parents=True, exist_ok=True)
        unique = uuid.uuid4().hex[:8]
        tmp = self.tmp_dir / f"{run_id}.{os.getpid()}.{unique}.parquet"
        try:
            pq.write_table(table, tmp)
            if record.get("status") == "ok":
                target = self.path(run_id)
            else:
                stamp = re.sub(r"[^0-9TZ]", "", _now())
                target = self.failed_dir / f"{run_id}.{stamp}.{os.getpid()}.{unique}.parquet"
            target.parent.mkdir(parents=True, exist_ok=True)
            _publish(tmp, target)
            return target
        finally:
            tmp.unlink(missing_ok=True)


def _publish(tmp: Path, target: Path) -> None:
    """Make ``tmp`` appear as ``target`` in one step, never replacing an existing file."""
    try:
        os.link(tmp, target)
    except FileExistsError:
        return  # the same run finished elsewhere first: keep that record
    except OSError:  # a file system without hard links: rename (atomic, the race is tiny)
        if not target.exists():
            os.replace(tmp, target)


def _entries(directory: Path) -> Iterable[Path]:
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if not p.name.startswith("."))


def _to_table(record: Mapping[str, Any], best_x: np.ndarray | None,
              trace: Mapping[str, np.ndarray] | None) -> pa.Table:
    columns: dict[str, pa.Array] = {}
    for key, value in record.items():
        if isinstance(value, np.generic):
            value = value.item()
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
        columns[TRACE_PREFIX + key] = pa.array([values], type=pa.list_(kind))
    table = pa.table(columns)
    return table.replace_schema_metadata({_META_KEY: STORE_FORMAT.encode()})


def _read(path: Path) -> dict[str, Any]:
    try:
        table = pq.read_table(path)
    except Exception as exc:  # pyarrow raises several types for damaged files
        raise StoreError(f"{path}: cannot be read as a Parquet run record ({exc}); move it "
                         "out of the study or delete it to run that run again") from None
    meta = table.schema.metadata or {}
    if meta.get(_META_KEY) != STORE_FORMAT.encode():
        raise StoreError(f"{path}: a Parquet file that is not a metaknot run record "
                         f"(format {meta.get(_META_KEY)!r}); move it out of the study")
    if table.num_rows != 1:
        raise StoreError(f"{path}: a run record holds one row; this file has {table.num_rows}")
    return table.to_pylist()[0]


@dataclass(frozen=True, eq=False)
class Study:
    """A study read back from the store (complete or partial).

    Attributes
    ----------
    path, name
        The study directory and its name.
    runs
        One row per run: every record field (``run_id`` first), ``best_x`` as a list. A run
        that only failed appears with its latest failure (``status == "failed"``).
    trace
        Long format, one row per trace point: ``run_id``, ``evaluations``, ``best_f``, the
        incumbent's metrics (``rmse``, ``n_control_points``, ...), ``improvement``,
        ``checkpoint``.
    failures
        Every failed attempt (also of runs that later succeeded).
    """

    path: Path
    name: str
    runs: pd.DataFrame
    trace: pd.DataFrame
    failures: pd.DataFrame

    def fronts(self) -> pd.DataFrame:
        """The Pareto fronts of the two-objective runs (objective ``pareto``) in long format:
        ``run_id``, ``member`` (0.. by control points), ``objective_0``, ``objective_1`` and the
        members' metrics (``n_control_points``, ``rmse``, ...). Empty if no run has a front."""
        import pandas as pd

        if "front" not in self.runs:
            return pd.DataFrame(columns=["run_id", "member", "objective_0", "objective_1"])
        parts = []
        for run_id, text in zip(self.runs["run_id"], self.runs["front"], strict=True):
            if isinstance(text, str):
                part = pd.DataFrame(json.loads(text))
                part.insert(0, "member", np.arange(len(part)))
                part.insert(0, "run_id", run_id)
                parts.append(part)
        if not parts:
            return pd.DataFrame(columns=["run_id", "member", "objective_0", "objective_1"])
        return pd.concat(parts, ignore_index=True)

    def __repr__(self) -> str:
        ok = int((self.runs["status"] == "ok").sum()) if len(self.runs) else 0
        return (f"Study({self.name!r}: {len(self.runs)} runs, {ok} ok, "
                f"{len(self.failures)} failed attempts, {len(self.trace)} trace points)")


def load_study(path: str | os.PathLike) -> Study:
    """Read a study directory (``<results_dir>/<study>``) into pandas tables.

    Raises
    ------
    StoreError
        If the directory does not exist or holds a file the store cannot read (named).
    """
    import pandas as pd

    store = Store(path)
    if not store.study_dir.is_dir():
        raise StoreError(f"{store.study_dir}: no such study directory")
    store.completed()  # foreign files in runs/ are an error
    rows, traces = [], []
    for entry in _entries(store.runs_dir):
        row = _read(entry)
        if row.get("run_id") != entry.stem:
            raise StoreError(f"{entry}: holds the record of run {row.get('run_id')!r}, not of "
                             f"{entry.stem!r}")
        rows.append(row)
    failures = []
    for entry in _entries(store.failed_dir):
        if not FAILED_FILE.match(entry.name):
            raise StoreError(f"{entry}: not a metaknot failed-run record; move it out of the "
                             "study")
        failures.append(_read(entry))
    ok_ids = {r["run_id"] for r in rows}
    latest: dict[str, dict[str, Any]] = {}
    for row in sorted(failures, key=lambda r: r.get("timestamp") or ""):
        if row["run_id"] not in ok_ids:
            latest[row["run_id"]] = row
    all_rows = rows + list(latest.values())
    for row in all_rows:
        traces.append(_pop_trace(row))
    for row in failures:
        _pop_trace(row)
    runs = _frame(all_rows)
    traces = [t for t in traces if len(t)]  # a run that failed before evaluating has none
    trace = pd.concat(traces, ignore_index=True) if traces else pd.DataFrame(
        columns=["run_id", "evaluations", "best_f", "improvement", "checkpoint"])
    return Study(path=store.study_dir, name=store.study_dir.name, runs=runs, trace=trace,
                 failures=_frame(failures))


def _pop_trace(row: dict[str, Any]) -> pd.DataFrame:
    import pandas as pd

    columns = {k[len(TRACE_PREFIX):]: row.pop(k) for k in list(row) if
               k.startswith(TRACE_PREFIX)}
    columns = {k: v for k, v in columns.items() if v is not None}
    n = len(columns.get("evaluations", []))
    frame = pd.DataFrame({"run_id": [row["run_id"]] * n, **columns})
    return frame


def _frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    import pandas as pd

    if not rows:
        return pd.DataFrame(columns=["run_id", "status"])
    frame = pd.DataFrame.from_records(rows)
    order = [c for c in ("data", "problem", "encoding", "algorithm", "budget", "seed")
             if c in frame.columns]
    if order:
        frame = frame.sort_values(order, kind="stable", ignore_index=True)
    first = ["run_id", "study"]
    return frame[[c for c in first if c in frame] + [c for c in frame if c not in first]]
