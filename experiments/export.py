"""A study's traces in other tools' formats: ``metaknot export STUDY --format iohprofiler``.

IOHprofiler's format is the one IOHexperimenter's Python package ``ioh`` (0.4.x) writes with
its ``Analyzer`` logger, which IOHanalyzer and IOHinspector load. Per algorithm folder and
function::

    <out>/<algorithm>/IOHprofiler_f<fid>_<function>.json        meta data (its runs, best values)
    <out>/<algorithm>/data_f<fid>_<function>/IOHprofiler_f<fid>_DIM<d>.dat
    <out>/functions.csv                                          function id -> instance and task

The ``.dat`` file holds, for each run, the header line ``evaluations raw_y`` and then one row
``<evaluation> <objective>`` per improvement of the run's best, and a last row at the run's
final evaluation with its best value when that evaluation did not improve (``ioh`` logs a run's
last evaluation; the trace keeps best-so-far values only). ``raw_y`` has 10 decimals, as
``ioh`` writes it; the meta data's ``best.y`` keeps every digit, and ``best.x`` is a list of
integers for an integer encoding (mask bits, knot indices), of floats otherwise.

Mapping (see docs/guide/export.md):

- function: a suite run's ``<suite.instance>__<suite.task>``, another run's
  ``<data>__<problem>__<objective>``; its id (IOH keeps function ids below 65,536) is
  :func:`suite_function_id` for a task of the suite's own instances, else
  :func:`hashed_function_id` of the name, moved to the next free id on a collision
  (:func:`function_ids`). ``functions.csv`` lists every id with its instance and task.
- dimension: the run's ``n_var`` (the length of the searched vector).
- instance: 1, or the data noise's seed for a run with ``problem.noise > 0`` (a suite
  instance's noise is part of its id, so of the function).
- algorithm: the run's ``label`` (one folder each); ``algorithm.info`` its optimizer, budget
  and hyperparameters. When runs of one label differ in these, each setting is an algorithm of
  its own, named by the label and the settings that differ (``ga_budget=500``).
- only runs with status ``ok``, and of their traces only the improvement rows (not the
  checkpoints).
"""

from __future__ import annotations

import csv
import functools
import json
import os
import re
import zlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np

from .store import load_study

__all__ = ["FUNCTIONS_FILE", "IOH_FORMAT_VERSION", "SUITE_TASKS", "ExportedFunction",
           "export_iohprofiler", "function_ids", "hashed_function_id", "suite_function_id"]

#: The ``ioh`` release whose Analyzer output the files mirror (the meta data's ``version``).
IOH_FORMAT_VERSION = "0.4.2"
#: The file of the output folder that maps each function id to its instance and task.
FUNCTIONS_FILE = "functions.csv"
#: The suite's task names, in the order of their ids (see :func:`suite_function_id`).
SUITE_TASKS = ("fixed_k_small.indices", "fixed_k_small.free", "fixed_k_large.indices",
               "fixed_k_large.free", "tolerance_1e-2", "tolerance_1e-3", "tolerance_noise",
               "seed", "front")
#: Ids per suite instance (the tasks' slots, one spare), and the range of the hashed ids.
_SUITE_SLOTS = 10
_HASHED_FIRST, _HASHED_END = 10_000, 60_000
#: The largest number IOH's readers store as a function id or an instance (16 bits).
_IOH_MAX = 65_535
#: Characters kept in a function or algorithm name (others become ``_``): they name files.
_UNSAFE = re.compile(r"[^A-Za-z0-9_.+=-]")


@dataclass(frozen=True)
class ExportedFunction:
    """One function of an export: its file name and what it stands for.

    Attributes
    ----------
    name
        The function name written (``<instance>__<task>`` or ``<data>__<problem>__<objective>``,
        unsafe characters replaced).
    suite_instance, suite_task
        The suite instance and task of a suite run, else empty.
    data, problem, objective
        The run's data, encoding and objective.
    """

    name: str
    suite_instance: str
    suite_task: str
    data: str
    problem: str
    objective: str


@functools.cache
def _suite_positions() -> dict[str, int]:
    from metaknot.suite import instances

    return {instance.id: i for i, instance in enumerate(instances(plugins=False))}


def suite_function_id(instance: str, task: str) -> int | None:
    """The function id of a task of the suite's own instances, below 10,000.

    ``1 + 10 * position + slot``: ``position`` is the instance's place in
    ``metaknot.suite.instances(plugins=False)`` (the base instances, then their noisy variants,
    in the suite's fixed order), ``slot`` the task's place in :data:`SUITE_TASKS`.

    Parameters
    ----------
    instance
        The suite instance's id, e.g. ``titanium`` or ``galvez_f1+noise0.01s0``.
    task
        The task's id, e.g. ``tolerance_1e-3``.

    Returns
    -------
    int or None
        The id, or ``None`` for a plugin's instance, a noisy variant outside the suite, or a
        task name outside :data:`SUITE_TASKS`.
    """
    position = _suite_positions().get(instance)
    if position is None or task not in SUITE_TASKS:
        return None
    fid = 1 + _SUITE_SLOTS * position + SUITE_TASKS.index(task)
    return fid if fid < _HASHED_FIRST else None


def hashed_function_id(name: str) -> int:
    """The preferred function id of a function outside the suite's own tasks:
    ``10000 + crc32(name) mod 50000``, from 10,000 to 59,999, depending on the name alone."""
    return _HASHED_FIRST + zlib.crc32(name.encode()) % (_HASHED_END - _HASHED_FIRST)


def function_ids(functions: Iterable[ExportedFunction]) -> dict[str, int]:
    """The function id of each function of an export, by name.

    A suite task gets :func:`suite_function_id`; any other function
    :func:`hashed_function_id` of its name, or, when that id is taken, the next free one
    (after 59,999 comes 10,000), the functions taken in the order of their names. So the ids
    of one set of functions are always the same, and a hashed id changes only when another
    function of the same export took it first.

    Parameters
    ----------
    functions
        The export's functions (a name given twice counts once).

    Returns
    -------
    dict[str, int]
        Function name -> id, every id below 60,000 and distinct.
    """
    ids: dict[str, int] = {}
    hashed = []
    for function in sorted(set(functions), key=lambda f: f.name):
        if function.name in ids:
            continue
        fid = suite_function_id(function.suite_instance, function.suite_task)
        if fid is None:
            hashed.append(function.name)
        else:
            ids[function.name] = fid
    taken = set(ids.values())
    width = _HASHED_END - _HASHED_FIRST
    if len(hashed) > width:
        raise ValueError(f"{len(hashed)} functions outside the suite; at most {width} fit")
    for name in hashed:
        fid = hashed_function_id(name)
        while fid in taken:
            fid = _HASHED_FIRST + (fid + 1 - _HASHED_FIRST) % width
        ids[name] = fid
        taken.add(fid)
    return ids


def _function(run: Mapping[str, Any]) -> ExportedFunction:
    data, problem, objective = (str(run.get(k, "")) for k in ("data", "problem", "objective"))
    if isinstance(run.get("suite.task"), str):
        instance, task = str(run["suite.instance"]), str(run["suite.task"])
        name = f"{instance}__{task}"
    else:
        instance = task = ""
        name = f"{data}__{problem}__{objective}"
    return ExportedFunction(_UNSAFE.sub("_", name), instance, task, data, problem, objective)


def _instance(run: Mapping[str, Any], config: Mapping[str, Any]) -> int:
    problem = config.get("problem", {})
    if not problem.get("noise"):
        return 1
    fixed = problem.get("noise_seed")
    instance = int(fixed if fixed is not None else run["seed"])
    if not 0 <= instance <= _IOH_MAX:
        raise ValueError(f"run {run['run_id']}: noise seed {instance} is the run's IOHprofiler "
                         f"instance, which must be 0 to {_IOH_MAX}")
    return instance


def _settings(config: Mapping[str, Any]) -> dict[str, Any]:
    """What makes a run's algorithm: the optimizer, its budget and hyperparameters."""
    optimizer = dict(config.get("optimizer", {}))
    settings = {"optimizer": optimizer.pop("_name_", "?"), "budget": config.get("budget")}
    settings.update((k, v) for k, v in sorted(optimizer.items()) if v is not None)
    return settings


def _algorithm_info(settings: Mapping[str, Any]) -> str:
    rest = " ".join(f"{k}={v}" for k, v in settings.items() if k not in ("optimizer", "budget"))
    return f"metaknot {settings['optimizer']} budget={settings['budget']} {rest}".strip()


def _algorithm_names(label: str, infos: Mapping[str, Mapping[str, Any]]) -> dict[str, str]:
    """The algorithm name of each setting (by its info) of the runs of one label: the label
    alone for one setting, else the label and the settings that differ, ``ga_budget=500``."""
    base = _UNSAFE.sub("_", label)
    if len(infos) == 1:
        return dict.fromkeys(infos, base)
    keys = sorted({k for settings in infos.values() for k in settings})
    differ = [k for k in keys if len({json.dumps(s.get(k), sort_keys=True, default=str)
                                      for s in infos.values()}) > 1]
    names = {info: _UNSAFE.sub("_", base + "".join(f"_{k}={settings.get(k)}" for k in differ))
             for info, settings in infos.items()}
    if len(set(names.values())) < len(names):  # told apart only by characters replaced
        names = {info: f"{name}_{zlib.crc32(info.encode()):08x}" for info, name in names.items()}
    return names


def _check_out_dir(out_dir: Path, force: bool) -> None:
    if out_dir.exists() and not out_dir.is_dir():
        raise FileExistsError(f"{out_dir}: exists and is not a folder")
    if not force and out_dir.is_dir() and any(out_dir.iterdir()):
        raise FileExistsError(f"{out_dir}: the folder is not empty; give another --out, or "
                              "--force to write over the files of the same names")


def export_iohprofiler(study_path: str | os.PathLike, out_dir: str | os.PathLike, *,
                       force: bool = False) -> list[Path]:
    """Write a study's traces in IOHprofiler's format (as ``ioh``'s Analyzer logger writes it).

    Parameters
    ----------
    study_path
        The study folder, ``RESULTS_DIR/STUDY``.
    out_dir
        The folder to write into: one folder per algorithm (the runs' ``label``, and the
        settings that differ between runs of one label) inside, and :data:`FUNCTIONS_FILE`.
    force
        Write into a folder that is not empty (files of the same names are replaced, others
        are left as they are).

    Returns
    -------
    list[Path]
        The files written: :data:`FUNCTIONS_FILE`, then per algorithm and function its
        meta-data file (``.json``) and its data files (``.dat``), in a fixed order.

    Raises
    ------
    FileExistsError
        If ``out_dir`` is not empty (and not ``force``) or is a file.
    ValueError
        If the study has no run to export, or a run's noise seed (its instance) is outside
        IOH's 0 to 65,535; :class:`~metaknot.experiments.store.StoreError` if the study cannot
        be read.
    """
    out_dir = Path(out_dir)
    _check_out_dir(out_dir, force)
    study = load_study(study_path)
    runs = study.runs[study.runs["status"] == "ok"]
    if not len(runs):
        raise ValueError(f"{study.path}: no finished run with a trace to export")
    trace = study.trace
    if len(trace):
        trace = trace[trace["improvement"].astype(bool)]
    rows_of = {run_id: part for run_id, part in trace.groupby("run_id", sort=False)}
    # (label, info) -> function name -> dimension -> list of (run, instance, rows)
    grouped: dict[tuple[str, str], dict[str, dict[int, list[tuple[Any, int, Any]]]]] = {}
    settings_of: dict[str, dict[str, dict[str, Any]]] = {}  # label -> info -> settings
    functions: dict[str, ExportedFunction] = {}
    records = runs.sort_values(["label", "seed", "run_id"], kind="stable").to_dict("records")
    for record in cast(list[dict[str, Any]], records):  # pandas-stubs: Hashable keys
        rows = rows_of.get(record["run_id"])
        if rows is None or not len(rows):
            continue  # evaluated nothing: no best value to report
        config = json.loads(record["config"])
        label, settings = str(record["label"]), _settings(config)
        info = _algorithm_info(settings)
        settings_of.setdefault(label, {})[info] = settings
        function = _function(record)
        function = functions.setdefault(function.name, function)
        grouped.setdefault((label, info), {}).setdefault(function.name, {}).setdefault(
            int(record["n_var"]), []).append((record, _instance(record, config), rows))
    if not grouped:
        raise ValueError(f"{study.path}: no finished run with a trace to export")
    ids = function_ids(functions.values())
    algorithms = {(label, info): name for label, infos in settings_of.items()
                  for info, name in _algorithm_names(label, infos).items()}
    out_dir.mkdir(parents=True, exist_ok=True)
    written = [_write_functions(out_dir / FUNCTIONS_FILE, functions, ids)]
    for key in sorted(grouped, key=lambda k: (algorithms[k], k)):
        folder = out_dir / algorithms[key]
        folder.mkdir(parents=True, exist_ok=True)
        for name, scenarios in sorted(grouped[key].items()):
            written += _write_function(folder, algorithms[key], key[1], ids[name], name,
                                       scenarios)
    return written


def _write_functions(path: Path, functions: Mapping[str, ExportedFunction],
                     ids: Mapping[str, int]) -> Path:
    """:data:`FUNCTIONS_FILE`: one row per function id, with its instance and task."""
    with path.open("w", newline="") as file:
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow(["function_id", "function_name", "suite_instance", "suite_task",
                         "data", "problem", "objective"])
        for name in sorted(functions, key=lambda n: ids[n]):
            f = functions[name]
            writer.writerow([ids[name], name, f.suite_instance, f.suite_task, f.data,
                             f.problem, f.objective])
    return path


def _best_x(values: Any) -> list[int] | list[float]:
    """A run's best candidate as ``ioh`` writes it: integers for an integer encoding."""
    x = np.asarray(values)
    if x.dtype.kind in "iub":
        return [int(v) for v in x]
    return [float(v) for v in x]


def _write_function(folder: Path, algorithm: str, info: str, fid: int, name: str,
                    scenarios: Mapping[int, list[tuple[Any, int, Any]]]) -> list[Path]:
    """The meta-data file and the data files of one function of one algorithm."""
    data_dir = folder / f"data_f{fid}_{name}"
    data_dir.mkdir(exist_ok=True)
    meta_scenarios, data_files = [], []
    for dimension in sorted(scenarios):
        path = data_dir / f"IOHprofiler_f{fid}_DIM{dimension}.dat"
        lines, meta_runs = [], []
        for record, instance, rows in scenarios[dimension]:
            best: dict[str, Any] = {"evals": int(rows["evaluations"].iloc[-1]),
                                    "y": float(rows["best_f"].iloc[-1])}
            logged = list(zip(rows["evaluations"], rows["best_f"], strict=True))
            if int(record["n_evaluations"]) > best["evals"]:  # ioh logs a run's last one too
                logged.append((record["n_evaluations"], best["y"]))
            lines.append("evaluations raw_y")
            lines += [f"{int(e)} {float(y):.10f}" for e, y in logged]
            if isinstance(record.get("best_x"), list | np.ndarray):
                best["x"] = _best_x(record["best_x"])
            meta_runs.append({"instance": instance, "evals": int(record["n_evaluations"]),
                              "best": best})
        path.write_text("\n".join(lines) + "\n")
        data_files.append(path)
        meta_scenarios.append({"dimension": dimension,
                               "path": f"{data_dir.name}/{path.name}", "runs": meta_runs})
    meta_path = folder / f"IOHprofiler_f{fid}_{name}.json"
    meta_path.write_text(_meta_text(fid, name, algorithm, info, meta_scenarios))
    return [meta_path, *data_files]


def _meta_text(fid: int, name: str, algorithm: str, info: str,
               scenarios: list[dict[str, Any]]) -> str:
    """The meta-data file, laid out as ``ioh`` lays it out (one line per run)."""
    def dump(value: Any) -> str:
        return json.dumps(value, ensure_ascii=False)

    lines = ["{", f'\t"version": {dump(IOH_FORMAT_VERSION)}, ', '\t"suite": "metaknot", ',
             f'\t"function_id": {fid}, ', f'\t"function_name": {dump(name)}, ',
             '\t"maximization": false, ',
             f'\t"algorithm": {dump({"name": algorithm, "info": info})},',
             '\t"attributes": ["evaluations", "raw_y"],', '\t"scenarios": [']
    for i, scenario in enumerate(scenarios):
        lines += [f'\t\t{{"dimension": {scenario["dimension"]},',
                  f'\t\t"path": {dump(scenario["path"])},', '\t\t"runs": [']
        runs = scenario["runs"]
        lines += [f"\t\t\t{dump(run)}" + ("," if j < len(runs) - 1 else "")
                  for j, run in enumerate(runs)]
        lines.append("\t\t]}" + ("," if i < len(scenarios) - 1 else ""))
    lines += ["\t]", "}"]
    return "\n".join(lines) + "\n"
