""":func:`tune_spec`: a tuning study's configuration (``metaknot tune``), validated."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..errors import ConfigError, naming
from ..spec import (
    NULL,
    PROBLEM,
    RUN,
    SECTION,
    STUDY,
    Setting,
    _optimizer_class,
    _unknown,
    check_section,
    check_value,
    plain_config,
    run_spec,
    signature_settings,
)
from .space import ENCODING_CHOICES, SearchSpace
from .study import Instance, TuneSpec

__all__ = ["TRAIN_SEED_OFFSET", "tune_spec"]

#: Training replicate seeds are ``TRAIN_SEED_OFFSET + i``; test seeds are ``0 .. n - 1`` with
#: ``n <= TRAIN_SEED_OFFSET``: the two never meet.
TRAIN_SEED_OFFSET = 1_000_000
SPLIT = Setting((Mapping,), expect="a mapping with instances and seeds")
#: The settings of a tuning study (others are refused, not ignored).
TUNE = {**STUDY, "tune": SECTION, "n_trials": Setting((int,), low=1),
        "timeout": Setting((float, NULL), None, 0.0), "workers": Setting((int,), 1, 1),
        "worker_index": Setting((int,), 0, 0),
        "storage": Setting((str, NULL), None, test=lambda url: url != "", expect="null, "
                           "journal, journal:<file> or an Optuna storage URL"),
        "seed": Setting((int,), 0, 0),
        "sampler": Setting((), "tpe", values=("tpe", "random")),
        "pruner": Setting((), "median", values=("median", "percentile", "successive_halving",
                                                "hyperband", "none")),
        "budget": RUN["budget"], "objective": SECTION,
        "reference": Setting((str,), "averaging", expect="an optimizer's name"),
        "train": SPLIT, "test": SPLIT,
        "compare_with": Setting((str, list, NULL), None, expect="an optimizer's name or a list"),
        "evaluate": Setting((bool,), True), "heartbeat_interval": Setting((int,), 10, 1),
        "grace_period": Setting((int,), 30, lambda top: top["heartbeat_interval"] + 1),
        "max_retry": Setting((int,), 2, 0),
        "degree": PROBLEM["degree"], "parameterization": PROBLEM["parameterization"]}
TUNE_SECTION = {"optimizer": Setting((str,), expect="an optimizer's name"),
                "encoding": Setting((dict, NULL), None), "space": Setting((object,), None),
                "fixed": Setting((dict, NULL), None,
                                 expect="a mapping of hyperparameters to values")}
INSTANCES = {"instances": Setting((object,)),
             "seeds": Setting((int,), low=1, high=TRAIN_SEED_OFFSET)}
INSTANCE_LIST = Setting((list,), test=bool, expect="suite:<split> or a non-empty list of "
                        "{curve, noise} or {suite: ID}")
INSTANCE = Setting((Mapping,), expect="a mapping {curve: ..., noise: ...} or {suite: ID}")


def _instances(section: str, cfg: Any) -> tuple[tuple[Instance, ...], int]:
    from metaknot.problems import CURVES
    from metaknot.suite import get_instance

    checked = check_section(section, cfg, INSTANCES)
    items = checked["instances"]
    if isinstance(items, str) and items.startswith("suite:"):  # a split of the suite
        from metaknot.suite.splits import split

        with naming(f"{section}.instances"):
            items = [{"suite": i} for i in split(items[len("suite:"):])]
    check_value(f"{section}.instances", items, INSTANCE_LIST)
    curve = {"curve": Setting(values=tuple(sorted(CURVES))), "noise": PROBLEM["noise"]}
    out = []
    for i, item in enumerate(items):
        key = f"{section}.instances[{i}]"
        if "suite" in check_value(key, item, INSTANCE):
            suite = check_section(key, item, {"suite": Setting((object,))})["suite"]
            with naming(f"{key}.suite"):
                out.append(Instance(None, 0.0, get_instance(str(suite)).id))
        else:
            out.append(Instance(**check_section(key, item, curve)))
    if len(set(out)) != len(out):
        raise ConfigError(f"{section}.instances: an instance is listed twice")
    return tuple(out), checked["seeds"]


def tune_spec(cfg: Mapping[str, Any]) -> TuneSpec:
    """Validate a ``metaknot tune`` configuration (plain mapping or DictConfig).

    Raises
    ------
    ConfigError
        One line naming the first key that cannot work: an empty or contradictory search space,
        a parameter the optimizer does not have, overlapping training and test instances,
        ``n_trials < 1``, ...
    """
    raw = plain_config(cfg)
    top = check_section("", raw, TUNE)
    tune = check_section("tune", top["tune"], TUNE_SECTION)
    optimizer = tune["optimizer"]
    names = set(signature_settings(_optimizer_class(optimizer, "tune.optimizer")))
    space = SearchSpace(tune["space"], names, optimizer)
    fixed = tune["fixed"] or {}
    both = set(fixed) & set(space.names())
    if both:
        raise ConfigError(f"tune.fixed: {', '.join(sorted(both))} also in tune.space "
                          "(fixed and searched at once)")
    _unknown("tune.fixed", fixed, names)
    encoding = dict(tune["encoding"] or {"kind": "mask"})
    check_value("tune.encoding.kind", encoding.get("kind"), Setting(values=ENCODING_CHOICES))
    objective = dict(top["objective"])
    train, n_train = _instances("train", top["train"])
    test, n_test = _instances("test", top["test"])
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
        check_section("objective", objective, {"task": Setting((object,))})
        from metaknot.suite.tasks import get_task

        for instance in (*train, *test):
            if instance.suite is None:
                raise ConfigError(f"objective.task: the task of a suite instance; "
                                  f"{instance.key} is not one (give name: and its options)")
            with naming("objective.task"):
                get_task(instance.suite, str(objective["task"]))
    compare = top["compare_with"] or []
    compare = [compare] if isinstance(compare, str) else compare
    for name in compare:
        _optimizer_class(name, "compare_with")
    settings = {key: top[key] for key in TUNE if key in TuneSpec.__dataclass_fields__}
    spec = TuneSpec(**{**settings, "results_dir": Path(top["results_dir"]),
                       "optimizer": optimizer, "space": space, "fixed": dict(fixed),
                       "encoding": encoding, "objective": objective, "train": train,
                       "train_seeds": tuple(TRAIN_SEED_OFFSET + i for i in range(n_train)),
                       "test": test, "test_seeds": tuple(range(n_test)),
                       "reference": _optimizer_class(top["reference"], "reference").name,
                       "compare_with": tuple(compare), "raw": raw})
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
