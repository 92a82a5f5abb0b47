"""Best-known values of the suite: every stored knot vector re-evaluated by an independent
reference fit (scipy's make_lsq_spline for open data, FITPACK's periodic least squares for
closed outlines), the exhaustive proofs, and the rule that a value is never replaced by a worse
one."""

from __future__ import annotations

import dataclasses
import itertools
import json

import numpy as np
import pytest
from scipy.interpolate import make_lsq_spline, splev, splprep

from metaknot.suite import instances
from metaknot.suite.best import (
    KINDS_WITH_BEST,
    BestKnown,
    absorb,
    candidate_of,
    front_candidates,
    improve,
    load_best_known,
    save_best_known,
)
from metaknot.suite.tasks import get_task, tasks

ENTRIES = load_best_known()


def reference_residuals(problem, knots: np.ndarray) -> np.ndarray:
    """Point distances of the least-squares spline with interior ``knots``, by scipy."""
    u, q, p = problem.params, problem.points, problem.degree
    if problem.closed:
        from metaknot.bspline import periodic_knot_vector

        t = periodic_knot_vector(knots, p)
        tck, _ = splprep(np.vstack((q, q[:1])).T, u=np.append(u, 1.0), k=p, task=-1, t=t,
                         per=1, quiet=1)
        fitted = np.array(splev(u, tck)).T
    else:
        t = np.r_[[u[0]] * (p + 1), knots, [u[-1]] * (p + 1)]
        fitted = make_lsq_spline(u, q, t, k=p)(u)
    return np.linalg.norm(q - fitted.reshape(q.shape), axis=1)


def reference_value(task, problem, knots: np.ndarray) -> float:
    """The task's objective written out from its definition (metaknot.suite.tasks)."""
    distances = reference_residuals(problem, knots)
    n = len(distances)
    sse, max_dev = float(distances @ distances), float(distances.max())
    cp = len(knots) + (1 if problem.closed else problem.degree + 1)
    scale = problem.data.scale
    objective = task.objective
    if objective["name"] == "rmse":
        return np.sqrt(sse / n)
    if objective["name"] == "error_bounded":
        tol = objective["tolerance"] or objective["relative_tolerance"] * scale
        err = max_dev if objective["metric"] == "max_deviation" else np.sqrt(sse / n)
        return cp + err / tol if err <= tol else n + 2 + err / tol
    assert objective["name"] == "paper"
    return cp * max(np.sqrt(sse), objective["error_floor"] * scale * np.sqrt(n))


def test_every_task_has_a_best_known_value() -> None:
    wanted = {(t.instance, t.id) for i in instances(plugins=False) for t in tasks(i)
              if t.kind in KINDS_WITH_BEST}
    assert wanted - set(ENTRIES) == set()
    assert set(ENTRIES) - wanted == set()  # nothing stored for tasks that do not exist


def reference_gap(task, problem, masks: np.ndarray) -> float:
    """The front's hypervolume gap written out from the objective ``pareto``: each member's
    (control points / N, 1 + log10(max(RMSE / scale, floor)) / -log10(floor)) by scipy's
    fit, and the area they dominate in the unit box as a staircase."""
    floor, n = task.objective["error_floor"], problem.curve.n_points
    points = []
    for x in masks:
        knots = problem.params[np.flatnonzero(x) + 1]
        rmse = np.sqrt(np.mean(reference_residuals(problem, knots) ** 2))
        cp = len(knots) + problem.curve.extra_control_points
        error = 1 + np.log10(max(rmse / problem.data.scale, floor)) / -np.log10(floor)
        points.append((cp / n, error))
    area, lowest = 0.0, 1.0
    for f0, f1 in sorted(points):
        if f0 < 1 and f1 < lowest:
            area += (1 - f0) * (lowest - f1)
            lowest = f1
    return 1 - area


@pytest.mark.parametrize("key", sorted(k for k in ENTRIES if ENTRIES[k].front is not None),
                         ids="/".join)
def test_stored_fronts_give_the_stored_gap(key: tuple[str, str]) -> None:
    entry = ENTRIES[key]
    task = get_task(*key)
    problem = task.problem()
    masks = front_candidates(entry, problem)
    assert reference_gap(task, problem, masks) == pytest.approx(entry.value, rel=1e-9)
    # no member dominates another, and the knee is one of them
    F = problem.evaluate(masks)
    assert not any(np.all(F[i] <= F[j]) and i != j for i in range(len(F)) for j in range(len(F)))
    knee = problem.params[np.asarray(entry.candidate, dtype=np.int64)]
    assert any(np.array_equal(knee, problem.params[np.flatnonzero(x) + 1]) for x in masks)


@pytest.mark.parametrize("key", sorted(k for k in ENTRIES if ENTRIES[k].front is None),
                         ids="/".join)
def test_stored_knots_give_the_stored_value(key: tuple[str, str]) -> None:
    entry = ENTRIES[key]
    task = get_task(*key)
    problem = task.problem()
    knots = np.asarray(entry.knots)
    assert np.all(np.diff(knots) > 0)
    assert reference_value(task, problem, knots) == pytest.approx(entry.value, rel=1e-9,
                                                                  abs=1e-12)
    # the stored candidate is the same knots in the task's encoding, scored the same by the
    # framework's own evaluation
    x = candidate_of(entry, problem)
    assert float(problem.evaluate(x[None, :])[0]) == pytest.approx(entry.value, rel=1e-9)
    assert entry.metrics["n_control_points"] == len(knots) + problem.curve.extra_control_points


def test_small_index_tasks_are_proven_by_enumeration() -> None:
    """Titanium (49 points) at K = 3: the stored optimum beats every one of the C(47, 3) index
    sets, each fitted here by scipy (a sample: every 97th set, plus the stored one)."""
    entry = ENTRIES[("titanium", "fixed_k_small.indices")]
    assert entry.proven and entry.method == "exhaustive"
    task = get_task("titanium", "fixed_k_small.indices")
    problem = task.problem()
    sets = list(itertools.combinations(range(1, problem.curve.n_points - 1), 3))
    assert entry.budget == len(sets) == 16215
    for chosen in sets[::97]:
        value = reference_value(task, problem, problem.params[list(chosen)])
        assert value >= entry.value * (1 - 1e-12)
    # and no optimizer does better
    from metaknot import minimize

    for name in ("ga", "local_search"):
        result = minimize(problem, name, budget=2000, seed=1)
        assert result.best_f >= entry.value * (1 - 1e-12)


def test_a_value_is_never_replaced_by_a_worse_one(tmp_path) -> None:
    path = tmp_path / "best.json"
    # a value lower than a short search reaches (made up here) is kept as it is
    stored = ENTRIES[("titanium", "seed")]
    claimed = dataclasses.replace(stored, value=stored.value / 2, method="made-up")
    save_best_known({("titanium", "seed"): claimed}, path)
    improve(["titanium"], budget=300, path=path, report=lambda _: None)
    assert load_best_known(path)[("titanium", "seed")] == claimed
    # a worse stored value (the same knots claimed at a higher value) is improved
    worse = dataclasses.replace(stored, value=stored.value * 2, method="made-up")
    save_best_known({("titanium", "seed"): worse}, path)
    counts = improve(["titanium"], budget=300, path=path, report=lambda _: None)
    assert counts["improved"] >= 1
    assert load_best_known(path)[("titanium", "seed")].value < worse.value
    # every task of the instance is filled in, and proven values are not searched again
    assert {t for (_, t) in load_best_known(path)} == {
        t.id for t in tasks("titanium") if t.kind in KINDS_WITH_BEST}
    again = improve(["titanium"], budget=1, path=path, report=lambda _: None)
    assert again["searched"] == len(load_best_known(path)) - 1  # the proven one is skipped
    # the front is searched on its own, from the other tasks' knots and its own members
    front = load_best_known(path)[("titanium", "front")]
    assert improve(["titanium"], budget=1, path=path, kinds=("front",),
                   report=lambda _: None) == {"searched": 1, "improved": 0, "new": 0, "kept": 1}
    assert load_best_known(path)[("titanium", "front")] == front
    with pytest.raises(ValueError, match="got nope"):
        improve(["titanium"], budget=1, path=path, kinds=("nope",))


def _study_row(task_id: str, optimizer: str, seed: int, budget: int = 300) -> dict:
    """A run of the titanium task as ``load_study(...).runs`` gives it (the fields absorb
    reads)."""
    from metaknot import minimize

    result = minimize(get_task("titanium", task_id).problem(), optimizer, budget=budget,
                      seed=seed)
    return {"run_id": f"{optimizer}-{seed}", "suite.instance": "titanium",
            "suite.task": task_id, "status": "ok", "best_f": result.best_f,
            "best_x": list(result.best_x), "label": optimizer, "optimizer": optimizer,
            "budget": budget, "seed": seed}


def test_a_study_run_is_absorbed_only_where_it_improves(tmp_path) -> None:
    path = tmp_path / "best.json"
    stored = ENTRIES[("titanium", "seed")]
    rows = [_study_row("seed", name, seed) for name in ("ga", "one_plus_one") for seed in (1, 2)]
    best = min(rows, key=lambda r: r["best_f"])
    lines: list[str] = []
    # a stored value better than every run (made up here) is kept, and the file not written
    claimed = dataclasses.replace(stored, value=best["best_f"] / 2, method="made-up")
    save_best_known({("titanium", "seed"): claimed}, path)
    before = path.read_text()
    assert absorb(rows, path=path, report=lines.append) == {
        "tasks": 1, "improved": 0, "new": 0, "kept": 1, "refused": 0}
    assert path.read_text() == before and lines == []
    # a worse stored value is replaced by the lowest run, its value evaluated again, which an
    # independent fit by scipy confirms
    worse = dataclasses.replace(stored, value=best["best_f"] * 2, method="made-up")
    save_best_known({("titanium", "seed"): worse}, path)
    assert absorb(rows, path=path, report=lines.append)["improved"] == 1
    entry = load_best_known(path)[("titanium", "seed")]
    assert (entry.method, entry.budget, entry.seed) == (best["label"], 300, best["seed"])
    assert entry.value == pytest.approx(best["best_f"], rel=1e-12)
    task = get_task("titanium", "seed")
    assert reference_value(task, task.problem(), np.asarray(entry.knots)) == pytest.approx(
        entry.value, rel=1e-9)
    assert lines and best["run_id"] in lines[0]
    # no stored value: the run's is new; a record naming the task by its alias counts for
    # the task it names
    assert absorb(rows, path=tmp_path / "new.json", report=lines.append)["new"] == 1
    alias = _study_row("tolerance", "ga", 1)
    assert absorb([alias], path=tmp_path / "new.json", report=lines.append)["new"] == 1
    assert set(load_best_known(tmp_path / "new.json")) == {("titanium", "seed"),
                                                          ("titanium", "tolerance_1e-3")}
    # a run whose candidate does not give its recorded value is refused and named
    tampered = dict(best, best_f=best["best_f"] / 3, run_id="tampered")
    save_best_known({("titanium", "seed"): worse}, path)
    lines.clear()
    assert absorb([tampered], path=path, report=lines.append)["refused"] == 1
    assert load_best_known(path)[("titanium", "seed")] == worse
    assert "tampered" in lines[0] and "not stored" in lines[0]
    # failed runs and runs outside the suite are passed over; a proven value is kept
    failed = dict(best, status="failed")
    outside = {k: v for k, v in best.items() if not k.startswith("suite.")}
    assert absorb([failed, outside], path=path, report=lines.append)["tasks"] == 0
    proven_key = ("titanium", "fixed_k_small.indices")
    save_best_known({proven_key: ENTRIES[proven_key]}, path)
    row = _study_row("fixed_k_small.indices", "ga", 1)
    assert absorb([dict(row, best_f=row["best_f"] / 2)], path=path,
                  report=lines.append)["kept"] == 1
    assert load_best_known(path)[proven_key] == ENTRIES[proven_key]


def test_a_refused_best_run_gives_way_to_the_next_best_genuine_one(tmp_path) -> None:
    """The runs of a task are tried lowest first: a forged best run (its candidate does not
    give its recorded value) is refused by name, and the genuine second-best run, which
    improves the stored value, is stored (it was given up with the forged one). Runs that
    cannot improve the stored value are not tried."""
    path = tmp_path / "best.json"
    stored = ENTRIES[("titanium", "seed")]
    rows = sorted((_study_row("seed", name, 1) for name in ("ga", "one_plus_one")),
                  key=lambda r: r["best_f"])
    genuine, worse_run = rows
    assert genuine["best_f"] < worse_run["best_f"]
    forged = [dict(worse_run, best_f=genuine["best_f"] / factor, run_id=f"forged-{factor}")
              for factor in (3, 2)]
    worse = dataclasses.replace(stored, value=genuine["best_f"] * 2, method="made-up")
    save_best_known({("titanium", "seed"): worse}, path)
    lines: list[str] = []
    counts = absorb([*forged, worse_run, genuine], path=path, report=lines.append)
    assert counts == {"tasks": 1, "improved": 1, "new": 0, "kept": 0, "refused": 2}
    entry = load_best_known(path)[("titanium", "seed")]
    assert entry.value == pytest.approx(genuine["best_f"], rel=1e-12)
    assert (entry.method, entry.seed) == (genuine["label"], 1)
    assert ["forged-3" in lines[0], "forged-2" in lines[1], genuine["run_id"] in lines[2]] \
        == [True, True, True] and len(lines) == 3
    # without a stored value, the genuine run is new
    assert absorb([forged[0], genuine], path=tmp_path / "new.json", report=lines.append) == {
        "tasks": 1, "improved": 0, "new": 1, "kept": 0, "refused": 1}
    # a stored value between the forged and the genuine run: the forged one is refused, the
    # stored one kept, and runs recorded above it are not tried (a forged one there is not
    # named: it could not have changed anything)
    between = dataclasses.replace(stored, value=genuine["best_f"] * 0.9, method="made-up")
    save_best_known({("titanium", "seed"): between}, path)
    lines.clear()
    above = dict(worse_run, best_f=genuine["best_f"] * 0.95, run_id="forged-above")
    assert absorb([forged[0], genuine, above], path=path, report=lines.append) == {
        "tasks": 1, "improved": 0, "new": 0, "kept": 1, "refused": 1}
    assert len(lines) == 1 and "forged-3" in lines[0]
    assert load_best_known(path)[("titanium", "seed")] == between


def test_the_file_round_trips_and_refuses_other_formats(tmp_path) -> None:
    path = tmp_path / "best.json"
    entry = BestKnown("titanium", "seed", 1.5, [0.1, 0.2], [3.0, 7.0], "ga", 100, 0)
    save_best_known({("titanium", "seed"): entry}, path)
    assert load_best_known(path) == {("titanium", "seed"): entry}
    assert not list(tmp_path.glob("*.tmp"))
    path.write_text(json.dumps({"version": 99, "entries": []}))
    with pytest.raises(ValueError, match="format 99"):
        load_best_known(path)
    assert load_best_known(tmp_path / "missing.json") == {}


def test_no_free_knot_value_is_behind_the_index_set_of_the_same_count() -> None:
    """Every index set is a free-knot vector too: a free value above the index set's at the
    same K would say the free-knot search is not sound."""
    behind = [(instance, task) for (instance, task), entry in ENTRIES.items()
              if task.endswith(".free") and (instance, task[:-5] + ".indices") in ENTRIES
              and entry.value > ENTRIES[(instance, task[:-5] + ".indices")].value * (1 + 1e-12)]
    assert behind == []


def test_a_free_task_is_searched_from_its_stored_best_too(monkeypatch) -> None:
    """``search`` runs ``varpro`` from the task's stored best (``incumbent``): with the
    portfolio emptied and no index set, an incumbent at equally spaced knots is all it has to
    start from, and it ends below that (without the incumbent: nothing found)."""
    import metaknot.suite.best as best

    monkeypatch.setattr(best, "PORTFOLIO", {**best.PORTFOLIO, "free": ()})
    task = get_task("titanium", "fixed_k_small.free")
    problem = task.problem()
    knots = np.linspace(*problem.knot_bounds, problem.n_knots + 2)[1:-1]
    value = float(problem.evaluate(knots[None, :])[0])
    stored = ENTRIES[("titanium", "fixed_k_small.free")]
    incumbent = dataclasses.replace(stored, knots=[float(k) for k in knots], value=value,
                                    method="made-up")
    assert best.search(task, budget=300) is None
    found = best.search(task, budget=300, incumbent=incumbent)
    assert found is not None and found.method == "varpro from best-known"
    assert found.value < value * (1 - 1e-3)
    assert found.value == pytest.approx(reference_value(task, problem, np.sort(found.knots)),
                                        rel=1e-9)


def test_improve_searches_each_task_from_its_stored_best(monkeypatch, tmp_path) -> None:
    import metaknot.suite.best as best

    path = tmp_path / "best.json"
    stored = ENTRIES[("titanium", "fixed_k_small.free")]
    save_best_known({("titanium", "fixed_k_small.free"): stored}, path)
    seen: dict[str, BestKnown | None] = {}

    def recording(task, **options):
        seen[task.id] = options.get("incumbent")
        return None

    monkeypatch.setattr(best, "search", recording)
    improve(["titanium"], budget=1, path=path, kinds=("fixed_k",), report=lambda _: None)
    assert seen["fixed_k_small.free"] == stored and seen["fixed_k_large.free"] is None
