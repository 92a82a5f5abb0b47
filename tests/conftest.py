"""Suite-wide settings."""

from __future__ import annotations

import numba
import pytest


@pytest.fixture(autouse=True, scope="session")
def _one_numba_thread():
    """Run the batched evaluator on one thread during the tests.

    The suite runs in two pytest-xdist workers on two cores; numba's worker threads spin after
    each parallel region and starve the other worker and numpy's BLAS (the SVD-based references
    slow down tenfold). Results do not depend on the number of threads, which
    ``test_results_do_not_depend_on_threads`` checks with every thread enabled.
    """
    old = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(old)
