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



def pytest_configure(config: pytest.Config) -> None:
    """``--dist loadgroup`` keeps each ``xdist_group`` (a module's shared study, the one
    PostgreSQL database) on one worker, by a suffix on the test ids that pytest 9.2 no longer
    lets pytest-xdist add (pytest-xdist#1386): stop there rather than split the groups."""
    if config.getoption("dist", "no") != "loadgroup":
        return
    version = tuple(int(part) for part in pytest.__version__.split(".")[:2] if part.isdigit())
    if version >= (9, 2):
        raise pytest.UsageError(
            f"pytest {pytest.__version__} breaks --dist loadgroup (pytest-xdist#1386): the "
            "tests' groups would be split between workers; install pytest<9.2 "
            "(pip install -e '.[dev]')")
