"""Packaging: ``problems/``, ``algorithms/`` and ``experiments/`` ship as ``metaknot.*`` only.

The repository keeps these packages as top-level folders; ``pyproject.toml`` maps them to
``metaknot.problems``, ``metaknot.algorithms`` and ``metaknot.experiments``. They must never be
importable as global top-level packages (``import problems``) from an installation.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest

# one shared build for the module: keep its tests on one xdist worker
pytestmark = pytest.mark.xdist_group("packaging")

REPO = Path(__file__).resolve().parents[1]
MAPPED = {"problems": "problems", "algorithms": "algorithms", "experiments": "experiments"}

CHECK_IMPORTS = """
import importlib, importlib.util, json, sys
out = {"sys_path": sys.path}
for sub in ("problems", "algorithms", "experiments"):
    mod = importlib.import_module("metaknot." + sub)
    out["metaknot." + sub] = mod.__file__
    out["global " + sub] = importlib.util.find_spec(sub) is not None
    try:
        importlib.import_module(sub)
        out["import " + sub] = True
    except ImportError:
        out["import " + sub] = False
import metaknot

out["metaknot"] = metaknot.__file__
print(json.dumps(out))
"""


def _run(code: str, cwd: Path, env: dict[str, str] | None = None,
         python: str = sys.executable) -> dict:
    proc = subprocess.run([python, "-c", code], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _clean_env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    env.pop("PYTHONHOME", None)
    env["PYTHONNOUSERSITE"] = "1"
    return env


def _venv_with_dependencies(venv: Path) -> Path:
    """A new venv without metaknot that sees this environment's packages (numpy, setuptools,
    ...) through a path entry; the editable install of this checkout there is not active (its
    ``.pth`` files are read only in site folders). Returns the venv's Python."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=120, capture_output=True)
    python = venv / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; "
                           "print(sysconfig.get_paths()['purelib'])"], check=True, timeout=60,
                          capture_output=True, text=True).stdout.strip()
    (Path(site) / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    return python


# --------------------------------------------------------------------------------------------
# editable install
# --------------------------------------------------------------------------------------------


def test_in_process_subpackages_are_the_repo_folders():
    import metaknot.algorithms
    import metaknot.experiments
    import metaknot.problems

    for module, folder in [(metaknot.problems, "problems"), (metaknot.algorithms, "algorithms"),
                           (metaknot.experiments, "experiments")]:
        assert Path(module.__file__).resolve() == REPO / folder / "__init__.py"
    # the submodules come from the same folders
    import metaknot.problems.curves

    assert Path(metaknot.problems.curves.__file__).resolve() == REPO / "problems" / "curves.py"


def test_editable_install_outside_the_repo(tmp_path):
    out = _run(CHECK_IMPORTS, cwd=tmp_path, env=_clean_env())
    # the repository root is not on the path ('' is the working directory, tmp_path)
    assert not any(Path(p or tmp_path).resolve() == REPO for p in out["sys_path"])
    assert Path(out["metaknot"]).resolve() == REPO / "metaknot" / "__init__.py"
    for sub, folder in MAPPED.items():
        assert Path(out["metaknot." + sub]).resolve() == REPO / folder / "__init__.py"
        assert out["global " + sub] is False, f"'{sub}' is importable as a top-level package"
        assert out["import " + sub] is False


def test_editable_install_does_not_leak_other_folders(tmp_path):
    names = ["problems", "algorithms", "experiments", "tests", "benchmarks", "bspline",
             "curves", "random_search", "docs"]
    code = (
        "import importlib.util, json\n"
        f"names = {names!r}\n"
        "specs = {n: importlib.util.find_spec(n) for n in names}\n"
        "print(json.dumps({n: (s.origin or str(list(s.submodule_search_locations or [])))\n"
        "                  if s else None for n, s in specs.items()}))\n"
    )
    out = _run(code, cwd=tmp_path, env=_clean_env())
    for name, origin in out.items():
        # not importable at all, or (some unrelated installed package, such as the top-level
        # `tests` that ioh's wheel installs into the venv) not from this repo's folders
        installed = origin is not None and "site-packages" in Path(origin).parts
        assert origin is None or installed or str(REPO) not in origin, (name, origin)


# --------------------------------------------------------------------------------------------
# wheel
# --------------------------------------------------------------------------------------------


def _copy_source(dest: Path, compiled: bool = False) -> Path:
    """A copy of the source tree, so that building leaves the working tree untouched.

    Parameters
    ----------
    dest
        The copy's folder (made).
    compiled
        Keep the compiled kernels numba cached beside the sources (``__pycache__``): the copy
        keeps the files' times, so numba loads them instead of compiling anew (a minute).
    """
    caches = () if compiled else ("__pycache__", "*.nbi", "*.nbc")
    ignore = shutil.ignore_patterns(".venv", ".git", "build", "dist", "*.egg-info",
                                    ".ruff_cache", ".pytest_cache", ".hypothesis", "outputs",
                                    "multirun", *caches)
    shutil.copytree(REPO, dest, ignore=ignore)
    return dest


#: a build frontend's way to the sdist: the hook of the backend pyproject.toml names
SDIST = """
import importlib, sys, tomllib
with open("pyproject.toml", "rb") as file:
    system = tomllib.load(file)["build-system"]
sys.path[:0] = system.get("backend-path", [])
print(importlib.import_module(system["build-backend"]).build_sdist(sys.argv[1]))
"""


@dataclass
class Build:
    """The wheel and the sdist built from the source tree, and what the wheel's build
    printed."""

    wheel: Path
    sdist: Path
    output: str


def _pip_wheel(source: Path, out: Path) -> tuple[Path, str]:
    """``pip wheel`` of ``source`` (a folder or an sdist) into ``out``: the wheel, and the
    output (verbose: pip shows the backend's)."""
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
         "--no-index", "-v", "-w", str(out), str(source)],
        capture_output=True, text=True, timeout=300, env=_clean_env(),
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    wheels = list(out.glob("metaknot-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0], proc.stdout + proc.stderr


@pytest.fixture(scope="session")  # kept if other modules run in between
def build(tmp_path_factory) -> Build:
    root = tmp_path_factory.mktemp("wheel")
    src = _copy_source(root / "src")
    wheel, output = _pip_wheel(src, root / "dist")
    made = subprocess.run([sys.executable, "-c", SDIST, str(root / "sdist")], cwd=src,
                          capture_output=True, text=True, timeout=300, env=_clean_env())
    assert made.returncode == 0, made.stdout + made.stderr
    return Build(wheel, root / "sdist" / made.stdout.strip().splitlines()[-1], output)


@pytest.fixture(scope="session")
def wheel(build) -> Path:
    return build.wheel


@pytest.mark.slow
def test_the_build_prints_no_warning(build):
    """setuptools warned that each configuration group's folder and suite/data were packages
    left out of `packages` (eight warnings, about 330 lines even with pip's ``-q``)."""
    assert "is absent from the `packages` configuration" not in build.output
    warnings = [line for line in build.output.splitlines() if "Warning:" in line]
    assert warnings == []


@pytest.mark.slow
def test_the_sdist_builds_the_same_wheel(build, tmp_path):
    """The sdist holds what building needs (the backend of build_backend/ included)."""
    wheel, _ = _pip_wheel(build.sdist, tmp_path)
    assert sorted(zipfile.ZipFile(wheel).namelist()) == sorted(
        zipfile.ZipFile(build.wheel).namelist())


def _shipped_files() -> set[str]:
    """Every module and data file of the repository's package folders, by the path it has in
    an installation (``problems/curves.py`` is ``metaknot/problems/curves.py``)."""
    folders = {"metaknot": "metaknot", "problems": "metaknot/problems",
               "algorithms": "metaknot/algorithms", "experiments": "metaknot/experiments",
               "suite": "metaknot/suite",
               "experiments/hydra_plugins": "hydra_plugins"}
    files = set()
    for folder, installed in folders.items():
        for path in (REPO / folder).rglob("*"):
            relative = path.relative_to(REPO / folder)
            if (not path.is_file() or "__pycache__" in relative.parts
                    or (folder == "experiments" and relative.parts[0] == "hydra_plugins")):
                continue
            assert path.suffix in (".py", ".yaml", ".json"), f"{path}: shipped or not?"
            files.add(f"{installed}/{relative.as_posix()}")
    return files


@pytest.mark.slow
def test_the_wheel_holds_every_module_and_configuration_file(wheel):
    names = {n for n in zipfile.ZipFile(wheel).namelist() if ".dist-info/" not in n}
    expected = _shipped_files()
    assert {"metaknot/experiments/conf/encoding/mask.yaml", "metaknot/experiments/conf/config.yaml",
            "metaknot/suite/data/best_known.json", "metaknot/problems/curves.py",
            "hydra_plugins/metaknot_study_sweeper/__init__.py"} <= expected
    assert sorted(expected - names) == []  # nothing left out
    assert sorted(names - expected) == []  # nothing else


@pytest.mark.slow
def test_a_wheel_installation_finds_its_configuration(wheel, tmp_path):
    """Installed from the wheel (not editable), the command finds the Hydra configuration
    groups in the package: every folder of experiments/conf with its YAML files."""
    python = _venv_with_dependencies(tmp_path / "venv")
    env = _clean_env()
    done = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
         "--no-index", "-q", str(wheel)],
        capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    command = str(python.parent / "metaknot")
    listed = subprocess.run([command, "list"], cwd=tmp_path, capture_output=True, text=True,
                            timeout=300, env=env)
    assert listed.returncode == 0, listed.stderr
    assert "encodings:  free, indices, mask" in listed.stdout
    assert "random_search" in listed.stdout
    helped = subprocess.run([command, "run", "--help"], cwd=tmp_path, capture_output=True,
                            text=True, timeout=300, env=env)
    assert helped.returncode == 0, helped.stderr
    groups = dict(line.split(": ", 1) for line in helped.stdout.split(
        "== Configuration groups ==")[1].split("== Config ==")[0].splitlines()
        if ": " in line and "=" not in line)
    for folder in (REPO / "experiments" / "conf").iterdir():
        if folder.is_dir() and folder.name != "__pycache__":
            options = sorted(p.stem for p in folder.glob("*.yaml"))
            assert groups.get(folder.name) == ", ".join(options), folder.name
    where = subprocess.run([str(python), "-c", "import metaknot.experiments.app as app; "
                            "print(app.CONFIG_DIR)"], cwd=tmp_path, capture_output=True,
                           text=True, timeout=300, env=env)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(tmp_path / "venv")


@pytest.mark.slow
def test_wheel_contents(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    top = {n.split("/")[0] for n in names}
    assert "metaknot" in top
    # besides metaknot: only the study sweeper, in Hydra's plugin namespace (no __init__.py)
    assert all(t in ("metaknot", "hydra_plugins") or t.endswith(".dist-info") for t in top), \
        sorted(top)
    plugins = {n.split("/")[1] for n in names if n.startswith("hydra_plugins/")}
    assert plugins == {"metaknot_study_sweeper"}
    assert "hydra_plugins/__init__.py" not in names
    # the Hydra configuration ships with the package
    for yaml in (REPO / "experiments" / "conf").rglob("*.yaml"):
        relative = yaml.relative_to(REPO / "experiments").as_posix()
        assert f"metaknot/experiments/{relative}" in names, relative
    for needed in ("metaknot/__init__.py", "metaknot/problems/__init__.py",
                   "metaknot/problems/curves.py", "metaknot/problems/objectives.py",
                   "metaknot/problems/knot_problems.py", "metaknot/algorithms/__init__.py",
                   "metaknot/algorithms/random_search.py", "metaknot/experiments/__init__.py",
                   "metaknot/bspline/__init__.py"):
        assert needed in names, needed
    for forbidden in ("problems/", "algorithms/", "experiments/", "tests/", "benchmarks/"):
        assert not any(n.startswith(forbidden) for n in names), forbidden
    # every module of the mapped folders is in the wheel
    for folder in MAPPED:
        for py in (REPO / folder).glob("*.py"):
            assert f"metaknot/{folder}/{py.name}" in names
    top_level = [n for n in names if n.endswith(".dist-info/top_level.txt")]
    if top_level:
        listed = zipfile.ZipFile(wheel).read(top_level[0]).decode().split()
        assert sorted(listed) == ["hydra_plugins", "metaknot"]


@pytest.mark.slow
def test_wheel_imports_without_the_repo(wheel, tmp_path):
    extracted = tmp_path / "extracted"
    zipfile.ZipFile(wheel).extractall(extracted)
    # a plain venv: it does not see the editable install of the project venv
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=120, capture_output=True)
    python = venv / "bin" / "python"
    assert python.exists()
    site_packages = sysconfig.get_paths()["purelib"]  # dependencies (numpy, scipy, ...)
    env = _clean_env()
    env["PYTHONPATH"] = os.pathsep.join([str(extracted), site_packages])
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba_cache")
    code = CHECK_IMPORTS.replace(
        'print(json.dumps(out))',
        'import metaknot.problems as mp\n'
        'c = mp.get_curve("epitrochoid")\n'
        'out["curve"] = [c.n_points, c.dim, float(c.points[180, 0])]\n'
        'out["optimizers"] = metaknot.available_optimizers()\n'
        'from hydra.core.plugins import Plugins\n'
        'from hydra.plugins.sweeper import Sweeper\n'
        'out["sweepers"] = [c.__name__ for c in Plugins.instance().discover(Sweeper)]\n'
        'print(json.dumps(out))',
    )
    out = _run(code, cwd=tmp_path, env=env, python=str(python))
    assert not any(Path(p or tmp_path).resolve() == REPO for p in out["sys_path"])
    assert Path(out["metaknot"]).resolve() == extracted / "metaknot" / "__init__.py"
    for sub in MAPPED:
        module_file = Path(out["metaknot." + sub]).resolve()
        assert module_file == extracted / "metaknot" / sub / "__init__.py"
        assert out["global " + sub] is False
        assert out["import " + sub] is False
    # epitrochoid at t = 0: (a + b) - h = 2
    assert out["curve"][:2] == [361, 2]
    assert out["curve"][2] == pytest.approx(2.0, abs=1e-12)
    assert "random_search" in out["optimizers"]
    # installed from a wheel, Hydra's own plugin scan finds the study sweeper
    assert "StudySweeper" in out["sweepers"]


# --------------------------------------------------------------------------------------------
# the README's example, from the folder that holds a clone named metaknot
# --------------------------------------------------------------------------------------------


def readme_example() -> str:
    """The README's Python example: its first ``python`` code block, as written."""
    text = (REPO / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)
    assert blocks, "the README has no Python example"
    return blocks[0]


@pytest.mark.slow
def test_readme_example_runs_from_the_folder_that_holds_the_clone(tmp_path):
    """A clone named ``metaknot``, installed with ``pip install -e``, and the README's example
    run as a script from the clone's parent folder: that folder is the first entry of
    ``sys.path`` and holds ``metaknot/`` without ``__init__.py``, which Python's path finder
    takes for a namespace package unless it finds a regular ``metaknot`` on the path (it was
    imported as an empty namespace: ``module 'metaknot' has no attribute 'minimize'``)."""
    example = readme_example()
    # in this process first: the kernels it compiles are cached in the checkout, and copied
    exec(compile(example, "README.md", "exec"), {"__name__": "readme_example"})
    clone = _copy_source(tmp_path / "metaknot", compiled=True)
    assert not (clone / "__init__.py").exists()
    python = _venv_with_dependencies(tmp_path / "venv")
    env = _clean_env()
    done = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
         "--no-index", "--no-build-isolation", "-q", "-e", str(clone)],
        capture_output=True, text=True, timeout=300, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    # nor does it warn: not of packages missing from `packages` (the configuration's folders),
    # nor that a folder named like the package in the working directory may be imported
    assert [line for line in (done.stdout + done.stderr).splitlines() if "Warning" in line] == []
    script = tmp_path / "example.py"
    script.write_text(example + "\nimport metaknot\nprint(metaknot.__file__)\n")
    ran = subprocess.run([str(python), script.name], cwd=tmp_path, capture_output=True,
                         text=True, timeout=600, env=env)
    assert ran.returncode == 0, ran.stderr[-3000:]
    assert Path(ran.stdout.strip().splitlines()[-1]) == clone / "metaknot" / "__init__.py"
    # the same from a Python started in that folder ('' first on the path)
    ran = subprocess.run([str(python), "-c", "import metaknot; print(metaknot.minimize)"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300, env=env)
    assert ran.returncode == 0 and "function minimize" in ran.stdout, ran.stderr[-3000:]
