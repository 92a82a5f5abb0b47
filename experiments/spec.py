"""From a study configuration to one validated, reproducible run.

:func:`run_spec` checks a composed configuration (Hydra's, or a plain mapping of the same shape)
and returns a :class:`RunSpec`: the normalised settings, the run id, and builders for the problem
and the optimizer. Every check names the configuration key it is about, in one line
(:class:`ConfigError`), so a bad sweep fails before any run starts.

Seeds are paired: the replicate seed ``s`` gives the data noise ``SeedSequence(s,
spawn_key=(0,))`` and the optimizer ``SeedSequence(s, spawn_key=(1,))``, so replicate ``s`` of
every optimizer sees the same data and comparisons can be paired by replicate.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import re
import tempfile
import types
import typing
from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, overload

import numpy as np
from hydra.errors import CompactHydraException

from metaknot.validate import is_integer, is_real

__all__ = ["ENCODINGS", "ConfigError", "RunSpec", "objective_defaults", "optimizer_defaults",
           "plain_config", "run_spec", "signature_defaults"]

#: Encoding name in the configuration -> (problem's registry name, encoding kind).
ENCODINGS = {"mask": ("mask", "binary"), "indices": ("indices", "integer"),
             "free": ("free", "continuous")}
#: Top-level keys that define a run (the run id hashes them, normalised).
RUN_KEYS = ("problem", "encoding", "objective", "optimizer", "budget", "seed",
            "checkpoints_per_decade")
#: Every top-level key of a run configuration (others are refused, not ignored).
CONFIG_KEYS = frozenset({*RUN_KEYS, "study", "label", "results_dir", "threads", "progress"})
PARAMETERIZATIONS = ("uniform", "chord", "centripetal")
STUDY_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.=,+-]*")  # matched in full (fullmatch)
FITPACK_COUNT = re.compile(r"^fitpack:(.+)$")


class ConfigError(ValueError, CompactHydraException):
    """A configuration value that cannot work; the message names the key, in one line."""


# --------------------------------------------------------------------------------------------
# small checks


@overload
def _int(key: str, value: Any, *, low: int | None = ..., high: int | None = ...,
         optional: Literal[False] = ...) -> int: ...
@overload
def _int(key: str, value: Any, *, low: int | None = ..., high: int | None = ...,
         optional: bool) -> int | None: ...
def _int(key: str, value: Any, *, low: int | None = None, high: int | None = None,
         optional: bool = False) -> int | None:
    if value is None and optional:
        return None
    if not is_integer(value):
        raise ConfigError(f"{key}: expected an integer, got {value!r}")
    if low is not None and value < low:
        raise ConfigError(f"{key}: must be >= {low}, got {value!r}")
    if high is not None and value > high:
        raise ConfigError(f"{key}: must be <= {high}, got {value!r}")
    return int(value)


@overload
def _float(key: str, value: Any, *, low: float | None = ..., high: float | None = ...,
           optional: Literal[False] = ...) -> float: ...
@overload
def _float(key: str, value: Any, *, low: float | None = ..., high: float | None = ...,
           optional: bool) -> float | None: ...
def _float(key: str, value: Any, *, low: float | None = None, high: float | None = None,
           optional: bool = False) -> float | None:
    if value is None and optional:
        return None
    if not is_real(value):
        raise ConfigError(f"{key}: expected a number, got {value!r}")
    value = float(value)
    if not np.isfinite(value):
        raise ConfigError(f"{key}: must be finite, got {value!r}")
    if low is not None and value < low:
        raise ConfigError(f"{key}: must be >= {low}, got {value!r}")
    if high is not None and value > high:
        raise ConfigError(f"{key}: must be <= {high}, got {value!r}")
    return value


def _choice(key: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise ConfigError(f"{key}: must be one of {', '.join(choices)}; got {value!r}")
    return str(value)


def not_a_setting(args: list[str], example: str) -> str | None:
    """The first of ``args`` that is neither a setting (``key=value``, ``~key``) nor an option,
    as a one-line error showing ``example``, or ``None``: a bare word (a file name, say) got
    Hydra's "missing EQUAL at '<EOF>'"."""
    for arg in args:
        if "=" not in arg and not arg.startswith(("-", "~")):
            return f"{arg!r} is not a setting: settings are key=value, e.g. {example}"
    return None


def _bool(key: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{key}: true or false, got {value!r}")
    return value


def _section(cfg: Mapping[str, Any], key: str) -> dict[str, Any]:
    value = cfg.get(key)
    if not isinstance(value, Mapping):
        raise ConfigError(f"{key}: missing or not a group of settings (got {value!r})")
    return dict(value)


def _unknown(key: str, given: Mapping[str, Any], known: AbstractSet[str]) -> None:
    extra = sorted(set(given) - known)
    if extra:
        name = f"{key}.{extra[0]}" if key else extra[0]
        raise ConfigError(f"{name}: unknown setting (known: {', '.join(sorted(known))})")


# --------------------------------------------------------------------------------------------
# optimizers: hyperparameters and their types from the optimizer's signature


def _optimizer_class(name: str) -> Any:  # a registered optimizer class
    from metaknot.registry import _lookup

    try:
        return _lookup("optimizer", name)
    except ValueError as exc:
        raise ConfigError(f"optimizer._name_: {exc}") from None


def signature_defaults(cls: type[Any]) -> dict[str, Any]:
    """The keyword arguments of ``cls.__init__`` with their defaults (``"???"``: required; a
    default that is not a plain value as its ``repr``): the settings of a config node."""
    out: dict[str, Any] = {}
    for p in inspect.signature(cls.__init__).parameters.values():
        if p.name == "self" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        default = p.default
        if default is inspect.Parameter.empty:
            out[p.name] = "???"
        elif default is None or isinstance(default, bool | int | float | str):
            out[p.name] = default
        else:
            out[p.name] = repr(default)
    return out


def optimizer_defaults(name: str) -> dict[str, Any]:
    """Hyperparameters of a registered optimizer with their defaults, read from its
    signature (:func:`signature_defaults`): the config node ``optimizer=<name>``."""
    return {"_name_": name, **signature_defaults(_optimizer_class(name))}


def objective_defaults(name: str) -> dict[str, Any]:
    """Settings of an objective with their defaults, read from its signature
    (:func:`signature_defaults`): the config node ``objective=<name>``."""
    from metaknot.problems import OBJECTIVES

    return {"name": name, **signature_defaults(OBJECTIVES[name])}


def _allowed_types(hint: Any) -> tuple[set[type], set[Any]] | None:
    """Python types (and Literal values) a hint admits; ``None`` when it cannot be told."""
    origin = typing.get_origin(hint)
    if hint is Any:
        return None
    if origin is typing.Literal:
        return set(), set(typing.get_args(hint))
    if origin in (typing.Union, types.UnionType):
        types_, literals = set(), set()
        for arg in typing.get_args(hint):
            sub = _allowed_types(arg)
            if sub is None:
                return None
            types_ |= sub[0]
            literals |= sub[1]
        return types_, literals
    if hint is type(None) or hint is None:
        return {type(None)}, set()
    if isinstance(hint, type):
        return {hint}, set()
    return None


def _check_hyperparameter(key: str, value: Any, hint: Any) -> Any:
    allowed = _allowed_types(hint)
    if allowed is None:
        return value
    kinds, literals = allowed
    if not isinstance(value, bool | float | list | dict) and any(
            value == v for v in literals):
        return value
    if value is None:
        if type(None) in kinds:
            return None
    elif isinstance(value, bool):
        if bool in kinds:
            return value
    elif isinstance(value, int):
        if int in kinds:
            return value
        if float in kinds:
            return float(value)
    elif isinstance(value, float):
        if float in kinds:
            return value
        if int in kinds and value.is_integer():
            return int(value)
    elif isinstance(value, str) and str in kinds:
        return value
    names = sorted({"null" if k is type(None) else k.__name__ for k in kinds}
                   | {repr(v) for v in literals})
    raise ConfigError(f"{key}: expected {' or '.join(names)}, got {value!r}")


def _optimizer(cfg: dict[str, Any]) -> tuple[str, dict[str, Any], type]:
    name = cfg.pop("_name_", None)
    if not isinstance(name, str):
        raise ConfigError(f"optimizer._name_: the name of a registered optimizer, got {name!r}")
    cls = _optimizer_class(name)
    return name, _check_signature("optimizer", cls, cfg), cls


def _check_signature(group: str, cls: type[Any], cfg: dict[str, Any]) -> dict[str, Any]:
    """``cfg`` checked against the keyword arguments of ``cls``: no unknown keys, values of the
    annotated types, defaults filled in."""
    signature = inspect.signature(cls.__init__)
    try:
        hints = typing.get_type_hints(cls.__init__)
    except Exception:  # unresolvable annotations of a plugin: check values by instantiation only
        hints = {}
    known = {p for p in signature.parameters if p != "self"}
    _unknown(group, cfg, known)
    params = {}
    for pname, value in cfg.items():
        if value == "???":
            raise ConfigError(f"{group}.{pname}: required, no value given")
        params[pname] = _check_hyperparameter(f"{group}.{pname}", value, hints.get(pname, Any))
    for pname, p in signature.parameters.items():
        if pname == "self" or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        if pname not in params:
            if p.default is inspect.Parameter.empty:
                raise ConfigError(f"{group}.{pname}: required, no value given")
            params[pname] = p.default
    return params


# --------------------------------------------------------------------------------------------
# the run


@dataclass(frozen=True)
class RunSpec:
    """A validated run: normalised settings, identity and builders.

    Attributes
    ----------
    config
        The normalised run-defining settings (problem, encoding, objective, optimizer, budget,
        seed, checkpoints_per_decade), plain values only.
    run_id
        Stable hash of :attr:`config`: the same settings and seed give the same id, in any
        process, on any machine.
    study, results_dir
        Where the run is stored (``results_dir/study``).
    label
        The method's name in reports (``label`` in the configuration, else the optimizer's
        name); not part of the run's identity.
    threads, progress
        Execution settings (not part of the run's identity).
    """

    config: dict[str, Any]
    run_id: str
    study: str
    results_dir: Path
    threads: int | str = "auto"
    progress: bool | str = "auto"
    label: str = ""
    _optimizer_class: type | None = field(default=None, repr=False, compare=False)

    @property
    def study_dir(self) -> Path:
        return self.results_dir / self.study

    @property
    def optimizer(self) -> str:
        """The optimizer's registered name."""
        return self.config["optimizer"]["_name_"]

    @property
    def seed(self) -> int:
        return self.config["seed"]

    @property
    def budget(self) -> int:
        return self.config["budget"]

    def optimizer_seed(self) -> np.random.SeedSequence:
        """The optimizer's seed: child 1 of the replicate seed."""
        return np.random.SeedSequence(self.seed, spawn_key=(1,))

    def noise_seed(self) -> np.random.SeedSequence:
        """The data noise's seed: child 0 of the replicate seed, or ``problem.noise_seed``."""
        fixed = self.config["problem"]["noise_seed"]
        if fixed is not None:
            return np.random.SeedSequence(fixed)
        return np.random.SeedSequence(self.seed, spawn_key=(0,))

    def compatible(self) -> str | None:
        """``None`` if the optimizer handles the encoding, else the reason it cannot."""
        kind = ENCODINGS[self.config["encoding"]["kind"]][1]
        if self.config["encoding"].get("max_multiplicity", 1) > 1:
            kind = "integer"  # a multiplicity per data point
        encodings = getattr(self._optimizer_class, "encodings", ())
        if kind not in encodings:
            return (f"optimizer {self.optimizer!r} handles {', '.join(encodings)} encodings; "
                    f"encoding {self.config['encoding']['kind']!r} is {kind}")
        objective = self.config["objective"]["name"]
        if objective == "pareto" and not self.build_optimizer().multi_objective:
            return (f"optimizer {self.optimizer!r} minimises one objective; objective "
                    "'pareto' needs a multi-objective one (pymoo with variant=NSGA2)")
        return None

    def suite_fields(self) -> dict[str, str]:
        """``suite.instance``, ``suite.family`` and ``suite.task`` (when set) of a run on a
        suite instance, for its record; empty for other runs."""
        problem = self.config["problem"]
        if problem.get("instance") is None:
            return {}
        from metaknot.suite import get_instance

        fields = {"suite.instance": problem["instance"],
                  "suite.family": get_instance(problem["instance"]).family}
        if problem.get("task") is not None:
            fields["suite.task"] = problem["task"]
        return fields

    def build_problem(self, *, noise: bool = True):
        """The problem of this run (with the replicate's noise unless ``noise=False``)."""
        return _build_problem(self.config, self.noise_seed() if noise else None)

    def build_curve(self, *, noise: bool = True):
        """The data of this run as its curve model (:func:`metaknot.bspline.curve.make_curve`):
        the points, with the replicate's noise unless ``noise=False``, and their parameters,
        as the run's problem has them (without building the problem)."""
        from metaknot.bspline.curve import make_curve

        problem = self.config["problem"]
        data = _build_data(self.config, self.noise_seed() if noise else None)
        try:
            return make_curve(data.points, degree=problem["degree"],
                              parameterization=problem["parameterization"],
                              closed=problem.get("closed", False), params=data.params)
        except ValueError as exc:
            raise ConfigError(f"problem: {exc}") from None

    def build_optimizer(self):
        """The optimizer of this run, with its hyperparameters."""
        from metaknot.registry import get_optimizer

        params = {k: v for k, v in self.config["optimizer"].items() if k != "_name_"}
        try:
            return get_optimizer(self.optimizer, **params)
        except (ValueError, TypeError) as exc:
            raise ConfigError(f"optimizer ({self.optimizer}): {exc}") from None


def _suite_instance(problem: Mapping[str, Any]) -> Any:
    """The suite instance ``problem.instance`` names (``None`` if it names none)."""
    name = problem.get("instance")
    if name is None:
        return None
    if problem.get("points") is not None or problem.get("curve") is not None:
        raise ConfigError("problem.instance: a suite instance replaces problem.curve and "
                          "problem.points; leave those null (problem=suite does)")
    from metaknot.suite import get_instance

    try:
        return get_instance(str(name))
    except ValueError as exc:
        raise ConfigError(f"problem.instance: {exc}") from None


def _suite_task(problem: Mapping[str, Any], instance: Any) -> Any:
    """The suite task ``problem.task`` names on ``instance`` (``None`` if it names none)."""
    name = problem.get("task")
    if name is None:
        return None
    if instance is None:
        raise ConfigError("problem.task: a suite task needs a suite instance "
                          "(problem=suite problem.instance=ID)")
    from metaknot.suite.tasks import get_task

    try:
        return get_task(instance, str(name))
    except ValueError as exc:
        raise ConfigError(f"problem.task: {exc}") from None


def check_study(cfg: Mapping[str, Any]) -> tuple[str, str]:
    """The configuration's ``study`` name and ``results_dir``, checked."""
    study = cfg.get("study")
    if not isinstance(study, str) or not STUDY_NAME.fullmatch(study):
        raise ConfigError(f"study: a name of letters, digits and _.=,+- (no slashes), "
                          f"got {study!r}")
    results_dir = cfg.get("results_dir")
    if not isinstance(results_dir, str) or not results_dir:
        raise ConfigError(f"results_dir: a directory path, got {results_dir!r}")
    try:
        if not os.path.isdir(os.path.realpath(results_dir, strict=True)):
            raise ConfigError(f"results_dir: {results_dir} is not a folder")
    except FileNotFoundError:
        pass  # made when the first run is stored
    except OSError as exc:  # a loop of symbolic links, a folder without permission, ...
        raise ConfigError(f"results_dir: {results_dir} cannot be used: "
                          f"{os.strerror(exc.errno) if exc.errno else exc}") from None
    return study, results_dir


def check_writable(folder: Path) -> None:
    """Raise a :class:`ConfigError` naming ``folder`` unless a file can be written there (in
    its nearest existing parent if it does not exist yet): a read-only results folder is found
    before any run is computed, not after each one."""
    existing = folder
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as exc:
        raise ConfigError(f"results_dir: cannot write into {existing} "
                          f"({exc.strerror or exc}); nothing was run") from None


def run_spec(cfg: Mapping[str, Any], *, check_build: bool = True) -> RunSpec:
    """Validate a run configuration and return its :class:`RunSpec`.

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
    cfg = plain_config(cfg)
    _unknown("", cfg, CONFIG_KEYS)
    study, results_dir = check_study(cfg)
    threads = cfg.get("threads", "auto")
    if threads != "auto":
        threads = _int("threads", threads, low=1)
    progress = cfg.get("progress", "auto")
    if progress not in ("auto", True, False):
        raise ConfigError(f"progress: auto, true or false; got {progress!r}")

    problem = _section(cfg, "problem")
    _unknown("problem", problem, {"name", "curve", "points", "params_column", "n_points",
                                  "noise", "noise_seed", "degree", "parameterization",
                                  "fingerprint", "closed", "instance", "task"})
    from metaknot.problems import CURVES

    points: Any  # a file name (checked below)
    curve, points = problem.get("curve"), problem.get("points")
    instance = _suite_instance(problem)
    if instance is not None:
        curve = points = None
    elif points is not None:
        if not isinstance(points, str) or points == "???":
            raise ConfigError(f"problem.points: a .csv or .npy file, got {points!r}")
        if not Path(points).is_file():
            raise ConfigError(f"problem.points: file not found: {points}")
        points = str(Path(points).resolve())
        curve = None
    elif curve is None:
        raise ConfigError("problem.curve: give a seed curve or problem.points=FILE")
    else:
        curve = _choice("problem.curve", curve, tuple(sorted(CURVES)))
    degree = _int("problem.degree", problem.get("degree", 3), low=1, high=5)
    name = problem.get("name")
    if name is None:
        name = instance.id if instance is not None else curve if curve is not None else \
            Path(points).stem
    elif not isinstance(name, str):
        raise ConfigError(f"problem.name: a label, got {name!r}")
    problem_out = {
        "name": name,
        "curve": curve,
        "points": points,
        "fingerprint": _check_fingerprint(points, problem.get("fingerprint")),
        "params_column": _int("problem.params_column", problem.get("params_column"),
                              optional=True),
        "n_points": _int("problem.n_points", problem.get("n_points"), low=degree + 2,
                         optional=True),
        "noise": _float("problem.noise", problem.get("noise", 0.0), low=0.0),
        "noise_seed": _int("problem.noise_seed", problem.get("noise_seed"), low=0,
                           optional=True),
        "degree": degree,
        "parameterization": _choice("problem.parameterization",
                                    problem.get("parameterization", "centripetal"),
                                    PARAMETERIZATIONS),
    }
    closed = _bool("problem.closed", problem.get("closed", False))
    if instance is not None:  # only when set, as closed: run ids of other problems stay
        problem_out["instance"] = instance.id
        closed = instance.closed
    if closed:  # only when set, so the run ids of open problems stay as they were
        problem_out["closed"] = True

    encoding = _section(cfg, "encoding")
    kind = _choice("encoding.kind", encoding.get("kind"), tuple(ENCODINGS))
    if kind == "mask":
        _unknown("encoding", encoding, {"kind", "density", "max_multiplicity"})
        encoding_out = {"kind": kind, "density": _float("encoding.density",
                                                        encoding.get("density", 0.5),
                                                        low=0.0, high=1.0)}
        multiplicity = _int("encoding.max_multiplicity", encoding.get("max_multiplicity", 1),
                            low=1, high=degree)
        if multiplicity > 1:  # only when set, so the run ids of other runs stay
            encoding_out["max_multiplicity"] = multiplicity
    else:
        known = {"kind", "n_knots"} | ({"variable_count", "merge_spacing"} if kind == "free"
                                       else {"max_multiplicity"})
        _unknown("encoding", encoding, known)
        n_knots = encoding.get("n_knots", 20)
        if n_knots == "max":
            pass  # the most the data allow (N - degree - 1; N - 1 closed), set when built
        elif isinstance(n_knots, str):
            match = FITPACK_COUNT.match(n_knots)
            try:
                factor = float(match.group(1)) if match else None
            except ValueError:
                factor = None
            if factor is None or not np.isfinite(factor) or factor <= 0:
                raise ConfigError(f"encoding.n_knots: an integer, 'max' or 'fitpack:<factor>' "
                                  f"with a factor > 0, got {n_knots!r}")
            n_knots = f"fitpack:{factor!r}"
        else:
            n_knots = _int("encoding.n_knots", n_knots, low=1)
        encoding_out = {"kind": kind, "n_knots": n_knots}
        if kind == "indices":
            multiplicity = _int("encoding.max_multiplicity",
                                encoding.get("max_multiplicity", 1), low=1, high=degree)
            if multiplicity > 1:  # only when set, so the run ids of other runs stay
                encoding_out["max_multiplicity"] = multiplicity
        if kind == "free":
            encoding_out["variable_count"] = _bool("encoding.variable_count",
                                                   encoding.get("variable_count", False))
            merge = _float("encoding.merge_spacing", encoding.get("merge_spacing"), low=0.0,
                           optional=True)
            if merge is not None:  # only when set, so the run ids of other runs stay
                encoding_out["merge_spacing"] = merge

    objective = _section(cfg, "objective")
    from metaknot.problems import OBJECTIVES

    objective_name = _choice("objective.name", objective.pop("name", None),
                             tuple(OBJECTIVES))
    objective_out = {"name": objective_name,
                     **_check_signature("objective", OBJECTIVES[objective_name], objective)}

    task = _suite_task(problem, instance)
    if task is not None:  # the suite's task decides the encoding and the objective
        problem_out["task"] = task.id
        encoding_out, objective_out = dict(task.encoding), dict(task.objective)

    optimizer_name, params, cls = _optimizer(_section(cfg, "optimizer"))
    config = {
        "problem": problem_out,
        "encoding": encoding_out,
        "objective": objective_out,
        "optimizer": {"_name_": optimizer_name, **params},
        "budget": _int("budget", cfg.get("budget"), low=1),
        "seed": _int("seed", cfg.get("seed"), low=0),
        "checkpoints_per_decade": _int("checkpoints_per_decade",
                                       cfg.get("checkpoints_per_decade", 10), low=1),
    }
    label = cfg.get("label")
    if label is not None and not isinstance(label, str):
        raise ConfigError(f"label: a name for reports, got {label!r}")
    spec = RunSpec(config=config, run_id=run_id(config), study=study,
                   results_dir=Path(results_dir), threads=threads, progress=progress,
                   label=label or optimizer_name, _optimizer_class=cls)
    if check_build:
        spec.build_optimizer()
        spec.build_problem(noise=False)
    return spec


def run_id(config: Mapping[str, Any]) -> str:
    """Stable 16-hex-digit hash of the run-defining settings (:data:`RUN_KEYS`, as sorted-key
    JSON)."""
    text = json.dumps({k: config[k] for k in RUN_KEYS}, sort_keys=True, default=str,
                      separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def plain_config(cfg: Mapping[str, Any]) -> dict[str, Any]:
    """A resolved plain-dict copy of a DictConfig (or mapping), without Hydra's own node."""
    from omegaconf import DictConfig, OmegaConf

    out: dict[Any, Any]
    if isinstance(cfg, DictConfig):
        from omegaconf.errors import MissingMandatoryValue

        out = {}
        for key in cfg:
            if key == "hydra":
                continue
            try:
                value = cfg[key]  # resolved in the context of the whole configuration
                out[key] = OmegaConf.to_container(value, resolve=True, throw_on_missing=True) \
                    if OmegaConf.is_config(value) else value
            except MissingMandatoryValue as exc:
                raise ConfigError(f"{exc.full_key}: required, no value given") from None
    else:
        out = _deep_copy(cfg)
    out.pop("hydra", None)
    return out


def _deep_copy(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _deep_copy(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_deep_copy(v) for v in value]
    return value


def _check_fingerprint(points: str | None, stored: Any) -> str | None:
    """The data file's digest; a stored one (a configuration read back from a record) must
    match it, or the file changed since the run."""
    if points is None:
        return None
    from metaknot.problems import check_points_file

    try:  # its kind and size from its first bytes, before the digest reads it through
        check_points_file(points)
    except ValueError as exc:
        raise ConfigError(f"problem.points: {exc}") from None
    digest = _file_digest(points)
    if stored is not None and stored != digest:
        raise ConfigError(f"problem.points: {points} changed since the run was configured "
                          f"(fingerprint {digest}, recorded {stored})")
    return digest


def _file_digest(path: str) -> str:
    """Short SHA-256 of a data file (read in blocks): a changed file gives new run ids."""
    with open(path, "rb") as file:
        return hashlib.file_digest(file, "sha256").hexdigest()[:16]


def _build_data(config: Mapping[str, Any], noise_seed: np.random.SeedSequence | None):
    """The run's data points (a ``PointSet``), with noise when ``noise_seed`` is given."""
    from metaknot.problems import add_noise, get_curve, load_points

    problem = config["problem"]
    try:
        if problem.get("instance") is not None:
            from metaknot.suite import get_instance

            data = get_instance(problem["instance"]).point_set()
        elif problem["points"] is not None:
            data = load_points(problem["points"], params_column=problem["params_column"])
        else:
            kwargs = {} if problem["n_points"] is None else {"n_points": problem["n_points"]}
            data = get_curve(problem["curve"], **kwargs)
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"problem: {exc}") from None
    data = type(data)(data.points, name=problem["name"], params=data.params)
    if problem["noise"] > 0 and noise_seed is not None:
        data = add_noise(data, problem["noise"], noise_seed)
        data = type(data)(data.points, name=problem["name"], params=data.params,
                          noise=data.noise, noise_seed=data.noise_seed)
    return data


def _build_problem(config: Mapping[str, Any], noise_seed: np.random.SeedSequence | None):
    from metaknot.problems import FreeKnots, KnotIndices, KnotSelection, get_objective

    problem, encoding = config["problem"], config["encoding"]
    data = _build_data(config, noise_seed)
    options = dict(config["objective"])
    name = options.pop("name")
    try:
        objective = get_objective(name, **options)
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"objective ({name}): {exc}") from None
    common = {"degree": problem["degree"], "parameterization": problem["parameterization"],
              "objective": objective, "closed": problem.get("closed", False)}
    kind = encoding["kind"]
    try:
        if kind == "mask":
            return KnotSelection(data, density=encoding["density"],
                                 max_multiplicity=encoding.get("max_multiplicity", 1), **common)
        n_knots = encoding["n_knots"]
        if n_knots == "max":
            n_knots = KnotSelection(data, **common).curve.max_interior_knots
        elif isinstance(n_knots, str):
            n_knots = fitpack_count(data, float(n_knots.split(":", 1)[1]), common)
        if kind == "indices":
            return KnotIndices(data, n_knots=n_knots,
                               max_multiplicity=encoding.get("max_multiplicity", 1), **common)
        return FreeKnots(data, n_knots=n_knots, variable_count=encoding["variable_count"],
                         merge_spacing=encoding.get("merge_spacing"), **common)
    except (ValueError, TypeError) as exc:
        raise ConfigError(f"encoding ({kind}): {exc}") from None


def fitpack_count(data, factor: float, common: Mapping[str, Any]) -> int:
    """Interior knots FITPACK places at smoothing ``s = N * factor`` (at least 1)."""
    from metaknot.bspline import fitpack, parameterize

    method = data.params if data.params is not None else common["parameterization"]
    u = parameterize(data.points, method, degree=common["degree"])
    knots = fitpack.interior_knots(u, data.points, common["degree"], data.n_points * factor)
    return max(1, int(knots.size))
