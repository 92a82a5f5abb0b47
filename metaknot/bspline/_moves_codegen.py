"""Renders ``_moves_rows.py``: the row loop of delta evaluation, per degree and dimension.

:mod:`metaknot.bspline._moves` rotates data rows into a banded factor in three places: the
forward sweep and the backward sweep over an incumbent (saving a state at every knot), and
the window of a move (the rows whose basis functions the move changed, under the candidate's
knots). ``window_p{p}_d{d}`` rotates rows ``j0..j1 - 1`` into a flat factor whose first column
is the knot vector's column ``col0``; ``sweep_p{p}_d{d}`` is the same loop over every row,
saving a state at given row boundaries (the forward and the mirrored sweeps);
``absorb_p{p}_d{d}`` rotates a backward state's rows into a merged factor.

The loops reuse the kernel's templates (:mod:`._codegen`: de Boor-Cox with a table of
reciprocal knot differences, square-root-free Givens rotations on a flat factor of ``W = 1 +
p + d`` entries per column, empty columns as ``dinv = EMPTY``, unsigned indices), so they
compile to the same straight-line code. They add the column sums of the rows' basis values
(the conditioning certificate needs them) and, with ``store``, keep the basis values and spans
(the maximum deviation).

The generated file is committed; ``python -m metaknot.bspline._moves_codegen`` rewrites it and
a test checks it is current.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

from ._codegen import _basis_lines as basis_lines
from ._codegen import _rotation_lines as rotation_lines
from ._codegen import _row_rotation_lines as row_rotation_lines
from ._codegen import write

MAX_DEGREE = 5
MAX_DIMENSION = 3
TARGET = Path(__file__).with_name("_moves_rows.py")

HEADER = '''"""Row loops of delta evaluation, by degree and dimension. GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._moves_codegen``; see that module and ``_moves``.
"""

import numpy as np
from numba import njit

from ._rows import EMPTY, FASTMATH, U0, U1, U2, U3, U4, U5, U6, U7, U8, U9

__all__ = ["EMPTY", "FASTMATH", "U0", "U1", "U2", "U3", "U4", "U5", "U6", "U7", "U8", "U9"]
'''


def _row_lines(p: int, d: int, indent: str, first: str, guarded: bool) -> list[str]:
    """One data row ``j``: its span (walking up to ``last``), basis values, column sums, the
    stored basis and span (under ``if store:`` when ``guarded``), its rotation into ``st``."""
    store = [f"{indent}spans[j] = span", *[f"{indent}basis[j, {i}] = h{i}" for i in range(p + 1)]]
    if guarded:
        store = [f"{indent}if store:", *("    " + line for line in store)]
    return [
        f"{indent}x = u[j]",
        f"{indent}while t[span + U1] <= x and span < last:",
        f"{indent}    span += U1",
        *basis_lines(p, indent),
        f"{indent}first = {first}",
        *[f"{indent}colsum[first + U{i}] += h{i}" for i in range(p + 1)],
        *store,
        *row_rotation_lines(p, d, indent),
    ]


def render_window(p: int, d: int) -> str:
    """Source of ``window_p{p}_d{d}``."""
    ind = " " * 8
    lines = [
        "@njit(cache=True, fastmath=FASTMATH, error_model='numpy')",
        f"def window_p{p}_d{d}(u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis,",
        "                    spans):",
        f'    """Rotate data rows ``j0..j1 - 1`` into the flat factor ``st`` (degree {p},',
        f"    dimension {d}), whose first column is the knot vector's column ``col0``; the",
        "    spans start at ``span`` and stop at ``last``. Adds the rows' basis values to",
        "    ``colsum`` (indexed like ``st``) and, if ``basis`` is not empty, stores them and",
        "    the spans by row. Returns the rows' residual SSE and the last span.",
        '    """',
        "    store = basis.shape[0] > 0",
        *[f"    o{j} = np.uint64({j - 1} * t.size)" for j in range(2, p + 1)],
        "    span = np.uint64(span)",
        "    last = np.uint64(last)",
        "    col0 = np.uint64(col0)",
        "    sse = 0.0",
        "    for j in range(j0, j1):",
        *_row_lines(p, d, ind, f"span - U{p} - col0", guarded=True),
        "    return sse, span",
    ]
    return "\n".join(lines) + "\n"


def render_sweep(p: int, d: int) -> str:
    """Source of ``sweep_p{p}_d{d}``: a whole sweep with its saved states."""
    ind = " " * 12
    width = 1 + p + d
    lines = [
        "@njit(cache=True, fastmath=FASTMATH, error_model='numpy')",
        f"def sweep_p{p}_d{d}(u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum,",
        "                   basis, spans):",
        f'    """Rotate every data row into the flat factor ``st`` (degree {p}, dimension',
        f"    {d}), in steps: before step ``s`` (rows ``bounds[s]..bounds[s + 1] - 1``), save",
        "    the factor's columns ``blocks[s] ..`` (``p`` of them) in ``S[s]``, the residual",
        "    so far in ``Ssse[s]`` and those columns' sums in ``Scol[s]``; a last state is saved",
        "    after the last step. Stores every row's basis values and span.",
        '    """',
        *[f"    o{j} = np.uint64({j - 1} * t.size)" for j in range(2, p + 1)],
        "    steps = bounds.size - 1",
        "    last = np.uint64(last)",
        "    sse = 0.0",
        f"    span = U{p}",
        "    for s in range(steps + 1):",
        "        b = blocks[s]",
        f"        S[s, :] = st[b * {width} : (b + {p}) * {width}]",
        "        Ssse[s] = sse",
        *[f"        Scol[s, {a}] = colsum[b + {a}]" for a in range(p)],
        "        if s == steps:",
        "            break",
        "        for j in range(bounds[s], bounds[s + 1]):",
        *_row_lines(p, d, ind, f"span - U{p}", guarded=False),
    ]
    return "\n".join(lines) + "\n"


def render_absorb(p: int, d: int) -> str:
    """Source of ``absorb_p{p}_d{d}``: a backward state's rows into a merged factor."""
    width = 1 + p + d
    ind = " " * 8
    lines = [
        "@njit(cache=True, fastmath=FASTMATH, error_model='numpy')",
        f"def absorb_p{p}_d{d}(st, first, G, c, unreached):",
        f'    """Rotate the rows of the backward state ``G[c]`` (degree {p}, dimension {d}) into',
        "    the flat factor ``st`` at columns ``first ..``: row ``a`` of the state is the",
        "    mirror's column, a unit entry at position ``p - 1 - a`` and its off-diagonal",
        "    entries leftwards, weighted by ``1 / G[c, a * W]`` (a row never reached is",
        "    skipped). Returns what the rotations leave of them.",
        '    """',
        "    first = np.uint64(first)",
        "    sse = 0.0",
    ]
    for a in range(p):
        o = a * width
        lines += [
            f"    big_w = G[c, {o}]",
            "    if big_w < unreached:",
        ]
        for pos in range(p + 1):
            k = p - 1 - a - pos  # the entry's distance from the unit entry
            value = "1.0" if k == 0 else (f"G[c, {o + k}]" if 0 < k <= p else "0.0")
            lines.append(f"{ind}h{pos} = {value}")
        lines += [f"{ind}y{k} = G[c, {o + p + 1 + k}]" for k in range(d)]
        for i in range(p):
            lines += rotation_lines(p, d, i, ind)
        left_over = " + ".join(f"y{k} * y{k}" for k in range(d))
        lines.append(f"{ind}sse += ({left_over}) / big_w")
    lines.append("    return sse")
    return "\n".join(lines) + "\n"


def _dispatch(name: str, params: str, doc: str) -> list[str]:
    """``name``: the loop of the right degree and dimension."""
    lines = ["@njit(cache=True, inline='always')", f"def {name}(p, d, {params}):",
             f'    """{doc}"""']
    first = True
    for p in range(1, MAX_DEGREE + 1):
        for d in range(1, MAX_DIMENSION + 1):
            keyword = "if" if first else "elif"
            first = False
            call = textwrap.wrap(f"return {name}_p{p}_d{d}({params})", 88,
                                 subsequent_indent=" " * (len(name) + 19))
            lines += [f"    {keyword} p == {p} and d == {d}:", *(" " * 8 + c for c in call)]
    return [*lines, "    raise ValueError('degree 1-5 and dimension 1-3 only')"]


def render_dispatch() -> str:
    """Source of ``window`` and ``sweep``: the loops of the right degree and dimension."""
    window = _dispatch("window", "u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, "
                       "spans", "``window_p{p}_d{d}`` for the given degree and dimension.")
    sweep = _dispatch("sweep", "u, q, t, iv, last, bounds, blocks, st, S, Ssse, Scol, colsum, "
                      "basis, spans", "``sweep_p{p}_d{d}`` for the given degree and dimension.")
    absorb = _dispatch("absorb", "st, first, G, c, unreached",
                       "``absorb_p{p}_d{d}`` for the given degree and dimension.")
    return "\n\n\n".join("\n".join(f) for f in (window, sweep, absorb)) + "\n"


def render() -> str:
    """The whole generated module."""
    parts = [HEADER]
    for p in range(1, MAX_DEGREE + 1):
        for d in range(1, MAX_DIMENSION + 1):
            parts.append("\n" + render_window(p, d))
            parts.append("\n" + render_sweep(p, d))
            parts.append("\n" + render_absorb(p, d))
    parts.append("\n" + render_dispatch())
    return "\n".join(parts)


if __name__ == "__main__":
    write(TARGET, render())
