"""From a study configuration to one validated, reproducible run.

:func:`run_spec` checks a composed configuration (Hydra's, or a plain mapping of the same shape)
and returns a :class:`~.run.RunSpec`: the normalised settings, the run id, and builders for the
problem and the optimizer. Every check names the configuration key it is about, in one line
(:class:`~.errors.ConfigError`), so a bad sweep fails before any run starts.
"""

from __future__ import annotations

import hashlib
import inspect
import os
import re
import types
import typing
from collections.abc import Callable, Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from metaknot.validate import is_integer, is_real

from .errors import ConfigError, naming, short
from .run import ENCODINGS, RUN_KEYS, RunSpec, run_id

__all__ = ["ConfigError", "config_node", "plain_config", "run_spec"]

# the curve model's (metaknot.bspline.PARAMETERIZATIONS), written here so that checking a
# configuration does not load the compiled kernels; tests/test_spec.py keeps the two equal
PARAMETERIZATIONS = ("uniform", "chord", "centripetal")
STUDY_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.=,+-]*")  # matched in full (fullmatch)


# --------------------------------------------------------------------------------------------
# the schema: every setting described once, checked by one checker


Bound = float | Callable[[Mapping[str, Any]], float] | None
REQUIRED = "???"  # Hydra's mark of a value still to be given: the default of a required setting


@dataclass(frozen=True)
class Setting:
    """One setting of a configuration: the values it takes and its default.

    Attributes
    ----------
    kinds
        The types it takes: ``int`` (an integer, not a bool), ``float`` (any real number,
        stored as a float), ``bool``, ``str``, ``NULL`` (null), ``object`` (anything) or
        another class (its instances).
    default
        Its value when it is not given (:data:`REQUIRED`: it must be given).
    low, high
        Bounds of a number, or functions of the settings of its section checked before it.
    values
        Values it takes besides its kinds (its choices, when ``kinds`` is empty).
    test
        A further condition on a value of its kinds (the message then says ``expect``).
    expect
        What it takes, in the message (default: its kinds and values).
    annotated
        Read from an annotation of a signature: a whole float counts as an int, and a float
        may be infinite.
    omit
        Left out of the checked section at its default, so that the run ids of runs that do
        not set it stay as they were.
    """

    kinds: tuple[type, ...] = ()
    default: Any = REQUIRED
    low: Bound = None
    high: Bound = None
    values: tuple[Any, ...] = ()
    test: Callable[[Any], Any] | None = None
    expect: str = ""
    annotated: bool = False
    omit: bool = False


NULL = type(None)
NAMES = {int: "an integer", float: "a number", bool: "true or false", str: "a string",
         NULL: "null"}
_REFUSED = object()
SECTION = Setting((Mapping,), expect="a group of settings")


def check_value(key: str, value: Any, setting: Setting,
                section: Mapping[str, Any] | None = None) -> Any:
    """``value`` of the setting ``key`` as ``setting`` takes it (an integer of a float setting
    as a float, ...); ``section`` holds the settings checked before it, for its bounds.

    Raises
    ------
    ConfigError
        One line naming ``key``, the value and what the setting takes.
    """
    if isinstance(value, str) and value == REQUIRED:
        raise ConfigError(f"{key}: required, no value given")
    out = _converted(value, setting)
    if out is _REFUSED or (setting.test is not None and not setting.test(out)):
        if not setting.kinds and not setting.expect:
            raise ConfigError(f"{key}: must be one of {', '.join(map(str, setting.values))}; "
                              f"got {short(repr(value))}")
        names = [repr(v) for v in setting.values]
        names += [NAMES.get(kind, kind.__name__) for kind in setting.kinds]
        raise ConfigError(f"{key}: {setting.expect or 'expected ' + ' or '.join(names)}, "
                          f"got {short(repr(value))}")
    if isinstance(out, float) and not setting.annotated and not np.isfinite(out):
        raise ConfigError(f"{key}: must be finite, got {out!r}")
    if is_real(out):
        low, high = (bound(section or {}) if callable(bound) else bound
                     for bound in (setting.low, setting.high))
        if low is not None and out < low:
            raise ConfigError(f"{key}: must be >= {low}, got {out!r}")
        if high is not None and out > high:
            raise ConfigError(f"{key}: must be <= {high}, got {out!r}")
    return out


def _converted(value: Any, setting: Setting) -> Any:
    """``value`` as ``setting`` takes it, or ``_REFUSED``."""
    kinds = setting.kinds
    if any(type(value) is type(v) and value == v for v in setting.values) \
            or type(value) in kinds or object in kinds:
        return value
    if int in kinds and (is_integer(value) or (setting.annotated and isinstance(value, float)
                         and value.is_integer())):
        return int(value)
    if float in kinds and is_real(value):
        return float(value)
    if any(isinstance(value, kind) for kind in kinds if kind not in NAMES):
        return value
    return _REFUSED


def check_section(key: str, given: Any, schema: Mapping[str, Setting]) -> dict[str, Any]:
    """The section ``key`` of a configuration (``""``: the whole) checked against ``schema``:
    no unknown settings, every value as :func:`check_value` takes it, in the order of
    ``schema``, and the defaults of the settings not given (but those marked ``omit``)."""
    _unknown(key, check_value(key, given, SECTION), schema.keys())
    out: dict[str, Any] = {}
    for name, setting in schema.items():
        value = given.get(name, setting.default)
        if name in given or (isinstance(value, str) and value == REQUIRED):
            value = check_value(f"{key}.{name}" if key else name, value, setting, out)
        if not (setting.omit and value == setting.default):
            out[name] = value
    return out


def _unknown(key: str, given: Mapping[str, Any], known: AbstractSet[str]) -> None:
    extra = sorted(set(given) - known, key=str)  # keys of a YAML file need not be strings
    if extra:
        name = f"{key}.{extra[0]}" if key else extra[0]
        known_names = ", ".join(sorted(known)) or "none"
        raise ConfigError(f"{name}: unknown setting (known: {known_names})")


# --------------------------------------------------------------------------------------------
# optimizers and objectives: their settings from their signatures


def _optimizer_class(name: str, key: str = "optimizer._name_") -> Any:
    """The registered optimizer class ``name``, the setting ``key``'s value."""
    from metaknot.registry import _lookup

    with naming(key):
        return _lookup("optimizer", name)


def signature_settings(cls: type[Any]) -> dict[str, Setting]:
    """The keyword arguments of ``cls.__init__`` as settings: the types their annotations admit
    (anything, where that cannot be told) and their defaults."""
    try:
        hints = typing.get_type_hints(cls.__init__)
    except Exception:  # unresolvable annotations of a plugin: its constructor checks the values
        hints = {}
    out = {}
    for p in inspect.signature(cls.__init__).parameters.values():
        if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            kinds, values = _admitted(hints.get(p.name, Any))
            out[p.name] = Setting(kinds, REQUIRED if p.default is p.empty else p.default,
                                  values=values, annotated=True)
    return out


def _admitted(hint: Any) -> tuple[tuple[type, ...], tuple[Any, ...]]:
    """The types and the ``Literal`` values ``hint`` admits (``object``: it cannot be told)."""
    origin = typing.get_origin(hint)
    if origin is typing.Literal:
        return (), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        parts = [_admitted(arg) for arg in typing.get_args(hint)]
        return sum((kinds for kinds, _ in parts), ()), sum((values for _, values in parts), ())
    return ((hint,) if isinstance(hint, type) and hint is not Any else (object,)), ()


def config_node(group: str, name: str) -> dict[str, Any]:
    """The config node ``<group>=<name>``: a registered optimizer (``group="optimizer"``: its
    ``_name_``) or an objective (``"objective"``: its ``name``) and the keyword arguments of its
    class with their defaults, read from its signature (``"???"``: required; a default that is
    not a plain value as its ``repr``)."""
    from metaknot.problems import OBJECTIVES

    key, cls = ("_name_", _optimizer_class(name)) if group == "optimizer" else \
        ("name", OBJECTIVES[name])
    plain = NULL | bool | int | float | str
    return {key: name, **{setting: s.default if isinstance(s.default, plain) else repr(s.default)
                          for setting, s in signature_settings(cls).items()}}


def _named(section: str, given: Mapping[str, Any], name_key: str, name: Setting,
           classes: Callable[[str], type[Any]]) -> tuple[dict[str, Any], type[Any]]:
    """A section that names its class (``optimizer._name_``, ``objective.name``), checked
    against the class's signature: the name first, then its settings."""
    given = dict(given)
    chosen = check_value(f"{section}.{name_key}", given.pop(name_key, None), name)
    cls = classes(chosen)
    return {name_key: chosen, **check_section(section, given, signature_settings(cls))}, cls


# --------------------------------------------------------------------------------------------
# the run


def _usable_dir(path: str) -> bool:
    """Whether ``path`` names a usable folder or nothing yet (made when the first run is stored)."""
    try:
        if path and not os.path.isdir(os.path.realpath(path, strict=True)):
            raise ConfigError(f"results_dir: {path} is not a folder")
    except FileNotFoundError:
        pass
    except OSError as exc:  # a loop of symbolic links, a folder without permission, ...
        raise ConfigError(f"results_dir: {path} cannot be used: "
                          f"{os.strerror(exc.errno) if exc.errno else exc}") from None
    return bool(path)


def _fitpack_factor(text: str) -> float | None:
    """The factor of a knot count ``"fitpack:<factor>"`` (a finite number > 0), else None."""
    head, _, factor = text.partition(":")
    try:
        value = float(factor)
    except ValueError:
        return None
    return value if head == "fitpack" and np.isfinite(value) and value > 0 else None


#: Where a study is stored (a run's and a tuning study's settings).
STUDY = {"study": Setting((str,), test=STUDY_NAME.fullmatch,
                          expect="a name of letters, digits and _.=,+- (no slashes)"),
         "results_dir": Setting((str,), test=_usable_dir, expect="a directory path")}
#: The settings of a run (others are refused); the run id hashes those of :data:`~.run.RUN_KEYS`.
RUN = {**STUDY, "threads": Setting((int,), "auto", 1, values=("auto",)),
       "progress": Setting((bool,), "auto", values=("auto",), expect="auto, true or false"),
       "problem": SECTION, "encoding": SECTION, "objective": SECTION, "optimizer": SECTION,
       "budget": Setting((int,), low=1), "seed": Setting((int,), low=0),
       "checkpoints_per_decade": Setting((int,), 10, 1),
       "label": Setting((str, NULL), None, expect="a name for reports")}
PROBLEM = {"name": Setting((str, NULL), None, expect="a label"),
           "curve": Setting((object,), None),  # checked when it is used
           "points": Setting((str, NULL), None, expect="a .csv or .npy file"),
           "fingerprint": Setting((object,), None),
           "degree": Setting((int,), 3, 1, 5),
           "params_column": Setting((int, NULL), None),
           "n_points": Setting((int, NULL), None, lambda problem: problem["degree"] + 2),
           "noise": Setting((float,), 0.0, 0.0),
           "noise_seed": Setting((int, NULL), None, 0),
           "parameterization": Setting((), "centripetal", values=PARAMETERIZATIONS),
           "closed": Setting((bool,), False, omit=True),
           "instance": Setting((object,), None, omit=True),
           "task": Setting((object,), None, omit=True)}
N_KNOTS = Setting((int, str), 20, 1,
                  test=lambda n: not isinstance(n, str) or n == "max" or _fitpack_factor(n),
                  expect="an integer, 'max' or 'fitpack:<factor>' with a factor > 0")


def encoding_schema(kind: str, degree: int) -> dict[str, Setting]:
    """The settings of the encoding ``kind`` of a spline of ``degree``."""
    multiplicity = Setting((int,), 1, 1, degree, omit=True)
    return {"kind": Setting(values=tuple(ENCODINGS)), **{
        "mask": {"density": Setting((float,), 0.5, 0.0, 1.0), "max_multiplicity": multiplicity},
        "indices": {"n_knots": N_KNOTS, "max_multiplicity": multiplicity},
        "free": {"n_knots": N_KNOTS, "variable_count": Setting((bool,), False),
                 "merge_spacing": Setting((float, NULL), None, 0.0, omit=True)}}[kind]}


def run_spec(cfg: Mapping[str, Any], *, check_build: bool = True) -> RunSpec:
    """Validate a run configuration and return its :class:`~.run.RunSpec`.

    Parameters
    ----------
    cfg
        The composed configuration (``DictConfig`` or mapping): ``problem``, ``encoding``,
        ``objective``, ``optimizer`` groups and the top-level ``budget``, ``seed``, ``study``,
        ``results_dir``, ``checkpoints_per_decade``, ``threads``, ``progress``.
    check_build
        Also build the problem (without noise) and the optimizer, so their own checks run.

    Raises
    ------
    ConfigError
        Naming the first key whose value cannot work.
    """
    from metaknot.problems import CURVES, OBJECTIVES

    top = check_section("", plain_config(cfg), RUN)
    problem = check_section("problem", top["problem"], PROBLEM)
    instance = problem.get("instance")
    if instance is not None:
        if problem["points"] is not None or problem["curve"] is not None:
            raise ConfigError("problem.instance: a suite instance replaces problem.curve and "
                              "problem.points; leave those null (problem=suite does)")
        from metaknot.suite import get_instance

        with naming("problem.instance"):
            instance = get_instance(str(instance))
        problem.update(instance=instance.id, closed=instance.closed)
    elif problem["points"] is not None:
        if not Path(problem["points"]).is_file():
            raise ConfigError(f"problem.points: file not found: {problem['points']}")
        problem.update(points=str(Path(problem["points"]).resolve()), curve=None)
    elif problem["curve"] is None:
        raise ConfigError("problem.curve: give a seed curve or problem.points=FILE")
    else:
        check_value("problem.curve", problem["curve"], Setting(values=tuple(sorted(CURVES))))
    if problem["name"] is None:
        problem["name"] = instance.id if instance is not None else \
            problem["curve"] or Path(problem["points"]).stem
    problem["fingerprint"] = _check_fingerprint(problem["points"], problem["fingerprint"])
    if not problem.get("closed"):  # only when set, so the run ids of open problems stay
        problem.pop("closed", None)

    kind = check_value("encoding.kind", top["encoding"].get("kind"),
                       Setting(values=tuple(ENCODINGS)))
    encoding = check_section("encoding", top["encoding"],
                             encoding_schema(kind, problem["degree"]))
    if isinstance(encoding.get("n_knots"), str) and encoding["n_knots"] != "max":
        encoding["n_knots"] = f"fitpack:{_fitpack_factor(encoding['n_knots'])!r}"
    objective, _ = _named("objective", top["objective"], "name",
                          Setting(values=tuple(OBJECTIVES)), OBJECTIVES.__getitem__)
    if problem.get("task") is not None:  # the suite's task decides encoding and objective
        if instance is None:
            raise ConfigError("problem.task: a suite task needs a suite instance "
                              "(problem=suite problem.instance=ID)")
        from metaknot.suite.tasks import get_task

        with naming("problem.task"):
            task = get_task(instance, str(problem["task"]))
        problem["task"] = task.id
        encoding, objective = dict(task.encoding), dict(task.objective)
    optimizer, cls = _named("optimizer", top["optimizer"], "_name_", Setting(
        (str,), expect="the name of a registered optimizer"), _optimizer_class)
    top.update(problem=problem, encoding=encoding, objective=objective, optimizer=optimizer)
    config = {key: top[key] for key in RUN_KEYS}
    spec = RunSpec(config=config, run_id=run_id(config), study=top["study"],
                   results_dir=Path(top["results_dir"]), threads=top["threads"],
                   progress=top["progress"], label=top["label"] or optimizer["_name_"],
                   _optimizer_class=cls)
    if check_build:
        spec.build_optimizer()
        spec.build_problem(noise=False)
    return spec


def plain_config(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """A resolved plain-dict copy of a DictConfig (or mapping), without Hydra's own node."""
    from omegaconf import DictConfig, OmegaConf
    from omegaconf.errors import MissingMandatoryValue

    if not isinstance(cfg, DictConfig):
        return {key: value for key, value in _deep_copy(cfg).items() if key != "hydra"}
    try:  # each value resolved in the context of the whole configuration
        out: dict[Any, Any] = {
            key: OmegaConf.to_container(value, resolve=True, throw_on_missing=True)
            if OmegaConf.is_config(value) else value
            for key, value in cfg.items() if key != "hydra"}
    except MissingMandatoryValue as exc:
        raise ConfigError(f"{exc.full_key}: required, no value given") from None
    return out


def _deep_copy(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _deep_copy(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_deep_copy(v) for v in value]
    return value


def _check_fingerprint(points: str | None, stored: Any) -> str | None:
    """The data file's digest (SHA-256, 16 hex digits); a stored one (a configuration read back
    from a record) must match it, or the file changed since the run."""
    if points is None:
        return None
    from metaknot.problems import check_points_file

    with naming("problem.points"):  # its kind and size from its first bytes, before the
        check_points_file(points)     # digest reads it through
    with open(points, "rb") as file:  # read in blocks; a changed file gives new run ids
        digest = hashlib.file_digest(file, "sha256").hexdigest()[:16]
    if stored is not None and stored != digest:
        raise ConfigError(f"problem.points: {points} changed since the run was configured "
                          f"(fingerprint {digest}, recorded {stored})")
    return digest
