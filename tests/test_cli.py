"""The command line: the demo prints one row per curve and optimizer, with consistent metrics."""

from __future__ import annotations

import numpy as np
import pytest

from metaknot.cli import main
from metaknot.problems import Paper, get_curve


def table(out: str) -> list[list[str]]:
    lines = out.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("curve")) + 1
    return [line.split() for line in lines[start:]]


def test_demo_prints_a_row_per_curve_and_optimizer(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--budget", "150", "--seed", "3", "--quiet",
                 "--optimizers", "dolphin", "random_search"]) == 0
    rows = table(capsys.readouterr().out)
    assert {(r[0], r[1]) for r in rows} == {
        (c, o) for c in ("epitrochoid", "archimedean", "vivaldi")
        for o in ("dolphin", "random_search")
    }
    for cols in rows:
        data = get_curve(cols[0])
        cp, objective, ed = int(cols[2]), float(cols[3]), float(cols[5])
        assert 4 <= cp <= data.n_points
        # paper objective = control points x max(Euclidean distance, error floor)
        floor = Paper().error_floor * data.scale * np.sqrt(data.n_points)
        assert objective == pytest.approx(cp * max(ed, floor), rel=2e-3)
        assert int(cols[7]) == 150


def test_demo_is_reproducible(capsys: pytest.CaptureFixture[str]) -> None:
    tables = []
    for _ in range(2):
        main(["demo", "--budget", "100", "--seed", "5", "--quiet", "--curves", "archimedean"])
        tables.append([row[:-1] for row in table(capsys.readouterr().out)])  # drop seconds
    assert tables[0] == tables[1]


def test_list_names_builtins(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in ("mask", "indices", "free", "random_search", "dolphin",
                 "ga", "nlopt", "uniform", "averaging", "fitpack"):
        assert name in out
    # the word a study's configuration uses for them (encoding=mask), not "problems", which
    # a study uses for the data (problem=archimedean)
    assert out.splitlines()[0].split(":")[0] == "encodings"


def test_bad_option_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--optimizers", "no_such_thing", "--quiet"]) == 2
    assert "unknown optimizer 'no_such_thing'" in capsys.readouterr().err
