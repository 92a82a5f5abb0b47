"""Memory and time of reading a point file with ``load_points``, and of refusing hostile files.

Writes a CSV table (a header row, then ``--rows`` rows of two full-precision coordinates) and
the same points as ``.npy`` into a temporary folder, and loads each in a fresh process: the
peak resident memory the load adds (peak minus the resident size before it) is printed as a
ratio to the size of the array itself, with the load time. Then the hostile files of
tests/test_input_files.py (a 2 GB sparse ``.csv``, a 2 GB ``.npy`` whose header claims 1e9
points) are refused, with the time and the memory that takes.

Run: ``python benchmarks/bench_input.py [--rows 1000000]``; the last lines are
``csv_peak_over_array: <ratio>`` and ``csv_load_seconds: <s>``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

#: Run in a fresh process: the resident size before the load, the load time, the peak after.
CHILD = """
import json, sys, time
from metaknot.problems import load_points

def memory(field):  # bytes; VmHWM is this process's peak (ru_maxrss counts its parent's)
    with open("/proc/self/status") as status:
        return 1024 * int(next(line.split()[1] for line in status if line.startswith(field)))

before = memory("VmRSS:")
start = time.perf_counter()
try:
    data = load_points(sys.argv[1])
    outcome, size = "loaded", data.points.nbytes
except ValueError as exc:
    outcome, size = str(exc), 0
seconds = time.perf_counter() - start
peak = memory("VmHWM:")
print(json.dumps({"outcome": outcome, "seconds": seconds, "added": peak - before,
                  "array": size}))
"""


def measure(path: Path) -> dict:
    """Outcome, seconds and added peak memory of ``load_points(path)`` in a fresh process."""
    done = subprocess.run([sys.executable, "-c", CHILD, str(path)], capture_output=True,
                          text=True, check=True)
    return json.loads(done.stdout)


def write_files(folder: Path, rows: int) -> dict[str, Path]:
    t = np.linspace(0.0, 2.0 * np.pi, rows)
    points = np.column_stack((6 * np.cos(t) - 4 * np.cos(6 * t), 6 * np.sin(t) - 4 * np.sin(6 * t)))
    csv, npy = folder / "points.csv", folder / "points.npy"
    with csv.open("w") as file:
        file.write("x,y\n")
        file.writelines(f"{x!r},{y!r}\n" for x, y in points.tolist())
    np.save(npy, points)
    sparse, claims = folder / "sparse.csv", folder / "claims.npy"
    with sparse.open("wb") as file:
        file.truncate(2 * 2**30)
    with claims.open("wb") as file:
        np.lib.format.write_array_header_1_0(
            file, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 2)})
        file.truncate(2 * 2**30)
    return {"csv": csv, "npy": npy, "2 GB sparse .csv": sparse, "2 GB .npy header": claims}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=1_000_000)
    args = parser.parse_args()
    mb = 2**20
    with tempfile.TemporaryDirectory() as scratch:
        files = write_files(Path(scratch), args.rows)
        results = {name: measure(path) for name, path in files.items()}
        sizes = {name: path.stat().st_size for name, path in files.items()}
    print(f"{'file':<18} {'size MB':>9} {'seconds':>8} {'added MB':>9} {'array MB':>9} "
          f"{'ratio':>6}  outcome")
    for name, r in results.items():
        ratio = f"{r['added'] / r['array']:6.2f}" if r["array"] else "     -"
        outcome = r["outcome"] if len(r["outcome"]) < 60 else r["outcome"][:57] + "..."
        print(f"{name:<18} {sizes[name] / mb:9.1f} {r['seconds']:8.3f} {r['added'] / mb:9.1f} "
              f"{r['array'] / mb:9.1f} {ratio}  {outcome.split(': ', 1)[-1]}")
    csv = results["csv"]
    print(f"csv_peak_over_array: {csv['added'] / csv['array']:.2f}")
    print(f"csv_load_seconds: {csv['seconds']:.2f}")


if __name__ == "__main__":
    main()
