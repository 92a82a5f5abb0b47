"""Griffe extension for the API reference (``mkdocs.yml``): metaknot as it is installed.

Two things the plain loader does not know:

* **The package layout.** ``pyproject.toml`` maps folders of the repository into the package
  (``metaknot.problems`` is ``problems/``, ``metaknot.algorithms`` is ``algorithms/``,
  ``metaknot.experiments`` is ``experiments/``). When ``metaknot`` is loaded, the mapped
  folders are loaded as its subpackages, so the reference shows the names users import.
* **One place per object.** Names a package re-exports (``metaknot.Task`` is
  ``metaknot.task.Task``) are documented once, where they are defined; cross-references to
  either name lead there.
* **Sphinx roles in docstrings.** ``:func:`fit_spline```, ``:class:`~metaknot.Task```,
  ``:mod:`.tables``` and the like become cross-references when they name a public object
  of metaknot (resolved as Python would from where the docstring is: the class, the module,
  the package, then as a full path), and inline code otherwise (private helpers, other
  libraries). ``~`` shows the last part of the name only, as in Sphinx.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

import griffe

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "metaknot"
ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|attr|data|obj|exc|const):`(~?)([^`]+)`")


def mapped_subpackages(root: Path = ROOT) -> dict[str, Path]:
    """Subpackages of metaknot that live in folders of their own: ``{name: folder}``."""
    with open(root / "pyproject.toml", "rb") as file:
        package_dir = tomllib.load(file)["tool"]["setuptools"]["package-dir"]
    return {
        name.removeprefix(f"{PACKAGE}."): root / folder
        for name, folder in package_dir.items()
        if name.startswith(f"{PACKAGE}.") and name.count(".") == 1
    }


def lookup(collection: Any, path: str) -> griffe.Object | None:
    """The object ``path`` names (aliases followed), or None."""
    try:
        found = collection[path]
        return found.final_target if found.is_alias else found
    except (KeyError, ValueError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None


def is_public(obj: griffe.Object) -> bool:
    """Whether the reference renders ``obj``: a metaknot object, no part of its path private
    (``mkdocs.yml`` hides names starting with ``_``)."""
    parts = obj.path.split(".")
    return parts[0] == PACKAGE and not any(part.startswith("_") for part in parts)


def scopes(obj: griffe.Object) -> list[str]:
    """Where a bare name in ``obj``'s docstring is looked up, innermost first."""
    paths = []
    scope: griffe.Object | None = obj if (obj.is_class or obj.is_module) else obj.parent
    while scope is not None:
        paths.append(scope.path)
        scope = scope.parent
    return paths


def relative_base(obj: griffe.Object, dots: int) -> str:
    """The package a relative name with ``dots`` leading dots starts from."""
    module = obj.module
    base = module.path if module.is_init_module else module.path.rpartition(".")[0]
    for _ in range(dots - 1):
        base = base.rpartition(".")[0]
    return base


def resolve(obj: griffe.Object, name: str, collection: Any) -> griffe.Object | None:
    """The public metaknot object ``name`` stands for in ``obj``'s docstring, or None."""
    name = name.strip().removesuffix("()")
    if name.startswith("."):
        dots = len(name) - len(name.lstrip("."))
        candidates = [f"{relative_base(obj, dots)}.{name[dots:]}"]
    else:
        candidates = [f"{scope}.{name}" for scope in scopes(obj)]
        candidates += [name, f"{PACKAGE}.{name}"]
    for path in candidates:
        target = lookup(collection, path)
        if target is not None and is_public(target):
            return target
    return None


def convert_roles(text: str, obj: griffe.Object, collection: Any) -> str:
    """``text`` with its Sphinx roles as cross-references or inline code."""

    def replace(match: re.Match[str]) -> str:
        tilde, name = match.groups()
        shown = name.strip().lstrip(".")
        if tilde:
            shown = shown.rpartition(".")[2]
        target = resolve(obj, name, collection)
        if target is None:
            return f"`{shown}`"
        return f"[`{shown}`][{target.path}]"

    return ROLE.sub(replace, text)


def walk(obj: griffe.Object) -> list[griffe.Object]:
    """``obj`` and every object defined in it (aliases left out)."""
    found = [obj]
    for member in obj.members.values():
        if not member.is_alias:
            found.extend(walk(member))
    return found


class MetaknotLayout(griffe.Extension):
    """Loads the mapped folders as subpackages of metaknot, documents re-exported names where
    they are defined, and converts Sphinx roles."""

    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader,
                   **kwargs: Any) -> None:
        if pkg.name != PACKAGE:
            return
        for name, folder in mapped_subpackages().items():
            if name in pkg.members:
                continue
            module = loader._load_module(name, folder / "__init__.py", parent=pkg)
            pkg.set_member(name, module)
            loader.expand_exports(module)
            loader.expand_wildcards(module, external=False)
        for obj in walk(pkg):
            if obj.is_module:
                for member in obj.members.values():
                    if member.is_alias:
                        member.public = False
            if obj.docstring is not None:
                obj.docstring.value = convert_roles(obj.docstring.value, obj,
                                                    loader.modules_collection)
