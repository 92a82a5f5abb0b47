"""Ctrl-C and ``kill``: a run or sweep stops cleanly, says what is stored, and exits 130/143.

While :func:`interrupt_on_signals` is active, SIGINT and SIGTERM raise :class:`Interrupted`
in the main thread (a second signal while the first is being handled ends the process at
once). The code that knows what was planned (the sweep, a single run) fills in the counts;
``metaknot run`` prints :meth:`Interrupted.message` and exits with :attr:`Interrupted.exit_code`.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["Interrupted", "interrupt_on_signals", "stop_child_processes"]

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived. A :class:`KeyboardInterrupt`, so that code which cleans up
    after Ctrl-C (joblib stops its workers) does so, and ``except Exception`` lets it pass.

    Attributes
    ----------
    signum
        The signal.
    stopped
        The ids of the child processes (the launcher's workers) stopped on the signal.
    stored, total
        The planned runs that have a complete record, and all planned runs (``None`` until
        the code that planned them fills them in).
    """

    def __init__(self, signum: int, stopped: list[int]) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum
        self.stopped = stopped
        self.stored: int | None = None
        self.total: int | None = None

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
def interrupt_on_signals() -> Iterator[None]:
    """Inside the block, SIGINT and SIGTERM stop the child processes at once (no worker goes
    on computing) and raise :class:`Interrupted` in the main thread."""

    def handler(signum: int, frame: object) -> None:
        for sig in SIGNALS:  # a second signal during the clean-up: stop at once
            signal.signal(sig, lambda s, f: os._exit(128 + s))
        raise Interrupted(signum, stop_child_processes())

    previous = {sig: signal.signal(sig, handler) for sig in SIGNALS}
    try:
        yield
    finally:
        for sig, action in previous.items():
            signal.signal(sig, action)


def stop_child_processes() -> list[int]:
    """SIGKILL every process descended from this one but resource trackers (they clean up
    after the others and end with this process), wait until they are gone, and return their
    ids. Reads ``/proc``; where there is none, nothing is done (joblib still stops its own
    workers on an interrupt)."""
    proc = Path("/proc")
    if not proc.is_dir():
        return []
    parents: dict[int, int] = {}
    for entry in proc.iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue  # ended meanwhile
            parents[int(entry.name)] = int(fields[1])
    children: dict[int, list[int]] = {}
    for pid, parent in parents.items():
        children.setdefault(parent, []).append(pid)
    descendants, todo = [], list(children.get(os.getpid(), []))
    while todo:
        pid = todo.pop()
        todo.extend(children.get(pid, []))
        try:
            if b"resource_tracker" not in (proc / str(pid) / "cmdline").read_bytes():
                descendants.append(pid)
        except OSError:
            pass  # ended meanwhile
    for pid in descendants:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_running(pid) for pid in descendants):
        time.sleep(0.01)
    return descendants


def _running(pid: int) -> bool:
    """True while ``pid`` exists and is not a zombie (killed, waiting to be reaped)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"
