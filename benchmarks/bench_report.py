"""Time to build the report of a stored study (target: the seed paper's 1440 runs in < 60 s).

Run ``make seed-paper`` first (or any study), then
``python benchmarks/bench_report.py [results/seed_paper]``. Printed: the time to read the study
from the store, to build the report without figures, and with them; the last line is

    report_seconds: <the whole report, figures included>
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from _timing import timed

from metaknot.experiments import load_study
from metaknot.experiments.report import build


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", nargs="?", default="results/seed_paper", type=Path)
    args = parser.parse_args()
    study, read = timed(load_study, args.study)
    print(f"read {len(study.runs)} runs and {len(study.trace)} trace points: {read:.1f} s")
    with tempfile.TemporaryDirectory() as out:
        _, tables = timed(build, args.study, Path(out) / "tables-only", figures=False, log=None)
        print(f"report without figures: {tables:.1f} s", flush=True)
        report, full = timed(build, args.study, Path(out) / "full", log=None)
        print(f"report with {len(report.figures) // 2} figures: {full:.1f} s")
    print(f"report_seconds: {full:.1f}")


if __name__ == "__main__":
    main()
