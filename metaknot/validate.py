"""What counts as a whole number, a real number or a flag among the values users give metaknot.

``True`` is an ``int`` to Python, but a budget, a degree or a seed of ``True`` is a mistake; numpy
integers and floats (what arrays and YAML-through-numpy give) are numbers like any other. Every
check of an integer or real setting asks these two functions, so all agree.
"""

from __future__ import annotations

from typing import TypeGuard

import numpy as np

__all__ = ["check_flag", "check_tolerance", "is_integer", "is_real"]


def is_integer(value: object) -> TypeGuard[int | np.integer]:
    """True for a Python or numpy integer, not for a bool (nor a float such as ``3.0``)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def is_real(value: object) -> TypeGuard[int | float | np.integer | np.floating]:
    """True for a Python or numpy integer or float, not for a bool (NaN and inf included: check
    finiteness where it matters)."""
    return isinstance(value, int | float | np.integer | np.floating) \
        and not isinstance(value, bool | np.bool_)


def check_flag(name: str, value: object) -> bool:
    """``value`` as a bool if it is one (Python's or numpy's), else a ``ValueError`` naming
    ``name``: the string ``"false"`` or ``None`` would otherwise count as a truth value."""
    if not isinstance(value, bool | np.bool_):
        raise ValueError(f"{name} must be True or False; got {value!r}")
    return bool(value)


def check_tolerance(value: object) -> float:
    """``value`` as a float if it is a finite number > 0 (an error bound), else a
    ``ValueError`` saying so: the one check of a tolerance, for ``metaknot fit``, the
    literature methods and the optimizers that take one."""
    if not (is_real(value) and np.isfinite(value) and value > 0):
        raise ValueError(f"the tolerance must be a number > 0; got {value!r}")
    return float(value)
