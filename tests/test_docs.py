"""The documentation: the README stays short, every relative link resolves, the site builds in
strict mode (``make docs``), and the code the how-tos show runs."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
import unicodedata
from pathlib import Path

import pytest

from metaknot.budget import Evaluator

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
README_LIMIT = 10_000  # bytes

FENCE = re.compile(r"^(```|~~~).*?^\1", re.S | re.M)
INLINE_CODE = re.compile(r"`[^`\n]*`")
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.M)


def markdown_files() -> list[Path]:
    """README.md and every Markdown page of docs/."""
    return [REPO / "README.md", *sorted(p for p in DOCS.rglob("*.md") if "_ext" not in p.parts)]


def slug(heading: str) -> str:
    """The anchor Python-Markdown's table of contents (and GitHub) gives a heading."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).replace("`", "")
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode()
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


def anchors(page: Path) -> set[str] | None:
    """The heading anchors of a Markdown page; None for a page with generated API sections
    (their anchors are checked by the strict build)."""
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    if re.search(r"^::: ", text, re.M):
        return None
    return {slug(h) for h in HEADING.findall(text)}


def broken_links(page: Path) -> list[str]:
    """The relative links of ``page`` whose file or heading does not exist."""
    text = INLINE_CODE.sub("", FENCE.sub("", page.read_text(encoding="utf-8")))
    broken = []
    for target in LINK.findall(text):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # https:, mailto:, ...
            continue
        path, _, anchor = target.partition("#")
        file = (page.parent / path).resolve() if path else page
        if not file.exists():
            broken.append(f"{target}: no such file")
            continue
        if anchor and file.suffix == ".md":
            known = anchors(file)
            if known is not None and anchor not in known:
                broken.append(f"{target}: no heading with this anchor")
    return broken


def test_readme_is_short() -> None:
    assert (REPO / "README.md").stat().st_size <= README_LIMIT


@pytest.mark.parametrize("page", markdown_files(), ids=lambda p: str(p.relative_to(REPO)))
def test_relative_links_resolve(page: Path) -> None:
    assert broken_links(page) == []


def test_link_check_finds_missing_files_and_headings(tmp_path: Path) -> None:
    (tmp_path / "other.md").write_text("# Other page\n\n## The `budget` section\n")
    page = tmp_path / "page.md"
    page.write_text(
        "# Page\n\n[fine](other.md#the-budget-section) [gone](missing.md) "
        "[wrong](other.md#no-such-section) [here](#page) [web](https://example.org/x.md)\n\n"
        "```\n[in code](nowhere.md)\n```\n")
    assert broken_links(page) == ["missing.md: no such file",
                                  "other.md#no-such-section: no heading with this anchor"]


def test_sphinx_roles_become_cross_references_or_code() -> None:
    spec = importlib.util.spec_from_file_location("griffe_metaknot",
                                                  DOCS / "_ext" / "griffe_metaknot.py")
    ext = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ext)
    import griffe

    loader = griffe.GriffeLoader(extensions=griffe.load_extensions(ext.MetaknotLayout()),
                                 search_paths=[str(REPO)])
    loader.load("metaknot")
    collection = loader.modules_collection
    # the folders pyproject maps into the package are its subpackages
    assert collection["metaknot.problems.knot_problems"].filepath == (
        REPO / "problems" / "knot_problems.py")
    bspline = collection["metaknot.bspline"]
    convert = ext.convert_roles
    assert convert(":func:`fit_spline`", bspline, collection) == (
        "[`fit_spline`][metaknot.bspline.fit.fit_spline]")
    assert convert(":class:`~metaknot.Task`", bspline, collection) == (
        "[`Task`][metaknot.task.Task]")
    assert convert(":mod:`.tables`", collection["metaknot.experiments.report"], collection) == (
        "[`tables`][metaknot.experiments.report.tables]")
    # private objects and other libraries are not in the reference: inline code
    assert convert(":mod:`._codegen`", bspline, collection) == "`_codegen`"
    assert convert(":class:`scipy.interpolate.BSpline`", bspline, collection) == (
        "`scipy.interpolate.BSpline`")


@pytest.mark.slow
def test_site_builds_in_strict_mode(tmp_path: Path) -> None:
    site = tmp_path / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for page in ("index.html", "getting-started/index.html", "guide/fit/index.html",
                 "how-to/add-a-problem/index.html", "results/seed-paper/index.html",
                 "seed-paper-report/report/index.html", "adding-an-optimizer/index.html"):
        assert (site / page).is_file(), page
    api = {name: (site / "api" / name / "index.html").read_text(encoding="utf-8")
           for name in ("metaknot", "bspline", "problems", "algorithms", "experiments", "apps")}
    for name, anchor in [("metaknot", "metaknot.runner.minimize"),
                         ("metaknot", "metaknot.budget.add_fits"),
                         ("bspline", "metaknot.bspline.moves.MoveEvaluator"),
                         ("problems", "metaknot.problems.knot_problems.KnotSelection"),
                         ("algorithms", "metaknot.algorithms.dolphin.DolphinEcholocation"),
                         ("experiments", "metaknot.experiments.store.load_study"),
                         ("experiments", "metaknot.experiments.tuning"),
                         ("apps", "metaknot.apps.fit.fit")]:
        assert f'id="{anchor}"' in api[name], anchor


def test_add_a_problem_how_to_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """The how-to's code, as written: it finds the terms of the cubic its data come from."""
    import metaknot.problems  # noqa: F401  (the built-in problems, in the real registry)
    import metaknot.registry as registry

    # the page registers its problem: on a copy of the registry
    monkeypatch.setitem(registry._REGISTRY, "problem", dict(registry._REGISTRY["problem"]))
    text = (DOCS / "how-to" / "add-a-problem.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```python\n(.*?)^```", text, re.S | re.M)
    namespace: dict = {"__name__": "add_a_problem"}
    for block in blocks:
        exec(compile(block, "docs/how-to/add-a-problem.md", "exec"), namespace)
    result = namespace["result"]
    assert result.status == "ok"
    assert set(result.solution) == {0, 1, 3}
    assert result.record()["n_evaluations"] <= 2000


def test_sequential_optimizer_example_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """The simulated annealing of "A sequential optimizer at kernel speed", as written: its
    moves scored by delta evaluation, its next steps asked ahead (far fewer calls than
    evaluations)."""
    import metaknot.algorithms  # noqa: F401  (the built-in optimizers, in the real registry)
    import metaknot.registry as registry

    # the page registers its optimizer: on a copy of the registry
    monkeypatch.setitem(registry._REGISTRY, "optimizer",
                        dict(registry._REGISTRY["optimizer"]))
    text = (DOCS / "adding-an-optimizer.md").read_text(encoding="utf-8")
    section = text.split("## A sequential optimizer at kernel speed")[1].split("\n## ")[0]
    blocks = re.findall(r"^```python\n(.*?)^```", section, re.S | re.M)
    assert len(blocks) == 2
    assert len(blocks[0].splitlines()) <= 60  # a short example
    namespace: dict = {"__name__": "annealing"}
    calls = []
    evaluate = Evaluator.__call__

    def counting(self, X, near=None, accept=None):
        calls.append(accept is not None)
        return evaluate(self, X, near=near, accept=accept)

    monkeypatch.setattr(Evaluator, "__call__", counting)
    for block in blocks:
        exec(compile(block, "docs/adding-an-optimizer.md", "exec"), namespace)
    assert len(calls) < 3000 / 3 and sum(calls) > len(calls) / 2
    result = namespace["annealing"]
    assert result.status == "ok" and result.n_evaluations == 3000
    assert result.delta_evaluations > 2000  # nearly every step a delta move
    assert result.trace.evaluations[0] == 1
    assert result.best_f < result.trace.best_f[0]  # it improved on its start
    again = namespace["mk"].minimize("mask", "annealing", budget=3000, seed=1,
                                     problem_kwargs={"points": "archimedean"})
    assert again.best_f == result.best_f  # reproducible from its seed

