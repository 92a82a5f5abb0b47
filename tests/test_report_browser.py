"""The HTML report as a reviewer sees it: ``report.html`` opened in a real headless browser
(Debian's Chromium, driven by playwright without a browser download of its own). It loads
cleanly and on its own, every figure decodes, the sections are there, and the page is not
blank; the Markdown report's figure links resolve."""

from __future__ import annotations

import base64
import hashlib
import io
import os
import re
import shutil
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass, field
from html import unescape
from pathlib import Path
from urllib.parse import urlsplit

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import sync_playwright

from metaknot.experiments.report import build

# one study and report for the whole module: keep its tests on one xdist worker (--dist loadgroup)
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("report_browser")]

ENV = {**os.environ, "PYTHONUNBUFFERED": "1"}
STUDY = "default"
INSTANCES = ("archimedean", "vivaldi")
BROWSER_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run",
                "--disable-background-networking", "--disable-component-update",
                "--disable-sync"]
VIEWPORT = {"width": 1200, "height": 900}
#: The only places a self-contained report may load anything from.
LOCAL_SCHEMES = {"file", "data"}


def chromium_path() -> str:
    path = shutil.which("chromium")
    if path is None:
        pytest.fail("Debian's chromium is not on the PATH: install it (apt-get install chromium, "
                    "or `make chromium`) to check the HTML report in a browser; do not run "
                    "`playwright install`", pytrace=False)
    return path


@dataclass
class Visit:
    """The report open in a browser tab, with what happened while it loaded."""

    page: object
    console_errors: list[str] = field(default_factory=list)
    page_errors: list[str] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)


@pytest.fixture(scope="module")
def chromium() -> str:
    return chromium_path()


@pytest.fixture(scope="session")  # kept if other modules run in between
def report(tmp_path_factory):
    """A small real study (3 methods x 2 instances x 2 budgets x 6 seeds) and its report."""
    tmp = tmp_path_factory.mktemp("report-browser")
    done = subprocess.run(
        [sys.executable, "-m", "metaknot.cli", "run", "-m",
         "optimizer=ga,random_search,dolphin", "problem=" + ",".join(INSTANCES),
         "budget=300,600", "seed=range(0,6)", f"results_dir={tmp}"],
        cwd=tmp, capture_output=True, text=True, timeout=600, env=ENV)
    assert done.returncode == 0, done.stderr
    return build(tmp / STUDY, tmp / "report", log=None)


@pytest.fixture(scope="module")
def visit(chromium, report):
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=BROWSER_ARGS)
        try:
            context = browser.new_context(viewport=VIEWPORT)
            # nothing may go out; should the report try, the request fails and is seen below
            context.route(re.compile(r"^(https?|wss?|ftp):"), lambda route: route.abort())
            page = context.new_page()
            seen = Visit(page)
            page.on("console",
                    lambda m: m.type == "error" and seen.console_errors.append(m.text))
            page.on("pageerror", lambda e: seen.page_errors.append(str(e)))
            page.on("requestfailed",
                    lambda r: seen.failed.append(f"{r.url[:120]}: {r.failure}"))
            page.on("request", lambda r: seen.requests.append(r.url))
            page.on("websocket", lambda w: seen.requests.append(w.url))
            page.goto(report.html.resolve().as_uri(), wait_until="load")
            page.wait_for_load_state("networkidle")
            yield seen
        finally:
            browser.close()


def sections(page) -> list[dict]:
    """Each h2/h3 with what follows it up to the next heading."""
    return page.evaluate("""() => Array.from(document.querySelectorAll('h2, h3'), h => {
        const parts = [];
        for (let el = h.nextElementSibling; el && !/^H[1-3]$/.test(el.tagName);
             el = el.nextElementSibling) {
            parts.push({tag: el.tagName, text: el.textContent.trim(),
                        tables: el.querySelectorAll('table').length + (el.tagName === 'TABLE'),
                        images: el.querySelectorAll('img').length});
        }
        return {level: h.tagName, title: h.textContent.trim(), parts};
    })""")


def tables(page) -> list[dict]:
    """Every table: header cells, the cell count of each body row, and which cells are bold."""
    return page.evaluate("""() => Array.from(document.querySelectorAll('table'), t => ({
        header: Array.from(t.querySelectorAll('thead tr th'), th => th.textContent.trim()),
        headerRows: t.querySelectorAll('thead tr').length,
        rows: Array.from(t.querySelectorAll('tbody tr'), tr => Array.from(tr.cells, td => ({
            text: td.textContent.trim(), bold: td.querySelector('strong') !== null}))),
        section: (() => {
            let el = t.closest('div.scroll') || t;
            while (el && !/^H[1-3]$/.test(el.tagName)) el = el.previousElementSibling;
            return el ? el.textContent.trim() : null;
        })(),
    }))""")


def digest(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def test_chromium_is_installed():
    assert Path(chromium_path()).exists()


def test_the_page_loads_cleanly_and_on_its_own(visit):
    page = visit.page
    assert page.title() == f"metaknot report: {STUDY}"
    assert not visit.console_errors, visit.console_errors
    assert not visit.page_errors, visit.page_errors
    assert not visit.failed, visit.failed
    outside = [url[:120] for url in visit.requests if urlsplit(url).scheme not in LOCAL_SCHEMES]
    assert not outside, f"requests that leave the file: {outside}"
    assert visit.requests, "the browser did not even request the report"
    # what the page itself recorded as loaded, and every reference in it
    resources = page.evaluate(
        "() => performance.getEntriesByType('resource').map(e => e.name)")
    assert all(urlsplit(url).scheme in LOCAL_SCHEMES for url in resources), resources
    references = page.evaluate("""() => Array.from(
        document.querySelectorAll('[src], [href], [srcset], [poster], [data]'),
        el => ['src', 'href', 'srcset', 'poster', 'data'].map(a => el.getAttribute(a))
              .filter(v => v !== null)).flat()""")
    remote = [ref[:80] for ref in references
              if not (ref.startswith(("data:", "#")) or ref == "")]
    assert not remote, f"references to other files or sites: {remote}"
    styles = page.evaluate("""() => Array.from(document.styleSheets, s => Array.from(
        s.cssRules, r => r.cssText).join('\\n')).join('\\n')""")
    assert "url(" not in styles and "@import" not in styles


def test_every_figure_decodes(visit, report):
    images = visit.page.evaluate("""() => Promise.all(Array.from(document.images, async img => {
        let decoded = true;
        try { await img.decode(); } catch (e) { decoded = String(e); }
        const box = img.getBoundingClientRect();
        const figure = img.closest('figure');
        const caption = figure && figure.querySelector('figcaption');
        return {src: img.getAttribute('src'), alt: img.alt, complete: img.complete, decoded,
                width: img.naturalWidth, height: img.naturalHeight,
                shown: [box.width, box.height], caption: caption ? caption.textContent : ''};
    }))""")
    pngs = sorted((report.out / "figures").glob("*.png"))
    assert len(pngs) >= 10  # per instance: budget, convergence, ecdf, front, curves
    assert len(images) == len(pngs), (len(images), [p.name for p in pngs])
    for image in images:
        name = image["alt"] or image["src"][:60]
        assert image["complete"] and image["decoded"] is True, (name, image["decoded"])
        assert image["width"] > 0 and image["height"] > 0, name
        assert min(image["shown"]) > 0, f"{name} takes no room on the page"
        assert image["shown"][0] <= VIEWPORT["width"], f"{name} is wider than the window"
        assert image["alt"].strip() and image["caption"].strip(), name
        assert image["src"].startswith("data:image/png;base64,"), name
    # the embedded figures are exactly the PNG files, each once
    embedded = Counter(digest(base64.b64decode(i["src"].split(",", 1)[1])) for i in images)
    assert embedded == Counter(digest(p.read_bytes()) for p in pngs)
    for image in images:
        with Image.open(io.BytesIO(base64.b64decode(image["src"].split(",", 1)[1]))) as png:
            assert png.size == (image["width"], image["height"]), image["alt"]


def test_the_page_has_the_expected_sections(visit):
    page = visit.page
    (h1,) = page.evaluate("() => Array.from(document.querySelectorAll('h1'), h => h.textContent)")
    assert STUDY in h1
    found = sections(page)
    h2 = [s["title"] for s in found if s["level"] == "H2"]
    assert h2[0] == "Summary", h2
    summary = found[0]["parts"]
    assert [p for p in summary if p["tag"] == "P" and p["text"]], "the summary says nothing"
    assert "The study" in h2 and "Files" in h2
    for instance in INSTANCES:
        assert h2.count(instance) == 1, (instance, h2)
        (section,) = [s for s in found if s["title"] == instance]
        assert sum(p["tables"] for p in section["parts"]) == 1, instance
        assert sum(p["images"] for p in section["parts"]) >= 4, instance
    for metric in ("objective", "RMSE"):
        assert f"Pairwise tests: {metric}" in h2
        assert any(s["title"] == f"Across instances: {metric}" for s in found)
    every = tables(page)
    assert len(every) >= len(INSTANCES) + 5  # summaries, 2 pairwise, 2 ranks, the appendix
    for table in every:
        assert table["headerRows"] == 1 and table["header"], table["section"]
        assert all(table["header"]), f"an empty column name in {table['section']}"
        assert table["rows"], f"an empty table in {table['section']}"
        widths = {len(row) for row in table["rows"]}
        assert widths == {len(table["header"])}, (table["section"], widths)
    assert page.evaluate("() => document.querySelectorAll('td strong').length") >= 1
    # each instance's table: the best median of every budget and column in bold
    for instance in INSTANCES:
        (table,) = [t for t in every if t["section"] == instance]
        header = table["header"]
        assert header[:3] == ["budget", "method", "runs"], header
        budgets = {row[0]["text"] for row in table["rows"]}
        for column in range(3, len(header)):
            for budget in budgets:
                bold = [row[1]["text"] for row in table["rows"]
                        if row[0]["text"] == budget and row[column]["bold"]]
                assert bold, f"{instance}, budget {budget}: no best {header[column]} in bold"
    # no cell shows a number Python could not format
    texts = [cell["text"] for table in every for row in table["rows"] for cell in row]
    assert not [t for t in texts if re.search(r"\bnan\b|\binf\b|None", t)]
    # the window does not scroll sideways
    width = page.evaluate("() => document.documentElement.scrollWidth")
    assert width <= VIEWPORT["width"], width


def test_a_full_page_screenshot_is_not_blank(visit, tmp_path_factory):
    shot = tmp_path_factory.mktemp("screenshot") / "report.png"
    visit.page.screenshot(path=shot, full_page=True)
    image = Image.open(shot).convert("RGB")
    width, height = image.size
    assert width == VIEWPORT["width"]
    assert height >= 4000, f"{shot}: only {height} px high"
    colours = image.getcolors(maxcolors=1 << 24)
    assert len(colours) >= 1000, f"{shot}: {len(colours)} colours"
    grey = np.asarray(image.convert("L"), dtype=float)
    assert grey.std() > 10, f"{shot}: pixel standard deviation {grey.std():.1f}"
    inked = grey < 250
    assert inked.mean() > 0.02, f"{shot}: {inked.mean():.1%} of the pixels not white"
    # no long stretch of the page is blank (a figure that did not draw, a collapsed section)
    band = VIEWPORT["height"]
    for top in range(0, height - band // 3, band):
        part = grey[top:top + band]
        assert part.std() > 5 and inked[top:top + band].mean() > 0.01, (
            f"{shot}: rows {top}-{top + len(part)} are blank")


def test_markdown_figure_links_resolve(report):
    text = report.markdown.read_text(encoding="utf-8")
    links = re.findall(r"!\[([^\]]*)\]\(([^)\s]+)\)", text)
    pngs = sorted((report.out / "figures").glob("*.png"))
    assert len(links) == len(pngs), (links, [p.name for p in pngs])
    for title, link in links:
        assert title.strip(), link
        assert not Path(link).is_absolute() and "://" not in link, link
        target = report.out / link
        assert target.is_file(), f"{link} does not exist"
        with Image.open(target) as image:
            assert image.format == "PNG" and min(image.size) > 0, link
    assert sorted((report.out / link).resolve() for _, link in links) == [
        p.resolve() for p in pngs]
    # the same figures, in the same order and with the same titles, as the HTML report
    html = report.html.read_text(encoding="utf-8")
    alts = [unescape(a) for a in re.findall(r"<img alt='([^']*)'", html)]
    assert [title for title, _ in links] == alts
