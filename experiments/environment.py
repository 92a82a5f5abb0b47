"""Where a run ran: versions of metaknot and its numerical stack, the git commit, the host."""

from __future__ import annotations

import functools
import os
import platform
import subprocess
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

__all__ = ["environment", "git_commit"]


def _version(package: str) -> str | None:
    try:
        return version(package)
    except PackageNotFoundError:
        return None


#: Set by a process that has looked the commit up, so its worker processes need not.
GIT_COMMIT_VARIABLE = "METAKNOT_GIT_COMMIT"


@functools.cache
def git_commit() -> str | None:
    """Commit of the metaknot source checkout (``+dirty`` if it has local changes), or ``None``
    for an installed copy outside a git work tree.

    The answer is also put in the environment variable ``METAKNOT_GIT_COMMIT`` (an empty value
    for ``None``), which child processes (sweep workers) read instead of running git again.
    """
    if GIT_COMMIT_VARIABLE in os.environ:
        return os.environ[GIT_COMMIT_VARIABLE] or None
    commit = _ask_git()
    os.environ[GIT_COMMIT_VARIABLE] = commit or ""
    return commit


def _ask_git() -> str | None:
    here = Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True,
                              text=True, timeout=10, check=True).stdout.strip()
        status = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                                cwd=here, capture_output=True, text=True, timeout=10,
                                check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{head}+dirty" if status else head or None


@functools.cache
def environment() -> dict[str, str | None]:
    """Versions (metaknot, Python, numpy, scipy, numba), git commit and host name."""
    from metaknot import __version__

    return {
        "metaknot_version": __version__,
        "python_version": platform.python_version(),
        "numpy_version": _version("numpy"),
        "scipy_version": _version("scipy"),
        "numba_version": _version("numba"),
        "git_commit": git_commit(),
        "host": platform.node(),
    }
