"""The instances of the benchmark suite: stable ids, families, definitions, deterministic points.

A base instance is a data set generated from its definition (never downloaded); a noisy
instance adds Gaussian noise of standard deviation ``level`` times the data's range (the range
of ``f(x)`` for functions, the bounding-box diagonal for curves), drawn from a seed that is part
of its id: ``<base>+noise<level>s<seed>``, e.g. ``galvez_f1+noise0.01s0``.

Third-party packages add instances through the entry-point group ``metaknot.instances``: an
entry point names a callable returning an iterable of :class:`Instance` objects.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from importlib.metadata import entry_points
from typing import Any, Literal

import numpy as np

from metaknot.problems import PointSet, add_noise

from .functions import FUNCTIONS
from .glyphs import digit_outline
from .shapes import CLOSED_CURVES, OPEN_CURVES, SPACE_CURVES

__all__ = ["FAMILIES", "NOISE_LEVELS", "Instance", "base_instances", "get_instance",
           "instances"]

Kind = Literal["function", "open", "closed"]

#: Noise levels of the suite's noisy instances (standard deviation relative to the range), and
#: the noise seed they use.
NOISE_LEVELS = (0.01, 0.03)
NOISE_SEED = 0
ENTRY_POINT_GROUP = "metaknot.instances"

_NOISY_ID = re.compile(r"(?P<base>[a-z0-9_]+)\+noise(?P<level>[0-9.eE+-]+)s(?P<seed>[0-9]+)\Z")


@dataclass(frozen=True, eq=False)
class Instance:
    """One data set of the suite.

    Attributes
    ----------
    id
        Stable name (``[a-z0-9_]``; noisy instances add ``+noise<level>s<seed>``).
    family
        Its family (see :data:`FAMILIES`).
    kind
        ``"function"`` (data ``y = f(x)``, ``x`` the parameter), ``"open"`` or ``"closed"``
        (a curve fitted by a clamped or a periodic spline).
    generate
        The definition: a callable returning ``(x, y)`` for a function, the points ``(N, d)``
        for a curve. Its docstring says what it is and where it comes from.
    noise, noise_seed
        Standard deviation of the added noise relative to the range (0: none) and its seed.
    """

    id: str
    family: str
    kind: Kind
    generate: Callable[[], Any] = field(repr=False)
    noise: float = 0.0
    noise_seed: int = NOISE_SEED

    @property
    def closed(self) -> bool:
        return self.kind == "closed"

    @property
    def base_id(self) -> str:
        """The id of the noise-free instance this one derives from (its own id if noise-free)."""
        return self.id.split("+", 1)[0]

    @property
    def definition(self) -> str:
        """What the data are and their source (the generator's docstring)."""
        return " ".join((self.generate.__doc__ or "").split())

    def _clean(self) -> PointSet:
        if self.kind == "function":
            x, y = self.generate()
            return PointSet(np.asarray(y, dtype=np.float64)[:, None], name=self.id,
                            params=np.asarray(x, dtype=np.float64))
        return PointSet(np.asarray(self.generate(), dtype=np.float64), name=self.id)

    @property
    def sigma(self) -> float:
        """The noise's standard deviation in data units: ``noise`` times the scale of the data
        without noise (0 for an instance without noise)."""
        return self.noise * self._clean().scale if self.noise else 0.0

    def point_set(self) -> PointSet:
        """The instance's data: points (``f(x)`` as one column for a function, with ``x`` as
        the explicit parameters), noise included."""
        data = self._clean()
        if not self.noise:
            return data
        noisy = add_noise(data, self.sigma, np.random.SeedSequence(self.noise_seed))
        return replace(noisy, name=self.id)

    @property
    def dim(self) -> int:
        return self.point_set().dim

    def with_noise(self, level: float, seed: int = NOISE_SEED) -> Instance:
        """This instance with noise of ``level`` times its range, drawn from ``seed``."""
        if self.noise:
            raise ValueError(f"{self.id} is already noisy")
        return Instance(f"{self.id}+noise{level:g}s{seed}", self.family, self.kind,
                        self.generate, float(level), int(seed))


def _digit(d: int) -> Callable[[], np.ndarray]:
    def generate() -> np.ndarray:
        return digit_outline(d)

    generate.__doc__ = (f"The outer outline of the digit {d} in DejaVu Sans Mono (matplotlib's "
                        "bundled font, via matplotlib.textpath.TextPath), 200 points at equal "
                        "arc length; holes left out.")
    return generate


@functools.cache
def base_instances() -> tuple[Instance, ...]:
    """The suite's base instances (without noise), in a fixed order."""
    found = [Instance(key, family, "function", generate)
             for key, (family, generate) in FUNCTIONS.items()]
    found += [Instance(key, "open_curves", "open", generate)
              for key, generate in OPEN_CURVES.items()]
    found += [Instance(key, "closed_curves", "closed", generate)
              for key, generate in CLOSED_CURVES.items()]
    found += [Instance(f"digit_{d}", "glyphs", "closed", _digit(d)) for d in range(10)]
    found += [Instance(key, "space_curves", "closed" if closed else "open", generate)
              for key, (generate, closed) in SPACE_CURVES.items()]
    return tuple(found)


#: The families, in the order of :func:`base_instances`.
FAMILIES = tuple(dict.fromkeys(i.family for i in base_instances()))


def _noisy(base: Iterable[Instance]) -> list[Instance]:
    """The noisy variants: every function and every planar curve at each noise level."""
    return [i.with_noise(level) for i in base if i.family != "space_curves"
            for level in NOISE_LEVELS]


@functools.cache
def _plugin_instances() -> tuple[Instance, ...]:
    found = []
    for point in entry_points(group=ENTRY_POINT_GROUP):
        for instance in point.load()():
            if not isinstance(instance, Instance):
                raise TypeError(f"entry point {point.name!r} in group {ENTRY_POINT_GROUP!r} "
                                f"gave {instance!r}, not a metaknot.suite.Instance")
            found.append(instance)
    return tuple(found)


def instances(*, family: str | None = None, noise: bool = True,
              plugins: bool = True) -> list[Instance]:
    """The suite: base instances, their noisy variants (``noise``) and those of installed
    packages (``plugins``), optionally of one ``family``.

    Raises
    ------
    ValueError
        For an unknown family.
    """
    found = list(base_instances())
    if noise:
        found += _noisy(base_instances())
    if plugins:
        found += _plugin_instances()
    if family is not None:
        known = {i.family for i in found}
        if family not in known:
            raise ValueError(f"unknown family {family!r}; the suite's: "
                             f"{', '.join(sorted(known))}")
        found = [i for i in found if i.family == family]
    return found


def get_instance(instance_id: str) -> Instance:
    """An instance by id: a base instance, a noisy variant of one at any level and seed
    (``<base>+noise<level>s<seed>``), or a plugin's.

    Raises
    ------
    ValueError
        For an unknown id (naming the closest known one).
    """
    by_id = {i.id: i for i in (*base_instances(), *_plugin_instances())}
    if instance_id in by_id:
        return by_id[instance_id]
    noisy = _NOISY_ID.match(instance_id)
    if noisy and noisy["base"] in by_id:
        level = float(noisy["level"])
        if not (np.isfinite(level) and level > 0):
            raise ValueError(f"{instance_id}: the noise level must be a number > 0")
        return by_id[noisy["base"]].with_noise(level, int(noisy["seed"]))
    import difflib

    close = difflib.get_close_matches(instance_id, list(by_id), n=1)
    hint = f" Did you mean {close[0]!r}?" if close else ""
    raise ValueError(f"unknown suite instance {instance_id!r}.{hint}")
