"""How long ``import metaknot`` takes, and that it loads no compiled kernel.

The core (problems' interfaces, optimizers, the runner) imports without numba or the generated
row loops; the applications (``metaknot fit``) and the spline layer load them on first use.
Each figure is the median, over ``--repeats`` fresh interpreters, of the wall time of the
import beyond the interpreter's own start (``python -c pass``, timed alongside); the spline
layer (``metaknot.bspline``, what any fit needs) is timed the same way in the same run, as the
reference.

Prints ``import_metaknot_ms``, ``import_bspline_ms``, ``core_loads_numba: <True|False>`` and
last ``core_import_ratio: <import metaknot / import metaknot.bspline>``.

Run: ``python benchmarks/bench_import.py [--repeats 7]``
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys

from _timing import timed


def seconds(code: str) -> float:
    """Wall time of a fresh interpreter running ``code``."""
    return timed(subprocess.run, [sys.executable, "-c", code], check=True)[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    seconds("import metaknot.bspline")  # numba's cache warm, as in every later run
    bare, core, spline = [], [], []
    for _ in range(args.repeats):  # interleaved: all three see the same machine
        bare.append(seconds("pass"))
        core.append(seconds("import metaknot"))
        spline.append(seconds("import metaknot.bspline"))
    start = statistics.median(bare)
    core_ms = 1000 * (statistics.median(core) - start)
    spline_ms = 1000 * (statistics.median(spline) - start)
    loads = subprocess.run(
        [sys.executable, "-c", "import sys, metaknot; print('numba' in sys.modules or "
         "'metaknot.bspline._rows' in sys.modules)"],
        capture_output=True, text=True, check=True).stdout.strip()
    print(f"import_metaknot_ms: {core_ms:.0f}")
    print(f"import_bspline_ms: {spline_ms:.0f}")
    print(f"core_loads_numba: {loads}")
    print(f"core_import_ratio: {core_ms / spline_ms:.2f}")


if __name__ == "__main__":
    main()
