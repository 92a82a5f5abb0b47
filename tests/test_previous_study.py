"""A study written by an earlier version of metaknot, carried over by ``metaknot migrate``, is
read, reported and resumed.

``tests/data/previous-study`` was written at commit c75b5b6 (before records stored the fitted
spline) by::

    metaknot run -m problem=archimedean algorithm=ga,random_search seed=0,1 budget=200 \\
        study=previous-study results_dir=results

plus one run of ``algorithm=ga seed=7`` whose optimizer raised before its first evaluation
(its record, under ``failed/``, was built by that version's code for such runs). The Hydra
folder was left out. Its records name the optimizer ``algorithm`` and have the run ids of that
version; migrated, they have today's.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from metaknot.experiments.migrate import migrate_study
from metaknot.experiments.report import build
from metaknot.experiments.store import load_study

DATA = Path(__file__).parent / "data" / "previous-study"
SWEEP = ("-m", "problem=archimedean", "optimizer=ga,random_search", "seed=0,1", "budget=200",
         "study=previous-study")
#: The run ids the version that wrote the study gave its runs, and today's.
FORMER_IDS = {"592e106461ab81fe": "7f1a6388a38ddef6", "a43e63dcb1ce181e": "9fc1069a96206317",
              "cf7d777ee8ac916e": "6023607fd986d660", "d32528d769ad2043": "4a9be703dc62d753",
              "c4f013fc391a2e5f": "f173d56c4b7db254"}
RUN_IDS = {"7f1a6388a38ddef6", "6023607fd986d660", "9fc1069a96206317", "4a9be703dc62d753"}
FAILED_ID = "f173d56c4b7db254"


@pytest.fixture
def results(tmp_path: Path) -> Path:
    """A migrated copy of the previous study in a results folder."""
    shutil.copytree(DATA, tmp_path / "results" / "previous-study")
    assert migrate_study(tmp_path / "results" / "previous-study").run_ids == FORMER_IDS
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
    assert set(ok.problem) == {"mask"} and "algorithm" not in study.runs
    assert ok.loc[ok.optimizer == "ga", "optimizer.population"].eq(50).all()
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


def test_a_sweep_of_the_same_configuration_finds_every_run_stored(results):
    before = snapshot(results / "previous-study")
    done = subprocess.run([sys.executable, "-m", "metaknot.cli", "run", *SWEEP,
                           f"results_dir={results}"], cwd=results.parent, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert done.returncode == 0, done.stderr
    assert f"study {results / 'previous-study'}: 4 jobs, 0 to run, 4 already stored" \
        in done.stderr
    assert snapshot(results / "previous-study") == before
