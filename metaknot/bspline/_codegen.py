"""Renders ``_rows.py``: the row loop of the least-squares kernel, one function per degree.

The row loop (basis functions of a data point, then square-root-free Givens rotations of its
row into the triangular factor) is the evaluator's hot spot. Written once per degree with every
basis value and row entry in a local variable, it runs about twice as fast as the same loop over
small arrays, which the compiler must reload after every store. The generated file is committed;
``python -m metaknot.bspline._codegen`` rewrites it and a test checks it is current.
"""

from __future__ import annotations

from pathlib import Path

MAX_DEGREE = 5
TARGET = Path(__file__).with_name("_rows.py")

HEADER = '''"""Row loops of the least-squares kernel, one per degree. GENERATED: do not edit.

Rendered by ``python -m metaknot.bspline._codegen``; see that module and ``_kernel._solve``.
"""

import numpy as np
from numba import njit

'''


def _basis_lines(p: int, indent: str) -> list[str]:
    """De Boor-Cox (NURBS Book A2.2) unrolled: values h0..hp of the non-zero basis functions.

    The denominators ``t[lo + j] - t[lo]`` depend on the knots only; their reciprocals come from
    the table ``iv`` (``iv[lo * p + j - 1]``), so the loop does no division.
    """
    lines = []
    for j in range(1, p + 1):
        knot = f"t[span - {j - 1}]" if j > 1 else "t[span]"
        lines.append(f"{indent}l{j} = x - {knot}")
        lines.append(f"{indent}r{j} = t[span + {j}] - x")
    prev = ["1.0"]
    for j in range(1, p + 1):
        cur = []
        saved = None
        for r in range(j):
            # 1 / (t[lo + j] - t[lo]) with lo = span + 1 - j + r, precomputed per knot vector
            lo = f"(span - {j - r - 1})" if j - r - 1 else "span"
            factor = "" if prev[r] == "1.0" else f"{prev[r]} * "
            lines.append(f"{indent}tmp = {factor}iv[{lo} * {p} + {j - 1}]")
            name = f"b{j}_{r}" if j < p else f"h{r}"
            term = f"r{r + 1} * tmp"
            lines.append(f"{indent}{name} = {term}" if saved is None
                         else f"{indent}{name} = {saved} + {term}")
            lines.append(f"{indent}s{j}_{r} = l{j - r} * tmp")
            saved = f"s{j}_{r}"
            cur.append(name)
        name = f"b{j}_{j}" if j < p else f"h{j}"
        lines.append(f"{indent}{name} = {saved}")
        cur.append(name)
        prev = cur
    return lines


def _rotation_lines(p: int, i: int, indent: str) -> list[str]:
    """Rotate the row's entry ``h{i}`` (column ``first + i``) into the factor."""
    rest = range(i + 1, p + 1)
    out = [
        f"{indent}if not absorbed and h{i} != 0.0:",
        f"{indent}    col = first + {i}",
        f"{indent}    di = dinv[col]",
        f"{indent}    if di == np.inf:",
        f"{indent}        ix = 1.0 / h{i}",
        f"{indent}        dinv[col] = big_w * ix * ix",
        f"{indent}        for k in range(d):",
        f"{indent}            z[col, k] = rhs[k] * ix",
    ]
    out += [f"{indent}        rb[col, {a - i}] = h{a} * ix" for a in rest]
    out += [
        f"{indent}        absorbed = True",
        f"{indent}    else:",
        f"{indent}        bw = big_w + h{i} * h{i} * di",
        f"{indent}        inv = 1.0 / bw",
        f"{indent}        cb = big_w * inv",
        f"{indent}        sb = h{i} * di * inv",
        f"{indent}        dinv[col] = di * cb",
        f"{indent}        for k in range(d):",
        f"{indent}            zk = z[col, k]",
        f"{indent}            yk = rhs[k]",
        f"{indent}            z[col, k] = cb * zk + sb * yk",
        f"{indent}            rhs[k] = yk - h{i} * zk",
    ]
    for a in rest:
        out += [
            f"{indent}        ra = rb[col, {a - i}]",
            f"{indent}        rb[col, {a - i}] = cb * ra + sb * h{a}",
            f"{indent}        h{a} = h{a} - h{i} * ra",
        ]
    out.append(f"{indent}        big_w = bw")
    return out


def render_rows(p: int) -> str:
    """Source of ``rows_p{p}``."""
    ind = " " * 8
    lines = [
        "@njit(cache=True)",
        f"def rows_p{p}(u, q, t, iv, n, rb, dinv, z, basis, spans):",
        f'    """Rotate every data row into the factor (degree {p}); return the residual SSE."""',
        "    m, d = q.shape",
        "    store = basis.shape[0] > 0",
        "    rhs = np.empty(d)",
        f"    span = {p}",
        "    sse = 0.0",
        "    for j in range(m):",
        "        x = u[j]",
        "        while span < n - 1 and t[span + 1] <= x:",
        "            span += 1",
    ]
    lines += _basis_lines(p, ind)
    lines += [
        "        if store:",
        "            spans[j] = span",
        *[f"            basis[j, {i}] = h{i}" for i in range(p + 1)],
        "        for k in range(d):",
        "            rhs[k] = q[j, k]",
        f"        first = span - {p}",
        "        big_w = 1.0",
        "        absorbed = False",
    ]
    for i in range(p + 1):
        lines += _rotation_lines(p, i, ind)
    lines += [
        "        if not absorbed:",
        "            # what the rotations leave of the row, with its weight, is its residual",
        "            left_over = 0.0",
        "            for k in range(d):",
        "                left_over += rhs[k] * rhs[k]",
        "            sse += left_over / big_w",
        "    return sse",
    ]
    return "\n".join(lines) + "\n"


def render() -> str:
    """Source of the whole generated module."""
    body = "\n\n".join(render_rows(p) for p in range(1, MAX_DEGREE + 1))
    dispatch = [
        "@njit(cache=True)",
        "def rows(u, q, t, iv, p, n, rb, dinv, z, basis, spans):",
        '    """Dispatch on the degree."""',
    ]
    for p in range(1, MAX_DEGREE + 1):
        kw = "if" if p == 1 else "elif"
        dispatch += [f"    {kw} p == {p}:",
                     f"        return rows_p{p}(u, q, t, iv, n, rb, dinv, z, basis, spans)"]
    dispatch += ["    return np.nan"]
    return HEADER + "\n" + body + "\n\n" + "\n".join(dispatch) + "\n"


if __name__ == "__main__":
    TARGET.write_text(render())
    print(f"wrote {TARGET}")
