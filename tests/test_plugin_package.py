"""An optimizer shipped by another package is usable by name, with no change to metaknot.

The package is the one ``docs/adding-an-optimizer.md`` shows: its complete example as the
module, its ``pyproject.toml`` as written there. The test builds the package from these two
texts, installs it with pip into a temporary folder and runs it, by name, in a fresh
interpreter.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import pytest

# one shared study or build for the module: keep its tests on one xdist worker
pytestmark = pytest.mark.xdist_group("plugin_package")

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "adding-an-optimizer.md"
ENTRY_POINTS = '[project.entry-points."metaknot.optimizers"]'


def guide_module() -> str:
    """The first Python code block of the guide: the optimizer's module."""
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert blocks, "the guide has no Python example"
    return blocks[0]


def guide_pyproject() -> str:
    """The guide's ``pyproject.toml`` of the package: its TOML block declaring the entry
    point."""
    blocks = re.findall(r"^```toml\n(.*?)^```", GUIDE.read_text(), flags=re.S | re.M)
    found = [block for block in blocks if ENTRY_POINTS in block]
    assert len(found) == 1, "the guide shows no pyproject.toml with the entry point"
    return found[0]


def plugin_module() -> str:
    """The module the entry point ``hill_climber`` of the guide's ``pyproject.toml`` names."""
    config = tomllib.loads(guide_pyproject())
    return config["project"]["entry-points"]["metaknot.optimizers"]["hill_climber"].split(":")[0]


def test_the_guide_shows_a_whole_pyproject() -> None:
    """Build system, project and package, not only the entry point's lines."""
    config = tomllib.loads(guide_pyproject())
    assert config["build-system"]["build-backend"] == "setuptools.build_meta"
    assert {"name", "version", "dependencies"} <= set(config["project"])
    assert "metaknot" in config["project"]["dependencies"]
    package, module = plugin_module().split(".")
    assert config["tool"]["setuptools"]["packages"] == [package]
    # the page's drawing of the package's files names the same package and module
    layout = GUIDE.read_text().split(ENTRY_POINTS)[0].rsplit("```text\n", 1)[1].split("```")[0]
    assert f"{package}/" in layout and f"{module}.py" in layout and "pyproject.toml" in layout


@pytest.fixture(scope="session")  # kept if other modules run in between
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = tmp_path_factory.mktemp("plugin_src")
    package, module = plugin_module().split(".")
    (src / package).mkdir()
    (src / package / "__init__.py").write_text("")
    (src / package / f"{module}.py").write_text(guide_module())
    (src / "pyproject.toml").write_text(guide_pyproject())
    target = tmp_path_factory.mktemp("plugin_site")
    done = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-index",
         "--no-build-isolation", "--target", str(target), str(src)],
        capture_output=True, text=True, timeout=300,
    )
    assert done.returncode == 0, done.stderr
    return target


def run_python(code: str, site: Path) -> str:
    env = {**os.environ, "PYTHONPATH": str(site)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, cwd=site, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.slow
def test_installed_plugin_runs_by_name(installed: Path) -> None:
    out = run_python(textwrap.dedent("""
        import json
        import metaknot as mk
        names = mk.available_optimizers()
        runs = [mk.minimize("mask", "hill_climber", budget=300, seed=4,
                            problem_kwargs={"points": "archimedean"},
                            optimizer_kwargs={"neighbours": 25}) for _ in range(2)]
        baseline = mk.minimize("mask", "random_search", budget=300, seed=4,
                               problem_kwargs={"points": "archimedean"})
        print(json.dumps({
            "listed": "hill_climber" in names,
            "module": type(mk.get_optimizer("hill_climber")).__module__,
            "evaluations": runs[0].n_evaluations,
            "best": [r.best_f for r in runs],
            "random_best": baseline.best_f,
        }))
    """), installed)
    report = json.loads(out.strip().splitlines()[-1])
    assert report["listed"]
    assert report["module"] == plugin_module()
    assert report["evaluations"] == 300
    assert report["best"][0] == report["best"][1]  # same seed, same run
    assert report["best"][0] <= report["random_best"]  # climbing beats blind sampling here


def test_guide_example_is_not_registered_in_metaknot() -> None:
    import metaknot as mk

    assert "hill_climber" not in mk.available_optimizers()


@pytest.mark.slow
def test_installed_plugin_runs_in_a_study_without_a_yaml(installed: Path, tmp_path: Path) -> None:
    """`metaknot run optimizer=<plugin>` works from the plugin's signature alone: its
    hyperparameters are settable and validated, and the record names them."""
    env = {**os.environ, "PYTHONPATH": str(installed)}
    command = [sys.executable, "-m", "metaknot.cli", "run", "optimizer=hill_climber",
               "problem=archimedean", "budget=300", f"results_dir={tmp_path}"]
    done = subprocess.run([*command, "optimizer.neighbours=25"], capture_output=True,
                          text=True, env=env, cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    bad = subprocess.run([*command, "optimizer.neighbours=many"], capture_output=True,
                         text=True, env=env, cwd=tmp_path, timeout=300)
    assert bad.returncode == 2 and "optimizer.neighbours" in bad.stderr
    from metaknot.experiments.store import load_study

    (row,) = load_study(tmp_path / "default").runs.to_dict("records")
    assert row["optimizer"] == "hill_climber" and row["optimizer.neighbours"] == 25
    assert row["n_evaluations"] == 300 and row["status"] == "ok"
