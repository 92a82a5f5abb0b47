"""Registries of problems and optimizers: a decorator plus entry-point discovery.

Built-in classes register themselves with :func:`register` when ``metaknot.problems`` and
``metaknot.algorithms`` are imported. Third-party packages expose theirs through the
entry-point groups ``metaknot.problems`` and ``metaknot.optimizers``::

    [project.entry-points."metaknot.optimizers"]
    my_search = "my_package.search:MySearch"

and are found by name, without any change to metaknot.
"""

from __future__ import annotations

import difflib
import functools
import importlib
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any, Literal, TypeVar, cast

from .optimizer import Optimizer
from .problem import Problem

__all__ = [
    "available_optimizers",
    "available_problems",
    "get_optimizer",
    "get_problem",
    "register",
]

Kind = Literal["problem", "optimizer"]
T = TypeVar("T")

_REGISTRY: dict[str, dict[str, Callable[..., Any]]] = {"problem": {}, "optimizer": {}}
_GROUPS = {"problem": "metaknot.problems", "optimizer": "metaknot.optimizers"}
_BUILTIN = {"problem": "metaknot.problems", "optimizer": "metaknot.algorithms"}
_BASE = {"problem": Problem, "optimizer": Optimizer}


def _kind_of(obj: Any) -> Kind:
    for kind, base in _BASE.items():
        if isinstance(obj, type) and issubclass(obj, base):
            return kind  # type: ignore[return-value]
    raise TypeError(
        f"cannot tell whether {obj!r} is a problem or an optimizer; subclass Problem or "
        "Optimizer, or pass kind='problem' / kind='optimizer'"
    )


def register(name: str | None = None, *, kind: Kind | None = None) -> Callable[[T], T]:
    """Class (or factory) decorator that makes a problem or optimizer available by name.

    Parameters
    ----------
    name
        Registry name; defaults to the class's ``name`` attribute or ``__name__``.
    kind
        ``"problem"`` or ``"optimizer"``; inferred for subclasses of :class:`Problem` /
        :class:`Optimizer`, required for factory functions.
    """

    def decorator(obj: T) -> T:
        k = kind or _kind_of(obj)
        if k not in _REGISTRY:
            raise ValueError(f"kind must be 'problem' or 'optimizer'; got {k!r}")
        # a class's own ``name`` attribute (not one inherited from the base class), else __name__
        own = vars(obj).get("name") if isinstance(obj, type) else None
        key = name or own or obj.__name__  # type: ignore[attr-defined]
        existing = _REGISTRY[k].get(key)
        if existing is not None and existing is not obj:
            raise ValueError(f"a {k} named {key!r} is already registered ({existing!r})")
        if isinstance(obj, type):
            obj.name = key  # type: ignore[attr-defined]
        _REGISTRY[k][key] = obj  # type: ignore[assignment]
        return obj

    return decorator


def _load_builtin(kind: Kind) -> None:
    importlib.import_module(_BUILTIN[kind])


def _entry_point_names(kind: Kind) -> dict[str, Any]:
    return {ep.name: ep for ep in entry_points(group=_GROUPS[kind])}


def _lookup(kind: Kind, name: str) -> Callable[..., Any]:
    _load_builtin(kind)
    if name in _REGISTRY[kind]:
        return _REGISTRY[kind][name]
    eps = _entry_point_names(kind)
    if name in eps:
        obj = eps[name].load()
        if isinstance(obj, type) and not issubclass(obj, _BASE[kind]):
            raise TypeError(f"entry point {name!r} in group {_GROUPS[kind]!r} loads {obj!r}, "
                            f"which is not a {_BASE[kind].__name__}")
        _REGISTRY[kind].setdefault(name, obj)
        if isinstance(obj, type):  # a subclass of _BASE[kind] (checked above)
            cast("type[Optimizer | Problem]", obj).name = name
        return _REGISTRY[kind][name]
    if ":" in name:  # "family:variant", e.g. "nevergrad:NGOpt"
        base, variant = name.split(":", 1)
        if base in _REGISTRY[kind] or base in eps:
            factory = _lookup(kind, base)
            parameter = getattr(factory, "variant_parameter", None)
            if parameter is None:
                raise ValueError(f"{kind} {base!r} has no variants; use {base!r} alone")
            return functools.partial(factory, **{parameter: variant})
    known = sorted(set(_REGISTRY[kind]) | set(eps))
    close = difflib.get_close_matches(name, known, n=1)
    hint = f" Did you mean {close[0]!r}?" if close else ""
    raise ValueError(f"unknown {kind} {name!r}.{hint} Available: {', '.join(known)}")


def get_optimizer(name: str, **kwargs: Any) -> Optimizer:
    """Instantiate a registered optimizer by name with the given hyperparameters.

    A name ``"family:variant"`` selects a variant of an optimizer that declares a
    ``variant_parameter`` (``"nevergrad:NGOpt"`` is ``nevergrad`` with ``variant="NGOpt"``).
    """
    return _lookup("optimizer", name)(**kwargs)


def get_problem(name: str, **kwargs: Any) -> Problem:
    """Instantiate a registered problem by name (for example ``"mask"``)."""
    return _lookup("problem", name)(**kwargs)


def available_optimizers() -> list[str]:
    """Names of all registered and entry-point optimizers."""
    _load_builtin("optimizer")
    return sorted(set(_REGISTRY["optimizer"]) | set(_entry_point_names("optimizer")))


def available_problems() -> list[str]:
    """Names of all registered and entry-point problems."""
    _load_builtin("problem")
    return sorted(set(_REGISTRY["problem"]) | set(_entry_point_names("problem")))
