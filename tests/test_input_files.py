"""Hostile point files given to ``metaknot run`` and ``metaknot fit``: a 2 GB sparse file, a
``.npy`` header claiming a huge array, 10 MB of NUL bytes. Each is refused from its first
bytes in one short line naming the file, with bounded memory: the peak resident size of the
command stays far below the size of the file."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

#: A generous bound on the peak memory of a refusal (the commands start at about 200 MB; reading
#: the 2 GB files would take 2 GB and more).
PEAK_MB = 500


@pytest.fixture(scope="module")
def hostile(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, str]]:
    """Name: the file and the words of its refusal."""
    folder = tmp_path_factory.mktemp("hostile")
    sparse = folder / "sparse.csv"
    with sparse.open("wb") as file:
        file.truncate(2 * 2**30)
    claims = folder / "claims.npy"
    with claims.open("wb") as file:
        np.lib.format.write_array_header_1_0(
            file, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 2)})
        file.truncate(2 * 2**30)
    nul = folder / "nul.csv"
    nul.write_bytes(bytes(10 * 2**20))
    return {
        "sparse": (sparse, "2,147,483,648 bytes; a text file of points may have at most"),
        "claims": (claims, "1,000,000,000 points; a file may hold at most 1,000,000 points"),
        "nul": (nul, "binary data (a NUL byte at offset 0), not a text table of numbers"),
    }


#: The command line in a fresh process that prints its own peak resident memory last (VmHWM:
#: ru_maxrss would count the memory of the process that started it).
PROBE = """
import sys
from metaknot.cli import main
try:
    code = main(sys.argv[1:])
finally:
    with open("/proc/self/status") as status:
        print(next(line.split()[1] for line in status if line.startswith("VmHWM:")))
sys.exit(code)
"""


def run_measured(args: list[str], cwd: Path) -> tuple[int, str, float]:
    """Exit code, standard error and peak resident memory (MB) of ``metaknot ARGS``."""
    done = subprocess.run([sys.executable, "-c", PROBE, *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300)
    return done.returncode, done.stderr, int(done.stdout.split()[-1]) / 1024


COMMANDS = {
    "run": lambda path, tmp: ["run", "problem=points", f"problem.points={path}",
                              f"results_dir={tmp / 'results'}"],
    "fit": lambda path, tmp: ["fit", str(path), "--tol", "0.01", "--out", str(tmp / "fit")],
}


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("name", ["sparse", "claims", "nul"])
def test_a_hostile_file_is_refused_in_one_line_with_bounded_memory(hostile, tmp_path, command,
                                                                   name) -> None:
    path, words = hostile[name]
    code, err, peak_mb = run_measured(COMMANDS[command](path, tmp_path), tmp_path)
    assert code == 2
    (line,) = err.strip().splitlines()
    assert f"{path}: {words}" in line and len(line) < 200 + len(str(path))
    assert peak_mb < PEAK_MB, f"peak memory {peak_mb:.0f} MB"
    assert not (tmp_path / "fit").exists() and not (tmp_path / "results").exists()
