"""Statistical comparison reports of a stored study: ``metaknot report`` and :func:`build`.

``build(study_dir)`` reads a study (complete or partial) and writes, in a new folder beside it
(``<results_dir>/<study>-report`` unless ``out`` is given; the study is never modified):

* ``report.html`` — one self-contained file, figures embedded;
* ``report.md`` — the same in Markdown, figures linked from ``figures/``;
* ``tables/*.csv`` — every table; ``tables/*.tex`` — the main tables for a paper (booktabs);
* ``figures/*.png`` and ``*.svg``.

Tables and tests are in :mod:`.tables`, figures in :mod:`.figures`, the arrangement of runs
into instances, methods and budgets in :mod:`.data`.
"""

from __future__ import annotations

from .build import Report, build
from .data import Comparison, ReportError, prepare

__all__ = ["Comparison", "Report", "ReportError", "build", "prepare"]
