"""The command line: the demo prints one row per seed curve with consistent metrics."""

from __future__ import annotations

import numpy as np
import pytest

from metaknot.cli import main
from metaknot.problems import Paper, get_curve


def test_demo_prints_a_row_per_curve(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--budget", "150", "--seed", "3", "--quiet"]) == 0
    out = capsys.readouterr().out.splitlines()
    rows = {line.split()[0]: line.split() for line in out[2:]}
    assert set(rows) == {"epitrochoid", "archimedean", "vivaldi"}
    for name, cols in rows.items():
        data = get_curve(name)
        assert int(cols[1]) == data.n_points
        assert int(cols[2]) == data.dim
        cp, objective, ed = int(cols[3]), float(cols[4]), float(cols[6])
        # paper objective = control points x max(Euclidean distance, error floor)
        floor = Paper().error_floor * data.scale * np.sqrt(data.n_points)
        assert objective == pytest.approx(cp * max(ed, floor), rel=2e-3)
        assert int(cols[8]) == 150


def test_demo_is_reproducible(capsys: pytest.CaptureFixture[str]) -> None:
    tables = []
    for _ in range(2):
        main(["demo", "--budget", "100", "--seed", "5", "--quiet", "--curves", "archimedean"])
        line = capsys.readouterr().out.splitlines()[2].split()
        tables.append(line[:-1])  # all but the wall-clock column
    assert tables[0] == tables[1]


def test_list_names_builtins(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("knot_selection", "knot_indices", "free_knots", "random_search"):
        assert name in out


def test_bad_option_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--optimizer", "no_such_thing", "--quiet"]) == 2
    assert "unknown optimizer 'no_such_thing'" in capsys.readouterr().err
