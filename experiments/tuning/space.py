"""Search spaces of hyperparameters, as written in ``conf/tune/<optimizer>.yaml``.

A space maps each name to a distribution::

    population: {type: int, low: 10, high: 200, log: true}
    pp1:        {type: float, low: 0.01, high: 0.6}
    fitness:    {type: categorical, choices: [rank, inverse], when: {encoding: indices}}

``type`` is ``int``, ``float`` or ``categorical``; ``log`` and ``step`` are optional; ``when``
samples the parameter only when the named parameters (sampled before it, in file order) have
the given values. Two names are not hyperparameters of the optimizer but of the problem:
``encoding`` (``mask`` or ``indices``) and ``n_knots`` (K, for indices).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from metaknot.validate import is_real

from ..errors import ConfigError
from ..spec import Setting, check_value

__all__ = ["PROBLEM_PARAMETERS", "Parameter", "SearchSpace"]

#: Space entries that set the problem, not the optimizer.
PROBLEM_PARAMETERS = ("encoding", "n_knots")
ENCODING_CHOICES = ("mask", "indices")


@dataclass(frozen=True)
class Parameter:
    """One searched parameter."""

    name: str
    type: str
    low: float | None = None
    high: float | None = None
    log: bool = False
    step: float | None = None
    choices: tuple[Any, ...] = ()
    when: tuple[tuple[str, Any], ...] = ()

    def suggest(self, trial: Any) -> Any:
        """The trial's value (Optuna's ``suggest_*``)."""
        if self.type == "categorical":
            return trial.suggest_categorical(self.name, list(self.choices))
        if self.type == "int":
            assert self.low is not None and self.high is not None  # numbers have bounds
            return trial.suggest_int(self.name, int(self.low), int(self.high), log=self.log,
                                     step=int(self.step or 1))
        return trial.suggest_float(self.name, self.low, self.high, log=self.log, step=self.step)


def _parameter(name: str, entry: Any, earlier: dict[str, Parameter]) -> Parameter:
    key = f"tune.space.{name}"
    if not isinstance(entry, Mapping):
        raise ConfigError(f"{key}: a mapping such as {{type: float, low: 0, high: 1}}, "
                          f"got {entry!r}")
    unknown = set(entry) - {"type", "low", "high", "log", "step", "choices", "when"}
    if unknown:
        raise ConfigError(f"{key}: unknown field(s) {', '.join(sorted(unknown))}")
    kind = entry.get("type")
    when = entry.get("when") or {}
    if not isinstance(when, Mapping):
        raise ConfigError(f"{key}.when: a mapping of earlier parameters to values")
    for other, value in when.items():
        if other not in earlier or earlier[other].type != "categorical":
            raise ConfigError(f"{key}.when: {other!r} is not a categorical parameter listed "
                              "before it")
        if value not in earlier[other].choices:
            raise ConfigError(f"{key}.when: {other}={value!r} is not one of its choices "
                              f"{list(earlier[other].choices)} (the parameter would never be "
                              "sampled)")
    when_items = tuple(sorted(when.items()))
    if kind == "categorical":
        choices = entry.get("choices")
        if not isinstance(choices, list | tuple) or not choices:
            raise ConfigError(f"{key}.choices: a non-empty list, got {choices!r}")
        if len(set(map(repr, choices))) != len(choices):
            raise ConfigError(f"{key}.choices: repeated values in {list(choices)}")
        extra = set(entry) - {"type", "choices", "when"}
        if extra:
            raise ConfigError(f"{key}: {', '.join(sorted(extra))} do not apply to a "
                              "categorical parameter")
        return Parameter(name, kind, choices=tuple(choices), when=when_items)
    if kind not in ("int", "float"):
        raise ConfigError(f"{key}.type: int, float or categorical, got {kind!r}")
    if "choices" in entry:
        raise ConfigError(f"{key}.choices: only for type categorical")
    low: Any = entry.get("low")  # checked below: finite numbers
    high: Any = entry.get("high")
    for bound, value in (("low", low), ("high", high)):
        if not is_real(value) or not math.isfinite(value):
            raise ConfigError(f"{key}.{bound}: a finite number, got {value!r}")
        if kind == "int" and float(value) != int(value):
            raise ConfigError(f"{key}.{bound}: an integer for type int, got {value!r}")
    if not low < high:
        raise ConfigError(f"{key}: low must be below high, got low={low}, high={high} "
                          "(an empty range)")
    log = check_value(f"{key}.log", entry.get("log", False), Setting((bool,), False))
    if log and low <= 0:
        raise ConfigError(f"{key}: a log scale needs low > 0, got {low}")
    step = entry.get("step")
    if step is not None:
        if log:
            raise ConfigError(f"{key}: step and log cannot be combined (Optuna)")
        if not is_real(step) or step <= 0:
            raise ConfigError(f"{key}.step: a number > 0, got {step!r}")
    return Parameter(name, kind, float(low), float(high), log,
                     None if step is None else float(step), when=when_items)


class SearchSpace:
    """The parameters of a tuning study, validated against the optimizer's signature.

    Parameters
    ----------
    space
        ``{name: distribution}`` (see the module notes).
    hyperparameters
        The optimizer's hyperparameter names (its ``__init__`` arguments).
    optimizer
        The optimizer's name, for messages.
    """

    def __init__(self, space: object, hyperparameters: set[str], optimizer: str) -> None:
        if not isinstance(space, Mapping) or not space:
            raise ConfigError("tune.space: empty; list at least one parameter to search")
        self.parameters: dict[str, Parameter] = {}
        for name, entry in space.items():
            if name not in hyperparameters and name not in PROBLEM_PARAMETERS:
                raise ConfigError(
                    f"tune.space.{name}: {optimizer!r} has no such hyperparameter; it has "
                    f"{', '.join(sorted(hyperparameters))} (and the problem's "
                    f"{', '.join(PROBLEM_PARAMETERS)})")
            self.parameters[name] = _parameter(name, entry, self.parameters)
        encoding = self.parameters.get("encoding")
        if encoding is not None:
            if encoding.type != "categorical" or not set(encoding.choices) <= \
                    set(ENCODING_CHOICES):
                raise ConfigError("tune.space.encoding: categorical with choices among "
                                  f"{list(ENCODING_CHOICES)}")
        knots = self.parameters.get("n_knots")
        if knots is not None:
            if knots.type != "int" or knots.low is None or knots.low < 1:
                raise ConfigError("tune.space.n_knots: type int with low >= 1")
            if encoding is not None and dict(knots.when).get("encoding") != "indices":
                raise ConfigError("tune.space.n_knots: add when: {encoding: indices} (K only "
                                  "applies to index sets)")

    def suggest(self, trial: Any) -> dict[str, Any]:
        """Every parameter's value for ``trial`` (conditional ones only when they apply)."""
        values: dict[str, Any] = {}
        for name, parameter in self.parameters.items():
            if all(values.get(k) == v for k, v in parameter.when):
                values[name] = parameter.suggest(trial)
        return values

    def names(self) -> list[str]:
        return list(self.parameters)
