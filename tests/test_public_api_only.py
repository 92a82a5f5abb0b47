"""The code uses other packages through their public API only: no import of a private module
(``hydra._internal``, a plugin's ``_core``) or of a private name, and no configuration whose
``_target_`` is one. Hydra, its launcher plugins and the rest can then change their insides
without breaking studies."""

from __future__ import annotations

import ast
from pathlib import Path

from omegaconf import OmegaConf

ROOT = Path(__file__).resolve().parent.parent
FOLDERS = ("metaknot", "problems", "algorithms", "experiments", "benchmarks", "tests")
#: Top-level names of this repository's own modules (a private name of our own is fine).
OWN = {"tests", "metaknot", "problems", "algorithms", "experiments"}


def _private(dotted: str) -> bool:
    return any(part.startswith("_") and not part.startswith("__") for part in dotted.split("."))


def _own(module: str, folder: Path) -> bool:
    """A module of this repository: the package, our Hydra plugin, or a file beside the
    importing one (``benchmarks/_timing.py``)."""
    top = module.split(".")[0]
    return top in OWN or module.startswith("hydra_plugins.metaknot_") or \
        (folder / f"{top}.py").is_file() or (folder / top).is_dir()


def private_imports(source: str, folder: Path = ROOT) -> list[str]:
    """The private modules and names of other packages that ``source`` imports (also inside
    functions, and through ``importlib.import_module("...")``)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and not node.level and node.module:
            if _own(node.module, folder):
                continue
            if _private(node.module):
                found.append(node.module)
            found += [f"{node.module}.{a.name}" for a in node.names if _private(a.name)]
        elif isinstance(node, ast.Import):
            found += [a.name for a in node.names if not _own(a.name, folder) and _private(a.name)]
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(
                node.func, "id", None)) == "import_module" and node.args \
                and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            name = node.args[0].value
            if not _own(name, folder) and _private(name):
                found.append(name)
    return found


def test_the_finder_finds_what_the_study_sweeper_once_imported():
    source = (
        "from hydra._internal.core_plugins.basic_sweeper import BasicSweeper\n"
        "def warm():\n"
        "    from hydra_plugins.hydra_joblib_launcher._core import process_joblib_cfg\n"
        "    import importlib; importlib.import_module('hydra._internal.utils')\n"
        "from hydra.core.utils import _flush_loggers\n"
        "import hydra._internal.utils as u\n"
        "from metaknot.registry import _lookup\n"
        "from hydra.plugins.sweeper import Sweeper\n")
    assert sorted(private_imports(source)) == [
        "hydra._internal.core_plugins.basic_sweeper", "hydra._internal.utils",
        "hydra._internal.utils", "hydra.core.utils._flush_loggers",
        "hydra_plugins.hydra_joblib_launcher._core"]


def test_no_module_imports_a_private_module_of_another_package():
    offences = []
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            offences += [f"{path.relative_to(ROOT)}: {name}"
                         for name in private_imports(path.read_text(), path.parent)]
    assert offences == []


def test_no_configuration_targets_a_private_module():
    targets = []

    def walk(node):
        if isinstance(node, dict):
            for key, value in node.items():
                if key == "_target_" and isinstance(value, str):
                    targets.append(value)
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    for path in sorted((ROOT / "experiments" / "conf").rglob("*.yaml")):
        walk(OmegaConf.to_container(OmegaConf.load(path)))
    assert [t for t in targets if not _own(t, ROOT) and _private(t.rpartition(".")[0])] == []
