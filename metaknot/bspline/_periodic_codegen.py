"""Renders ``_periodic_rows.py``: the row loop of the periodic least-squares kernel
(:mod:`metaknot.bspline._periodic_kernel`), one function per degree and dimension.

The loop is the kernel's generic one, operation for operation (the same rotations in the same
order, so the same bits), with every basis value, row entry and right-hand side of a data row in
a local variable instead of small arrays the compiler must reload after every store:

* the basis functions (NURBS Book A2.2 with the reciprocal knot differences looked up, as
  ``_periodic_kernel._basis_table``), unrolled;
* the row's band part as a window of ``p + 1`` locals over the band columns ``first ..
  first + p`` (rotating the row against the factor's row ``col`` leaves its entries right of
  ``col``: the window shifts by one column per rotation), its tail (the ``p`` wrap-around
  columns) and right-hand sides as locals.

The generated file is committed; ``python -m metaknot.bspline._periodic_codegen`` rewrites it
and a test checks it is current.
"""

from __future__ import annotations

from pathlib import Path

#: The degrees and dimensions the loop is generated for (each pair adds about five seconds to
#: the first compile): cubic planar and space outlines. Others run the generic loop.
DEGREES = (3,)
DIMENSIONS = (2, 3)
TARGET = Path(__file__).with_name("_periodic_rows.py")

HEADER = '''"""Row loops of the periodic least-squares kernel, by degree and dimension.
GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._periodic_codegen``; see that module and
``_periodic_kernel.fit_one``.
"""

import math

from numba import njit


@njit(cache=True, inline="always")
def givens_norm(a, b):
    """``sqrt(a^2 + b^2)`` (as ``_periodic_kernel.givens_norm``)."""
    big = max(abs(a), abs(b))
    if 1e-150 < big < 1e150:
        return math.sqrt(a * a + b * b)
    return math.hypot(a, b)
'''


def _rotate(target: str, local: str, indent: str) -> list[str]:
    """Rotate the factor's entry ``target`` and the row's ``local`` by (cs, sn)."""
    return [f"{indent}a = {target}",
            f"{indent}{target} = cs * a + sn * {local}",
            f"{indent}{local} = -sn * a + cs * {local}"]


def _basis_lines(p: int, indent: str) -> list[str]:
    """``_periodic_kernel._basis_table`` unrolled: v0..vp at ``x`` in knot span ``span``."""
    lines = [f"{indent}v0 = 1.0"]
    for j in range(1, p + 1):
        lines += [f"{indent}l{j} = x - t[span - {j - 1}]" if j > 1 else
                  f"{indent}l{j} = x - t[span]",
                  f"{indent}r{j} = t[span + {j}] - x",
                  f"{indent}saved = 0.0",
                  f"{indent}at = {j - 1} * size + span - {j - 1}" if j > 1 else
                  f"{indent}at = span"]
        for r in range(j):
            lines += [f"{indent}temp = v{r} * iv[at + {r}]" if r else
                      f"{indent}temp = v{r} * iv[at]",
                      f"{indent}v{r} = saved + r{r + 1} * temp",
                      f"{indent}saved = l{j - r} * temp"]
        lines.append(f"{indent}v{j} = saved")
    return lines


def render_rows(p: int, d: int) -> str:
    """The row loop for degree ``p`` and dimension ``d``: returns the SSE."""
    i4, i8, i12, i16 = " " * 4, " " * 8, " " * 12, " " * 16
    window = [f"w{s}" for s in range(p + 1)]
    tails = [f"t{k}" for k in range(p)]
    ys = [f"y{c}" for c in range(d)]
    lines = [
        "@njit(cache=True)",
        f"def rows_p{p}_d{d}(u, q, t, iv, m, band, tail, has_tail, rhs, basis, spans, keep):",
        f'{i4}"""Rotate every data row into the factor (degree {p}, dimension {d}); the SSE."""',
        f"{i4}nb = m - {p}",
        *([f"{i4}size = t.size"] if p > 1 else []),
        f"{i4}sse = 0.0",
        f"{i4}j = 0",
        f"{i4}for i in range(u.size):",
        f"{i8}x = u[i]",
        f"{i8}while j < m - 1 and x >= t[{p + 1} + j]:",
        f"{i12}j += 1",
        f"{i8}span = {p} + j",
        *_basis_lines(p, i8),
        f"{i8}if keep:",
        f"{i12}spans[i] = j",
        *[f"{i12}basis[i, {k}] = v{k}" for k in range(p + 1)],
        f"{i8}{' = '.join(window + tails)} = 0.0",
        f"{i8}row_tail = False",
        f"{i8}first = j - {p} if j >= {p} else 0",
    ]
    for k in range(p + 1):  # scatter v_k into the band window or the tail
        lines += [f"{i8}ci = j + {k}" if k else f"{i8}ci = j",
                  f"{i8}if ci >= m:", f"{i12}ci -= m",
                  f"{i8}if ci >= {p}:", f"{i12}s = ci - {p} - first"]
        for s in range(p + 1):
            keyword = "if" if s == 0 else "elif" if s < p else "else"
            test = f" s == {s}:" if s < p else ":"
            lines += [f"{i12}{keyword}{test}", f"{i16}w{s} += v{k}"]
        lines += [f"{i8}else:", f"{i12}row_tail = True"]
        if p == 1:
            lines.append(f"{i12}t0 += v{k}")
        for c in range(p if p > 1 else 0):
            keyword = "if" if c == 0 else "elif" if c < p - 1 else "else"
            test = f" ci == {c}:" if c < p - 1 else ":"
            lines += [f"{i12}{keyword}{test}", f"{i16}t{c} += v{k}"]
    lines += [f"{i8}y{c} = q[i, {c}]" for c in range(d)]
    # the band columns, left to right
    lines += [f"{i8}for s in range({p + 1}):",
              f"{i12}col = first + s",
              f"{i12}if col >= nb:",
              f"{i16}break",
              f"{i12}w = w0",
              f"{i12}if w != 0.0:",
              f"{i16}r0 = band[col, 0]",
              f"{i16}h = givens_norm(r0, w)",
              f"{i16}inv = 1.0 / h",
              f"{i16}cs, sn = r0 * inv, w * inv",
              f"{i16}band[col, 0] = h"]
    for k in range(1, p + 1):
        lines += [f"{i16}if col + {k} < nb:", *_rotate(f"band[col, {k}]", f"w{k}", " " * 20)]
    lines.append(f"{i16}if row_tail or has_tail[col]:")
    for k in range(p):
        lines += _rotate(f"tail[col, {k}]", f"t{k}", " " * 20)
    lines += [f"{' ' * 20}has_tail[col] = True", f"{' ' * 20}row_tail = True"]
    for c in range(d):
        lines += _rotate(f"rhs[col, {c}]", f"y{c}", i16)
    lines.append(f"{i12}{', '.join(window)} = {', '.join([*window[1:], '0.0'])}")
    # then the tail columns against the final triangle
    lines.append(f"{i8}if row_tail:")
    for k in range(p):
        lines += [f"{i12}if t{k} != 0.0:",
                  f"{i16}r = nb + {k}" if k else f"{i16}r = nb",
                  f"{i16}r0 = tail[r, {k}]",
                  f"{i16}h = givens_norm(r0, t{k})",
                  f"{i16}inv = 1.0 / h",
                  f"{i16}cs, sn = r0 * inv, t{k} * inv",
                  f"{i16}tail[r, {k}] = h"]
        for kk in range(k + 1, p):
            lines += _rotate(f"tail[r, {kk}]", f"t{kk}", i16)
        for c in range(d):
            lines += _rotate(f"rhs[r, {c}]", f"y{c}", i16)
    lines += [f"{i8}sse += {y} * {y}" for y in ys]
    lines.append(f"{i4}return sse")
    return "\n".join(lines) + "\n"


def render_dispatch() -> str:
    """``rows``: the generated loop for (p, d), or -1.0 where none is generated."""
    lines = ["@njit(cache=True)",
             "def rows(u, q, t, iv, p, m, band, tail, has_tail, rhs, basis, spans, keep):",
             '    """Dispatch on the degree and dimension: the SSE, or -1.0 (no loop generated for',
             '    them: the caller runs its generic one)."""',
             "    d = q.shape[1]"]
    first = True
    for p in DEGREES:
        for d in DIMENSIONS:
            keyword = "if" if first else "elif"
            first = False
            lines += [f"    {keyword} p == {p} and d == {d}:",
                      f"        return rows_p{p}_d{d}(u, q, t, iv, m, band, tail, has_tail, rhs,"
                      f" basis,", "                            spans, keep)"]
    lines.append("    return -1.0")
    return "\n".join(lines) + "\n"


def render() -> str:
    """Source of the whole generated module."""
    body = "\n\n".join(render_rows(p, d) for p in DEGREES for d in DIMENSIONS)
    return HEADER + "\n\n" + body + "\n\n" + render_dispatch()


if __name__ == "__main__":
    from ._codegen import write

    write(TARGET, render())
