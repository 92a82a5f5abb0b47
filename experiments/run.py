"""One checked run: its identity, its seeds, and the data, problem and optimizer it builds.

:func:`~.spec.run_spec` checks a configuration and returns a :class:`RunSpec`; nothing here
checks settings again. The run id hashes the run-defining settings (:data:`RUN_KEYS`).

Seeds are paired: the replicate seed ``s`` gives the data noise ``SeedSequence(s,
spawn_key=(0,))`` and the optimizer ``SeedSequence(s, spawn_key=(1,))``, so replicate ``s`` of
every optimizer sees the same data and comparisons can be paired by replicate.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .errors import naming

__all__ = ["ENCODINGS", "RUN_KEYS", "RunSpec", "fitpack_count", "run_id"]

#: Encoding name in the configuration -> (problem's registry name, encoding kind).
ENCODINGS = {"mask": ("mask", "binary"), "indices": ("indices", "integer"),
             "free": ("free", "continuous")}
#: Top-level keys that define a run (the run id hashes them, normalised).
RUN_KEYS = ("problem", "encoding", "objective", "optimizer", "budget", "seed",
            "checkpoints_per_decade")


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
        with naming("problem"):
            return make_curve(data.points, degree=problem["degree"],
                              parameterization=problem["parameterization"],
                              closed=problem.get("closed", False), params=data.params)

    def build_optimizer(self):
        """The optimizer of this run, with its hyperparameters."""
        from metaknot.registry import get_optimizer

        params = {k: v for k, v in self.config["optimizer"].items() if k != "_name_"}
        with naming(f"optimizer ({self.optimizer})", (ValueError, TypeError)):
            return get_optimizer(self.optimizer, **params)


def run_id(config: Mapping[str, Any]) -> str:
    """Stable 16-hex-digit hash of the run-defining settings (:data:`RUN_KEYS`, as sorted-key
    JSON)."""
    text = json.dumps({k: config[k] for k in RUN_KEYS}, sort_keys=True, default=str,
                      separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _build_data(config: Mapping[str, Any], noise_seed: np.random.SeedSequence | None):
    """The run's data points (a ``PointSet``), with noise when ``noise_seed`` is given."""
    from metaknot.problems import add_noise, get_curve, load_points

    problem = config["problem"]
    with naming("problem", (ValueError, TypeError)):
        if problem.get("instance") is not None:
            from metaknot.suite import get_instance

            data = get_instance(problem["instance"]).point_set()
        elif problem["points"] is not None:
            data = load_points(problem["points"], params_column=problem["params_column"])
        else:
            kwargs = {} if problem["n_points"] is None else {"n_points": problem["n_points"]}
            data = get_curve(problem["curve"], **kwargs)
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
    with naming(f"objective ({name})", (ValueError, TypeError)):
        objective = get_objective(name, **options)
    common = {"degree": problem["degree"], "parameterization": problem["parameterization"],
              "objective": objective, "closed": problem.get("closed", False)}
    kind = encoding["kind"]
    with naming(f"encoding ({kind})", (ValueError, TypeError)):
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


def fitpack_count(data, factor: float, common: Mapping[str, Any]) -> int:
    """Interior knots FITPACK places at smoothing ``s = N * factor`` (at least 1)."""
    from metaknot.bspline import fitpack, parameterize

    method = data.params if data.params is not None else common["parameterization"]
    u = parameterize(data.points, method, degree=common["degree"])
    knots = fitpack.interior_knots(u, data.points, common["degree"], data.n_points * factor)
    return max(1, int(knots.size))

