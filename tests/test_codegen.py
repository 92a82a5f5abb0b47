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
    iv = _kernel.reciprocal_differences(t, degree)
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
