"""The suite's tasks: what is asked of an optimizer on an instance, named and fixed.

A task is an encoding and an objective with every setting resolved for one instance:

``fixed_k_small.indices``, ``fixed_k_large.indices``, ``fixed_k_small.free``, ``fixed_k_large.free``
    The RMSE (objective ``rmse``) with ``K`` interior knots, at data points (``indices``) or
    anywhere (``free``). ``K`` follows one rule for every instance of ``N`` points:
    ``K_small = max(2, floor(sqrt(N) / 2))`` and ``K_large = max(K_small + 1, floor(sqrt(N)))``
    (256 points: 8 and 16; titanium's 49: 3 and 7), capped at the most knots the data carry.
``tolerance_1e-2``, ``tolerance_1e-3`` (instances without noise)
    The fewest control points whose maximum deviation stays within ``1e-2`` / ``1e-3`` of the
    data's scale (the bounding-box diagonal; for a function, the range of ``f(x)``): objective
    ``error_bounded`` on masks.
``tolerance_noise`` (noisy instances)
    The fewest control points whose RMSE stays within ``1.05 sigma`` (``sigma`` the noise's
    standard deviation): within the noise, never below it, so no fit has to follow the noise.
``seed``
    The seed paper's masks and guarded ``paper`` objective (control points x distance). Its
    error floor is ``1e-5`` of the scale without noise and the noise's ``sigma`` with noise,
    so the guard never makes noisy data interpolate.
``front``
    The whole trade-off: objective ``pareto`` (control points and RMSE) on masks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from metaknot.problems import FreeKnots, KnotIndices, KnotProblem, KnotSelection

from .instances import Instance, get_instance

__all__ = ["TASK_KINDS", "Task", "fixed_k_sizes", "get_task", "tasks"]

TASK_KINDS = ("fixed_k", "tolerance", "seed", "front")
#: Relative tolerances of the tolerance tasks of instances without noise.
TOLERANCES = (1e-2, 1e-3)
#: A noisy instance's tolerance task: RMSE within this many noise standard deviations.
NOISE_TOLERANCE = 1.05
#: The seed task's error floor (relative to the scale) on instances without noise.
SEED_ERROR_FLOOR = 1e-5

_ENCODINGS = {"mask": KnotSelection, "indices": KnotIndices, "free": FreeKnots}


@dataclass(frozen=True)
class Task:
    """One task on one instance.

    Attributes
    ----------
    id
        The task's name (see the module docstring), e.g. ``fixed_k_small.indices``.
    kind
        ``fixed_k``, ``tolerance``, ``seed`` or ``front``.
    instance
        The instance's id.
    encoding
        The encoding as a study configures it: ``{"kind": "indices", "n_knots": 8}``.
    objective
        The objective and its options: ``{"name": "rmse"}``.
    """

    id: str
    kind: str
    instance: str
    encoding: dict[str, Any] = field(hash=False)
    objective: dict[str, Any] = field(hash=False)

    def problem(self) -> KnotProblem:
        """The task's problem on the instance's data (cubic, centripetal, closed as the
        instance is)."""
        instance = get_instance(self.instance)
        encoding = dict(self.encoding)
        cls = _ENCODINGS[encoding.pop("kind")]
        objective = dict(self.objective)
        return cls(instance.point_set(), objective=objective.pop("name"),
                   objective_options=objective, closed=instance.closed, **encoding)


def fixed_k_sizes(n_points: int, max_knots: int) -> tuple[int, int]:
    """``(K_small, K_large)`` of an instance of ``n_points`` that carries at most ``max_knots``
    interior knots."""
    small = max(2, math.isqrt(n_points) // 2)
    large = max(small + 1, math.isqrt(n_points))
    return min(small, max_knots), min(large, max_knots)


def tasks(instance: Instance | str) -> list[Task]:
    """Every task on ``instance``, resolved, in a fixed order."""
    instance = get_instance(instance) if isinstance(instance, str) else instance
    data = instance.point_set()
    curve = KnotSelection(data, closed=instance.closed).curve
    found = []
    for size, k in zip(("small", "large"), fixed_k_sizes(curve.n_points,
                                                         curve.max_interior_knots), strict=True):
        found.append(Task(f"fixed_k_{size}.indices", "fixed_k", instance.id,
                          {"kind": "indices", "n_knots": k}, {"name": "rmse"}))
        found.append(Task(f"fixed_k_{size}.free", "fixed_k", instance.id,
                          {"kind": "free", "n_knots": k, "variable_count": False},
                          {"name": "rmse"}))
    mask = {"kind": "mask", "density": 0.5}
    if instance.noise:
        sigma = instance.sigma
        found.append(Task("tolerance_noise", "tolerance", instance.id, mask,
                          {"name": "error_bounded", "tolerance": NOISE_TOLERANCE * sigma,
                           "metric": "rmse"}))
        floor = sigma / data.scale
    else:
        found += [Task(f"tolerance_{tol:.0e}".replace("e-0", "e-"), "tolerance", instance.id,
                       mask, {"name": "error_bounded", "tolerance": None,
                              "relative_tolerance": tol, "metric": "max_deviation"})
                  for tol in TOLERANCES]
        floor = SEED_ERROR_FLOOR
    found.append(Task("seed", "seed", instance.id, mask,
                      {"name": "paper", "error_floor": floor}))
    found.append(Task("front", "front", instance.id, mask,
                      {"name": "pareto", "metric": "rmse", "error_floor": 1e-6}))
    return found


def get_task(instance: Instance | str, task_id: str) -> Task:
    """The task ``task_id`` on ``instance``; ``tolerance`` names the instance's main
    tolerance task (``tolerance_1e-3``, or ``tolerance_noise`` on a noisy instance).

    Raises
    ------
    ValueError
        For a task the instance does not have (naming the ones it has).
    """
    instance = get_instance(instance) if isinstance(instance, str) else instance
    found = {t.id: t for t in tasks(instance)}
    if task_id == "tolerance":  # the instance's own: 1e-3 of the scale, or within the noise
        task_id = "tolerance_noise" if instance.noise else "tolerance_1e-3"
    if task_id not in found:
        raise ValueError(f"{instance.id} has no task {task_id!r}; its tasks: {', '.join(found)}")
    return found[task_id]
