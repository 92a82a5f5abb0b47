"""A study's traces in other tools' formats: ``metaknot export STUDY --format iohprofiler``.

IOHprofiler's format is the one IOHexperimenter's Python package ``ioh`` (0.3.x) writes with
its ``Analyzer`` logger, which IOHanalyzer loads. Per algorithm folder and function::

    <out>/<algorithm>/IOHprofiler_f<fid>_<function>.json        meta data (its runs, best values)
    <out>/<algorithm>/data_f<fid>_<function>/IOHprofiler_f<fid>_DIM<d>.dat

The ``.dat`` file holds, for each run, the header line ``evaluations raw_y`` and then one row
``<evaluation> <objective>`` per improvement of the run's best, and a last row at the run's
final evaluation with its best value when that evaluation did not improve (``ioh`` logs a run's
last evaluation; the trace keeps best-so-far values only). ``raw_y`` has 10 decimals, as
``ioh`` writes it; the meta data's ``best.y`` keeps every digit.

Mapping (see docs/guide/export.md):

- function: a suite run's ``<suite.instance>__<suite.task>``, another run's
  ``<data>__<problem>__<objective>``; its id is :func:`function_id` of that name.
- dimension: the run's ``n_var`` (the length of the searched vector).
- instance: 1, or the data noise's seed for a run with ``problem.noise > 0`` (a suite
  instance's noise is part of its id, so of the function).
- algorithm: the run's ``label`` (one folder each); ``algorithm.info`` its optimizer and
  hyperparameters.
- only runs with status ``ok``, and of their traces only the improvement rows (not the
  checkpoints).
"""

from __future__ import annotations

import json
import os
import re
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import numpy as np

from .store import load_study

__all__ = ["IOH_FORMAT_VERSION", "export_iohprofiler", "function_id"]

#: The ``ioh`` release whose Analyzer output the files mirror (the meta data's ``version``).
IOH_FORMAT_VERSION = "0.3.22"
#: Characters kept in a function or algorithm name (others become ``_``): they name files.
_UNSAFE = re.compile(r"[^A-Za-z0-9_.+=-]")


def function_id(name: str) -> int:
    """The IOHprofiler function id of a function name: ``100000 + crc32(name) mod 900000``,
    a six-digit number that depends on the name alone (the same in every export)."""
    return 100_000 + zlib.crc32(name.encode()) % 900_000


def _function_name(run: Mapping[str, Any]) -> str:
    if isinstance(run.get("suite.task"), str):
        name = f"{run['suite.instance']}__{run['suite.task']}"
    else:
        name = f"{run['data']}__{run['problem']}__{run['objective']}"
    return _UNSAFE.sub("_", name)


def _instance(run: Mapping[str, Any], config: Mapping[str, Any]) -> int:
    problem = config.get("problem", {})
    if not problem.get("noise"):
        return 1
    fixed = problem.get("noise_seed")
    return int(fixed if fixed is not None else run["seed"])


def _algorithm_info(config: Mapping[str, Any]) -> str:
    optimizer = dict(config.get("optimizer", {}))
    name = optimizer.pop("_name_", "?")
    settings = " ".join(f"{k}={v}" for k, v in sorted(optimizer.items()) if v is not None)
    return f"metaknot {name} budget={config.get('budget')} {settings}".strip()


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
        The folder to write into: one folder per algorithm (the runs' ``label``) inside.
    force
        Write into a folder that is not empty (files of the same names are replaced, others
        are left as they are).

    Returns
    -------
    list[Path]
        The files written: per algorithm and function its meta-data file (``.json``), then its
        data files (``.dat``), in a fixed order.

    Raises
    ------
    FileExistsError
        If ``out_dir`` is not empty (and not ``force``) or is a file.
    ValueError
        If the study has no run to export, or two function names share an id (both named);
        :class:`~metaknot.experiments.store.StoreError` if the study cannot be read.
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
    # algorithm -> function name -> dimension -> list of (run, instance, rows)
    grouped: dict[str, dict[str, dict[int, list[tuple[Any, int, Any]]]]] = {}
    info: dict[str, str] = {}
    records = runs.sort_values(["label", "seed", "run_id"], kind="stable").to_dict("records")
    for record in cast(list[dict[str, Any]], records):  # pandas-stubs: Hashable keys
        rows = rows_of.get(record["run_id"])
        if rows is None or not len(rows):
            continue  # evaluated nothing: no best value to report
        config = json.loads(record["config"])
        algorithm = _UNSAFE.sub("_", str(record["label"]))
        info.setdefault(algorithm, _algorithm_info(config))
        grouped.setdefault(algorithm, {}).setdefault(_function_name(record), {}).setdefault(
            int(record["n_var"]), []).append((record, _instance(record, config), rows))
    if not grouped:
        raise ValueError(f"{study.path}: no finished run with a trace to export")
    names = sorted({name for functions in grouped.values() for name in functions})
    ids: dict[int, str] = {}
    for name in names:
        other = ids.setdefault(function_id(name), name)
        if other != name:
            raise ValueError(f"functions {other!r:.40} and {name!r:.40} share the id "
                             f"{function_id(name)}")
    written = []
    for algorithm in sorted(grouped):
        folder = out_dir / algorithm
        folder.mkdir(parents=True, exist_ok=True)
        for name, scenarios in sorted(grouped[algorithm].items()):
            written += _write_function(folder, algorithm, info[algorithm], name, scenarios)
    return written


def _write_function(folder: Path, algorithm: str, info: str, name: str,
                    scenarios: Mapping[int, list[tuple[Any, int, Any]]]) -> list[Path]:
    """The meta-data file and the data files of one function of one algorithm."""
    fid = function_id(name)
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
                best["x"] = [float(v) for v in record["best_x"]]
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
