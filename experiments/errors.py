"""One-line configuration errors: :class:`ConfigError` names the setting it is about.

Hydra prints a ``CompactHydraException`` as its message alone, without a traceback, so a bad
command line is one line.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from hydra.errors import CompactHydraException

__all__ = ["ConfigError", "naming", "short"]


class ConfigError(ValueError, CompactHydraException):
    """A configuration value that cannot work; the message names the key, in one line."""


@contextmanager
def naming(key: str,
           errors: type[Exception] | tuple[type[Exception], ...] = ValueError) -> Iterator[None]:
    """``errors`` raised inside (a library's check of a value) as a :class:`ConfigError` that
    names ``key``."""
    try:
        yield
    except errors as exc:
        raise ConfigError(f"{key}: {exc}") from None


def short(text: str) -> str:
    """``text`` shortened to about 80 characters (user data in messages)."""
    return text if len(text) <= 80 else text[:77] + "..."
