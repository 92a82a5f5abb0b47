"""Ctrl-C and ``kill``: a run or sweep stops cleanly, says what is stored, and exits 130/143.

While :func:`interrupt_on_signals` is active, SIGINT and SIGTERM raise :class:`Interrupted`
in the main thread (a second signal while the first is being handled ends the process at
once). The code that knows what was planned (the sweep, a single run) fills in the counts;
``metaknot run`` prints :meth:`Interrupted.message` and exits with :attr:`Interrupted.exit_code`.
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["Interrupted", "child_processes", "interrupt_on_signals", "interruptible",
           "leave_ctrl_c_to_the_leader", "raise_pending"]

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived. A :class:`KeyboardInterrupt`, so that code which cleans up
    after Ctrl-C (joblib stops its workers) does so, and ``except Exception`` lets it pass.

    Attributes
    ----------
    signum
        The signal.
    workers
        The ids of the child processes (the launcher's workers) when the signal came: they
        are stopped on the way out, and their unfinished temp files removed.
    stored, total
        The planned runs that have a complete record, and all planned runs (``None`` until
        the code that planned them fills them in).
    line
        The line to print, where the code that stopped says it itself (``metaknot tune``:
        the trials the study holds); ``None`` otherwise.
    """

    #: Set in a process once a signal has been turned into this exception.
    raised = False

    def __init__(self, signum: int, workers: list[int]) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum
        self.workers = workers
        self.stored: int | None = None
        self.total: int | None = None
        self.line: str | None = None

    @property
    def exit_code(self) -> int:
        """128 + the signal number, as a shell reports a process a signal ended."""
        return 128 + self.signum

    def message(self) -> str:
        """The one line to print."""
        if self.total is None:
            return "interrupted before any run started; run the same command to start again"
        return (f"interrupted: {self.stored} of {self.total} runs stored; run the same command "
                "to resume")


@contextmanager
def interrupt_on_signals(*, anywhere: bool = True) -> Iterator[None]:
    """Inside the block, SIGINT and SIGTERM raise :class:`Interrupted` in the main thread.

    With ``anywhere=False`` the exception is raised only inside :func:`interruptible` blocks
    (at once) or when the next one begins: code that must not be cut short in the middle (a
    storage's file lock, Optuna's bookkeeping of a trial) runs outside them.

    The workers are not killed here: joblib kills its own on the way out (killing them from
    outside can leave its result pipe half written and the leader waiting on it for ever),
    and idle ones end with this process."""

    def handler(signum: int, frame: object) -> None:
        for sig in SIGNALS:  # a second signal during the clean-up: stop at once
            signal.signal(sig, lambda s, f: os._exit(128 + s))
        Interrupted.raised = True
        _STATE.pending = Interrupted(signum, child_processes())
        if anywhere or _STATE.depth:
            raise_pending()

    previous = {sig: signal.signal(sig, handler) for sig in SIGNALS}
    try:
        yield
    finally:
        _STATE.pending = None
        for sig, action in previous.items():
            signal.signal(sig, action)


class _State:
    """The interrupt a signal left for the next safe point, and how deep in
    :func:`interruptible` blocks the main thread is."""

    pending: Interrupted | None = None
    depth = 0


_STATE = _State()


def raise_pending() -> None:
    """Raise the :class:`Interrupted` a signal left (a safe point); nothing if none did."""
    stop, _STATE.pending = _STATE.pending, None
    if stop is not None:
        raise stop


@contextmanager
def interruptible() -> Iterator[None]:
    """A block a signal may cut short at once (see :func:`interrupt_on_signals`); an interrupt
    left before it begins is raised on entry."""
    raise_pending()
    _STATE.depth += 1
    try:
        yield
    finally:
        _STATE.depth -= 1


def leave_ctrl_c_to_the_leader() -> None:
    """In a launcher's worker process: ignore SIGINT. Ctrl-C reaches every process of the
    terminal's group; the leader alone handles it (joblib kills the workers), and a worker
    would only print a ``KeyboardInterrupt`` traceback. Where SIGINT has a handler other
    than Python's own (the leader's, when the basic launcher runs the jobs in it), nothing
    changes."""
    if threading.current_thread() is threading.main_thread() \
            and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def child_processes() -> list[int]:
    """The ids of the processes descended from this one (the launcher's workers). Reads
    ``/proc``; where there is none, the list is empty."""
    proc = Path("/proc")
    if not proc.is_dir():
        return []
    children: dict[int, list[int]] = {}
    for entry in proc.iterdir():
        if entry.name.isdigit():
            try:
                parent = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError):
                continue  # ended meanwhile
            children.setdefault(parent, []).append(int(entry.name))
    descendants, todo = [], list(children.get(os.getpid(), []))
    while todo:
        pid = todo.pop()
        descendants.append(pid)
        todo.extend(children.get(pid, []))
    return descendants
