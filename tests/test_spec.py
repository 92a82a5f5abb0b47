"""The study configuration and the run spec: every bad value named by its key in one line, the
optimizer configs generated from their signatures, stable run ids, paired seeds, FITPACK knot
counts, algorithm/encoding compatibility, the presets, and the sweep's fast composition."""

from __future__ import annotations

import functools
import inspect
import itertools
import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.config_loader import ConfigLoader
from hydra.core.global_hydra import GlobalHydra
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.utils import setup_globals
from hydra.errors import CompactHydraException
from hydra.types import HydraContext, RunMode
from omegaconf import OmegaConf
from scipy.interpolate import splprep

import metaknot as mk
from metaknot import registry
from metaknot.bspline import parameterize
from metaknot.experiments.app import CONFIG_DIR, register_hydra_plugins
from metaknot.experiments.run import ENCODINGS
from metaknot.experiments.spec import ConfigError, config_node, run_spec
from metaknot.experiments.store import Store
from metaknot.experiments.sweep import _Composer, expand, plan
from metaknot.problems import OBJECTIVES, FreeKnots, KnotIndices, add_noise, get_curve

register_hydra_plugins()

RESULTS = "spec-test-results"  # never written: run_spec only records it
CURVES = ("epitrochoid", "archimedean", "vivaldi")
PAPER_ITERATIONS = (10, 25, 50, 100, 250, 500, 1000, 2000)
HEX16 = re.compile(r"^[0-9a-f]{16}$")


@functools.cache  # composing takes tens of milliseconds; run_spec does not modify the result
def compose_cfg(*overrides: str, hydra: bool = False, results_dir: str = RESULTS):
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        return compose("config", overrides=[f"results_dir={results_dir}", *overrides],
                       return_hydra_config=hydra)


def spec_of(*overrides: str, check_build: bool = True):
    return run_spec(compose_cfg(*overrides), check_build=check_build)


DROP = object()  # a key to leave out


def plain_cfg(**changes):
    """The smallest plain-dict configuration; ``changes`` set nested keys spelt with ``__``
    (``problem__noise=0.1``), or remove them (``DROP``)."""
    cfg = {"study": "s", "results_dir": RESULTS, "budget": 100, "seed": 0,
           "problem": {"curve": "archimedean"}, "encoding": {"kind": "mask"},
           "objective": {"name": "paper"}, "optimizer": {"_name_": "dolphin"}}
    for dotted, value in changes.items():
        *parents, last = dotted.split("__")
        node = cfg
        for part in parents:
            node = node[part]
        if value is DROP:
            del node[last]
        else:
            node[last] = value
    return cfg


def assert_names_key(message: str, key: str) -> None:
    """One line that starts with ``key:``, or, for a check made by a constructor (optimizer,
    objective, problem), with ``group (name): leaf``."""
    assert "\n" not in message, message
    if message.startswith(f"{key}:"):
        return
    group, _, leaf = key.rpartition(".")
    assert group, message
    assert re.match(rf"{re.escape(group)} \(\w+\): {re.escape(leaf)}\b", message), \
        f"{message!r} does not name {key!r}"


def yaml_of(path: Path) -> dict:
    return OmegaConf.to_container(OmegaConf.load(path))


def signature_defaults(cls: type) -> dict:
    return {name: p.default for name, p in inspect.signature(cls.__init__).parameters.items()
            if name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)}


def sweep_values(params) -> dict[str, list[str]]:
    """Each swept key's values, expanded as Hydra's basic sweeper does."""
    parser = OverridesParser.create()
    out = {}
    for override in parser.parse_overrides([f"{k}={v}" for k, v in params.items()]):
        key = override.get_key_element()
        out[key] = [str(v) for v in override.sweep_iterator()] if override.is_sweep_override() \
            else [override.get_value_element_as_str()]
    return out


# --------------------------------------------------------------------------------------------
# validation: the key, in one line


BAD_OVERRIDES = [  # composed by Hydra, as on the command line
    (["optimizer.population=abc"], "optimizer.population"),
    (["optimizer.population=[1,2]"], "optimizer.population"),
    (["budget=0"], "budget"),
    (["budget=-3"], "budget"),
    (["budget=abc"], "budget"),
    (["seed=-1"], "seed"),
    (["seed=1.5"], "seed"),
    (["study=a/b"], "study"),
    (["problem.degree=7"], "problem.degree"),
    (["problem.parameterization=foo"], "problem.parameterization"),
    (["problem.noise=-1"], "problem.noise"),
    (["problem.curve=nope"], "problem.curve"),
    (["problem=points"], "problem.points"),
    (["problem=points", "problem.points=/no/such/file.csv"], "problem.points"),
    (["encoding.density=2"], "encoding.density"),
    (["encoding=indices", "encoding.n_knots=0"], "encoding.n_knots"),
    (["encoding=indices", "encoding.n_knots=fitpack:abc"], "encoding.n_knots"),
    (["encoding=indices", "encoding.n_knots=fitpack:-1"], "encoding.n_knots"),
    (["encoding=indices", "problem.n_points=10"], "encoding.n_knots"),  # 20 knots > N - 4
    (["objective.error_floor=-1"], "objective.error_floor"),
    (["objective=error_bounded", "objective.metric=foo"], "objective.metric"),
    (["+optimizer.populaton=3"], "optimizer.populaton"),
    (["+problem.colour=red"], "problem.colour"),
    (["+encoding.n_knots=3"], "encoding.n_knots"),  # the mask has no knot count
    (["optimizer.fitness=foo"], "optimizer.fitness"),
    (["optimizer=ga", "optimizer.crossover=foo"], "optimizer.crossover"),
    (["optimizer=nlopt", "encoding=free", "optimizer.variant=FOO"], "optimizer.variant"),
    (["threads=0"], "threads"),
    (["checkpoints_per_decade=0"], "checkpoints_per_decade"),
]


@pytest.mark.parametrize(("overrides", "key"), BAD_OVERRIDES,
                         ids=[" ".join(o) for o, _ in BAD_OVERRIDES])
def test_a_bad_value_is_named_by_its_key_in_one_line(overrides, key):
    cfg = compose_cfg(*overrides)
    with pytest.raises(ConfigError) as info:
        run_spec(cfg)
    assert_names_key(str(info.value), key)


def test_a_missing_points_file_is_named():
    with pytest.raises(ConfigError, match=re.escape("/no/such/file.csv")):
        spec_of("problem=points", "problem.points=/no/such/file.csv")


def test_an_unknown_setting_lists_the_known_ones():
    with pytest.raises(ConfigError) as info:
        spec_of("+optimizer.populaton=3")
    assert "population" in str(info.value).split(":", 1)[1]


INDICES = {"kind": "indices", "n_knots": 20}
BAD_PLAIN = [  # a plain mapping of the same shape
    ({"study": DROP}, "study"),
    ({"study": ""}, "study"),
    ({"results_dir": DROP}, "results_dir"),
    ({"results_dir": ""}, "results_dir"),
    ({"budget": DROP}, "budget"),
    ({"budget": True}, "budget"),
    ({"budget": 2.5}, "budget"),
    ({"seed": DROP}, "seed"),
    ({"seed": True}, "seed"),
    ({"seed": np.float64(2.0)}, "seed"),
    ({"threads": "abc"}, "threads"),
    ({"progress": "maybe"}, "progress"),
    ({"label": 3}, "label"),
    ({"checkpoints_per_decade": "abc"}, "checkpoints_per_decade"),
    ({"problem": DROP}, "problem"),
    ({"problem": "archimedean"}, "problem"),
    ({"problem__curve": DROP}, "problem.curve"),
    ({"problem__name": [1]}, "problem.name"),
    ({"problem__points": "???"}, "problem.points"),
    ({"problem__degree": 0}, "problem.degree"),
    ({"problem__noise": float("nan")}, "problem.noise"),
    ({"problem__noise": "abc"}, "problem.noise"),
    ({"problem__noise_seed": -1}, "problem.noise_seed"),
    ({"problem__n_points": 4}, "problem.n_points"),
    ({"encoding": DROP}, "encoding"),
    ({"encoding__kind": "bits"}, "encoding.kind"),
    ({"encoding__kind": DROP}, "encoding.kind"),
    ({"encoding__density": -0.5}, "encoding.density"),
    ({"encoding": {**INDICES, "n_knots": 1.5}}, "encoding.n_knots"),
    ({"encoding": {**INDICES, "n_knots": "many"}}, "encoding.n_knots"),
    ({"encoding": {**INDICES, "n_knots": "fitpack:0"}}, "encoding.n_knots"),
    ({"encoding": {**INDICES, "n_knots": "fitpack:inf"}}, "encoding.n_knots"),
    ({"encoding": {"kind": "free", "variable_count": 3}}, "encoding.variable_count"),
    ({"encoding": {"kind": "free", "merge_spacing": -1.0}}, "encoding.merge_spacing"),
    ({"encoding__max_multiplicity": 4}, "encoding.max_multiplicity"),  # degree 3
    ({"encoding__max_multiplicity": 0}, "encoding.max_multiplicity"),
    ({"encoding": {"kind": "free", "max_multiplicity": 2}}, "encoding.max_multiplicity"),
    ({"encoding": {**INDICES, "max_multiplicity": 5}}, "encoding.max_multiplicity"),
    ({"encoding": {"kind": "free", "merge_spacing": "close"}}, "encoding.merge_spacing"),
    ({"encoding": {**INDICES, "merge_spacing": 0.1}}, "encoding.merge_spacing"),
    ({"encoding": {"kind": "free", "density": 0.3}}, "encoding.density"),
    ({"objective": DROP}, "objective"),
    ({"objective__name": "foo"}, "objective.name"),
    ({"objective__name": DROP}, "objective.name"),
    ({"objective__error_floor": "abc"}, "objective.error_floor"),
    ({"objective__tolerance": 0.1}, "objective.tolerance"),  # paper has no tolerance
    ({"objective": {"name": "error_bounded", "tolerance": -1.0}}, "objective.tolerance"),
    ({"optimizer": DROP}, "optimizer"),
    ({"optimizer": ["dolphin"]}, "optimizer"),
    ({"optimizer___name_": DROP}, "optimizer._name_"),
    ({"optimizer___name_": 3}, "optimizer._name_"),
    ({"optimizer___name_": "dolfin"}, "optimizer._name_"),
    ({"optimizer__population": "???"}, "optimizer.population"),
    ({"optimizer__population": 1.5}, "optimizer.population"),
    ({"optimizer__population": {"a": 1}}, "optimizer.population"),
    ({"optimizer__pp1": 2}, "optimizer.pp1"),
    ({"optimizer__loops": 0}, "optimizer.loops"),
]


@pytest.mark.parametrize(("changes", "key"), BAD_PLAIN,
                         ids=[str(c).replace(str(DROP), "DROP") for c, _ in BAD_PLAIN])
def test_a_bad_plain_mapping_is_named_by_its_key(changes, key):
    with pytest.raises(ConfigError) as info:
        run_spec(plain_cfg(**changes))
    assert_names_key(str(info.value), key)


def test_config_error_is_a_value_error_hydra_reports_compactly():
    assert issubclass(ConfigError, ValueError)
    assert issubclass(ConfigError, CompactHydraException)
    with pytest.raises(ValueError, match=r"^budget:"):
        run_spec(plain_cfg(budget=0))


def test_unknown_optimizer_suggests_the_closest_name():
    with pytest.raises(ConfigError, match=r"^optimizer\._name_: .*dolphin") as info:
        config_node("optimizer", "dolfin")
    assert "\n" not in str(info.value)


def test_points_file_problem(tmp_path, monkeypatch):
    points = get_curve("archimedean").points
    path = tmp_path / "outline.csv"
    np.savetxt(path, points, delimiter=",")
    spec = spec_of("problem=points", f"problem.points={path}")
    problem = spec.build_problem()
    assert spec.config["problem"]["name"] == "outline"  # the file's stem
    np.testing.assert_array_equal(problem.data.points, points)
    # a relative path names the same file, and so the same run
    monkeypatch.chdir(tmp_path)
    assert spec_of("problem=points", "problem.points=outline.csv").run_id == spec.run_id
    # a changed file is a new run
    np.savetxt(path, points * 2.0, delimiter=",")
    assert spec_of("problem=points", f"problem.points={path}").run_id != spec.run_id


def test_a_bad_points_file_is_reported_as_a_problem_error(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("x,y\n1,2\n3,abc\n")
    with pytest.raises(ConfigError) as info:
        spec_of("problem=points", f"problem.points={path}")
    assert str(info.value).startswith("problem") and "\n" not in str(info.value)
    good = tmp_path / "good.csv"
    np.savetxt(good, get_curve("archimedean").points, delimiter=",")
    with pytest.raises(ConfigError) as info:
        spec_of("problem=points", f"problem.points={good}", "problem.params_column=5")
    assert str(info.value).startswith("problem") and "params_column" in str(info.value)


# --------------------------------------------------------------------------------------------
# the algorithm configs are the optimizers' signatures


#: The method presets that name a method (``method=default`` is none: the configured one).
METHOD_PRESETS = sorted(p for p in (CONFIG_DIR / "method").glob("*.yaml") if p.stem != "default")


def first_encoding(name: str) -> str:
    """The first encoding (of ENCODINGS) the optimizer handles."""
    kinds = type(mk.get_optimizer(name)).encodings
    return next(e for e, (_, kind) in ENCODINGS.items() if kind in kinds)


def algorithm_choice(name: str) -> tuple[str, ...]:
    return f"optimizer={name}", f"encoding={first_encoding(name)}", "problem=archimedean"


@pytest.mark.parametrize("name", sorted(mk.available_optimizers()))
def test_optimizer_choice_composes_the_signature_defaults(name):
    """``optimizer=NAME`` is generated from the constructor: no file restates it."""
    assert not (CONFIG_DIR / "optimizer").exists()
    node = OmegaConf.to_container(compose_cfg(f"optimizer={name}").optimizer)
    defaults = signature_defaults(type(mk.get_optimizer(name)))
    assert node == {"_name_": name, **defaults}
    for pname, value in defaults.items():  # 1 is not 1.0 in a run id
        assert type(node[pname]) is type(value), pname


def test_an_override_of_an_optimizer_default_changes_the_run():
    default = spec_of("optimizer=ga", "problem=archimedean")
    given = spec_of("optimizer=ga", "problem=archimedean", "optimizer.population=30")
    assert given.config["optimizer"]["population"] == 30
    assert given.build_optimizer().population == 30
    assert default.build_optimizer().population == 50
    assert given.run_id != default.run_id
    assert spec_of("optimizer=ga", "problem=archimedean",
                   "optimizer.population=50").run_id == default.run_id


def test_an_unknown_optimizer_setting_is_named_with_the_known_ones():
    with pytest.raises(ConfigError, match=r"^optimizer\.populaton: unknown setting \(known: "
                                          r".*\bpopulation\b.*\)$"):
        spec_of("optimizer=ga", "+optimizer.populaton=30")
    with pytest.raises(ConfigError, match=r"^optimizer\.population: unknown setting"):
        spec_of("optimizer=nlopt", "encoding=free", "+optimizer.population=30")


@pytest.mark.parametrize("name", sorted(mk.available_optimizers()))
def test_every_algorithm_config_composes_and_builds(name):
    cls = type(mk.get_optimizer(name))
    spec = spec_of(*algorithm_choice(name))
    assert spec.optimizer == name and spec.label == name and spec.compatible() is None
    assert type(spec.build_optimizer()) is cls


@pytest.mark.parametrize("name", sorted(OBJECTIVES))
def test_objective_choice_composes_the_signature_defaults(name):
    """``objective=NAME`` is generated from the objective's constructor, as ``optimizer=``."""
    assert not (CONFIG_DIR / "objective").exists()
    node = OmegaConf.to_container(compose_cfg(f"objective={name}").objective)
    defaults = signature_defaults(OBJECTIVES[name])
    assert node == {"name": name, **defaults}
    for pname, value in defaults.items():
        assert type(node[pname]) is type(value), pname


def test_an_override_of_an_objective_default_changes_the_run():
    default = spec_of("objective=error_bounded", "problem=archimedean")
    given = spec_of("objective=error_bounded", "problem=archimedean", "objective.tolerance=0.01")
    assert default.config["objective"]["tolerance"] is None
    assert given.config["objective"]["tolerance"] == 0.01
    assert given.build_problem(noise=False).objective.tolerance == 0.01
    assert given.run_id != default.run_id
    with pytest.raises(ConfigError, match=r"^objective\.tolerence: unknown setting \(known: "
                                          r"metric, relative_tolerance, tolerance\)$"):
        spec_of("objective=error_bounded", "+objective.tolerence=0.01")


@pytest.mark.parametrize("group", ["problem", "encoding"])
def test_yaml_settings_equal_the_code_defaults(group):
    """A group's YAML, given in full, is the same run as the bare choice it makes."""
    for path in sorted((CONFIG_DIR / group).glob("*.yaml")):
        if path.stem == "points":
            continue
        node = yaml_of(path)
        overrides = []
        if path.stem == "suite":  # an instance must be named: the one the suite lists first
            node["instance"] = "galvez_f1"
            overrides = ["problem.instance=galvez_f1"]
        bare = {"kind": node["kind"]} if group == "encoding" else {
            k: node[k] for k in ("curve", "instance") if k in node}
        full = run_spec(plain_cfg(**{group: node}), check_build=False)
        assert run_spec(plain_cfg(**{group: bare}), check_build=False).run_id == full.run_id
        assert spec_of(f"{group}={path.stem}", "budget=100", *overrides,
                       check_build=False).config[group] == full.config[group]


class _Probe(mk.Optimizer):
    """A plugin optimizer: a required parameter and a default that is not a plain value."""

    name = "spec_probe"

    def __init__(self, steps: int, shape: tuple = (1, 2), scale: float = 1.0) -> None:
        self.steps, self.shape, self.scale = steps, shape, scale

    def ask(self):
        return self.problem.sample(self.rng, 1)

    def tell(self, X, F):
        pass


def test_plugin_optimizer_settings_from_its_signature(monkeypatch):
    monkeypatch.setitem(registry._REGISTRY, "optimizer", dict(registry._REGISTRY["optimizer"]))
    registry._REGISTRY["optimizer"]["spec_probe"] = _Probe
    assert config_node("optimizer", "spec_probe") == {
        "_name_": "spec_probe", "steps": "???", "shape": "(1, 2)", "scale": 1.0}
    with pytest.raises(ConfigError, match=r"^optimizer\.steps: required"):
        run_spec(plain_cfg(optimizer={"_name_": "spec_probe"}))
    with pytest.raises(ConfigError, match=r"^optimizer\.steps: required"):
        run_spec(plain_cfg(optimizer=config_node("optimizer", "spec_probe")))
    with pytest.raises(ConfigError, match=r"^optimizer\.steps: expected an integer"):
        run_spec(plain_cfg(optimizer={"_name_": "spec_probe", "steps": "x"}))
    spec = run_spec(plain_cfg(optimizer={"_name_": "spec_probe", "steps": 3, "scale": 2}))
    assert spec.config["optimizer"] == {"_name_": "spec_probe", "steps": 3, "shape": (1, 2),
                                        "scale": 2.0}
    assert isinstance(spec.config["optimizer"]["scale"], float)
    assert spec.build_optimizer().steps == 3


# --------------------------------------------------------------------------------------------
# run ids


RUN_DEFINING = {"seed": 1, "budget": 101, "optimizer__population": 51,
                "optimizer__fitness": "rank", "problem__noise": 0.01, "problem__noise_seed": 3,
                "problem__degree": 4, "problem__parameterization": "chord",
                "problem__n_points": 60, "problem__name": "spiral", "encoding__density": 0.4,
                "objective__error_floor": 1e-6, "checkpoints_per_decade": 5}
GROUP_CHOICES = ["optimizer=ga", "problem=vivaldi", "encoding=indices", "objective=bic"]
NOT_RUN_DEFINING = {"study": "other", "results_dir": "/elsewhere", "threads": 2,
                    "progress": False, "label": "mine"}


def test_run_id_is_stable_and_short_hex():
    overrides = ("optimizer=ga", "encoding=indices", "problem.noise=0.01", "seed=3")
    first, second = (run_spec(compose_cfg.__wrapped__(*overrides), check_build=False)
                     for _ in range(2))  # composed twice, not from the cache
    assert HEX16.match(first.run_id)
    assert first.run_id == second.run_id and first.config == second.config


def test_run_id_is_the_same_for_the_plain_mapping():
    cfg = compose_cfg("optimizer=ga", "encoding=indices", "problem.noise=0.01")
    plain = OmegaConf.to_container(cfg, resolve=True)
    assert run_spec(plain, check_build=False).run_id == run_spec(cfg, check_build=False).run_id


@pytest.mark.slow
def test_run_id_is_the_same_in_a_fresh_process():
    overrides = ["optimizer=ga", "encoding=indices", "encoding.n_knots=fitpack:1e-4",
                 "problem=vivaldi", "problem.noise=0.01", "seed=7", "budget=1234"]
    code = "\n".join([
        "from hydra import compose, initialize_config_dir",
        "from metaknot.experiments.app import CONFIG_DIR, register_hydra_plugins",
        "from metaknot.experiments.spec import run_spec",
        "register_hydra_plugins()",
        "with initialize_config_dir(version_base='1.3', config_dir=str(CONFIG_DIR)):",
        f"    cfg = compose('config', overrides={[f'results_dir={RESULTS}', *overrides]!r})",
        "print(run_spec(cfg, check_build=False).run_id)",
    ])
    env = {**os.environ, "PYTHONHASHSEED": "12345"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == spec_of(*overrides, check_build=False).run_id


def test_run_id_changes_with_every_run_defining_value():
    base = run_spec(plain_cfg(), check_build=False).run_id
    ids = {key: run_spec(plain_cfg(**{key: value}), check_build=False).run_id
           for key, value in RUN_DEFINING.items()}
    assert base not in ids.values()
    assert len(set(ids.values())) == len(ids), ids


def test_run_id_changes_with_every_config_group_choice():
    base = spec_of(check_build=False).run_id
    ids = {choice: spec_of(choice, check_build=False).run_id for choice in GROUP_CHOICES}
    assert base not in ids.values()
    assert len(set(ids.values())) == len(ids), ids


@pytest.mark.parametrize("key", list(NOT_RUN_DEFINING))
def test_run_id_ignores_where_and_how_a_run_executes(key):
    spec = run_spec(plain_cfg(**{key: NOT_RUN_DEFINING[key]}), check_build=False)
    value = getattr(spec, key)
    assert (str(value) if key == "results_dir" else value) == NOT_RUN_DEFINING[key]
    assert spec.run_id == run_spec(plain_cfg(), check_build=False).run_id


def test_run_id_ignores_where_and_how_a_run_executes_on_the_command_line():
    spec = spec_of("study=other", "results_dir=/elsewhere", "threads=2", "progress=false",
                   "label=mine", check_build=False)
    assert (spec.study, spec.results_dir, spec.threads, spec.progress, spec.label) == \
        ("other", Path("/elsewhere"), 2, False, "mine")
    assert spec.run_id == spec_of(check_build=False).run_id


@pytest.mark.parametrize(("key", "value"), [
    ("optimizer__population", 50), ("optimizer__power", 1), ("optimizer__pp1", 0.1),
    ("optimizer__loops", None), ("encoding__density", 0.5), ("problem__degree", 3),
    ("problem__name", "archimedean"), ("problem__noise", 0), ("objective__error_floor", 1e-5),
    ("checkpoints_per_decade", 10)])
def test_a_value_equal_to_its_default_is_the_same_run(key, value):
    given = run_spec(plain_cfg(**{key: value}), check_build=False)
    assert given.run_id == run_spec(plain_cfg(), check_build=False).run_id


def test_a_value_given_at_its_default_on_the_command_line_is_the_same_run():
    assert spec_of("optimizer.population=50", "optimizer.power=1", "objective.error_floor=1e-5",
                   check_build=False).run_id == spec_of(check_build=False).run_id


@pytest.mark.parametrize("name", sorted(mk.available_optimizers()))
def test_hyperparameters_left_out_or_given_at_their_defaults_are_the_same_run(name):
    bare = run_spec(plain_cfg(optimizer={"_name_": name}), check_build=False)
    full = run_spec(plain_cfg(optimizer=config_node("optimizer", name)), check_build=False)
    assert bare.run_id == full.run_id and bare.config == full.config
    for pname, default in signature_defaults(type(mk.get_optimizer(name))).items():
        one = run_spec(plain_cfg(optimizer={"_name_": name, pname: default}), check_build=False)
        assert one.run_id == bare.run_id, pname
    # the composed configuration gives every hyperparameter
    composed = spec_of(*algorithm_choice(name), check_build=False)
    assert composed.run_id == run_spec(plain_cfg(optimizer={"_name_": name}, budget=3000,
                                                 encoding={"kind": first_encoding(name)}),
                                       check_build=False).run_id


def test_fitpack_factor_spellings_are_the_same_run():
    ids = {spec_of("encoding=indices", f"encoding.n_knots=fitpack:{f}",
                   check_build=False).run_id for f in ("1e-4", "0.0001", "1.0e-04")}
    assert len(ids) == 1
    other = spec_of("encoding=indices", "encoding.n_knots=fitpack:1e-6", check_build=False)
    assert other.run_id not in ids


# --------------------------------------------------------------------------------------------
# paired seeds


def noisy_spec(algorithm: str, seed: int, *extra: str):
    return spec_of(f"optimizer={algorithm}", f"seed={seed}", "problem=archimedean",
                   "problem.noise=0.01", *extra)


def test_every_algorithm_of_a_replicate_sees_the_same_data():
    data = {(alg, seed): noisy_spec(alg, seed).build_problem().data
            for alg in ("dolphin", "ga") for seed in (0, 1)}
    for seed in (0, 1):
        assert data["dolphin", seed].fingerprint == data["ga", seed].fingerprint
        expected = add_noise(get_curve("archimedean"), 0.01,
                             np.random.SeedSequence(seed, spawn_key=(0,)))
        np.testing.assert_array_equal(data["dolphin", seed].points, expected.points)
    assert data["dolphin", 0].fingerprint != data["dolphin", 1].fingerprint
    clean = noisy_spec("dolphin", 0).build_problem(noise=False).data
    np.testing.assert_array_equal(clean.points, get_curve("archimedean").points)
    assert noisy_spec("dolphin", 0).run_id != noisy_spec("ga", 0).run_id


def test_noise_and_optimizer_seeds_are_different_children_of_the_replicate():
    spec = noisy_spec("dolphin", 5)
    opt, noise = spec.optimizer_seed(), spec.noise_seed()
    assert (opt.entropy, opt.spawn_key) == (5, (1,))
    assert (noise.entropy, noise.spawn_key) == (5, (0,))
    assert not np.array_equal(opt.generate_state(4), noise.generate_state(4))
    other = noisy_spec("ga", 6)
    assert not np.array_equal(other.optimizer_seed().generate_state(4), opt.generate_state(4))


def test_a_fixed_noise_seed_fixes_the_data_across_replicates():
    specs = [noisy_spec("dolphin", seed, "problem.noise_seed=7") for seed in range(3)]
    prints = {spec.build_problem().data.fingerprint for spec in specs}
    assert len(prints) == 1
    assert len({spec.run_id for spec in specs}) == 3
    expected = add_noise(get_curve("archimedean"), 0.01, np.random.SeedSequence(7))
    np.testing.assert_array_equal(specs[0].build_problem().data.points, expected.points)
    assert specs[1].noise_seed().entropy == 7 and specs[1].noise_seed().spawn_key == ()
    # the optimizer still follows the replicate
    assert specs[1].optimizer_seed().entropy == 1
    assert specs[1].optimizer_seed().spawn_key == (1,)


# --------------------------------------------------------------------------------------------
# knot counts from FITPACK


def splprep_count(points: np.ndarray, u: np.ndarray, degree: int, s: float) -> int:
    tck, _ = splprep(points.T, u=u, k=degree, s=s, full_output=True, quiet=True)[0]
    return len(tck[0]) - 2 * (degree + 1)


@pytest.mark.parametrize(("curve", "factor", "degree", "encoding"), [
    ("epitrochoid", "1e-4", 3, "indices"),
    ("archimedean", "1e-4", 3, "indices"),
    ("vivaldi", "1e-4", 3, "indices"),
    ("vivaldi", "1e-6", 3, "indices"),
    ("archimedean", "1e-6", 5, "indices"),
    ("epitrochoid", "1e-6", 3, "free"),
])
def test_fitpack_knot_count_is_splprep_s(curve, factor, degree, encoding):
    spec = spec_of(f"problem={curve}", f"problem.degree={degree}", f"encoding={encoding}",
                   f"encoding.n_knots=fitpack:{factor}")
    problem = spec.build_problem()
    assert isinstance(problem, KnotIndices if encoding == "indices" else FreeKnots)
    points = get_curve(curve).points
    u = parameterize(points, "centripetal", degree=degree)
    expected = splprep_count(points, u, degree, len(points) * float(factor))
    assert expected > 1
    assert problem.n_knots == expected


def test_fitpack_knot_count_uses_explicit_parameters(tmp_path):
    x = np.linspace(0.0, 2.0, 80) ** 1.5
    y = np.sin(3.0 * x)
    path = tmp_path / "function.csv"
    np.savetxt(path, np.column_stack((x, y)), delimiter=",")
    spec = spec_of("problem=points", f"problem.points={path}", "problem.params_column=0",
                   "encoding=indices", "encoding.n_knots=fitpack:1e-6")
    expected = splprep_count(y[:, None], x, 3, len(y) * 1e-6)
    assert expected > 1
    assert spec.build_problem().n_knots == expected


# --------------------------------------------------------------------------------------------
# algorithm/encoding compatibility


@pytest.mark.parametrize(("name", "encoding"),
                         list(itertools.product(sorted(mk.available_optimizers()), ENCODINGS)))
def test_compatible_follows_the_optimizer_encodings(name, encoding):
    spec = run_spec(plain_cfg(optimizer={"_name_": name}, encoding={"kind": encoding}),
                    check_build=False)
    kind = ENCODINGS[encoding][1]
    handles = kind in type(mk.get_optimizer(name)).encodings
    reason = spec.compatible()
    if handles:
        assert reason is None
    else:
        assert isinstance(reason, str) and "\n" not in reason
        assert repr(name) in reason and repr(encoding) in reason and kind in reason


def test_incompatible_examples():
    assert spec_of("optimizer=nlopt", check_build=False).compatible() is not None  # mask
    assert spec_of("encoding=free", check_build=False).compatible() is not None  # dolphin
    assert spec_of("optimizer=nlopt", "encoding=free", check_build=False).compatible() is None
    assert spec_of(check_build=False).compatible() is None


# --------------------------------------------------------------------------------------------
# presets


def test_seed_paper_preset():
    cfg = compose_cfg("experiment=seed_paper", hydra=True)
    assert sweep_values(cfg.hydra.sweeper.params) == {
        "problem": list(CURVES),
        "optimizer": ["dolphin", "ga"],
        "budget": [str(50 * i) for i in PAPER_ITERATIONS],
        "seed": [str(s) for s in range(30)],
    }
    for algorithm in ("dolphin", "ga"):
        spec = run_spec(compose_cfg("experiment=seed_paper", f"optimizer={algorithm}"))
        assert spec.study == "seed_paper" and spec.compatible() is None
        assert spec.config["encoding"]["kind"] == "mask"
        assert spec.config["objective"] == {"name": "paper", "error_floor": 1e-5}
        assert spec.config["optimizer"]["population"] == 50
        assert spec.config["problem"]["degree"] == 3
        assert spec.config["problem"]["parameterization"] == "centripetal"


def test_fitpack_front_preset():
    cfg = compose_cfg("experiment=fitpack_front", hydra=True)
    values = sweep_values(cfg.hydra.sweeper.params)
    assert values["problem"] == list(CURVES)
    assert values["encoding.n_knots"] == ["fitpack:1e-4", "fitpack:1e-6"]
    single = {p.stem for p in METHOD_PRESETS  # not the fronts, nor masks (no count to set)
              if {"override /objective": "pareto"} not in yaml_of(p)["defaults"]
              and {"override /encoding": "mask"} not in yaml_of(p)["defaults"]}
    assert {"nsga2_mask", "front_free"}.isdisjoint(single)
    assert set(values["method"]) == single
    assert values["seed"] == [str(s) for s in range(5)]
    spec = run_spec(compose_cfg("experiment=fitpack_front", "method=dolphin_indices",
                                "encoding.n_knots=fitpack:1e-4"))
    assert spec.study == "fitpack_front" and spec.budget == 20000 and spec.label == "dolphin"
    assert spec.config["objective"] == {"name": "paper", "error_floor": 0.0}
    assert spec.config["encoding"] == {"kind": "indices", "n_knots": "fitpack:0.0001"}


def test_smoke_preset():
    cfg = compose_cfg("experiment=smoke", hydra=True)
    assert sweep_values(cfg.hydra.sweeper.params) == {
        "problem": list(CURVES),
        "optimizer": ["dolphin", "ga", "random_search", "one_plus_one", "averaging",
                      "local_search"],
        "budget": ["500", "1500"], "seed": [str(s) for s in range(8)]}
    spec = run_spec(cfg)
    assert spec.study == "smoke" and spec.config["encoding"]["kind"] == "mask"
    assert spec.config["objective"]["name"] == "paper"


def test_the_default_method_changes_nothing():
    for args in ((), ("optimizer=ga", "encoding=indices", "encoding.n_knots=5")):
        plain = spec_of(*args, "problem=archimedean")
        default = spec_of("method=default", *args, "problem=archimedean")
        assert default.config == plain.config and default.run_id == plain.run_id
        assert default.label == plain.label == plain.optimizer


@pytest.mark.parametrize("path", METHOD_PRESETS, ids=lambda p: p.stem)
def test_method_preset_composes_to_what_it_names(path):
    node = yaml_of(path)
    chosen = {k.split("/")[-1]: v for entry in node["defaults"] for k, v in entry.items()}
    count = [] if chosen["encoding"] == "mask" else ["encoding.n_knots=5"]
    spec = spec_of(f"method={path.stem}", "problem=archimedean", *count)
    assert spec.optimizer == chosen["optimizer"]
    assert spec.config["encoding"]["kind"] == chosen["encoding"]
    assert spec.label == node["label"]
    for key, value in node.get("optimizer", {}).items():
        assert spec.config["optimizer"][key] == value
    assert spec.compatible() is None
    prefix, _, encoding = path.stem.rpartition("_")
    assert encoding == chosen["encoding"]
    named = {spec.optimizer, spec.label, *spec.label.split("-"),
             str(spec.config["optimizer"].get("variant", "")).lower()}
    assert any(prefix.replace("_", "-") in n for n in named), (prefix, named)


def test_the_free_knot_front_preset_takes_every_count_the_data_allow():
    spec = spec_of("method=front_free", "problem=archimedean", "problem.n_points=50")
    assert spec.optimizer == "free_front" and spec.label == "free-front"
    assert spec.config["encoding"] == {"kind": "free", "n_knots": "max", "variable_count": True}
    problem = spec.build_problem()
    assert problem.variable_count and problem.n_objectives == 2
    assert problem.n_knots == 50 - 3 - 1  # N - degree - 1
    closed = spec_of("encoding=free", "encoding.n_knots=max", "problem=epitrochoid",
                     "problem.closed=true", "problem.n_points=60").build_problem()
    assert closed.n_knots == closed.data.n_points - 1


@pytest.mark.parametrize("path", sorted((CONFIG_DIR / "launcher").glob("*.yaml")),
                         ids=lambda p: p.stem)
def test_launcher_preset_composes(path):
    cfg = compose_cfg(f"launcher={path.stem}", hydra=True)
    for key, value in (yaml_of(path).get("hydra") or {}).get("launcher", {}).items():
        assert cfg.hydra.launcher[key] == value
    assert run_spec(cfg, check_build=False).run_id == spec_of(check_build=False).run_id


# --------------------------------------------------------------------------------------------
# the sweep: fast composition and the plan


def config_loader() -> ConfigLoader:
    setup_globals()  # the ${now:} resolver of hydra.sweep.dir
    with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
        return GlobalHydra.instance().config_loader()


class CountingLoader:
    """The config loader, counting full compositions."""

    def __init__(self, loader: ConfigLoader) -> None:
        self.loader, self.calls = loader, 0

    def __getattr__(self, name):
        return getattr(self.loader, name)

    def load_sweep_config(self, master, job):
        self.calls += 1
        return self.loader.load_sweep_config(master, job)


def study_sweeper(arguments: list[str]):
    """The study sweeper, set up as Hydra's multirun does, and the job arguments."""
    from hydra_plugins.metaknot_study_sweeper.study_sweeper import StudySweeper

    loader = config_loader()
    cfg = loader.load_configuration("config", overrides=arguments, run_mode=RunMode.MULTIRUN)
    sweeper = StudySweeper(max_batch_size=cfg.hydra.sweeper.max_batch_size,
                           params=OmegaConf.to_container(cfg.hydra.sweeper.params))
    sweeper.setup(hydra_context=HydraContext(config_loader=loader, callbacks=None),
                  task_function=lambda _: None, config=cfg)
    return sweeper


def sweep_jobs(sweeper, arguments: list[str]) -> list[list[str]]:
    """Every job of a sweep, as the study sweeper expands it."""
    parser = OverridesParser.create(config_loader=sweeper.hydra_context.config_loader)
    return expand(parser, sweeper.params, arguments)


def compare_with_full_composition(arguments: list[str], select=None):
    """Compose every job of the sweep fast, and the ``select``-ed ones (default: all) in full
    too; their specs must agree. Returns the jobs, the fast specs and the counting loader."""
    sweeper = study_sweeper(arguments)
    loader = sweeper.hydra_context.config_loader
    counting = CountingLoader(loader)
    fake = SimpleNamespace(hydra_context=SimpleNamespace(config_loader=counting),
                           config=sweeper.config)
    composer = _Composer(fake, OverridesParser.create(config_loader=loader))
    jobs = sweep_jobs(sweeper, arguments)
    specs = [run_spec(composer(job), check_build=False) for job in jobs]
    for index, (job, fast) in enumerate(zip(jobs, specs, strict=True)):
        if select is not None and not select(index, job):
            continue
        full = run_spec(loader.load_sweep_config(sweeper.config, list(job)), check_build=False)
        assert (fast.run_id, fast.config, fast.label, fast.study, fast.results_dir) == \
            (full.run_id, full.config, full.label, full.study, full.results_dir), job
    return jobs, specs, counting


@pytest.mark.slow
def test_fast_composition_equals_full_composition_on_the_smoke_study():
    # jobs: problem x algorithm (composed once each) x budget x seed (set on a copy); compare
    # in full one fast-path job for each of the 5 value changes, each in another group
    jobs, specs, counting = compare_with_full_composition(
        ["experiment=smoke", f"results_dir={RESULTS}"],
        select=lambda i, _: i < 80 and i % 16 == 1 + i // 16)
    assert len(jobs) == 3 * 6 * 2 * 8
    assert counting.calls == 3 * 6  # once per problem x algorithm: the fast path was taken
    for job, spec in zip(jobs, specs, strict=True):
        settings = dict(o.split("=", 1) for o in job)
        assert spec.config["problem"]["curve"] == settings["problem"]
        assert spec.optimizer == settings["optimizer"] and spec.study == "smoke"
        assert (spec.budget, spec.seed) == (int(settings["budget"]), int(settings["seed"]))
    assert len({spec.run_id for spec in specs}) == len(jobs)


def test_fast_composition_equals_full_composition_with_methods():
    # one method (config group) per base composition; the knot count and seed set on a copy,
    # so compare in full the jobs that change both
    jobs, specs, counting = compare_with_full_composition(
        ["experiment=fitpack_front", f"results_dir={RESULTS}", "problem=archimedean",
         "method=dolphin_indices,bobyqa_free,fitpack_free", "seed=0,3"],
        select=lambda _, job: "encoding.n_knots=fitpack:1e-6" in job and "seed=3" in job)
    assert len(jobs) == 3 * 2 * 2
    assert counting.calls == 3
    assert {spec.config["encoding"]["n_knots"] for spec in specs} == {"fitpack:0.0001",
                                                                     "fitpack:1e-06"}


def test_fast_composition_falls_back_for_interpolations():
    jobs, specs, counting = compare_with_full_composition(
        [f"results_dir={RESULTS}", "label=run-${seed}", "seed=0,1"])
    assert [spec.label for spec in specs] == ["run-0", "run-1"]
    assert counting.calls >= len(jobs)


def test_fast_composition_resolves_swept_interpolations():
    """A swept value that is an interpolation resolves as in full composition."""
    compare_with_full_composition(
        [f"results_dir={RESULTS}", "problem.name=plain,${problem.curve}-copy", "seed=0"])


def test_fast_composition_sets_a_forced_setting_on_a_copy():
    """``++optimizer.population=...`` (how metaknot run passes a run section's settings) takes
    the fast path: set on a copy, composed once, the same runs as in full composition; and the
    command line's ``++key`` replaces the same key of the sweep's parameters."""
    jobs, specs, counting = compare_with_full_composition(
        [f"results_dir={RESULTS}", "optimizer=ga", "++optimizer.population=20,30", "seed=0,1"])
    assert counting.calls == 1
    assert [spec.config["optimizer"]["population"] for spec in specs] == [20, 20, 30, 30]
    sweeper = study_sweeper([f"results_dir={RESULTS}", "experiment=smoke"])
    jobs = sweep_jobs(sweeper, ["++budget=7"])
    assert all(job.count("++budget=7") == 1 and not any(o.startswith("budget=") for o in job)
               for job in jobs)


def test_fast_composition_does_not_carry_values_between_jobs():
    loader = config_loader()
    cfg = loader.load_configuration("config", overrides=[f"results_dir={RESULTS}"],
                                    run_mode=RunMode.MULTIRUN)
    sweeper = SimpleNamespace(hydra_context=SimpleNamespace(config_loader=loader), config=cfg)
    composer = _Composer(sweeper, OverridesParser.create(config_loader=loader))
    for job in (["budget=500"], [], ["seed=3"]):
        fast = run_spec(composer(job), check_build=False)
        full = run_spec(loader.load_sweep_config(cfg, job), check_build=False)
        assert (fast.budget, fast.seed) == (full.budget, full.seed), job


def test_plan_finds_the_stored_runs(tmp_path):
    arguments = [f"results_dir={tmp_path}", "problem=archimedean", "optimizer=dolphin,ga",
                 "budget=100", "seed=0,1,2", "study=resume"]
    sweeper = study_sweeper(arguments)
    the_plan, study_dir = plan(sweeper, arguments)
    assert study_dir == tmp_path / "resume"
    assert the_plan.n_jobs == len(the_plan.to_run) == 6
    assert not the_plan.stored and not the_plan.duplicates and not the_plan.incompatible
    stored = [spec.run_id for _, spec in the_plan.to_run[1:5]]
    for run_id in stored:  # a record counts once it is a sound one (an empty file does not)
        Store(study_dir).write({"run_id": run_id, "status": "ok"})
    again, _ = plan(sweeper, arguments)
    assert sorted(spec.run_id for spec in again.stored) == sorted(stored)
    assert [spec.run_id for _, spec in again.to_run] == \
        [the_plan.to_run[0][1].run_id, the_plan.to_run[5][1].run_id]
    assert "4 already stored" in again.describe(study_dir)


def test_plan_skips_incompatible_pairs_and_duplicates(tmp_path):
    arguments = [f"results_dir={tmp_path}", "optimizer=nlopt,dolphin", "encoding=mask,free",
                 "seed=0,0", "budget=100"]
    the_plan, study_dir = plan(study_sweeper(arguments), arguments)
    assert the_plan.n_jobs == 8
    assert sorted((job[1], job[2]) for job, _ in the_plan.to_run) == \
        [("optimizer=dolphin", "encoding=mask"), ("optimizer=nlopt", "encoding=free")]
    assert the_plan.duplicates == 2
    assert sorted(the_plan.incompatible.values()) == [2, 2]
    assert any("'nlopt'" in r and "'mask'" in r for r in the_plan.incompatible)
    assert any("'dolphin'" in r and "'free'" in r for r in the_plan.incompatible)
    assert "2 duplicates" in the_plan.describe(study_dir)


def test_plan_stops_at_the_first_bad_job_naming_key_and_job(tmp_path):
    arguments = [f"results_dir={tmp_path}", "budget=100,0"]
    with pytest.raises(ConfigError) as info:
        plan(study_sweeper(arguments), arguments)
    message = str(info.value)
    assert message.startswith("budget:") and "budget=0" in message and "\n" not in message


def test_seed_paper_study_plans_without_errors_skips_or_duplicates(tmp_path):
    arguments = ["experiment=seed_paper", f"results_dir={tmp_path}", "seed=0,1"]
    sweeper = study_sweeper(arguments)
    sizes = {k: len(v) for k, v in sweep_values(sweeper.params).items() if k != "seed"}
    assert sizes == {"problem": 3, "optimizer": 2, "budget": 8}
    the_plan, study_dir = plan(sweeper, arguments)
    assert study_dir == tmp_path / "seed_paper"
    assert the_plan.n_jobs == len(the_plan.to_run) == 2 * 3 * 2 * 8
    assert not the_plan.incompatible and not the_plan.duplicates


@pytest.mark.parametrize("seeds", [0, [0, 1]])
def test_a_run_builds_its_problem_once(tmp_path, monkeypatch, seeds):
    """The task validates without building; the run builds the problem and optimizer once."""
    from metaknot.experiments import app, run

    built = []
    build = run._build_problem
    monkeypatch.setattr(run, "_build_problem",
                        lambda *args: built.append(1) or build(*args))
    cfg = OmegaConf.to_container(compose_cfg("budget=20", "problem.n_points=40",
                                             results_dir=str(tmp_path)))
    cfg["seed"] = seeds
    app.task(OmegaConf.create(cfg))
    assert len(built) == (len(seeds) if isinstance(seeds, list) else 1)
    assert len(Store(tmp_path / cfg["study"]).completed()) == len(built)


def test_free_knots_merge_close_knots_when_the_encoding_says_so():
    plain = spec_of("encoding=free", "encoding.n_knots=11")
    merging = spec_of("encoding=free", "encoding.n_knots=11", "encoding.merge_spacing=1e-6")
    assert "merge_spacing" not in plain.config["encoding"]  # the run ids of other runs stay
    assert merging.config["encoding"]["merge_spacing"] == 1e-6
    assert merging.run_id != plain.run_id
    problem = merging.build_problem()
    assert problem.merge_spacing == 1e-6 and problem.max_multiplicity == 3
    assert plain.build_problem().merge_spacing is None


def test_a_mask_of_multiplicities_is_an_integer_encoding_for_the_optimizers():
    plain = spec_of("problem.n_points=40")
    multiple = spec_of("problem.n_points=40", "encoding.max_multiplicity=3")
    assert "max_multiplicity" not in plain.config["encoding"]  # the run ids of other runs stay
    assert multiple.config["encoding"]["max_multiplicity"] == 3
    assert multiple.run_id != plain.run_id
    problem = multiple.build_problem()
    assert problem.max_multiplicity == 3 and problem.encoding.kind == "integer"
    assert spec_of("problem.n_points=40", "encoding.max_multiplicity=3",
                   "optimizer=ga").compatible() is None


def test_index_sets_with_repeats_are_configured_by_the_encoding():
    spec = spec_of("encoding=indices", "encoding.n_knots=6", "encoding.max_multiplicity=2")
    assert spec.config["encoding"] == {"kind": "indices", "n_knots": 6, "max_multiplicity": 2}
    problem = spec.build_problem()
    assert problem.max_multiplicity == 2 and not problem.encoding.distinct_sorted
    assert "max_multiplicity" not in spec_of("encoding=indices").config["encoding"]


def test_the_parameterizations_a_configuration_accepts_are_the_curve_models():
    from metaknot.bspline import PARAMETERIZATIONS
    from metaknot.experiments import spec

    assert spec.PARAMETERIZATIONS == PARAMETERIZATIONS
