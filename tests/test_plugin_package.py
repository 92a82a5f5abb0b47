"""An optimizer shipped by another package is usable by name, with no change to metaknot.

The optimizer is the complete example of ``docs/adding-an-optimizer.md``: the test builds a
throwaway package from it, installs it with pip into a temporary folder and runs it, by name,
in a fresh interpreter.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

# one shared study or build for the module: keep its tests on one xdist worker
pytestmark = pytest.mark.xdist_group("plugin_package")

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "adding-an-optimizer.md"


def guide_module() -> str:
    """The first Python code block of the guide: the optimizer's module."""
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert blocks, "the guide has no Python example"
    return blocks[0]


@pytest.fixture(scope="session")  # kept if other modules run in between
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = tmp_path_factory.mktemp("plugin_src")
    (src / "mk_plugin_demo").mkdir()
    (src / "mk_plugin_demo" / "__init__.py").write_text("")
    (src / "mk_plugin_demo" / "hill_climber.py").write_text(guide_module())
    (src / "pyproject.toml").write_text(textwrap.dedent("""
        [build-system]
        requires = ["setuptools>=77"]
        build-backend = "setuptools.build_meta"

        [project]
        name = "mk-plugin-demo"
        version = "0.0.1"

        [project.entry-points."metaknot.optimizers"]
        hill_climber = "mk_plugin_demo.hill_climber:HillClimber"

        [tool.setuptools]
        packages = ["mk_plugin_demo"]
    """))
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
    assert report["module"] == "mk_plugin_demo.hill_climber"
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
