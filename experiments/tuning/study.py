"""A checked tuning study: its instances, the settings that identify its trials, and the
``metaknot run`` configurations of its runs and trials.

:func:`~.spec.tune_spec` checks a ``metaknot tune`` configuration and returns a
:class:`TuneSpec`; nothing here checks settings again.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .space import SearchSpace

__all__ = ["Instance", "TuneSpec"]


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
    seed: int  # the other settings and their defaults: TUNE
    sampler: str
    pruner: str
    storage: str | None
    workers: int
    worker_index: int
    timeout: float | None
    evaluate: bool
    heartbeat_interval: int
    grace_period: int
    max_retry: int
    degree: int
    parameterization: str
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
