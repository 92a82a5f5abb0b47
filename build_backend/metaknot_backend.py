"""The build backend: setuptools' own, with one addition to the editable install.

``pyproject.toml`` installs folders of the repository under other names (``problems/`` as
``metaknot.problems``, ...), so setuptools installs ``pip install -e .`` through an import hook
on ``sys.meta_path``, after Python's path-based finder. That finder takes a folder named
``metaknot`` without ``__init__.py`` in the script's folder (or the working directory), such as
a clone of the repository seen from the folder that holds it, for a portion of a namespace
package; finding no regular package ``metaknot`` on ``sys.path``, it returns the namespace, and
the hook is never asked: ``import metaknot`` gives an empty module (``metaknot.minimize`` is
missing).

The editable wheel built here also holds a path entry at the end of ``sys.path`` whose finder
returns the checkout's regular package ``metaknot`` (``editable_path_entry.py``). A regular
package anywhere on the path wins over namespace portions, as an installed wheel's does, and a
regular ``metaknot`` earlier on the path (the checkout itself, from its root) still comes
first. Every other hook is setuptools' own.
"""

from __future__ import annotations

import base64
import hashlib
import os
import re
import tomllib
import warnings
import zipfile
from pathlib import Path

from setuptools import build_meta as _setuptools
from setuptools.build_meta import (
    build_sdist,
    build_wheel,
    get_requires_for_build_editable,
    get_requires_for_build_sdist,
    get_requires_for_build_wheel,
    prepare_metadata_for_build_editable,
    prepare_metadata_for_build_wheel,
)

__all__ = ["build_editable", "build_sdist", "build_wheel", "get_requires_for_build_editable",
           "get_requires_for_build_sdist", "get_requires_for_build_wheel",
           "prepare_metadata_for_build_editable", "prepare_metadata_for_build_wheel"]

TEMPLATE = Path(__file__).resolve().with_name("editable_path_entry.py")
PLACEHOLDER = "PACKAGES: dict[str, str] = {}"


def build_editable(wheel_directory: str,
                   config_settings: dict[str, str | list[str]] | None = None,
                   metadata_directory: str | None = None) -> str:
    """setuptools' editable wheel, with the path entry of the top-level packages added.

    Parameters
    ----------
    wheel_directory, config_settings, metadata_directory
        As PEP 660 defines them; the working directory is the project's root.

    Returns
    -------
    str
        The wheel's file name in ``wheel_directory``.
    """
    with warnings.catch_warnings():
        # setuptools' notice that a folder named like the package in the working directory
        # may be imported instead: the path entry added below is what keeps it from that
        warnings.filterwarnings("ignore", message=r"Editable installation\.",
                                category=UserWarning)
        name = str(_setuptools.build_editable(wheel_directory, config_settings,
                                              metadata_directory))
    add_path_entry(Path(wheel_directory) / name, top_level_packages(Path.cwd()))
    return name


def top_level_packages(root: Path) -> dict[str, str]:
    """The project's regular top-level packages and their folders.

    Parameters
    ----------
    root
        The project's root, where ``pyproject.toml`` is.

    Returns
    -------
    dict of str to str
        Package name -> absolute folder, for each undotted name of ``[tool.setuptools]
        packages`` whose folder (``package-dir``, else the name) has an ``__init__.py``.
    """
    config = tomllib.loads((root / "pyproject.toml").read_text(encoding="utf-8"))
    setuptools = config.get("tool", {}).get("setuptools", {})
    folders = setuptools.get("package-dir", {})
    found = {}
    for package in setuptools.get("packages", []):
        if "." in package:
            continue
        folder = root / folders.get(package, os.path.join(folders.get("", ""), package))
        if (folder / "__init__.py").is_file():
            found[package] = str(folder.resolve())
    return found


def add_path_entry(wheel: Path, packages: dict[str, str]) -> None:
    """Add the path entry's module and the ``.pth`` file that installs it to ``wheel``.

    Parameters
    ----------
    wheel
        An editable wheel; rewritten in place, its ``RECORD`` listing the two new files.
    packages
        Top-level package -> folder, as :func:`top_level_packages` gives them.
    """
    with zipfile.ZipFile(wheel) as old:
        members = [(info, old.read(info)) for info in old.infolist()]
    record = next(info.filename for info, _ in members
                  if re.fullmatch(r"[^/]+\.dist-info/RECORD", info.filename))
    stem = record.split("/")[0].removesuffix(".dist-info")  # name-version
    module = "__editable___" + re.sub(r"\W", "_", stem) + "_path_entry"
    template = TEMPLATE.read_text(encoding="utf-8")
    if template.count(PLACEHOLDER) != 1:
        raise RuntimeError(f"{TEMPLATE} has no line {PLACEHOLDER!r}")
    source = template.replace(PLACEHOLDER, f"PACKAGES: dict[str, str] = {packages!r}")
    added = {f"{module}.py": source.encode(),
             f"__editable__.{stem}.path-entry.pth": f"import {module}; {module}.install()\n"
                                                   .encode()}
    listed = next(data for info, data in members if info.filename == record)
    rows = [line for line in listed.decode().splitlines()
            if line and not line.startswith(f"{record},")]
    rows += [f"{path},sha256={_digest(data)},{len(data)}" for path, data in added.items()]
    rows.append(f"{record},,")
    partial = wheel.with_name(wheel.name + ".partial")
    with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as new:
        for info, data in members:
            if info.filename != record:
                new.writestr(info, data)
        for path, data in added.items():
            new.writestr(path, data)
        new.writestr(record, "\n".join(rows) + "\n")
    partial.replace(wheel)


def _digest(data: bytes) -> str:
    """A file's hash as ``RECORD`` writes it (urlsafe base64 without padding)."""
    return base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
