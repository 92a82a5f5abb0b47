"""What the benchmarks share (run as scripts: ``python benchmarks/bench_*.py``): timing, and
launching a ``metaknot run -m`` sweep."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable
from typing import Any, TypeVar

T = TypeVar("T")


def best_time(func: Callable[[], object], repeats: int) -> float:
    """The shortest of ``repeats`` wall-clock times of ``func()``, in seconds (the least
    disturbed by whatever else the machine is doing)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return min(times)


def timed(func: Callable[..., T], *args: Any, **kwargs: Any) -> tuple[T, float]:
    """``func(*args, **kwargs)`` and its wall-clock time, in seconds."""
    start = time.perf_counter()
    return func(*args, **kwargs), time.perf_counter() - start


def metaknot_run(overrides: list[str], **kwargs: Any) -> subprocess.CompletedProcess:
    """``metaknot run -m <overrides>`` in a fresh interpreter, its output unbuffered
    (``kwargs`` go to :func:`subprocess.run`)."""
    return subprocess.run([sys.executable, "-m", "metaknot.cli", "run", "-m", *overrides],
                          text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"}, **kwargs)
