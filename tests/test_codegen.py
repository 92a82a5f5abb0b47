"""The generated row loops are current and agree with a plain reference implementation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from metaknot.bspline import _codegen, clamped_knot_vector


def test_generated_module_is_current() -> None:
    """``_rows.py`` must be what ``python -m metaknot.bspline._codegen`` writes."""
    assert _codegen.TARGET.read_text() == _codegen.render(), (
        "metaknot/bspline/_rows.py is stale: run `python -m metaknot.bspline._codegen`"
    )


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_generated_basis_matches_scipy(degree: int) -> None:
    """The unrolled basis values stored by the row loop equal scipy's design matrix."""
    from metaknot.bspline import _kernel, _rows

    rng = np.random.default_rng(degree)
    u = np.sort(np.concatenate(([0.0, 1.0], rng.random(40))))
    q = rng.normal(size=(u.size, 2))
    interior = np.sort(rng.choice(u[1:-1], size=8, replace=False))
    t = clamped_knot_vector(u, interior, degree)
    n = t.size - degree - 1
    iv = np.empty(t.size * degree)
    _kernel.reciprocals(t, degree, iv, 0, t.size)
    assert iv[degree] == pytest.approx(1.0 / (t[degree + 1] - t[degree]))
    basis = np.empty((u.size, degree + 1))
    spans = np.empty(u.size, dtype=np.int64)
    st = np.zeros((n, 1 + degree + 2))
    st[:, 0] = _rows.EMPTY
    _, matched = _rows.rows(u, q, t, iv, degree, n, st.ravel(), basis, spans)
    assert matched
    dense = BSpline.design_matrix(u, t, degree).toarray()
    ours = np.zeros_like(dense)
    for j in range(u.size):
        ours[j, spans[j] - degree : spans[j] + 1] = basis[j]
    np.testing.assert_allclose(ours, dense, rtol=1e-13, atol=1e-15)


def _schoenberg_whitney(u: np.ndarray, t: np.ndarray, p: int, n: int) -> bool:
    """Plain reference: match each basis function to the first free data site in its support."""
    j = 0
    for i in range(n):
        while j < u.size and not (u[j] > t[i] or (i == 0 and u[j] >= t[i])):
            j += 1
        if j == u.size:
            return False
        if not (u[j] < t[i + p + 1] or (i == n - 1 and u[j] <= t[i + p + 1])):
            return False
        j += 1
    return True


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_row_loop_matching_is_schoenberg_whitney(degree: int) -> None:
    """The matching done in the row loop agrees with the plain greedy check, on knots at data
    sites, between them, clustered (spans without data) and too many."""
    from metaknot.bspline import _kernel, _rows

    rng = np.random.default_rng(100 + degree)
    verdicts = set()
    for case in range(400):
        m = int(rng.integers(degree + 2, 30))
        u = np.sort(np.concatenate(([0.0, 1.0], rng.random(m - 2))))
        q = rng.normal(size=(m, 1))
        kind = case % 4
        if kind == 0:  # at data sites
            k = int(rng.integers(0, m - 1))
            interior = np.sort(rng.choice(u[1:-1], size=min(k, m - 2), replace=False))
        elif kind == 1:  # anywhere
            interior = np.sort(rng.uniform(0.01, 0.99, size=int(rng.integers(0, m))))
        elif kind == 2:  # clustered
            centre = rng.uniform(0.1, 0.9)
            interior = np.sort(centre + rng.uniform(-0.05, 0.05, size=int(rng.integers(1, m))))
        else:  # exactly at data sites and between
            sites = rng.choice(u[1:-1], size=int(rng.integers(0, m // 2)), replace=False)
            interior = np.sort(np.concatenate((sites, rng.uniform(0.01, 0.99, size=2))))
        interior = np.unique(interior[(interior > 0.0) & (interior < 1.0)])
        t = clamped_knot_vector(u, interior, degree)
        n = t.size - degree - 1
        if n > m:
            continue
        st = np.zeros((n, 1 + degree + 1))
        st[:, 0] = _rows.EMPTY
        iv = np.empty(t.size * degree)
        _kernel.reciprocals(t, degree, iv, 0, t.size)
        _, matched = _rows.rows(u, q, t, iv, degree, n, st.ravel(), np.empty((0, degree + 1)),
                                np.empty(0, np.int64))
        expected = _schoenberg_whitney(u, t, degree, n)
        assert matched == expected, (case, interior)
        verdicts.add(expected)
    assert verdicts == {True, False}


COMPILE_ORDER_SCRIPT = """
import sys
import numpy as np
from metaknot.bspline.curve import make_curve

def scores(moves_first):
    t = np.linspace(0.0, 1.0, 150)
    curve = make_curve(np.c_[np.cos(5 * t), t * np.sin(3 * t)], degree=3)
    if moves_first:
        knots = np.sort(np.random.default_rng(9).uniform(0.05, 0.95, 10))
        curve.move_evaluator(knots).evaluate(knots.copy(), np.array([0, 10]),
                                             max_deviation=True)
    masks = np.random.default_rng(5).random((600, curve.n_points - 2)) < 0.2
    fits = [curve.evaluate_masks(masks[i : i + 16], max_deviation=True)  # on this thread
            for i in range(0, len(masks), 16)]
    return np.concatenate([np.r_[fit.sse, fit.max_deviation] for fit in fits])

if __name__ == "__main__":
    np.save(sys.argv[1], scores(moves_first=True))
"""

@pytest.mark.slow
def test_results_do_not_depend_on_which_kernels_compiled_first(tmp_path) -> None:
    """Batch scores (open curves) are bit for bit the same whether the move evaluator's kernels
    were compiled first, in the same process, or not at all (this process: kernels loaded from
    the cache, or compiled batch first). With fused multiply-adds they were not: whether one
    forms depends on what the compiler inlined, and that on which kernels the process had
    compiled before."""
    import os
    import subprocess
    import sys

    script = tmp_path / "order.py"
    script.write_text(COMPILE_ORDER_SCRIPT)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))  # an empty cache
    out = tmp_path / "moves_first.npy"
    subprocess.run([sys.executable, str(script), str(out)], env=env, check=True, timeout=900)
    namespace: dict = {"__name__": "order"}
    exec(compile(COMPILE_ORDER_SCRIPT, str(script), "exec"), namespace)
    here = namespace["scores"](moves_first=False)
    assert np.isfinite(here).sum() > 0.9 * here.size
    np.testing.assert_array_equal(np.load(out), here)


def test_the_reciprocal_table_fills_only_the_range_asked_for() -> None:
    """``_kernel.reciprocals`` writes ``lo_start <= lo < lo_stop`` only; an empty or negative
    range writes nothing (its unsigned loop bounds must not wrap around)."""
    from metaknot.bspline import _kernel

    t = np.array([0.0, 0.0, 0.25, 0.5, 0.5, 1.0, 1.0])
    iv = np.full(2 * t.size, -1.0)
    _kernel.reciprocals(t, 2, iv, 2, 4)
    written = np.flatnonzero(iv != -1.0)
    assert written.tolist() == [2, 3, t.size + 2, t.size + 3]
    assert iv[2] == 4.0 and iv[3] == 0.0 and iv[t.size + 2] == 4.0
    for start, stop in ((3, 3), (0, -5), (-4, -1)):
        iv[:] = -1.0
        _kernel.reciprocals(t, 2, iv, start, stop)
        assert (iv == -1.0).all()
