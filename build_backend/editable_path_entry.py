"""The path entry of an editable install of metaknot: finds the checkout's top-level packages.

The editable wheel installs this module with ``PACKAGES`` filled in, and a ``.pth`` file that
calls :func:`install` at start-up: a path hook, and an entry at the end of ``sys.path`` that only
this hook accepts. Python's path-based finder asks every entry in turn; a regular package found
at this one wins over a namespace portion found earlier (a folder ``metaknot`` without
``__init__.py`` in the working directory), and a regular ``metaknot`` earlier on the path wins
over this one. Subpackages installed from other folders (``metaknot.problems``, ...) are found by
setuptools' editable finder, as before.
"""

from __future__ import annotations

import sys
from importlib.machinery import ModuleSpec
from importlib.util import spec_from_file_location
from pathlib import Path

#: top-level package -> its folder in the checkout (filled in when the wheel is built)
PACKAGES: dict[str, str] = {}
#: the entry this module adds to ``sys.path``: no folder, only the hook below accepts it
PATH_ENTRY = f"{__name__}.__path_entry__"


class PackageFinder:
    """Path entry finder of the top-level packages in ``PACKAGES``."""

    @classmethod
    def hook(cls, entry: str) -> type[PackageFinder]:
        """The path hook: this finder for :data:`PATH_ENTRY`, ``ImportError`` for others.

        Parameters
        ----------
        entry
            An entry of ``sys.path``.

        Returns
        -------
        type
            This finder.
        """
        if entry != PATH_ENTRY:
            raise ImportError(f"not {PATH_ENTRY}")
        return cls

    @classmethod
    def find_spec(cls, fullname: str, target: object = None) -> ModuleSpec | None:
        """The spec of a regular package of ``PACKAGES``, else None.

        Parameters
        ----------
        fullname
            The module's full name.
        target
            Unused (a module being reloaded).

        Returns
        -------
        ModuleSpec or None
            The package's spec from its ``__init__.py``; None for any other name, or when the
            checkout's folder has no ``__init__.py`` any more.
        """
        folder = PACKAGES.get(fullname)
        if folder is None:
            return None
        init = Path(folder, "__init__.py")
        return spec_from_file_location(fullname, init) if init.is_file() else None

    @classmethod
    def invalidate_caches(cls) -> None:
        """Nothing is cached."""


def install() -> None:
    """Add the path hook and the path entry (once)."""
    if PackageFinder.hook not in sys.path_hooks:
        sys.path_hooks.append(PackageFinder.hook)
    if PATH_ENTRY not in sys.path:
        sys.path.append(PATH_ENTRY)
