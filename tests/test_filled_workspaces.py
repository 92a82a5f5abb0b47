"""No result depends on what an uninitialised workspace held.

The compiled kernels allocate their workspaces with ``np.empty``: whatever the memory held
before. A kernel that reads a cell it never wrote gives a result that depends on what ran
earlier in the process, which is how a fit of a 7-point circle once came out differently from
run to run (the open move kernel read forward states below column ``p`` of a fit with fewer
than ``2p`` control points). This test copies the package, fills every ``np.empty`` and
``np.empty_like`` of the copy (NaN for floats, a large negative number for integers, which also
makes an unwritten index crash), and runs the same evaluations under both builds
(``tests/_workspace_probe.py``): every result must be the same bits.

The copy compiles afresh every kernel of a file the fill changed, about two minutes; the
generated row loops, which allocate nothing and import nothing that is filled, are loaded from
the package's own compiled cache (about 100 s less), as the normal build loads them.
"""

from __future__ import annotations

import ast
import importlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import metaknot
from metaknot.bspline.moves import PATH_CHECKS, PATH_DELTA, PATH_FULL

pytestmark = pytest.mark.slow

PROBE = Path(__file__).with_name("_workspace_probe.py")
#: Subpackages installed from folders of their own (``pyproject.toml``'s package-dir).
SUBPACKAGES = ("problems", "algorithms", "suite")
#: What a filled workspace holds, by the dtype named in the allocation (floats by default).
FILLS = {"int64": "-1099511627769", "intp": "-1099511627769", "int8": "-77", "bool": "True"}
#: Modules whose compiled cache the filled copy takes over: the fill leaves them as they are, and
#: they import no other module of the package (their compiled code holds nothing filled).
REUSED_CACHES = ("bspline/_rows.py", "bspline/_moves_rows.py")


def filled(source: str) -> tuple[str, int]:
    """``source`` with every ``np.empty(shape[, dtype])`` and ``np.empty_like(a)`` turned into
    a filled allocation of the same shape and dtype; and how many were turned."""
    tree = ast.parse(source)
    starts = np.cumsum([0] + [len(line) for line in source.splitlines(keepends=True)])
    edits = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                and isinstance(node.func.value, ast.Name) and node.func.value.id == "np"
                and node.func.attr in ("empty", "empty_like")):
            continue
        shape = ast.unparse(node.args[0])
        if node.func.attr == "empty_like":  # the kernels' only one copies int64 rows
            new = f"np.full_like({shape}, {FILLS['int64']})"
        else:
            dtype = node.args[1] if len(node.args) > 1 else next(
                (k.value for k in node.keywords if k.arg == "dtype"), None)
            name = "" if dtype is None else ast.unparse(dtype)
            kind = next((k for k in FILLS if k in name), None)
            if kind is None and name and "float" not in name:
                raise ValueError(f"no fill for dtype {name!r} at line {node.lineno}")
            new = (f"np.full({shape}, {FILLS[kind] if kind else 'np.nan'}"
                   f"{', dtype=' + name if name else ''})")
        start = starts[node.lineno - 1] + node.col_offset
        end = starts[node.end_lineno - 1] + node.end_col_offset
        edits.append((start, end, new))
    for start, end, new in sorted(edits, reverse=True):
        source = source[:start] + new + source[end:]
    return source, len(edits)


def filled_copy(destination: Path) -> int:
    """The package, laid out as installed, copied to ``destination`` with every workspace
    filled; returns how many allocations were filled."""
    package = destination / "metaknot"
    ignore = shutil.ignore_patterns("__pycache__")
    shutil.copytree(Path(metaknot.__file__).parent, package, ignore=ignore)
    for name in SUBPACKAGES:
        if not (package / name).exists():
            module = importlib.import_module(f"metaknot.{name}")
            shutil.copytree(Path(module.__path__[0]), package / name, ignore=ignore)
    count = 0
    for path in package.rglob("*.py"):
        text, n = filled(path.read_text())
        if n:
            path.write_text(text)
            count += n
    reuse_caches(Path(metaknot.__file__).parent, package)
    return count


def reuse_caches(source: Path, package: Path) -> None:
    """Copy the numba cache files of :data:`REUSED_CACHES` from the package's ``__pycache__``
    folders into the copy's: numba takes them if the source file's size and time match, which
    the copy keeps (with no in-tree cache, e.g. ``NUMBA_CACHE_DIR`` set, the copy compiles
    those modules too)."""
    for name in REUSED_CACHES:
        module = package / name
        assert filled(module.read_text())[1] == 0, f"{name} allocates: it must be filled"
        imports = [node for node in ast.walk(ast.parse(module.read_text()))
                   if isinstance(node, ast.ImportFrom) and (node.level or "metaknot" in
                                                            (node.module or ""))]
        assert all(node.level == 1 and f"bspline/{node.module}.py" in REUSED_CACHES
                   for node in imports), f"{name} imports a module whose cache is not reused"
        cache = (source / name).parent / "__pycache__"
        target = module.parent / "__pycache__"
        for path in cache.glob(f"{module.stem}.*.nb[ic]") if cache.is_dir() else ():
            target.mkdir(exist_ok=True)
            shutil.copy2(path, target / path.name)


def probe(out: Path, pythonpath: Path | None) -> dict[str, np.ndarray]:
    env = dict(os.environ)
    if pythonpath is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(pythonpath),
                                                          env.get("PYTHONPATH")]))
    done = subprocess.run([sys.executable, str(PROBE), str(out)], env=env, cwd=out.parent,
                          capture_output=True, text=True, timeout=1500)
    assert done.returncode == 0, done.stderr[-3000:]
    with np.load(out) as results:
        return dict(results)


def test_the_fill_covers_every_allocation_form() -> None:
    text = ("a = np.empty(n)\nb = np.empty((n, p + 1))\nc = np.empty(m, dtype=np.int64)\n"
            "d = np.empty(k, np.int8)\ne = np.empty_like(X)\nf = np.empty(0, dtype=bool)\n")
    new, count = filled(text)
    assert count == 6
    namespace = {"np": np, "n": 3, "p": 2, "m": 2, "k": 2, "X": np.arange(3)}
    exec(new, namespace)
    assert np.isnan(namespace["a"]).all() and namespace["b"].shape == (3, 3)
    assert namespace["c"].dtype == np.int64 and (namespace["c"] < -1e12).all()
    assert namespace["d"].dtype == np.int8 and (namespace["d"] == -77).all()
    assert namespace["e"].dtype == namespace["X"].dtype and (namespace["e"] < -1e12).all()
    assert namespace["f"].dtype == bool and namespace["f"].size == 0
    with pytest.raises(ValueError, match=r"no fill for dtype 'np\.complex128'"):
        filled("z = np.empty(3, dtype=np.complex128)\n")



def test_results_do_not_depend_on_workspace_contents(tmp_path) -> None:
    build = tmp_path / "filled"
    assert filled_copy(build) > 50  # the kernels' workspaces are there to be filled
    assert "np.empty" not in (build / "metaknot/bspline/_moves.py").read_text()
    normal = probe(tmp_path / "normal.npz", None)
    refilled = probe(tmp_path / "refilled.npz", build)
    assert normal["module"] == str(Path(metaknot.__file__).parent / "bspline/moves.py")
    assert refilled["module"] == str(build / "metaknot/bspline/moves.py")
    paths = np.concatenate([v for k, v in normal.items() if k.endswith(":path")])
    assert {PATH_DELTA, PATH_CHECKS, PATH_FULL} <= set(paths.tolist())  # every path is probed
    assert sorted(normal) == sorted(refilled)
    differ = [key for key, value in normal.items() if key != "module" and not np.array_equal(
        value, refilled[key], equal_nan=value.dtype.kind == "f")]
    assert not differ, f"{len(differ)} results change with the workspaces' contents: " \
                       f"{differ[:10]}"
