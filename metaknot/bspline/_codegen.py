"""Renders the generated row loops: ``_rows.py``, the row loop of the least-squares kernel, and
``_moves_rows.py``, that of delta evaluation; one function per degree and dimension.

The row loop (basis functions of a data point, then square-root-free Givens rotations of its
row into the triangular factor) is the evaluator's hot spot. Written once per degree and
dimension with every basis value, row entry and right-hand side in a local variable, it runs
several times faster than the same loop over small arrays, which the compiler must reload after
every store. The loop is written to compile to straight-line code: branches on the data (does
the span advance, is the column new, is the entry zero) follow the knot vector, which the branch
predictor cannot guess:

* the state of the factor is one flat array, ``W = 1 + p + d`` entries per column: the
  reciprocal weight ``dinv``, the ``p`` off-diagonal entries of the unit upper triangular
  factor, the ``d`` right-hand sides; indices are unsigned, so no negative-index wraparound is
  generated for them, and divisions carry no zero check (``error_model='numpy'``);
* an empty column of the factor holds ``dinv = EMPTY`` (huge, finite) rather than infinity, so
  the first row rotated into it needs no branch of its own: with ``h`` the row's entry and
  ``big_w`` its reciprocal weight, the rotation replaces the column by the row scaled to a unit
  leading entry, up to a relative ``big_w / (h**2 * EMPTY)``, and leaves the row with the
  reciprocal weight ``h**2 * EMPTY``, so what it carries on is negligible. Entries that are
  exactly zero are rotated too (as no-ops, up to rounding);
* the span of a data point advances by one without a branch (a second step, rarely taken, only
  where a knot span holds no data);
* the Schoenberg-Whitney conditions are checked on the way, by the greedy matching of data
  points to basis functions (in data order, each point to the first unmatched function whose
  open support holds it), from the span of each data point;
* no fast-math flags: the multiply-adds of the rotations and of the basis recurrence are
  written as ``fma`` (LLVM's fused multiply-add, an intrinsic rendered into the header), which
  gives the same bits wherever it is inlined (``docs/internals/kernel.md`` says why).

Back substitution and the pass of the conditioning bound are generated too, with the band's
last values in locals. A column never reached keeps ``dinv = EMPTY`` and fails the ``RCOND``
test, as an infinite one did.

*Delta evaluation* (``_moves_rows.py``, for :mod:`metaknot.bspline._moves`) has the same
loops over other rows, on the same templates, adding the column sums of the rows' basis values
(the conditioning certificate needs them) and, with ``store``, keeping the basis values and
spans: ``window_p{p}_d{d}`` (the rows of a move's changed spans under the candidate's knots),
``sweep_p{p}_d{d}`` (every row, saving a state at given row boundaries), ``absorb_p{p}_d{d}``
(a backward state's rows into a merged factor) and ``frame_p{p}_d{d}`` (a sweep of a closed
frame, the wrap-around columns carried along).

The generated files are committed; ``python -m metaknot.bspline._codegen`` rewrites both and a
test checks they are current.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

MAX_DEGREE = 5
MAX_DIMENSION = 3
TARGET = Path(__file__).with_name("_rows.py")

HEADER = '''"""Row loops of the least-squares kernel, by degree, dimension. GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._codegen``; see that module and ``_kernel._solve_into``.
"""

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

# An empty column of the factor: its reciprocal weight (see _codegen).
EMPTY = 1e150


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (IEEE fused multiply-add), the same bits wherever inlined."""
    def codegen(context, builder, signature, args):
        return builder.fma(*args)
    return types.float64(types.float64, types.float64, types.float64), codegen


{constants}
'''


def _basis_lines(p: int, indent: str) -> list[str]:
    """De Boor-Cox (NURBS Book A2.2) unrolled: values h0..hp of the non-zero basis functions.

    The denominators ``t[lo + j] - t[lo]`` depend on the knots only; their reciprocals come from
    the table ``iv`` (``iv[(j - 1) * t.size + lo]``, see ``_kernel.reciprocals``), so the
    loop does no division.
    """
    lines = []
    for j in range(1, p + 1):
        knot = f"t[span - U{j - 1}]" if j > 1 else "t[span]"
        lines.append(f"{indent}l{j} = x - {knot}")
        lines.append(f"{indent}r{j} = t[span + U{j}] - x")
    prev = ["1.0"]
    for j in range(1, p + 1):
        cur = []
        saved = None
        for r in range(j):
            # 1 / (t[lo + j] - t[lo]) with lo = span + 1 - j + r, precomputed per knot vector
            lo = f"span - U{j - r - 1}" if j - r - 1 else "span"
            index = f"{lo} + o{j}" if j > 1 else lo
            factor = "" if prev[r] == "1.0" else f"{prev[r]} * "
            lines.append(f"{indent}tmp = {factor}iv[{index}]")
            name = f"b{j}_{r}" if j < p else f"h{r}"
            lines.append(f"{indent}{name} = r{r + 1} * tmp" if saved is None
                         else f"{indent}{name} = fma(r{r + 1}, tmp, {saved})")
            lines.append(f"{indent}s{j}_{r} = l{j - r} * tmp")
            saved = f"s{j}_{r}"
            cur.append(name)
        name = f"b{j}_{j}" if j < p else f"h{j}"
        lines.append(f"{indent}{name} = {saved}")
        cur.append(name)
        prev = cur
    return lines


def _givens_lines(array: str, offset: str, pivot: str, entries: list[tuple[str, str]],
                  rhs: list[tuple[str, str]], indent: str) -> list[str]:
    """Rotate the row's entry ``pivot`` into the column of the flat factor ``array`` that starts
    at ``offset`` (its reciprocal weight, then its entries): each of the row's later
    ``entries`` and right-hand sides ``rhs`` is a variable and its slot in the column.

    With ``big_w = 1 / w`` the row's reciprocal weight and ``di`` the column's, the new
    reciprocal weights are ``bw`` (row) and ``di * cb`` (column); the only division is off the
    chain from one row to the next in the same column.
    """
    out = [
        f"{indent}o = {offset}",
        f"{indent}di = {array}[o]",
        f"{indent}hd = {pivot} * di",
        f"{indent}bw = fma({pivot}, hd, big_w)",
        f"{indent}inv = 1.0 / bw",
        f"{indent}cb = big_w * inv",
        f"{indent}sb = hd * inv",
        f"{indent}{array}[o] = di * cb",
    ]
    for (name, slot), old in [*((e, "ra") for e in entries), *((e, "zk") for e in rhs)]:
        out += [
            f"{indent}{old} = {array}[o + {slot}]",
            f"{indent}{array}[o + {slot}] = fma(cb, {old}, sb * {name})",
            f"{indent}{name} = fma(-{pivot}, {old}, {name})",
        ]
    out.append(f"{indent}big_w = bw")
    return out


def _rotation_lines(p: int, d: int, i: int, indent: str) -> list[str]:
    """Rotate the row's entry ``h{i}`` (column ``first + i``) into the factor (``W = 1 + p + d``
    entries per column)."""
    return _givens_lines("st", f"(first + U{i}) * U{1 + p + d}", f"h{i}",
                         [(f"h{a}", f"U{a - i}") for a in range(i + 1, p + 1)],
                         [(f"y{k}", f"U{p + 1 + k}") for k in range(d)], indent)


def _triangle_lines(p: int, d: int, indent: str) -> list[str]:
    """Rotate what the band left of a row of a closed frame (its entries ``y0..y{p-1}`` in the
    wrap-around columns, right-hand side ``y{p}..``) into the wrap triangle ``tri`` (``p``
    columns of ``1 + p + d`` entries, the layout of ``_kernel.rotate_dense``)."""
    out = []
    for i in range(p):
        out += _givens_lines("tri", f"np.uint64({i * (1 + p + d)})", f"y{i}",
                             [(f"y{i + a}", f"U{a}") for a in range(1, p - i)],
                             [(f"y{p + k}", f"U{p + 1 + k}") for k in range(d)], indent)
    return out


def _row_rotation_lines(p: int, d: int, indent: str, wrap: bool = False) -> list[str]:
    """Rotate data row ``j`` (entries ``h0..hp`` from column ``first``, right-hand side
    ``q[j]``, weight 1) into the factor and add what is left of it to ``sse``. With ``wrap``, a
    row of a closed frame: the ``p`` wrap-around columns are carried as more right-hand sides
    (``y0..y{p-1}``, zero at first, before ``q[j]``'s) and what the band leaves of them is
    rotated into the wrap triangle ``tri`` (:func:`_triangle_lines`)."""
    w = p if wrap else 0
    lines = [*[f"{indent}y{k} = 0.0" for k in range(w)],
             *[f"{indent}y{w + k} = q[j, {k}]" for k in range(d)], f"{indent}big_w = 1.0"]
    for i in range(p + 1):
        lines += _rotation_lines(p, w + d, i, indent)
    if wrap:
        lines += _triangle_lines(p, d, indent)
    left_over = " + ".join(f"y{w + k} * y{w + k}" for k in range(d))
    return [*lines,
            f"{indent}# what the rotations leave of the row, with its weight, is its residual",
            f"{indent}sse += ({left_over}) / big_w"]


def render_rows(p: int, d: int) -> str:
    """Source of ``rows_p{p}_d{d}``."""
    ind = " " * 8
    lines = [
        "@njit(cache=True, error_model='numpy')",
        f"def rows_p{p}_d{d}(u, q, t, iv, n, st, basis, spans):",
        f'    """Rotate every data row into the factor (degree {p}, dimension {d}).',
        "",
        "    Return the residual SSE and whether the Schoenberg-Whitney conditions hold.",
        '    """',
        "    m = q.shape[0]",
        "    store = basis.shape[0] > 0",
        "    last = np.uint64(n - 1)",
        *[f"    o{j} = np.uint64({j - 1} * t.size)" for j in range(2, p + 1)],
        f"    span = U{p}",
        "    sse = 0.0",
        "    # greedy matching: data points so far matched to basis functions 0..matched - 1",
        "    matched = U0",
        "    before_last = U0",
        "    unmatched = False",
        "    for j in range(m):",
        "        x = u[j]",
        "        step = (t[span + U1] <= x) & (span < last)",
        "        span = span + U1 if step else span",
        "        while t[span + U1] <= x and span < last:",
        "            span += U1",
    ]
    lines += _basis_lines(p, ind)
    lines += [
        f"        first = span - U{p}",
        "        # x lies inside the support of basis functions first..span, but not of span",
        "        # itself at its left end (x == t[span]); the last point belongs to the last one",
        "        before_last = matched",
        "        unmatched |= matched < first",
        "        hi = span - U1 if l1 == 0.0 else span",
        "        matched = matched + U1 if matched <= hi else matched",
        "        if store:",
        "            spans[j] = span",
        *[f"            basis[j, {i}] = h{i}" for i in range(p + 1)],
    ]
    lines += _row_rotation_lines(p, d, ind)
    lines += [
        "    ok = not unmatched and matched == last + U1 and before_last >= last",
        "    return sse, ok",
    ]
    return "\n".join(lines) + "\n"


def render_back(p: int, d: int) -> str:
    """Source of ``back_p{p}_d{d}``: back substitution with the last ``p`` solutions in locals.

    Entries of ``rb`` beyond the last column are zero (no row reaches them) and the locals start
    at zero, so every row does the same operations.
    """
    width = 1 + p + d
    lines = [
        "@njit(cache=True)",
        f"def back_p{p}_d{d}(st, n, coef):",
        f'    """Control points from the factor (degree {p}, dimension {d})."""',
        *[f"    c{a}_{k} = 0.0" for k in range(d) for a in range(1, p + 1)],
        "    for i in range(n - 1, -1, -1):",
        f"        o = np.uint64(i) * U{width}",
        *[f"        r{a} = st[o + U{a}]" for a in range(1, p + 1)],
    ]
    for k in range(d):
        # nearest neighbour last: the chain from one control point to the next is short
        terms = "".join(f" - r{a} * c{a}_{k}" for a in range(p, 0, -1))
        lines.append(f"        v{k} = st[o + U{p + 1 + k}]{terms}")
        lines.append(f"        coef[i, {k}] = v{k}")
        lines += [f"        c{a}_{k} = c{a - 1}_{k}" for a in range(p, 1, -1)]
        lines.append(f"        c1_{k} = v{k}")
    return "\n".join(lines) + "\n"


def render_deviation(p: int, d: int) -> str:
    """Source of ``deviation_p{p}_d{d}``: the maximum-deviation pass over the stored bases.

    The operations of the plain loop over basis functions and coordinates, in its order.
    """
    lines = [
        "@njit(cache=True)",
        f"def deviation_p{p}_d{d}(q, coef, basis, spans):",
        f'    """Largest distance of a data point to its fitted point (degree {p}, dimension {d}).'
        '"""',
        "    worst = 0.0",
        "    for j in range(q.shape[0]):",
        f"        first = np.uint64(spans[j]) - U{p}",
        *[f"        b{i} = basis[j, {i}]" for i in range(p + 1)],
        "        dist2 = 0.0",
    ]
    for k in range(d):
        lines.append("        acc = 0.0")
        lines += [f"        acc += b{i} * coef[first + U{i}, {k}]" for i in range(p + 1)]
        lines += [f"        diff = q[j, {k}] - acc",
                  "        dist2 += diff * diff"]
    lines += ["        worst = max(worst, dist2)",
              "    return np.sqrt(worst)"]
    return "\n".join(lines) + "\n"


def render_bound(p: int) -> str:
    """Source of ``bound_p{p}``: one backward pass over the factor for ``_kernel._bound_from``.

    Returns the smallest and largest ``dinv``, the largest row sum of ``|rb|`` and the largest
    entry of ``M^-1 e``, in the order of operations of a loop over the band (the locals standing
    for entries past the last column are zero, as are those entries of ``rb``), with no
    contraction, so the verdicts are those of the plain loop.
    """
    lines = [
        "@njit(cache=True)",
        f"def bound_p{p}(st, width, n):",
        f'    """Extremes of dinv, largest row sum of |rb| and of M^-1 e (degree {p})."""',
        *[f"    v{a} = 0.0" for a in range(1, p + 1)],
        "    smallest = np.inf",
        "    largest = 0.0",
        "    v_max = 0.0",
        "    row_max = 0.0",
        "    w = np.uint64(width)",
        "    for i in range(n - 1, -1, -1):",
        "        o = np.uint64(i) * w",
        "        di = st[o]",
        "        smallest = min(smallest, di)",
        "        largest = max(largest, di)",
        "        acc = 1.0",
        "        row = 1.0",
    ]
    for a in range(p, 0, -1):
        lines += [f"        r = abs(st[o + U{a}])",
                  "        row += r",
                  f"        acc += r * v{a}"]
    lines += [f"        v{a} = v{a - 1}" for a in range(p, 1, -1)]
    lines += ["        v1 = acc",
              "        v_max = max(v_max, acc)",
              "        row_max = max(row_max, row)",
              "    return smallest, largest, row_max, v_max"]
    return "\n".join(lines) + "\n"


def _dispatch(name: str, params: str, doc: str, fallback: str, inline: bool = False,
              by_dimension: bool = True) -> list[str]:
    """Source of ``name``: a call of the generated ``{name}_p{p}_d{d}`` (``_p{p}`` unless
    ``by_dimension``) of the degree ``p`` and dimension ``d`` among ``params`` (``d`` read from
    the points, ``coef`` for ``back``, where ``params`` lacks it), else the line ``fallback``."""
    args = params.split(", ")
    inner = ", ".join(arg for arg in args if arg not in ("p", "d"))
    lines = ["@njit(cache=True, inline='always')" if inline else "@njit(cache=True)",
             *textwrap.wrap(f"def {name}({params}):", 96, subsequent_indent=" " * (len(name) + 5)),
             f'    """{doc}"""']
    if by_dimension and "d" not in args:
        lines.append("    d = coef.shape[1]" if name == "back" else "    d = q.shape[1]")
    keyword = "if"
    for p in range(1, MAX_DEGREE + 1):
        for d in (range(1, MAX_DIMENSION + 1) if by_dimension else [None]):
            cond, suffix = (f"p == {p} and d == {d}", f"_p{p}_d{d}") if by_dimension else \
                (f"p == {p}", f"_p{p}")
            call = textwrap.wrap(f"return {name}{suffix}({inner})", 88,
                                 subsequent_indent=" " * (len(name) + 19))
            lines += [f"    {keyword} {cond}:", *(" " * 8 + c for c in call)]
            keyword = "elif"
    return [*lines, f"    {fallback}"]


def render() -> str:
    """Source of the whole generated module."""
    constants = "\n".join(f"U{k} = np.uint64({k})"
                          for k in range(MAX_DEGREE + MAX_DIMENSION + 2))
    body = "\n\n".join(
        [render_rows(p, d) for p in range(1, MAX_DEGREE + 1) for d in range(1, MAX_DIMENSION + 1)]
        + [render_back(p, d) for p in range(1, MAX_DEGREE + 1)
           for d in range(1, MAX_DIMENSION + 1)]
        + [render_deviation(p, d) for p in range(1, MAX_DEGREE + 1)
           for d in range(1, MAX_DIMENSION + 1)]
        + [render_bound(p) for p in range(1, MAX_DEGREE + 1)])
    dispatch = [
        *_dispatch("rows", "u, q, t, iv, p, n, st, basis, spans",
                   "Dispatch on the degree and dimension: (SSE, Schoenberg-Whitney holds).",
                   "return np.nan, False"),
        "", "",
        *_dispatch("back", "st, p, n, coef", "Dispatch on the degree and dimension.",
                   "return None"),
        "", "",
        *_dispatch("deviation", "q, p, coef, basis, spans",
                   "Dispatch on the degree and dimension.", "return np.nan"),
        "", "",
        *_dispatch("bound", "st, p, width, n", "Dispatch on the degree.",
                   "return np.nan, np.nan, np.nan, np.nan", by_dimension=False),
    ]
    return (HEADER.format(constants=constants) + "\n\n" + body + "\n\n" + "\n".join(dispatch)
            + "\n")

def write(target: Path, source: str) -> None:
    """Write a generated module and drop the package's compiled cache: numba checks only a
    cached function's own file, so a kernel that calls the generated functions would keep their
    old code."""
    target.write_text(source)
    print(f"wrote {target}")
    for cached in target.parent.glob("__pycache__/*.nb[ic]"):
        cached.unlink(missing_ok=True)


MOVES_TARGET = Path(__file__).with_name("_moves_rows.py")

MOVES_HEADER = '''"""Row loops of delta evaluation, by degree and dimension. GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._codegen``; see that module and ``_moves``.
"""

import numpy as np
from numba import njit

from ._rows import EMPTY, U0, U1, U2, U3, U4, U5, U6, U7, U8, U9, fma

__all__ = ["EMPTY", "U0", "U1", "U2", "U3", "U4", "U5", "U6", "U7", "U8", "U9", "fma"]

{constants}
'''


def _row_lines(p: int, d: int, indent: str, first: str, wrap: bool = False) -> list[str]:
    """One data row ``j``: its span (walking up to ``last``), basis values, column sums, the
    stored basis and span (``if store:``), its rotation into ``st`` (with ``wrap``, that of a
    closed frame's row: :func:`_row_rotation_lines`)."""
    return [
        f"{indent}x = u[j]",
        f"{indent}while t[span + U1] <= x and span < last:",
        f"{indent}    span += U1",
        *_basis_lines(p, indent),
        f"{indent}first = {first}",
        *[f"{indent}colsum[first + U{i}] += h{i}" for i in range(p + 1)],
        f"{indent}if store:",
        f"{indent}    spans[j] = span",
        *[f"{indent}    basis[j, {i}] = h{i}" for i in range(p + 1)],
        *_row_rotation_lines(p, d, indent, wrap),
    ]


def render_window(p: int, d: int) -> str:
    """Source of ``window_p{p}_d{d}``."""
    ind = " " * 8
    lines = [
        "@njit(cache=True, error_model='numpy')",
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
        *_row_lines(p, d, ind, f"span - U{p} - col0"),
        "    return sse, span",
    ]
    return "\n".join(lines) + "\n"


def render_sweep(p: int, d: int, wrap: bool = False) -> str:
    """Source of ``sweep_p{p}_d{d}`` (a whole sweep with its saved states) or, with ``wrap``,
    ``frame_p{p}_d{d}`` (the same over a closed frame's rows that touch its band only, the
    wrap-around columns carried along: :func:`_row_lines`)."""
    ind = " " * 12
    width = 1 + p + d + (p if wrap else 0)
    lines = [
        "@njit(cache=True, error_model='numpy')",
        f"def {'frame' if wrap else 'sweep'}_p{p}_d{d}(u, q, t, iv, span, last, bounds, blocks,",
        "                   st, tri, S, T, Ssse, Scol, colsum, basis, spans, sse):",
        f'    """Rotate data rows into the flat factor ``st`` (degree {p}, dimension {d}; spans',
        "    from ``span`` up to ``last``), in steps: before step ``s`` (rows ``bounds[s]..",
        "    bounds[s + 1] - 1``), save the factor's columns ``blocks[s] ..`` (``p`` of them) in",
        "    ``S[s]``, the residual so far (from ``sse``) in ``Ssse[s]`` and those columns' sums",
        "    in ``Scol[s]``; a last state is saved after the last step. If ``basis`` is not",
        "    empty, stores every row's basis values and span. Returns the residual.",
        *(["    The factor has ``W = 1 + 2p + d`` entries per column: reciprocal weight, the",
           "    band's ``p`` entries, the ``p`` wrap-around entries, the right-hand sides; the",
           "    wrap triangle ``tri`` is saved with the states (``T[s]``)."] if wrap else []),
        '    """',
        "    store = basis.shape[0] > 0",
        *[f"    o{j} = np.uint64({j - 1} * t.size)" for j in range(2, p + 1)],
        "    steps = bounds.size - 1",
        "    span = np.uint64(span)",
        "    last = np.uint64(last)",
        "    for s in range(steps + 1):",
        "        b = blocks[s]",
        f"        S[s, :] = st[b * {width} : (b + {p}) * {width}]",
        *([f"        T[s, :] = tri[:{p * (1 + p + d)}]"] if wrap else []),
        "        Ssse[s] = sse",
        *[f"        Scol[s, {a}] = colsum[b + {a}]" for a in range(p)],
        "        if s == steps:",
        "            break",
        "        for j in range(bounds[s], bounds[s + 1]):",
        *_row_lines(p, d, ind, f"span - U{p}", wrap),
        "    return sse",
    ]
    return "\n".join(lines) + "\n"


def render_absorb(p: int, d: int) -> str:
    """Source of ``absorb_p{p}_d{d}``: a backward state's rows into a merged factor."""
    width = 1 + p + d
    ind = " " * 8
    lines = [
        "@njit(cache=True, error_model='numpy')",
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
            lines += _rotation_lines(p, d, i, ind)
        left_over = " + ".join(f"y{k} * y{k}" for k in range(d))
        lines.append(f"{ind}sse += ({left_over}) / big_w")
    lines.append("    return sse")
    return "\n".join(lines) + "\n"


def render_dispatch() -> str:
    """Source of ``window``, ``sweep``, ``absorb`` and ``frame``: the loops of the right degree
    and dimension."""
    params = {"window": "u, q, t, iv, j0, j1, span, last, col0, st, colsum, basis, spans",
              "sweep": "u, q, t, iv, span, last, bounds, blocks, st, tri, S, T, Ssse, Scol, "
                       "colsum, basis, spans, sse",
              "absorb": "st, first, G, c, unreached"}
    params["frame"] = params["sweep"]
    return "\n\n\n".join("\n".join(_dispatch(
        name, f"p, d, {args}", f"``{name}_p{{p}}_d{{d}}`` for the given degree and dimension.",
        "raise ValueError('degree 1-5 and dimension 1-3 only')", inline=True))
        for name, args in params.items()) + "\n"


def render_moves() -> str:
    """Source of the whole generated module of delta evaluation."""
    # the offsets of a closed frame's wider rows (render_sweep) beyond the kernel's
    constants = "\n".join(f"U{k} = np.uint64({k})"
                           for k in range(MAX_DEGREE + MAX_DIMENSION + 2,
                                          2 * MAX_DEGREE + MAX_DIMENSION + 2))
    parts = [MOVES_HEADER.format(constants=constants)]
    for p in range(1, MAX_DEGREE + 1):
        for d in range(1, MAX_DIMENSION + 1):
            parts.append("\n" + render_window(p, d))
            parts.append("\n" + render_sweep(p, d))
            parts.append("\n" + render_absorb(p, d))
            parts.append("\n" + render_sweep(p, d, wrap=True))
    parts.append("\n" + render_dispatch())
    return "\n".join(parts)



if __name__ == "__main__":
    write(TARGET, render())
    write(MOVES_TARGET, render_moves())
