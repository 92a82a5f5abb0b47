"""A study written by an earlier version of metaknot is still read, reported and resumed.

``tests/data/previous-study`` was written at commit c75b5b6 (before records stored the fitted
spline) by::

    metaknot run -m problem=archimedean algorithm=ga,random_search seed=0,1 budget=200 \\
        study=previous-study results_dir=results

plus one run of ``algorithm=ga seed=7`` whose optimizer raised before its first evaluation
(its record, under ``failed/``, was built by that version's code for such runs). The Hydra
folder was left out.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from metaknot.experiments.report import build
from metaknot.experiments.store import load_study

DATA = Path(__file__).parent / "data" / "previous-study"
SWEEP = ("-m", "problem=archimedean", "{optimizer}=ga,random_search", "seed=0,1", "budget=200",
         "study=previous-study")
RUN_IDS = {"592e106461ab81fe", "a43e63dcb1ce181e", "cf7d777ee8ac916e", "d32528d769ad2043"}
FAILED_ID = "c4f013fc391a2e5f"


@pytest.fixture
def results(tmp_path: Path) -> Path:
    """A copy of the previous study in a results folder (reading never changes a study, but a
    sweep writes its Hydra folder into it)."""
    shutil.copytree(DATA, tmp_path / "results" / "previous-study")
    return tmp_path / "results"


def snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.glob("*/*.parquet"))}


def test_load_study_reads_the_previous_version(results):
    study = load_study(results / "previous-study")
    ok = study.runs[study.runs.status == "ok"]
    assert set(ok.run_id) == RUN_IDS
    assert sorted(zip(ok.optimizer, ok.seed, strict=True)) == [
        ("ga", 0), ("ga", 1), ("random_search", 0), ("random_search", 1)]
    assert (ok.n_evaluations == 200).all() and (ok.rmse > 0).all()
    (failed,) = study.failures.to_dict("records")
    assert failed["run_id"] == FAILED_ID and "could not start" in failed["error"]
    assert set(study.runs.run_id) == RUN_IDS | {FAILED_ID}
    assert set(study.trace.run_id) == RUN_IDS


def test_the_report_reads_the_previous_version(results, tmp_path):
    before = snapshot(results / "previous-study")
    report = build(results / "previous-study", tmp_path / "report", log=None)
    figures = {p.name for p in report.figures if p.suffix == ".png"}
    assert "curves-archimedean.png" in figures  # drawn from the records without a spline
    text = (tmp_path / "report" / "report.md").read_text()
    assert "1 run(s) failed and are left out" in text
    assert snapshot(results / "previous-study") == before


@pytest.mark.parametrize("optimizer", ["optimizer", "algorithm"])  # "algorithm": as written
def test_a_sweep_of_the_same_configuration_finds_every_run_stored(results, optimizer):
    before = snapshot(results / "previous-study")
    sweep = [arg.format(optimizer=optimizer) for arg in SWEEP]
    done = subprocess.run([sys.executable, "-m", "metaknot.cli", "run", *sweep,
                           f"results_dir={results}"], cwd=results.parent, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert done.returncode == 0, done.stderr
    assert f"study {results / 'previous-study'}: 4 jobs, 0 to run, 4 already stored" \
        in done.stderr
    noted = "metaknot: 'algorithm' is deprecated, write 'optimizer'" in done.stderr
    assert noted == (optimizer == "algorithm")
    assert snapshot(results / "previous-study") == before
