"""The validated configuration of a tuning study (``metaknot tune``)."""

from __future__ import annotations

import copy
import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..spec import (
    ConfigError,
    _bool,
    _choice,
    _float,
    _int,
    _optimizer_class,
    _section,
    _unknown,
    check_study,
    run_spec,
)
from .space import SearchSpace

__all__ = ["TRAIN_SEED_OFFSET", "Instance", "TuneSpec", "tune_spec"]

#: Training replicate seeds are ``TRAIN_SEED_OFFSET + i``; test seeds are ``0 .. n - 1`` with
#: ``n <= TRAIN_SEED_OFFSET``: the two never meet.
TRAIN_SEED_OFFSET = 1_000_000
SAMPLERS = ("tpe", "random")
PRUNERS = ("median", "percentile", "successive_halving", "hyperband", "none")
KEYS = {"study", "results_dir", "tune", "n_trials", "timeout", "workers", "worker_index",
        "storage", "seed", "sampler", "pruner", "budget", "objective", "reference",
        "train", "test", "compare_with", "evaluate", "heartbeat_interval", "grace_period",
        "max_retry", "degree", "parameterization"}


@dataclass(frozen=True)
class Instance:
    """A problem instance: a seed curve with a noise level, or an instance of the benchmark
    suite by id (``suite``, its noise part of the id)."""

    curve: str | None
    noise: float = 0.0
    suite: str | None = None

    @property
    def key(self) -> str:
        return self.suite if self.suite is not None else f"{self.curve}/noise={self.noise:g}"

    @property
    def base(self) -> str:
        """The instance without its noise: held-out instances must differ in this."""
        if self.suite is None:
            return str(self.curve)
        from metaknot.suite import get_instance

        return get_instance(self.suite).base_id


@dataclass(frozen=True)
class TuneSpec:
    """Everything a tuning study needs, validated (see :func:`tune_spec`)."""

    study: str
    results_dir: Path
    optimizer: str
    space: SearchSpace
    fixed: dict[str, Any]
    encoding: dict[str, Any]
    objective: dict[str, Any]
    budget: int
    n_trials: int
    train: tuple[Instance, ...]
    train_seeds: tuple[int, ...]
    test: tuple[Instance, ...]
    test_seeds: tuple[int, ...]
    reference: str
    compare_with: tuple[str, ...]
    seed: int = 0
    sampler: str = "tpe"
    pruner: str = "median"
    storage: str | None = None
    workers: int = 1
    worker_index: int = 0
    timeout: float | None = None
    evaluate: bool = True
    heartbeat_interval: int = 10
    grace_period: int = 30
    max_retry: int = 2
    degree: int = 3
    parameterization: str = "centripetal"
    raw: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def study_dir(self) -> Path:
        return self.results_dir / self.study

    @property
    def test_study(self) -> str:
        """The held-out study's name in the results store."""
        return f"{self.study}-test"

    def identity(self) -> dict[str, Any]:
        """The settings that define the study's trials (a resumed study must match them)."""
        keys = ("tune", "budget", "objective", "reference", "train", "degree",
                "parameterization")
        return copy.deepcopy({k: self.raw.get(k) for k in keys})

    def run_config(self, instance: Instance, seed: int, *, optimizer: str | None = None,
                   params: Mapping[str, Any] | None = None,
                   encoding: Mapping[str, Any] | None = None, study: str | None = None,
                   threads: int | str = "auto") -> dict[str, Any]:
        """A ``metaknot run`` configuration of one run (for :func:`~..spec.run_spec`)."""
        problem = {"curve": instance.curve, "noise": instance.noise, "degree": self.degree,
                   "parameterization": self.parameterization}
        objective = dict(self.objective)
        if instance.suite is not None:
            problem.update(curve=None, points=None, instance=instance.suite)
            if "task" in objective:  # the objective of the instance's task
                from metaknot.suite.tasks import get_task

                objective = dict(get_task(instance.suite, objective["task"]).objective)
        return {
            "study": study or self.study, "results_dir": str(self.results_dir),
            "problem": problem,
            "encoding": dict(encoding or self.encoding),
            "objective": objective,
            "optimizer": {"_name_": optimizer or self.optimizer,
                          **(self.fixed if params is None else params)},
            "budget": self.budget, "seed": seed, "threads": threads, "progress": False,
        }

    def trial_setting(self, values: Mapping[str, Any]) -> tuple[dict[str, Any],
                                                                dict[str, Any]]:
        """Optimizer hyperparameters and encoding of a trial's sampled ``values``."""
        values = dict(values)
        encoding = dict(self.encoding)
        kind = values.pop("encoding", None)
        if kind is not None and kind != encoding["kind"]:
            encoding = {"kind": kind} if kind == "indices" else {"kind": kind, "density": 0.5}
        n_knots = values.pop("n_knots", None)
        if encoding["kind"] == "indices":
            encoding["n_knots"] = int(n_knots if n_knots is not None
                                      else encoding.get("n_knots", 20))
        return {**self.fixed, **values}, encoding


def _instances(section: str, cfg: Any) -> tuple[tuple[Instance, ...], int]:
    from metaknot.problems import CURVES

    if not isinstance(cfg, Mapping):
        raise ConfigError(f"{section}: a mapping with instances and seeds")
    _unknown(section, cfg, {"instances", "seeds"})
    items = cfg.get("instances")
    if isinstance(items, str) and items.startswith("suite:"):  # a split of the suite
        from metaknot.suite.splits import split

        try:
            items = [{"suite": i} for i in split(items[len("suite:"):])]
        except ValueError as exc:
            raise ConfigError(f"{section}.instances: {exc}") from None
    if not isinstance(items, list) or not items:
        raise ConfigError(f"{section}.instances: suite:<split> or a non-empty list of "
                          "{curve, noise} or {suite: ID}")
    out = []
    for i, item in enumerate(items):
        key = f"{section}.instances[{i}]"
        if not isinstance(item, Mapping):
            raise ConfigError(f"{key}: a mapping {{curve: ..., noise: ...}} or {{suite: ID}}, "
                              f"got {item!r}")
        if "suite" in item:
            _unknown(key, item, {"suite"})
            from metaknot.suite import get_instance

            try:
                out.append(Instance(None, 0.0, get_instance(str(item["suite"])).id))
            except ValueError as exc:
                raise ConfigError(f"{key}.suite: {exc}") from None
            continue
        _unknown(key, item, {"curve", "noise"})
        curve = _choice(f"{key}.curve", item.get("curve"), tuple(sorted(CURVES)))
        out.append(Instance(curve, _float(f"{key}.noise", item.get("noise", 0.0), low=0.0)))
    if len(set(out)) != len(out):
        raise ConfigError(f"{section}.instances: an instance is listed twice")
    return tuple(out), _int(f"{section}.seeds", cfg.get("seeds"), low=1,
                            high=TRAIN_SEED_OFFSET)


def tune_spec(cfg: Mapping[str, Any]) -> TuneSpec:
    """Validate a ``metaknot tune`` configuration (plain mapping or DictConfig).

    Raises
    ------
    ConfigError
        One line naming the first key that cannot work: an empty or contradictory search space,
        a parameter the optimizer does not have, overlapping training and test instances,
        ``n_trials < 1``, ...
    """
    from ..spec import plain_config

    raw = plain_config(cfg)
    _unknown("", raw, KEYS)
    study, results_dir = check_study(raw)
    tune = raw["tune"] = _section(raw, "tune")
    _unknown("tune", tune, {"optimizer", "encoding", "fixed", "space"})
    optimizer = tune.get("optimizer")
    if not isinstance(optimizer, str):
        raise ConfigError(f"tune.optimizer: an optimizer's name, got {optimizer!r}")
    cls = _optimizer_class(optimizer)
    names = {p for p in inspect.signature(cls.__init__).parameters if p != "self"}
    space = SearchSpace(tune.get("space"), names, optimizer)
    fixed = tune.get("fixed") or {}
    if not isinstance(fixed, Mapping):
        raise ConfigError("tune.fixed: a mapping of hyperparameters to values")
    both = set(fixed) & set(space.names())
    if both:
        raise ConfigError(f"tune.fixed: {', '.join(sorted(both))} also in tune.space "
                          "(fixed and searched at once)")
    unknown = set(fixed) - names
    if unknown:
        raise ConfigError(f"tune.fixed.{sorted(unknown)[0]}: {optimizer!r} has no such "
                          "hyperparameter")
    encoding = dict(tune.get("encoding") or {"kind": "mask"})
    if encoding.get("kind") not in ("mask", "indices"):
        raise ConfigError(f"tune.encoding.kind: mask or indices, got {encoding.get('kind')!r}")
    objective = _section(raw, "objective")
    train, n_train = _instances("train", raw.get("train"))
    test, n_test = _instances("test", raw.get("test"))
    overlap = set(train) & set(test)
    if overlap:
        raise ConfigError(f"test.instances: {sorted(i.key for i in overlap)[0]} is also a "
                          "training instance; a tuned configuration must be judged on "
                          "instances the tuner never saw")
    seen = {i.base for i in train if i.suite is not None}
    leaked = sorted(i.key for i in test if i.suite is not None and i.base in seen)
    if leaked:
        raise ConfigError(f"test.instances: {leaked[0]} is a training instance with other "
                          "noise; judge on instances the tuner never saw (suite:test)")
    if "task" in objective:
        _unknown("objective", objective, {"task"})
        from metaknot.suite.tasks import get_task

        for instance in (*train, *test):
            if instance.suite is None:
                raise ConfigError(f"objective.task: the task of a suite instance; "
                                  f"{instance.key} is not one (give name: and its options)")
            try:
                get_task(instance.suite, str(objective["task"]))
            except ValueError as exc:
                raise ConfigError(f"objective.task: {exc}") from None
    compare = raw.get("compare_with") or []
    if isinstance(compare, str):
        compare = [compare]
    for name in compare:
        _optimizer_class(name)
    sampler = _choice("sampler", raw.get("sampler", "tpe"), SAMPLERS)
    pruner = _choice("pruner", raw.get("pruner", "median"), PRUNERS)
    storage = raw.get("storage")
    if storage is not None and (not isinstance(storage, str) or not storage):
        raise ConfigError(f"storage: null, journal, journal:<file> or an Optuna storage URL, "
                          f"got {storage!r}")
    timeout = _float("timeout", raw.get("timeout"), low=0.0, optional=True)
    evaluate = _bool("evaluate", raw.get("evaluate", True))
    spec = TuneSpec(
        study=study, results_dir=Path(results_dir), optimizer=optimizer, space=space,
        fixed=dict(fixed), encoding=encoding, objective=objective,
        budget=_int("budget", raw.get("budget"), low=1),
        n_trials=_int("n_trials", raw.get("n_trials"), low=1),
        train=train, train_seeds=tuple(TRAIN_SEED_OFFSET + i for i in range(n_train)),
        test=test, test_seeds=tuple(range(n_test)),
        reference=_optimizer_class(raw.get("reference", "averaging")).name,
        compare_with=tuple(compare), seed=_int("seed", raw.get("seed", 0), low=0),
        sampler=sampler, pruner=pruner, storage=storage,
        workers=_int("workers", raw.get("workers", 1), low=1),
        worker_index=_int("worker_index", raw.get("worker_index", 0), low=0),
        timeout=timeout, evaluate=evaluate,
        heartbeat_interval=_int("heartbeat_interval", raw.get("heartbeat_interval", 10), low=1),
        grace_period=_int("grace_period", raw.get("grace_period", 30), low=1),
        max_retry=_int("max_retry", raw.get("max_retry", 2), low=0),
        degree=_int("degree", raw.get("degree", 3), low=1, high=5),
        parameterization=raw.get("parameterization", "centripetal"), raw=raw,
    )
    if spec.grace_period <= spec.heartbeat_interval:
        raise ConfigError(f"grace_period: longer than heartbeat_interval "
                          f"({spec.heartbeat_interval} s), got {spec.grace_period}")
    # every setting must build: defaults and the fixed values, on every instance
    for instance in (*train, *test):
        run_spec(spec.run_config(instance, 0))
        run_spec(spec.run_config(instance, 0, optimizer=spec.reference, params={}))
    for name in compare:
        run_spec(spec.run_config(test[0], 0, optimizer=name, params={}))
    if "encoding" in space.parameters and "n_knots" not in space.parameters \
            and "indices" in space.parameters["encoding"].choices \
            and "n_knots" not in encoding:
        raise ConfigError("tune.space: encoding may be indices but neither tune.space.n_knots "
                          "nor tune.encoding.n_knots gives K")
    return spec
