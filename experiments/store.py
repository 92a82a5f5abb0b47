"""The results store: one Parquet file per run, written atomically, read back as tidy tables.

Layout of a study directory ``<results_dir>/<study>/``::

    runs/<run_id>.parquet        the complete record of a run that finished (ok)
    failed/<run_id>.<time>.<pid>.parquet   a run that raised (kept, never overwritten)
    bad/<run_id>.<time>.<pid>.parquet      a damaged record moved out of runs/ (never deleted)
    tmp/                         files being written (a killed run leaves its temp file here)
    hydra/                       Hydra's logs and multirun.yaml (ignored by the store)

A record file holds one row: every field of the run record (settings, seeds, outcome, timings,
versions), the run's best candidate ``best_x`` and its trace as list columns ``trace.*``. A file
appears under ``runs/`` only once it is complete (written under ``tmp/``, synced to disk, then
hard-linked into place and the folder synced), so a killed run or a power cut never leaves a
partial record, and a record is never replaced: a run whose id already has a record is skipped,
which is how an interrupted study resumes. A record is checked (its Parquet footer, format and
field types) before it counts as stored; one that fails is moved to ``bad/`` and its run is
computed again. A record of an earlier format (:data:`FORMER_FORMATS`) is an error that names
the command carrying the study over, ``metaknot migrate STUDY`` (:mod:`.migrate`).
"""

from __future__ import annotations

import datetime as _dt
import errno
import json
import math
import operator
import os
import re
import shutil
import sys
import tempfile
import uuid
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

if TYPE_CHECKING:  # pandas loads only when a study is read (run workers do not need it)
    import pandas as pd

    from metaknot.bspline import CurveFit

__all__ = ["COMPLETE_STATUSES", "FORMER_FORMATS", "MIN_FREE_BYTES", "SPLINE_FIELDS",
           "STORE_FORMAT", "Store", "StoreError", "Study", "check_writable", "load_study",
           "read_record", "record_format", "spline_fields", "stored_fit"]

#: Written into every record file's Parquet metadata; files without it are foreign.
STORE_FORMAT = "metaknot-run-record/2"
#: The formats of records that ``metaknot migrate`` carries over (:mod:`.migrate`): read, they
#: are an error that names the command, never moved aside as damaged.
FORMER_FORMATS = frozenset({"metaknot-run-record/1"})
_META_KEY = b"metaknot"
#: File names, matched in full (``fullmatch``: no trailing newline slips through).
RUN_FILE = re.compile(r"(?P<run_id>[0-9a-f]{16})\.parquet")
FAILED_FILE = re.compile(r"(?P<run_id>[0-9a-f]{16})\.[0-9TZ]+\.[0-9]+(\.[0-9a-f]+)?\.parquet")
TRACE_PREFIX = "trace."
#: Record statuses of a run that is complete: stored under ``runs/`` (never run again). A run
#: that failed its budget audit (``budget_violation``) is complete too: running it again would
#: repeat what its optimizer did, and reports leave it out with a note. Any other status
#: (``failed``) is an attempt, kept under ``failed/``; its run is run again.
COMPLETE_STATUSES = frozenset({"ok", "budget_violation"})
#: The study of the runs made without ``study=`` (``study: default`` in experiments/conf).
DEFAULT_STUDY = "default"
#: A run starts only if the study's file system has this much free space (a record takes
#: about 20 KB), so a full disk does not cost the computation of runs that cannot be stored.
MIN_FREE_BYTES = 256 << 10
#: Record fields with a fixed kind of value (checked when a record is read or counted).
TEXT_FIELDS = ("run_id", "status")
NUMBER_FIELDS = ("best_f", "rmse", "euclidean_distance", "max_deviation", "n_control_points",
                 "n_evaluations", "budget", "seed", "audited_fits", "accounted_fits",
                 "spline.degree")
#: The fitted spline of a run's best candidate, stored so that a report draws it without
#: rebuilding the problem (:func:`spline_fields`, :func:`stored_fit`): the full knot vector,
#: every coefficient on it (scipy's ``BSpline.c``, ``(n, d)``: a closed curve's first
#: ``degree`` control points repeat at the end), the degree, and whether the curve is closed.
SPLINE_FIELDS = ("spline.knots", "spline.coefficients", "spline.degree", "spline.closed")


def spline_fields(fit: CurveFit) -> dict[str, Any]:
    """The record fields (:data:`SPLINE_FIELDS`) of a fitted spline."""
    from metaknot.bspline.fit import PeriodicFit

    return {"spline.knots": np.asarray(fit.spline.t, dtype=np.float64),
            "spline.coefficients": np.asarray(fit.spline.c, dtype=np.float64),
            "spline.degree": int(fit.spline.k), "spline.closed": isinstance(fit, PeriodicFit)}


def stored_fit(record: Mapping[str, Any] | pd.Series, params: np.ndarray,
               points: np.ndarray) -> CurveFit | None:
    """The fitted spline a record stores, as a fit of the run's data (parameters ``params``,
    points ``points``), or ``None`` if the record holds none (written before records stored
    the spline, or a run without a solution)."""
    knots = record.get("spline.knots")
    if not isinstance(knots, list | np.ndarray):
        return None
    from scipy.interpolate import BSpline

    from metaknot.bspline import SplineFit
    from metaknot.bspline.fit import PeriodicFit

    spline = BSpline(np.asarray(knots, dtype=np.float64),
                     np.asarray(list(record["spline.coefficients"]), dtype=np.float64),
                     int(record["spline.degree"]))
    kind = PeriodicFit if bool(record["spline.closed"]) else SplineFit
    return kind(spline, np.asarray(params), np.asarray(points))


def default_study_note(study_dir: Path) -> str:
    """The line a single run or a sweep prints when it writes into the default study."""
    return (f"metaknot run: note: these runs go to the default study {study_dir}, which every "
            "run made without study= shares; give study=NAME to keep an experiment apart")


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
        self.bad_dir = self.study_dir / "bad"
        self.tmp_dir = self.study_dir / "tmp"

    def path(self, run_id: str) -> Path:
        """Where the record of ``run_id`` lives once complete."""
        return self.runs_dir / f"{run_id}.parquet"

    def has(self, run_id: str) -> bool:
        """True if ``run_id`` has a sound complete record (then the run is skipped). A
        damaged record is moved to ``bad/`` (with a message) and does not count."""
        path = self.path(run_id)
        return path.is_file() and self._sound(path)

    def completed(self) -> set[str]:
        """Run ids with a sound complete record (damaged ones are moved to ``bad/``).

        Raises
        ------
        StoreError
            If ``runs/`` holds a file that is not a record file (named by the store).
        """
        return {run_id for entry, run_id in _run_files(self.runs_dir) if self._sound(entry)}

    def check_format(self) -> None:
        """Raise :class:`StoreError` naming ``metaknot migrate`` if the study's records are of
        an earlier format (:data:`FORMER_FORMATS`). A study is migrated as a whole, so the
        first readable record file of ``runs/`` (else of ``failed/``) stands for all."""
        for folder in (self.runs_dir, self.failed_dir):
            for entry in _entries(folder):
                try:
                    schema = pq.read_schema(entry)
                except (OSError, ValueError, pa.ArrowException):
                    continue  # a damaged file is named when its run is read
                _refuse_former(entry, schema)
                return

    def _sound(self, path: Path) -> bool:
        """Check a record's footer, format and field types (not its data pages: cheap); if
        it fails, move the file to ``bad/``, say so on stderr and return False."""
        try:
            meta = pq.read_metadata(path)
            schema = meta.schema.to_arrow_schema()
        except (OSError, ValueError, pa.ArrowException) as exc:  # a damaged file
            problem: str | None = f"cannot be read as a Parquet run record ({_short(exc)})"
        else:
            _refuse_former(path, schema)
            problem = _problem(schema, meta.num_rows)
        if problem is None:
            return True
        self.bad_dir.mkdir(parents=True, exist_ok=True)
        aside = self.bad_dir / _unique_name(path.stem)
        try:
            os.rename(path, aside)
        except FileNotFoundError:
            return False  # another process moved it first
        print(f"metaknot: {path}: {problem}; moved to {aside} (the run will be computed "
              "again)", file=sys.stderr, flush=True)
        return False

    def check_space(self) -> None:
        """Raise ``OSError(ENOSPC)`` if the study's file system has less than
        :data:`MIN_FREE_BYTES` free (checked before a run starts)."""
        existing = _nearest_existing(self.study_dir)
        free = shutil.disk_usage(existing).free
        if free < MIN_FREE_BYTES:
            raise OSError(errno.ENOSPC, f"{os.strerror(errno.ENOSPC)} ({free // 1024} KiB "
                          f"free, a run needs {MIN_FREE_BYTES // 1024} KiB)", str(existing))

    def remove_temp_files(self, pids: Iterable[int]) -> None:
        """Remove the temp files of writes by the processes ``pids`` (stopped mid-write)."""
        for pid in pids:
            for path in self.tmp_dir.glob(f"*.{pid}.*.parquet"):
                path.unlink(missing_ok=True)

    def write(self, record: Mapping[str, Any], *, best_x: np.ndarray | None = None,
              trace: Mapping[str, np.ndarray] | None = None) -> Path:
        """Store a run record atomically and durably, and return its path.

        A record whose status is in :data:`COMPLETE_STATUSES` goes to ``runs/<run_id>.parquet``;
        if that file exists already (another worker finished the same run first), it is kept
        and returned. Any other status goes to a new file under ``failed/``. Nothing is ever
        overwritten. The file is synced to disk before it is linked into place, and the folder
        after.

        Raises
        ------
        OSError
            If the file cannot be written (a full disk: nothing is published).
        """
        run_id = record["run_id"]
        if not re.fullmatch(r"[0-9a-f]{16}", str(run_id)):
            raise ValueError(f"run_id must be 16 hex digits; got {run_id!r}")
        table = _to_table(record, best_x, trace)
        self.tmp_dir.mkdir(parents=True, exist_ok=True)
        unique = uuid.uuid4().hex[:8]
        tmp = self.tmp_dir / f"{run_id}.{os.getpid()}.{unique}.parquet"
        try:
            with open(tmp, "wb") as handle:
                pq.write_table(table, handle)
                handle.flush()
                os.fsync(handle.fileno())
            if record.get("status") in COMPLETE_STATUSES:
                target = self.path(run_id)
            else:
                target = self.failed_dir / _unique_name(run_id, unique)
            target.parent.mkdir(parents=True, exist_ok=True)
            _publish(tmp, target)
            _sync_folder(target.parent)
            return target
        finally:
            tmp.unlink(missing_ok=True)


def check_writable(folder: Path) -> None:
    """Raise a :class:`~.errors.ConfigError` naming ``folder`` unless a file can be written
    there (in its nearest existing parent if it does not exist yet): a read-only results folder
    is found before any run is computed, not after each one."""
    from .errors import ConfigError  # Hydra's exception: loaded when a run starts, not to read

    existing = _nearest_existing(folder)
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        raise ConfigError(f"results_dir: cannot write into {existing} "
                          f"({exc.strerror or exc}); nothing was run") from None


def _nearest_existing(folder: Path) -> Path:
    """``folder``, or its nearest parent that exists."""
    while not folder.exists() and folder.parent != folder:
        folder = folder.parent
    return folder


def _unique_name(run_id: str, unique: str | None = None) -> str:
    """``<run_id>.<time>.<pid>.<unique>.parquet``: a file name no other write takes."""
    stamp = re.sub(r"[^0-9TZ]", "", _now())
    return f"{run_id}.{stamp}.{os.getpid()}.{unique or uuid.uuid4().hex[:8]}.parquet"


def _sync_folder(folder: Path) -> None:
    """Make a new name in ``folder`` durable (where the system can sync a folder)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass  # a file system that cannot sync folders
    finally:
        os.close(fd)


def _publish(tmp: Path, target: Path) -> None:
    """Make ``tmp`` appear as ``target`` in one step, never replacing an existing file."""
    try:
        os.link(tmp, target)
    except FileExistsError:
        return  # the same run finished elsewhere first: keep that record
    except OSError:  # a file system without hard links: rename (atomic, the race is tiny)
        if not target.exists():
            os.replace(tmp, target)


def _run_files(runs_dir: Path) -> list[tuple[Path, str]]:
    """The record files of ``runs/`` with their run ids; a foreign file is an error."""
    files = []
    for entry in _entries(runs_dir):
        match = RUN_FILE.fullmatch(entry.name)
        if not match:
            raise StoreError(f"{entry}: not a metaknot run record (the store writes only "
                             "<run id>.parquet files in runs/); move it out of the study")
        files.append((entry, match.group("run_id")))
    return files


def _entries(directory: Path) -> Iterable[Path]:
    if not directory.is_dir():
        return []
    return sorted(p for p in directory.iterdir() if not p.name.startswith("."))


def _to_table(record: Mapping[str, Any], best_x: np.ndarray | None,
              trace: Mapping[str, np.ndarray] | None) -> pa.Table:
    """A record as a one-row table. Its columns are built from buffers (:func:`_one_row`,
    :func:`_list_row`), with the types ``pa.array`` would give them: pyarrow's conversion of
    Python objects imports pandas (about 0.26 s), which a run does not otherwise need."""
    columns: dict[str, pa.Array] = {}
    for key, value in record.items():
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, np.ndarray):  # a list column (nested for a 2-D array)
            columns[key] = _list_row(value)
            continue
        if isinstance(value, dict | list | tuple):
            value = json.dumps(value, sort_keys=True, default=str)
        columns[key] = _one_row(value)
    x = None if best_x is None else np.asarray(best_x)
    if x is not None and x.dtype.kind in "iub":
        columns["best_x"] = _list_row(x, pa.int64())
    else:
        columns["best_x"] = _list_row(x, pa.float64())
    for key, values in (trace or {}).items():
        values = np.asarray(values)
        kind = pa.bool_() if values.dtype == bool else (
            pa.int64() if values.dtype.kind in "iu" else pa.float64())
        columns[TRACE_PREFIX + key] = _list_row(values, kind)
    table = pa.table(columns)
    return table.replace_schema_metadata({_META_KEY: STORE_FORMAT.encode()})


#: The Arrow type of an array's items in a record, by numpy dtype kind (``pa.array`` of its
#: ``tolist()``; a uint64 array, whose values may not fit int64, is left to pyarrow).
_KINDS: dict[str, pa.DataType] = {"b": pa.bool_(), "i": pa.int64(), "u": pa.int64(),
                                  "f": pa.float64()}


#: The numpy dtype of each Arrow type :func:`_flat` builds.
_NUMPY_TYPES = {pa.bool_(): np.bool_, pa.int32(): np.int32, pa.int64(): np.int64,
                pa.float64(): np.float64}


def _flat(values: np.ndarray, kind: pa.DataType) -> Any:
    """A flat numpy array as an Arrow array of ``kind`` (bool, int32, int64 or float64), no
    nulls."""
    dtype = _NUMPY_TYPES[kind]
    values = np.ascontiguousarray(values, dtype=dtype).ravel()
    data = np.packbits(values, bitorder="little") if dtype is np.bool_ else values
    return pa.Array.from_buffers(kind, values.size, [None, pa.py_buffer(data.tobytes())])


def _one_row(value: Any) -> pa.Array:
    """``pa.array([value])`` for a record's scalar (None, bool, int, float, str); other values
    are converted by pyarrow."""
    if value is None:
        return pa.nulls(1)
    if isinstance(value, str):
        data = value.encode()
        return pa.Array.from_buffers(pa.string(), 1, [
            None, pa.py_buffer(np.array([0, len(data)], dtype=np.int32).tobytes()),
            pa.py_buffer(data)])
    if isinstance(value, bool):
        return _flat(np.array([value]), pa.bool_())
    if isinstance(value, int) and -2**63 <= value < 2**63:
        return _flat(np.array([value]), pa.int64())
    if isinstance(value, float):
        return _flat(np.array([value]), pa.float64())
    return pa.array([value])


def _list_row(values: np.ndarray | None, kind: pa.DataType | None = None) -> Any:
    """One row of a list column: ``pa.array([values], type=pa.list_(kind))`` for a 1-D array
    of a given ``kind`` (``None``: a null list), else ``pa.array([values.tolist()])`` (a list
    of lists for a 2-D array; an empty list's items of the null type, as pyarrow infers
    them)."""
    if values is None or kind is not None:
        assert kind is not None and (values is None or values.ndim == 1)
        items = _flat(np.empty(0) if values is None else values, kind)
        mask = None if values is not None else _flat(np.array([True]), pa.bool_())
        return pa.ListArray.from_arrays(_flat(np.array([0, len(items)]), pa.int32()), items,
                                        mask=mask)
    if values.dtype.kind not in _KINDS or values.dtype == np.uint64 or values.ndim not in (1, 2):
        return pa.array([values.tolist()])
    items = _flat(values, _KINDS[values.dtype.kind]) if values.size else pa.nulls(0)
    if values.ndim == 2 and len(values):
        rows, width = values.shape
        items = pa.ListArray.from_arrays(_flat(np.arange(rows + 1) * width, pa.int32()), items)
    return pa.ListArray.from_arrays(_flat(np.array([0, len(values)]), pa.int32()), items)


def read_record(path: str | os.PathLike) -> dict[str, Any]:
    """One record file, checked, as a dict (``best_x``, the trace and the spline as lists).

    Raises
    ------
    StoreError
        If the file is not a sound run record (named).
    """
    path = Path(path)
    try:  # ParquetFile.read: read_table's table, at half its cost for a one-row file
        with pq.ParquetFile(path) as file:
            table = file.read(use_threads=False)
    except Exception as exc:  # pyarrow raises several types for damaged files
        raise StoreError(f"{path}: cannot be read as a Parquet run record ({_short(exc)}); "
                         "move it out of the study or delete it to run that run again") from None
    _refuse_former(path, table.schema)
    problem = _problem(table.schema, table.num_rows)
    if problem is not None:
        raise StoreError(f"{path}: {problem}; move it out of the study")
    return table.to_pylist()[0]


def record_format(schema: pa.Schema) -> str | None:
    """The format mark of a record file's schema (:data:`STORE_FORMAT` for the current one),
    or None if it has none."""
    mark = (schema.metadata or {}).get(_META_KEY)
    return None if mark is None else mark.decode(errors="replace")


def _refuse_former(path: Path, schema: pa.Schema) -> None:
    """Raise :class:`StoreError` naming ``metaknot migrate`` if the record at ``path`` is in
    one of the :data:`FORMER_FORMATS` (its run id is not the one the current version computes
    for its settings)."""
    found = record_format(schema)
    if found in FORMER_FORMATS:
        study = path.parent.parent
        raise StoreError(f"{path}: a record in the earlier format {found!r}, whose run id and "
                         f"field names are no longer current; carry the study over with: "
                         f"metaknot migrate {study}")


def _problem(schema: pa.Schema, num_rows: int) -> str | None:
    """What makes a file with this schema and row count not a sound run record (None: it
    is one): the format mark, one row, and the kinds of the :data:`TEXT_FIELDS` (required)
    and :data:`NUMBER_FIELDS` (where present; null when the run had no value)."""
    meta = schema.metadata or {}
    if meta.get(_META_KEY) != STORE_FORMAT.encode():
        return (f"a Parquet file that is not a metaknot run record (format "
                f"{meta.get(_META_KEY)!r:.80})")
    if num_rows != 1:
        return f"a run record holds one row; this file has {num_rows}"
    for name in TEXT_FIELDS:
        if name not in schema.names:
            return f"the record has no {name!r} field"
        kind = schema.field(name).type
        if not (pa.types.is_string(kind) or pa.types.is_large_string(kind)):
            return f"{name!r} must be text; it is {kind}"
    for name in NUMBER_FIELDS:
        if name in schema.names:
            kind = schema.field(name).type
            if not (pa.types.is_integer(kind) or pa.types.is_floating(kind)
                    or pa.types.is_null(kind)):
                return f"{name!r} must be a number; it is {kind}"
    return None


def _short(exc: Exception) -> str:
    """An exception's text, cut to 80 characters (it may quote file contents)."""
    text = str(exc).replace("\n", " ")
    return text if len(text) <= 80 else text[:77] + "..."


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
        If the directory does not exist, is a results folder (the message lists its
        studies), or holds a file the store cannot read, a field of the wrong kind or a
        record (under ``runs/`` or ``failed/``) changed after its run: settings that do not
        give its run id, an outcome its run could not reach (a best value out of its own
        trace or fit, a trace beyond its evaluations, metrics that disagree), another study's
        record (each named, with the field). Reading never changes the study.
    """
    import pandas as pd

    store = Store(path)
    if not store.study_dir.is_dir():
        try:
            os.stat(store.study_dir)
        except FileNotFoundError:
            raise StoreError(f"{store.study_dir}: no such study directory") from None
        except OSError as exc:  # a loop of symbolic links, a folder without permission, ...
            raise StoreError(f"{store.study_dir}: cannot be read: "
                             f"{os.strerror(exc.errno) if exc.errno else exc}") from None
        raise StoreError(f"{store.study_dir}: not a study directory (a file)")
    if not (store.runs_dir.is_dir() or store.failed_dir.is_dir()):
        studies = sorted(p.name for p in _entries(store.study_dir)
                         if (p / "runs").is_dir() or (p / "failed").is_dir())
        if studies:
            names = ", ".join(studies)
            raise StoreError(f"{store.study_dir}: a results folder, not a study; its studies: "
                             f"{names if len(names) <= 80 else names[:77] + '...'}")
    entries = list(_run_files(store.runs_dir))
    rows = [_checked(entry, run_id, row, complete=True) for (entry, run_id), row in
            zip(entries, _read_records([e for e, _ in entries]), strict=True)]
    failed = []
    for entry in _entries(store.failed_dir):
        match = FAILED_FILE.fullmatch(entry.name)
        if not match:
            raise StoreError(f"{entry}: not a metaknot failed-run record; move it out of the "
                             "study")
        failed.append((entry, match.group("run_id")))
    failures = [_checked(entry, run_id, row, complete=False) for (entry, run_id), row in
                zip(failed, _read_records([e for e, _ in failed]), strict=True)]
    every = [entry for entry, _ in entries + failed]
    _check_one_study(every, rows + failures, store.study_dir.name)
    _check_settings_stored(every, rows + failures)
    ok_ids = {r["run_id"] for r in rows}
    latest = {row["run_id"]: row for row in sorted(failures, key=lambda r: r.get("timestamp") or "")
              if row["run_id"] not in ok_ids}
    all_rows = rows + list(latest.values())
    traces = [_pop_trace(row) for row in all_rows]
    for row in failures:
        _pop_trace(row)
    runs = _frame(all_rows)
    traces = [t for t in traces if len(t)]  # a run that failed before evaluating has none
    trace = pd.concat(traces, ignore_index=True) if traces else pd.DataFrame(
        columns=["run_id", "evaluations", "best_f", "improvement", "checkpoint"])
    return Study(path=store.study_dir, name=store.study_dir.name, runs=runs, trace=trace,
                 failures=_frame(failures))


def _checked(entry: Path, run_id: str, row: dict[str, Any], *, complete: bool
             ) -> dict[str, Any]:
    """``row``, the record read from ``entry`` (named for ``run_id``) under ``runs/``
    (``complete``) or ``failed/``, once checked: a :class:`StoreError` naming the file and the
    field if it holds another run's record, a status of the other folder (a failed attempt
    shown as a finished run), settings without its run id or an outcome its run could not
    have had (:func:`_changed_after_the_run`)."""
    if row.get("run_id") != run_id:
        raise StoreError(f"{entry}: holds the record of run {row.get('run_id')!r:.40}, not "
                         f"of {run_id!r}")
    status = row.get("status")
    if (status in COMPLETE_STATUSES) != complete:
        where = "runs/ holds the records of complete runs" if complete else \
            "failed/ holds the attempts that failed"
        raise StoreError(f"{entry}: its status {status!r:.40} is not that of its folder "
                         f"({where}): the record was changed or moved after its run; move it "
                         "out of the study")
    changed = _changed_after_the_run(row, run_id)
    if changed is not None:
        raise StoreError(f"{entry}: {changed}: the record was changed after its run; move "
                         "it out of the study (or delete it to run that run again)")
    return row


def _check_one_study(entries: list[Path], rows: list[dict[str, Any]], folder: str) -> None:
    """Raise :class:`StoreError` naming a record of another study than the others (copied
    from another study's folder: a report would pair it with runs it was not paired with).
    The study is the folder's name if a record names it, else what most records name (a
    study folder renamed as a whole loads as it is)."""
    from collections import Counter

    named = Counter(row.get("study") for row in rows)
    if len(named) < 2:
        return
    study = folder if folder in named else named.most_common(1)[0][0]
    entry, row = next((e, r) for e, r in zip(entries, rows, strict=True)
                      if r.get("study") != study)
    raise StoreError(f"{entry}: the record of a run of study {row.get('study')!r}, not of "
                     f"{study!r} as {named[study]} other record(s) here; move it out of the "
                     "study")


def _check_settings_stored(entries: list[Path], rows: list[dict[str, Any]]) -> None:
    """Raise :class:`StoreError` naming a record without settings (``config``) in a study
    whose other records have them: a run stores its settings, so one without them had them
    removed, and its run id could not be checked."""
    with_settings = sum(row.get("config") is not None for row in rows)
    if not 0 < with_settings < len(rows):
        return
    entry = next(e for e, r in zip(entries, rows, strict=True) if r.get("config") is None)
    raise StoreError(f"{entry}: the record has no settings ('config'), as {with_settings} "
                     "other record(s) here have; it was changed after its run and its run id "
                     "cannot be checked; move it out of the study")


def _changed_after_the_run(row: Mapping[str, Any], run_id: str) -> str | None:
    """What shows a record was edited after its run (None: nothing does): settings that do not
    give its run id ``run_id``, or a seed or budget that are not those of its settings (the
    report pairs and groups runs by these fields), or an outcome its run could not have had
    (:func:`_outcome_changed`)."""
    return _settings_changed(row, run_id) or _outcome_changed(row)


#: Relative slack of the checks that compare a record's best value with its own fit metrics:
#: the run scores a candidate on one numerical path and its record's metrics come from the
#: decoded fit (another), which agree to about 1e-12. Near an exact fit, where the two
#: differ by rounding only, an absolute slack of 1e-9 of the fitted curve's size is added.
_SLACK = 1e-6


def _number(value: Any) -> float | None:
    """A record's number field as a float (None: empty, or not a number: a field the checks
    of :func:`_problem` leave alone is then not compared)."""
    return float(value) if isinstance(value, int | float) else None


def _outcome_changed(row: Mapping[str, Any]) -> str | None:
    """What shows a record's outcome was edited (None: nothing does), from the record alone
    (pure Python on a few fields and the trace: a small share of reading the file):

    - a best value that is not a number, is -inf, or is not the best of its own trace;
    - a trace whose best so far rises, or whose evaluation counts do not rise from 1 to at
      most the run's ``n_evaluations``; a run ``ok`` with more evaluations than its budget;
    - fit metrics that disagree with each other (``rmse`` is ``sqrt(sse / n_points)``,
      ``euclidean_distance`` ``sqrt(sse)``, ``max_deviation`` at least the RMSE) or with the
      stored spline (its control points, its knots for its coefficients);
    - a best value out of what the objective gives for the record's own fit
      (:func:`_objective_changed`).

    The data are not rebuilt, so the best candidate is not scored again."""
    best = _number(row.get("best_f"))
    if best is not None and best != best:
        return "its best value is not a number"
    if best == -math.inf:
        return "its best value is -inf"
    known = row.get(f"{TRACE_PREFIX}best_f") or []
    if None in known or not all(map(operator.eq, known, known)):  # NaN: not equal to itself
        known = [v for v in known if v is not None and v == v]
    if known:
        lowest = min(known)
        if best is not None and math.isfinite(best) and lowest != best:
            return f"its best value {best!r} is not the best of its own trace ({lowest!r})"
        if not all(map(operator.ge, known, known[1:])):
            rise = next(i for i in range(1, len(known)) if known[i] > known[i - 1])
            return (f"its trace's best so far rises (point {rise}: {known[rise - 1]!r} to "
                    f"{known[rise]!r})")
    evaluations = row.get(f"{TRACE_PREFIX}evaluations") or []
    n_evaluations, budget = _number(row.get("n_evaluations")), _number(row.get("budget"))
    if evaluations:
        if evaluations[0] < 1 or not all(map(operator.lt, evaluations, evaluations[1:])):
            return "its trace's evaluation counts do not rise from 1"
        if n_evaluations is not None and evaluations[-1] > n_evaluations:
            return (f"its trace reaches {evaluations[-1]} evaluations, beyond its "
                    f"n_evaluations {n_evaluations:g}")
    if (row.get("status") == "ok" and n_evaluations is not None and budget is not None
            and n_evaluations > budget):
        return f"its n_evaluations {n_evaluations:g} exceed its budget {budget:g}"
    return _fit_changed(row, best)


class _Near:
    """Whether two error values of a record agree: within :data:`_SLACK` relative, or within
    1e-9 of the size of the record's fitted curve (its largest coefficient; 1 without a
    spline), which is computed only for values that differ by more than the relative slack."""

    def __init__(self, row: Mapping[str, Any]) -> None:
        self.row = row
        self._absolute: float | None = None

    @property
    def absolute(self) -> float:
        if self._absolute is None:
            rows = self.row.get("spline.coefficients") or ()
            size = max((abs(v) for point in rows for v in point), default=1.0)
            self._absolute = 1e-9 * size
        return self._absolute

    def __call__(self, a: float, b: float) -> bool:
        gap = abs(a - b)
        return gap <= _SLACK * max(abs(a), abs(b)) or gap <= self.absolute


def _fit_changed(row: Mapping[str, Any], best: float | None) -> str | None:
    """The part of :func:`_outcome_changed` on the record's fit metrics and stored spline."""
    knots, coefficients = row.get("spline.knots"), row.get("spline.coefficients")
    degree = row.get("spline.degree")
    n_cp = _number(row.get("n_control_points"))
    if knots is not None and coefficients is not None and degree is not None:
        if len(knots) - degree - 1 != len(coefficients):
            return (f"its spline has {len(knots)} knots for {len(coefficients)} coefficients "
                    f"of degree {degree}")
        stored = len(coefficients) - (degree if row.get("spline.closed") else 0)
        if n_cp is not None and n_cp == n_cp and n_cp != stored:
            return f"its n_control_points {n_cp:g} are not its spline's ({stored})"
    sse, n_points = _number(row.get("sse")), _number(row.get("n_points"))
    if sse is None or sse != sse or n_points is None or not n_points > 0:
        return None  # no fit (a run that failed before evaluating, a hand-made record)
    if not 0 <= sse < math.inf:
        return f"its sse {sse!r} is not a finite value >= 0"
    near, error = _Near(row), math.sqrt(sse / n_points)
    rmse = _number(row.get("rmse"))
    if rmse is not None and not near(rmse, error):
        return f"its rmse {rmse!r} is not sqrt(sse / n_points) ({error!r})"
    distance = _number(row.get("euclidean_distance"))
    if distance is not None and distance == distance and not near(distance, math.sqrt(sse)):
        return f"its euclidean_distance {distance!r} is not sqrt(sse) ({math.sqrt(sse)!r})"
    deviation = _number(row.get("max_deviation"))
    if deviation is not None and deviation < error and not near(deviation, error):
        return f"its max_deviation {deviation!r} is below its rmse ({error!r})"
    if best is None or not math.isfinite(best) or n_cp is None or n_cp != n_cp:
        return None
    return _objective_changed(row, best, sse, n_points, n_cp, near)


def _objective_changed(row: Mapping[str, Any], best: float, sse: float, n_points: float,
                       n_cp: float, near: _Near) -> str | None:
    """A best value out of what the record's objective (its ``objective`` field) gives for its
    own fit metrics (None: within it, or an objective not known here):

    - ``rmse``: the record's RMSE;
    - ``paper``: control points x ``sqrt(sse)``, or more (the floor, a share of the data's
      scale, which the record does not hold);
    - ``error_bounded``: control points plus at most 1 (within the tolerance) or at least
      ``n_points + 2`` (beyond it);
    - ``bic``: ``n ln(sse / n) + ln(n) k`` on the record's SSE, or more (the SSE floor);
    - ``pareto``: a hypervolume gap in [0, 1], with ``hypervolume`` its complement."""
    objective = row.get("objective")
    error = math.sqrt(sse / n_points)
    lowest: float | None = None
    if objective == "rmse":
        if not near(best, error):
            return f"its best value {best!r} is not its rmse ({error!r}), which the run minimised"
    elif objective == "pareto":
        if not 0.0 <= best <= 1.0:
            return f"its best value {best!r} (a hypervolume gap) is not within [0, 1]"
        volume = _number(row.get("hypervolume"))
        if volume is not None and abs(volume - (1.0 - best)) > 1e-12:
            return f"its hypervolume {volume!r} is not 1 - its best value ({1.0 - best!r})"
    elif objective == "paper":
        product = n_cp * math.sqrt(sse)
        if best < product and not near(best, product):
            lowest = product
    elif objective == "error_bounded":
        if best < n_cp * (1 - _SLACK):
            lowest = n_cp
        elif n_cp + 1 + _SLACK * n_cp < best < (n_points + 2) * (1 - _SLACK):
            return (f"its best value {best!r} is neither within 1 of its {n_cp:g} control "
                    f"points nor beyond n_points + 2 ({n_points + 2:g})")
    elif objective == "bic":
        dim, degree = _number(row.get("dim")), _number(row.get("degree"))
        if dim is not None and degree is not None:
            from metaknot.bspline.knots import extra_control_points
            from metaknot.problems.objectives import bic_value

            extra = extra_control_points(int(degree), closed=bool(row.get("closed")))
            formula = float(bic_value(max(sse, sys.float_info.min), n_points, dim, n_cp, extra))
            if best < formula - _SLACK * max(1.0, abs(formula)):
                lowest = formula
    if lowest is not None:
        return (f"its best value {best!r} is below what its {objective} objective gives for "
                f"its own fit ({lowest!r})")
    return None


def _settings_changed(row: Mapping[str, Any], run_id: str) -> str | None:
    """What shows the settings of a record (``config``, and the ``seed`` and ``budget`` fields
    that copy them) were edited, by :func:`~.run.run_id`, the function that named the run
    (None: nothing does; a record that stores no settings is not checked)."""
    from .run import run_id as settings_id

    text = row.get("config")
    if text is None:
        return None
    try:
        config = json.loads(text)
        given = settings_id(config)
    except (TypeError, ValueError, KeyError) as exc:
        return f"its settings cannot be read ({_short(exc)})"
    if given != run_id:
        return f"its settings give the run id {given}, not {run_id}"
    for name in ("seed", "budget"):
        if name in row and row[name] != config[name]:
            return f"its {name} {row[name]!r:.40} is not that of its settings ({config[name]!r})"
    return None


def _read_records(paths: list[Path]) -> Iterator[dict[str, Any]]:
    """:func:`read_record` of every path, in order, on a few threads (pyarrow decodes without
    the GIL); the first file that cannot be read raises, as read one by one."""
    if len(paths) < 64:
        yield from map(read_record, paths)
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(max_workers=min(4, os.cpu_count() or 1)) as pool:
        yield from pool.map(read_record, paths)


def _pop_trace(row: dict[str, Any]) -> pd.DataFrame:
    import pandas as pd

    columns = {k[len(TRACE_PREFIX):]: row.pop(k) for k in list(row) if
               k.startswith(TRACE_PREFIX)}
    columns = {k: v for k, v in columns.items() if v is not None}
    n = len(columns.get("evaluations", []))
    return pd.DataFrame({"run_id": [row["run_id"]] * n, **columns})


def _frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    import pandas as pd

    if not rows:
        return pd.DataFrame(columns=["run_id", "status"])
    frame = pd.DataFrame.from_records(rows)
    order = [c for c in ("data", "problem", "encoding", "optimizer", "budget", "seed")
             if c in frame.columns]
    if order:
        frame = frame.sort_values(order, kind="stable", ignore_index=True)
    first = ["run_id", "study"]
    return frame[[c for c in first if c in frame] + [c for c in frame if c not in first]]
