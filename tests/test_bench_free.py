"""``benchmarks/bench_free.py`` end to end at a tiny size (one instance, one seed, a small
budget and reference), so that the benchmark keeps working. Its figures are printed, never
checked against a time; at this size only their form is checked."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_free.py"
FIGURES = ("free_vs_attainable_worst_ratio", "free_vs_index_worst_ratio",
           "free_vs_bobyqa_median_ratio", "lbfgs_vs_bobyqa_median_ratio",
           "jacobian_cost_ratio", "kang_recovery_rmse", "kang_recovery_from_sites_rmse")


def test_the_free_knot_benchmark_runs_and_prints_its_figures() -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--instances", "titanium", "--seeds",
                           "1", "--budget", "60", "--reference-fits", "300"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    printed = dict(line.split(": ", 1) for line in done.stdout.splitlines() if ": " in line)
    assert set(FIGURES) <= set(printed)
    values = {name: float(printed[name]) for name in FIGURES}
    assert all(value > 0 for value in values.values())
    assert values["jacobian_cost_ratio"] > 1  # a Jacobian costs more than one fit
    # the reference is at least as good as the best-known index set it starts from
    rows = [line.split() for line in done.stdout.splitlines() if line.startswith("titanium")]
    assert len(rows) == 2 and all(float(row[6]) <= float(row[7]) * (1 + 1e-9) for row in rows)
