"""``metaknot migrate STUDY``: carry a stored study over to the current record format, in place.

Records of the earlier format (:data:`~.store.FORMER_FORMATS`) have run ids hashed from names
that are no longer the settings' names, and the oldest of them name the optimizer's fields as
they were then. The current version reads neither (:func:`~.store.read_record` names this
command). Migrating a study rewrites each such record under the current names, with the run
id :func:`~.run.run_id` computes for its settings, in the current format:

1. every record is read and checked first: its settings must give back the run id it is stored
   under (else nothing is changed and the file is named);
2. every new record is written completely (under ``tmp/``, synced to disk) and linked into
   ``runs/`` or ``failed/`` under its new name;
3. only then are the former files removed.

A migration that is stopped leaves every run with a record (former, new or both); running the
command again completes it. Records already in the current format are left as they are, so a
migrated study migrates to itself. A tuning study's Optuna storage in the folder
(``optuna.db`` or ``optuna.journal``, as ``metaknot tune`` makes them without ``storage=``)
gets the identity under the current names, so that the tuning study resumes. Nothing else in
the folder (``bad/``, ``hydra/``) changes. No run may write into the study while it is
migrated.
"""

from __future__ import annotations

import hashlib
import json
import os
import uuid
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from .run import RUN_KEYS, run_id
from .store import (
    FAILED_FILE,
    FORMER_FORMATS,
    STORE_FORMAT,
    Store,
    StoreError,
    _entries,
    _publish,
    _run_files,
    _sync_folder,
    _unique_name,
    record_format,
)

__all__ = ["Migration", "migrate_study"]

#: The earlier record format's optimizer field and config key (``algorithm``), and the
#: hyperparameters it stored under other names (optimizer -> earlier name -> current name).
_FORMER_OPTIMIZER_KEY = "algorithm"
_FORMER_HYPERPARAMETERS: dict[str, dict[str, str]] = {
    "nlopt": {"algorithm": "variant", "local_algorithm": "local_variant"},
    "pymoo": {"algorithm": "variant"},
    "nevergrad": {"optimizer": "variant"},
    "free_front": {"local_algorithm": "local_variant"},
}
#: The earlier record format's names of the knot problems (earlier -> current).
_FORMER_PROBLEMS = {"knot_selection": "mask", "knot_indices": "indices", "free_knots": "free"}


@dataclass
class Migration:
    """What :func:`migrate_study` did.

    Attributes
    ----------
    study_dir
        The study folder.
    run_ids
        Former run id -> current run id, of every record carried over (complete runs and
        failed attempts).
    current
        Records that were in the current format already (left as they were).
    set_aside
        New records not linked into place because a different record of the same run was
        there already (a run computed again by the current version): kept under ``bad/``.
    tuning
        The names of the tuning studies whose stored identity was carried over.
    """

    study_dir: Path
    run_ids: dict[str, str] = field(default_factory=dict)
    current: int = 0
    set_aside: list[Path] = field(default_factory=list)
    tuning: list[str] = field(default_factory=list)


@dataclass
class _Planned:
    old: Path
    new: Path
    table: pa.Table
    tmp: Path = Path()


def current_config(config: Mapping[str, Any]) -> dict[str, Any]:
    """A stored run configuration under the current names (the optimizer under ``optimizer``,
    its hyperparameters under their current names)."""
    out = dict(config)
    if _FORMER_OPTIMIZER_KEY in out:
        if "optimizer" in out:
            raise ValueError("the configuration has both 'algorithm' and 'optimizer'")
        section = dict(out.pop(_FORMER_OPTIMIZER_KEY))
        renames = _FORMER_HYPERPARAMETERS.get(str(section.get("_name_")), {})
        out["optimizer"] = {renames.get(k, k): v for k, v in section.items()}
    return out


def former_run_id(config: Mapping[str, Any]) -> str:
    """The run id the earlier format gave the settings ``config`` (current names): the same
    hash as :func:`~.run.run_id`, over the optimizer's earlier names."""
    section = dict(config["optimizer"])
    back = {new: old for old, new in _FORMER_HYPERPARAMETERS.get(str(section.get("_name_")), {})
            .items()}
    former = {**{k: config[k] for k in RUN_KEYS if k != "optimizer"},
              _FORMER_OPTIMIZER_KEY: {back.get(k, k): v for k, v in section.items()}}
    text = json.dumps(former, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _field(name: str, optimizer: str) -> str:
    """A record field's current name (``algorithm.<x>`` is ``optimizer.<current x>``)."""
    head, dot, tail = name.partition(".")
    if name == _FORMER_OPTIMIZER_KEY:
        return "optimizer"
    if head == _FORMER_OPTIMIZER_KEY and dot:
        return f"optimizer.{_FORMER_HYPERPARAMETERS.get(optimizer, {}).get(tail, tail)}"
    return name


def _text_column(table: pa.Table, name: str, value: str) -> pa.Table:
    return table.set_column(table.schema.get_field_index(name), name,
                            pa.array([value], type=pa.string()))


def _plan(path: Path, new_dir: Path) -> _Planned | None:
    """The migrated record of the file ``path`` (None if it is current already).

    Raises
    ------
    StoreError
        If the file is not a record, or its settings do not give its run id.
    """
    try:
        with pq.ParquetFile(path) as file:
            table = file.read(use_threads=False)
    except Exception as exc:  # pyarrow raises several types for damaged files
        raise StoreError(f"{path}: cannot be read as a Parquet run record ({exc}); move it "
                         "out of the study and migrate again") from None
    found = record_format(table.schema)
    if found == STORE_FORMAT:
        return None
    if found not in FORMER_FORMATS:
        raise StoreError(f"{path}: not a metaknot run record (format {found!r:.80}); move it "
                         "out of the study and migrate again")
    if table.num_rows != 1 or not {"run_id", "config"} <= set(table.column_names):
        raise StoreError(f"{path}: a damaged record (one row with run_id and config expected); "
                         "move it out of the study and migrate again")
    row = table.slice(0, 1).select(["run_id", "config"]).to_pylist()[0]
    old_id = row["run_id"]
    if not path.name.startswith(f"{old_id}."):
        raise StoreError(f"{path}: holds the record of run {old_id!r:.40}")
    try:
        config = current_config(json.loads(row["config"]))
        new_id = run_id(config)
        consistent = former_run_id(config) == old_id
    except (TypeError, KeyError, ValueError, AttributeError) as exc:
        raise StoreError(f"{path}: its stored configuration cannot be read ({exc})") from None
    if not consistent:
        raise StoreError(f"{path}: its stored configuration does not give its run id "
                         f"{old_id}; the study is left as it is")
    optimizer = config["optimizer"].get("_name_")
    table = table.rename_columns([_field(c, optimizer) for c in table.column_names])
    table = _text_column(table, "run_id", new_id)
    table = _text_column(table, "config", json.dumps(config, sort_keys=True, default=str))
    if "problem" in table.column_names:
        problem = table.column("problem")[0].as_py()
        if problem in _FORMER_PROBLEMS:
            table = _text_column(table, "problem", _FORMER_PROBLEMS[problem])
    meta = {**(table.schema.metadata or {}), b"metaknot": STORE_FORMAT.encode()}
    table = table.replace_schema_metadata(meta)
    return _Planned(old=path, new=new_dir / (new_id + path.name[len(old_id):]), table=table)


def _study_files(store: Store) -> list[tuple[Path, Path]]:
    """Every record file of the study with the folder its migrated record goes to."""
    files = [(entry, store.runs_dir) for entry, _ in _run_files(store.runs_dir)]
    for entry in _entries(store.failed_dir):
        if not FAILED_FILE.fullmatch(entry.name):
            raise StoreError(f"{entry}: not a metaknot failed-run record; move it out of the "
                             "study and migrate again")
        files.append((entry, store.failed_dir))
    return files


#: The files of a tuning study's Optuna storage in its folder (``metaknot tune``'s default).
_TUNING_FILES = ("optuna.db", "optuna.journal")
#: The user attribute that holds a tuning study's identity (``experiments.tuning.runner``).
_IDENTITY = "metaknot_identity"


def _check_study(study_dir: Path) -> None:
    if not study_dir.is_dir():
        raise StoreError(f"{study_dir}: no such study directory")
    if (study_dir / "runs").is_dir() or (study_dir / "failed").is_dir() or any(
            (study_dir / name).is_file() for name in _TUNING_FILES):
        return
    studies = sorted(p.name for p in _entries(study_dir)
                     if (p / "runs").is_dir() or (p / "failed").is_dir())
    if studies:
        names = ", ".join(studies)
        raise StoreError(f"{study_dir}: a results folder, not a study; migrate each of its "
                         f"studies: {names if len(names) <= 80 else names[:77] + '...'}")
    raise StoreError(f"{study_dir}: not a metaknot study (it has no runs/ or failed/ folder and "
                     "no tuning storage); nothing was changed")


def current_identity(identity: Mapping[str, Any]) -> dict[str, Any] | None:
    """A tuning study's stored identity under the current names (the optimizer under
    ``tune.optimizer``), or None if it names nothing by a former name."""
    tune = identity.get("tune")
    if not isinstance(tune, Mapping) or _FORMER_OPTIMIZER_KEY not in tune:
        return None
    if "optimizer" in tune:
        raise ValueError("the identity has both tune.algorithm and tune.optimizer")
    return {**identity, "tune": {("optimizer" if k == _FORMER_OPTIMIZER_KEY else k): v
                                 for k, v in tune.items()}}


def _migrate_tuning(study_dir: Path) -> list[str]:
    """Carry the identities of the tuning studies in ``study_dir``'s Optuna storage over;
    return their names."""
    import optuna
    from optuna.storages import JournalStorage, RDBStorage
    from optuna.storages.journal import JournalFileBackend

    done = []
    for name in _TUNING_FILES:
        path = study_dir / name
        if not path.is_file():
            continue
        optuna.logging.set_verbosity(optuna.logging.WARNING)
        storage = RDBStorage(f"sqlite:///{path}") if name.endswith(".db") else \
            JournalStorage(JournalFileBackend(str(path)))
        for study in storage.get_all_studies():
            stored = study.user_attrs.get(_IDENTITY)
            try:
                identity = current_identity(json.loads(stored)) if stored else None
            except ValueError as exc:
                raise StoreError(f"{path}: tuning study {study.study_name!r}: {exc}") from None
            if identity is not None:
                study_id = storage.get_study_id_from_name(study.study_name)
                storage.set_study_user_attr(study_id, _IDENTITY,
                                            json.dumps(identity, sort_keys=True, default=str))
                done.append(study.study_name)
    return done


def _write(store: Store, planned: _Planned) -> None:
    """Write the migrated record under ``tmp/`` and sync it to disk."""
    store.tmp_dir.mkdir(parents=True, exist_ok=True)
    planned.tmp = store.tmp_dir / (f"{planned.new.name.partition('.')[0]}.{os.getpid()}."
                                   f"{uuid.uuid4().hex[:8]}.parquet")
    with open(planned.tmp, "wb") as handle:
        pq.write_table(planned.table, handle)
        handle.flush()
        os.fsync(handle.fileno())


def migrate_study(study_dir: str | os.PathLike) -> Migration:
    """Carry the study at ``study_dir`` over to the current record format, in place (see the
    module's description for the order that keeps every record).

    Parameters
    ----------
    study_dir
        ``<results_dir>/<study>``.

    Returns
    -------
    Migration
        The former and current run ids of the records carried over.

    Raises
    ------
    StoreError
        If ``study_dir`` is not a study (a results folder is named with its studies), or holds
        a file that is not a record or whose settings do not give its run id: then nothing is
        changed.
    OSError
        If a new record cannot be written (a full disk): the records already linked into
        place stay, every former record stays; migrate again once there is space.
    """
    store = Store(study_dir)
    _check_study(store.study_dir)
    migration = Migration(store.study_dir)
    migration.tuning = _migrate_tuning(store.study_dir)
    plans = []
    for path, new_dir in _study_files(store):
        planned = _plan(path, new_dir)
        if planned is None:
            migration.current += 1
        else:
            plans.append(planned)
    if not plans:
        return migration
    try:
        for planned in plans:
            _write(store, planned)
        for planned in plans:
            planned.new.parent.mkdir(parents=True, exist_ok=True)
            _publish(planned.tmp, planned.new)  # never replaces a record
            if planned.tmp.exists() and planned.new.read_bytes() != planned.tmp.read_bytes():
                aside = store.bad_dir / _unique_name(planned.new.name.partition(".")[0])
                store.bad_dir.mkdir(parents=True, exist_ok=True)
                os.replace(planned.tmp, aside)
                migration.set_aside.append(aside)
        for folder in {p.new.parent for p in plans} | {store.bad_dir}:
            if folder.is_dir():
                _sync_folder(folder)
        for planned in plans:
            planned.old.unlink(missing_ok=True)
            migration.run_ids[planned.old.name.partition(".")[0]] = \
                planned.new.name.partition(".")[0]
        for folder in {p.old.parent for p in plans}:
            _sync_folder(folder)
    finally:
        for planned in plans:
            if planned.tmp.name:
                planned.tmp.unlink(missing_ok=True)
    return migration

