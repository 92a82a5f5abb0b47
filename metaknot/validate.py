"""What counts as a whole number or a real number among the values users give metaknot.

``True`` is an ``int`` to Python, but a budget, a degree or a seed of ``True`` is a mistake; numpy
integers and floats (what arrays and YAML-through-numpy give) are numbers like any other. Every
check of an integer or real setting asks these two functions, so all agree.
"""

from __future__ import annotations

import numpy as np

__all__ = ["is_integer", "is_real"]


def is_integer(value: object) -> bool:
    """True for a Python or numpy integer, not for a bool (nor a float such as ``3.0``)."""
    return isinstance(value, int | np.integer) and not isinstance(value, bool | np.bool_)


def is_real(value: object) -> bool:
    """True for a Python or numpy integer or float, not for a bool (NaN and inf included: check
    finiteness where it matters)."""
    return isinstance(value, int | float | np.integer | np.floating) \
        and not isinstance(value, bool | np.bool_)
