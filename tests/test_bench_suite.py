"""``benchmarks/bench_suite.py`` end to end at its smoke size (``--quick``: the mini split, one
seed), with a small budget and the report's tables only, so that the benchmark keeps working.
Its figures are printed, never checked against a time."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from metaknot.experiments import load_study
from metaknot.suite import instances
from metaknot.suite.splits import split

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_suite.py"


@pytest.mark.slow
def test_the_quick_suite_benchmark_runs_and_prints_its_figures(tmp_path) -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--budget", "40",
                           "--no-figures", "--keep", str(tmp_path)],
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr
    printed = dict(line.split(": ", 1) for line in done.stdout.splitlines() if ": " in line)
    assert int(printed["suite_instances"]) == len(instances())
    assert int(printed["suite_families"]) == len({i.family for i in instances()})
    assert float(printed["suite_study_seconds"]) > 0
    assert float(printed["suite_report_seconds"]) > 0
    runs = load_study(tmp_path / "bench_suite").runs
    assert len(runs) == 5 * len(split("mini")) == int(printed["suite_runs"].split()[0])
    assert set(runs["status"]) == {"ok"} and set(runs["budget"]) == {40}
    # problem.task=tolerance: the instance's own (the mini split has no noise: 1e-3)
    assert set(runs["suite.task"]) == {"tolerance_1e-3"}
    assert (tmp_path / "bench_suite-report" / "report.html").is_file()
