"""Old spellings and their current names: one table per concept, and the translations.

metaknot says *optimizer* for the method that searches (``minimize(optimizer=)``, the
``metaknot run`` config group ``optimizer=``, the record field ``optimizer``), where configs and
records once said *algorithm*; the method of a library an adapter runs (nlopt's ``LN_BOBYQA``,
pymoo's ``GA``, nevergrad's ``NGOpt``) is the optimizer's ``variant``. A knot encoding is named
as in the configs, ``mask``, ``indices`` or ``free`` (the registered problems were
``knot_selection``, ``knot_indices``, ``free_knots``). The old spellings keep
working: command lines, presets and tuning spaces are translated with a one-line note on stderr
(once per spelling), Python keywords with a :class:`DeprecationWarning`, and stored records
on read. Run ids hash the old names (:func:`legacy_config`), so a stored run keeps its id.
See ``docs/guide/glossary.md``.
"""

from __future__ import annotations

import functools
import re
import sys
import warnings
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["KEYWORDS", "OPTIMIZER_KEY", "OPTIMIZER_PARAMETERS", "PROBLEM_NAMES", "Metrics",
           "deprecated", "legacy_config", "new_config", "new_hyperparameters", "new_overrides",
           "new_problem_name", "new_record", "note", "renamed_parameters"]

#: The optimizer's config group and record field (new <- old).
OPTIMIZER_KEY = ("optimizer", "algorithm")
#: Hyperparameters renamed per optimizer (old -> new).
OPTIMIZER_PARAMETERS: dict[str, dict[str, str]] = {
    "nlopt": {"algorithm": "variant", "local_algorithm": "local_variant"},
    "pymoo": {"algorithm": "variant"},
    "nevergrad": {"optimizer": "variant"},
    "free_front": {"local_algorithm": "local_variant"},
}
#: Keywords of public functions renamed (function -> old -> new): a tolerance is ``tolerance``.
KEYWORDS: dict[str, dict[str, str]] = {"fit": {"tol": "tolerance"},
                                       "fewest_within": {"tol": "tolerance"}}
#: Registered knot problems (old -> new): named by their encoding, as in the configs.
PROBLEM_NAMES = {"knot_selection": "mask", "knot_indices": "indices", "free_knots": "free"}
_NOTED: set[str] = set()


def deprecated(message: str) -> None:
    """A :class:`DeprecationWarning` attributed to the first caller outside metaknot's own
    modules (the line the user wrote, however deep inside metaknot the old name arrived)."""
    frame, level = sys._getframe(1), 2
    while frame is not None and frame.f_globals.get("__name__", "").partition(".")[0] \
            == "metaknot":
        frame, level = frame.f_back, level + 1
    warnings.warn(message, DeprecationWarning, stacklevel=level)


class Metrics(dict):
    """Metrics by name: a dictionary wherever metaknot gives metrics (``fit.metrics``,
    ``result.metrics``); calling it, as when some were methods, still works with a warning."""

    def __call__(self) -> Metrics:
        deprecated("metrics() is deprecated: metrics is a dictionary, write .metrics")
        return self


def new_problem_name(name: str) -> str:
    """The current name of a registered problem (a former one warns)."""
    if name in PROBLEM_NAMES:
        deprecated(f"problem {name!r} is deprecated, use {PROBLEM_NAMES[name]!r}")
        return PROBLEM_NAMES[name]
    return name


def note(old: str, new: str, where: str = "") -> None:
    """Say once per process on stderr that the spelling ``old`` (in ``where``) is now
    ``new``."""
    if old not in _NOTED:
        _NOTED.add(old)
        print(f"metaknot: {where}{old!r} is deprecated, write {new!r}", file=sys.stderr)


def renamed_parameters(name: str, table: Mapping[str, Mapping[str, str]] = OPTIMIZER_PARAMETERS
                       ) -> Callable[[Callable], Callable]:
    """Decorate the ``__init__`` of the optimizer ``name`` (or the function ``name`` of
    :data:`KEYWORDS`) so that its old keywords still work, with a :class:`DeprecationWarning`."""
    renames = table[name]

    def decorate(function: Callable) -> Callable:
        @functools.wraps(function)  # inspect.signature sees the new names only
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            for old in renames.keys() & kwargs.keys():
                deprecated(f"{name}: {old}= is deprecated, use {renames[old]}=")
                kwargs[renames[old]] = kwargs.pop(old)
            return function(*args, **kwargs)
        return wrapper
    return decorate


def _section(section: Mapping[str, Any], renames: Mapping[str, str]) -> dict[str, Any]:
    both = [old for old in renames.keys() & section.keys() if renames[old] in section]
    if both:
        raise ValueError(f"{both[0]} and {renames[both[0]]}: the same setting twice (the "
                         f"first is its deprecated name)")
    return {renames.get(k, k): v for k, v in section.items()}


def new_config(cfg: Mapping[str, Any]) -> tuple[dict[str, Any], list[tuple[str, str]]]:
    """A run configuration (or preset) with its optimizer under the current names, and the
    ``(old, new)`` spellings replaced (``("algorithm", "optimizer")``, ...)."""
    new, old = OPTIMIZER_KEY
    out, used = dict(cfg), []
    if old in out:
        used.append((old, new))
        out = _section(out, {old: new})
    section = out.get(new)
    if isinstance(section, Mapping):
        out[new], inner = new_hyperparameters(section.get("_name_"), section)
        used += [(f"{new}.{old_key}", f"{new}.{key}") for old_key, key in inner]
    return out, used


def new_hyperparameters(optimizer: Any, values: Mapping[str, Any]) -> tuple[
        dict[str, Any], list[tuple[str, str]]]:
    """``values`` (hyperparameters of ``optimizer``) under their current names, and the
    ``(old, new)`` names replaced."""
    renames = OPTIMIZER_PARAMETERS.get(optimizer, {}) if isinstance(optimizer, str) else {}
    return (_section(values, renames),
            [(key, renames[key]) for key in sorted(renames.keys() & values.keys())])


def legacy_config(config: Mapping[str, Any]) -> dict[str, Any]:
    """``config`` under the names run ids were computed from before the optimizer was named
    so (:func:`new_config` undone), so that the ids of stored runs stay valid."""
    new, old = OPTIMIZER_KEY
    section = dict(config[new])
    renames = OPTIMIZER_PARAMETERS.get(section.get("_name_"), {})
    back = {v: k for k, v in renames.items()}
    return {**{k: v for k, v in config.items() if k != new},
            old: {back.get(k, k): v for k, v in section.items()}}


def new_record(row: dict[str, Any]) -> dict[str, Any]:
    """A stored record's fields under the current names (``algorithm``, ``algorithm.<x>``
    become ``optimizer``, ``optimizer.<x>``; ``problem`` ``knot_selection`` becomes ``mask``)."""
    new, old = OPTIMIZER_KEY
    if row.get("problem") in PROBLEM_NAMES:
        row = {**row, "problem": PROBLEM_NAMES[row["problem"]]}
    if old not in row:
        return row
    renames = OPTIMIZER_PARAMETERS.get(row[old], {})
    out = {}
    for key, value in row.items():
        head, dot, tail = key.partition(".")
        if key == old:
            key = new
        elif head == old and dot:
            key = f"{new}.{renames.get(tail, tail)}"
        out[key] = value
    return out


#: An override's key (after ``+``, ``++`` or ``~``) and the rest (``@package``, ``=value``).
_OVERRIDE = re.compile(r"(?P<sign>[+~]*)(?P<key>[\w.]+)(?P<rest>[@=].*)?", re.S)
_ANY_PARAMETER = {k: v for renames in OPTIMIZER_PARAMETERS.values() for k, v in renames.items()}


def new_overrides(args: list[str]) -> list[str]:
    """Command-line overrides with the old spellings (``algorithm=ga``, ``algorithm.pp1=0.2``,
    ``+algorithm...``, ``tune.algorithm=``) replaced by the current ones, each noted once."""
    new, old = OPTIMIZER_KEY
    out = []
    for arg in args:
        match = _OVERRIDE.fullmatch(arg)
        if match and not arg.startswith("-"):
            parts = match["key"].split(".")
            at = 1 if parts[0] == "tune" and len(parts) == 2 else 0
            if parts[at] == old:
                parts[at] = new
                if at == 0 and len(parts) == 2:
                    parts[1] = _ANY_PARAMETER.get(parts[1], parts[1])
                key = ".".join(parts)
                note(match["key"], key)
                arg = f"{match['sign']}{key}{match['rest'] or ''}"
        out.append(arg)
    return out
