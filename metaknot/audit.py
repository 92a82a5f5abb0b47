"""The fit tally: how many fits a problem's model layer made, counted where they are made.

The evaluator counts the candidates it scores; this module counts, independently, the fits the
model layer computes. metaknot's B-spline layer (the batched kernels, the move evaluator, the
periodic kernel and the single fits of :mod:`metaknot.bspline`) adds every fit it makes with
:func:`add_fits`, whoever calls it. :func:`metaknot.minimize` compares the fits tallied during a
run with those the run accounts for (its evaluations, further fits made during its evaluator's
calls, and the fits the optimizer declared with :meth:`metaknot.Task.count_fits`); more fits
than that mark the run ``status="budget_violation"``.

The tally is per thread, so runs in different threads of one process audit only their own fits.
A problem whose model is not metaknot's spline layer can take part by calling :func:`add_fits`
from its own evaluation code.
"""

from __future__ import annotations

import threading

__all__ = ["add_fits", "fits"]


class _Tally(threading.local):
    count = 0


_tally = _Tally()


def add_fits(n: int) -> None:
    """Add ``n`` fits to this thread's tally (called by the model layer, once per call)."""
    _tally.count += n


def fits() -> int:
    """Fits tallied in this thread so far."""
    return _tally.count
