"""The report's figures tell the methods apart: up to twelve methods each have a style of their
own (colours that differ for normal vision and with protanopia or deuteranopia, a marker each),
a method keeps its style in every figure of a report, and legends sit outside the axes."""

from __future__ import annotations

import itertools
import string
from pathlib import Path
from types import SimpleNamespace

import matplotlib

matplotlib.use("Agg")
import matplotlib.colors as mcolors
import matplotlib.figure
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.lines import Line2D

from metaknot.experiments.report import build, prepare
from metaknot.experiments.report import figures as figures_module
from tests.test_report import _run, _write

# one shared study for the module: keep its tests on one xdist worker
pytestmark = pytest.mark.xdist_group("report_figures")

TWELVE = list(string.ascii_uppercase[:12])

# --------------------------------------------------------------------------------------------
# colour differences: CIELAB (D65), CIEDE2000, and dichromacy simulated by Machado, Oliveira and
# Fernandes (IEEE TVCG 15, 1291, 2009; severity 1.0), applied to linear RGB

MACHADO = {
    "protanopia": np.array([[0.152286, 1.052583, -0.204868],
                            [0.114503, 0.786281, 0.099216],
                            [-0.003882, -0.048116, 1.051998]]),
    "deuteranopia": np.array([[0.367322, 0.860646, -0.227968],
                              [0.280085, 0.672501, 0.047413],
                              [-0.011820, 0.042940, 0.968881]]),
}
SRGB_TO_XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                        [0.2126729, 0.7151522, 0.0721750],
                        [0.0193339, 0.1191920, 0.9503041]])
WHITE_D65 = np.array([0.95047, 1.0, 1.08883])


def seen(colour: object, vision: str | None = None) -> np.ndarray:
    """The sRGB (0 to 1) of a matplotlib colour as seen with normal vision or ``vision`` (a key
    of ``MACHADO``)."""
    rgb = np.asarray(mcolors.to_rgb(colour))
    if vision is None:
        return rgb
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    linear = MACHADO[vision] @ linear
    return np.where(linear <= 0.0031308, 12.92 * linear,
                    1.055 * np.abs(linear) ** (1 / 2.4) * np.sign(linear) - 0.055)


def lab(colour: object, vision: str | None = None) -> np.ndarray:
    """CIELAB of a matplotlib colour, as seen with normal vision or ``vision``."""
    rgb = np.clip(seen(colour, vision), 0.0, 1.0)
    linear = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    xyz = SRGB_TO_XYZ @ linear / WHITE_D65
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def ciede2000(first: np.ndarray, second: np.ndarray) -> float:
    """The CIEDE2000 colour difference of two CIELAB colours (Sharma, Wu and Dalal, Color
    Research & Application 30, 21, 2005)."""
    (l1, a1, b1), (l2, a2, b2) = first, second
    mean_c = (np.hypot(a1, b1) + np.hypot(a2, b2)) / 2
    g = 0.5 * (1 - np.sqrt(mean_c**7 / (mean_c**7 + 25.0**7)))
    a1, a2 = (1 + g) * a1, (1 + g) * a2
    c1, c2 = np.hypot(a1, b1), np.hypot(a2, b2)
    h1, h2 = np.degrees(np.arctan2(b1, a1)) % 360, np.degrees(np.arctan2(b2, a2)) % 360
    dh = 0.0 if c1 * c2 == 0 else (h2 - h1 + 180) % 360 - 180
    big_dh = 2 * np.sqrt(c1 * c2) * np.sin(np.radians(dh / 2))
    mean_l, mean_cp = (l1 + l2) / 2, (c1 + c2) / 2
    if c1 * c2 == 0:
        mean_h = h1 + h2
    elif abs(h1 - h2) <= 180:
        mean_h = (h1 + h2) / 2
    else:
        mean_h = (h1 + h2 + 360) / 2 if h1 + h2 < 360 else (h1 + h2 - 360) / 2
    t = (1 - 0.17 * np.cos(np.radians(mean_h - 30)) + 0.24 * np.cos(np.radians(2 * mean_h))
         + 0.32 * np.cos(np.radians(3 * mean_h + 6)) - 0.20 * np.cos(np.radians(4 * mean_h - 63)))
    rotation = -np.sin(np.radians(60 * np.exp(-(((mean_h - 275) / 25) ** 2)))) * 2 * np.sqrt(
        mean_cp**7 / (mean_cp**7 + 25.0**7))
    sl = 1 + 0.015 * (mean_l - 50) ** 2 / np.sqrt(20 + (mean_l - 50) ** 2)
    sc, sh = 1 + 0.045 * mean_cp, 1 + 0.015 * mean_cp * t
    terms = ((l2 - l1) / sl, (c2 - c1) / sc, big_dh / sh)
    return float(np.sqrt(terms[0]**2 + terms[1]**2 + terms[2]**2
                         + rotation * terms[1] * terms[2]))


@pytest.mark.parametrize(("first", "second", "expected"), [
    # pairs of Sharma, Wu and Dalal's test data
    ((50.0, 2.6772, -79.7751), (50.0, 0.0, -82.7485), 2.0425),
    ((50.0, -1.0, 2.0), (50.0, 0.0, 0.0), 2.3669),
    ((50.0, 2.5, 0.0), (73.0, 25.0, -18.0), 27.1492),
    ((2.0776, 0.0795, -1.1350), (0.9033, -0.0636, -0.5514), 0.9082),
])
def test_the_colour_difference_is_ciede2000(first, second, expected):
    assert ciede2000(np.array(first), np.array(second)) == pytest.approx(expected, abs=1e-4)


@pytest.mark.parametrize(("colour", "vision", "expected"), [
    # colorspacious 1.1.2: cspace_convert(rgb, {"name": "sRGB1+CVD", "cvd_type":
    # "protanomaly" or "deuteranomaly", "severity": 100}, "sRGB1")
    ("#d62728", "protanopia", (0.380200, 0.340738, 0.146155)),
    ("#d62728", "deuteranopia", (0.546495, 0.487877, 0.120379)),
    ("#2ca02c", "protanopia", (0.641139, 0.567375, 0.096475)),
    ("#2ca02c", "deuteranopia", (0.589173, 0.531791, 0.218604)),
    ("#0072B2", "protanopia", (0.324406, 0.457122, 0.708545)),
    ("#0072B2", "deuteranopia", (0.230261, 0.401993, 0.693347)),
])
def test_the_simulated_vision_is_colorspacious(colour, vision, expected):
    assert seen(colour, vision) == pytest.approx(expected, abs=2e-6)


# --------------------------------------------------------------------------------------------
# styles


def test_twelve_methods_have_distinct_styles():
    """The old palette gave the second, fourth and sixth methods orange, vermilion and light
    brown (CIEDE2000 11.6 apart; 6.1 with protanopia)."""
    look = figures_module.styles(SimpleNamespace(methods=TWELVE))
    assert list(look) == TWELVE
    for first, second in itertools.combinations(TWELVE, 2):
        one, other = look[first], look[second]
        if mcolors.same_color(one["color"], other["color"]):
            assert one["linestyle"] != other["linestyle"], (first, second)
            continue
        for vision, least in ((None, 20.0), ("protanopia", 10.0), ("deuteranopia", 10.0)):
            difference = ciede2000(lab(one["color"], vision), lab(other["color"], vision))
            assert difference >= least, (first, second, one["color"], other["color"], vision)
    assert len({v["marker"] for v in look.values()}) == 12  # a marker each
    assert len({(mcolors.to_hex(v["color"]), v["marker"]) for v in look.values()}) == 12
    # at least eight colours before one comes back
    assert len({mcolors.to_hex(v["color"]) for v in look.values()}) >= 8
    assert figures_module.palette(SimpleNamespace(methods=TWELVE)) == {
        m: v["color"] for m, v in look.items()}


def test_a_method_keeps_its_style_whatever_follows_it():
    few = figures_module.styles(SimpleNamespace(methods=TWELVE[:3]))
    many = figures_module.styles(SimpleNamespace(methods=TWELVE))
    assert few == {m: many[m] for m in few}


# --------------------------------------------------------------------------------------------
# figures of a report of twelve methods


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Twelve methods on one instance at two budgets, four seeds: method k's objective is about
    1 + k / 10 (the report's order is A to L)."""
    rng = np.random.default_rng(7)
    runs = [_run(method, seed, budget, (1 + k / 10) * rng.lognormal(0, 0.01) * 300 / budget,
                 n_control_points=int(rng.integers(15, 30)), rmse=rng.lognormal(-9, 0.3))
            for k, method in enumerate(TWELVE) for budget in (300, 1000) for seed in range(4)]
    return _write(tmp_path_factory.mktemp("figures") / "study", runs)


def _window(artist: object, renderer: object) -> object:
    return artist.get_window_extent(renderer)  # type: ignore[attr-defined]


def legends_on_the_axes(figure: matplotlib.figure.Figure) -> list[str]:
    """The legends of ``figure`` that overlap an axes' area or leave the figure."""
    canvas = FigureCanvasAgg(figure)  # a report closes its figures: their canvas is gone
    canvas.draw()
    renderer = canvas.get_renderer()
    legends = list(figure.legends) + [ax.get_legend() for ax in figure.axes
                                      if ax.get_legend() is not None]
    found = []
    for legend in legends:
        box = _window(legend, renderer)
        for k, ax in enumerate(figure.axes):
            if ax.get_visible() and box.overlaps(_window(ax, renderer)):
                found.append(f"legend on axes {k}")
        if not figure.bbox.containsx(box.x0) or not figure.bbox.containsx(box.x1) \
                or not figure.bbox.containsy(box.y0) or not figure.bbox.containsy(box.y1):
            found.append("legend beyond the figure")
    return found


def test_the_budget_figure_has_its_legend_outside_the_axes(study):
    comparison = prepare(study)
    assert comparison.methods == TWELVE
    figure = figures_module.budget_figure(comparison, comparison.instances[0])
    try:
        assert len(figure.axes) == 3
        legends = list(figure.legends) + [ax.get_legend() for ax in figure.axes
                                          if ax.get_legend() is not None]
        assert len(legends) == 1
        assert [text.get_text() for text in legends[0].get_texts()] == TWELVE
        assert legends_on_the_axes(figure) == []
    finally:
        plt.close(figure)


def _method(label: str) -> str | None:
    """The method a legend or line label names: ``A``, ``A (1,000 evals)``, ``A (median ...``."""
    name = label.split(" (")[0]
    return name if name in TWELVE else None


@pytest.mark.slow  # a whole report with its figures: about 11 s
def test_every_figure_of_a_report_draws_a_method_in_its_one_style(study, tmp_path, monkeypatch):
    """Lines, markers, legend entries, the fitted curve's colour and the critical-difference
    diagram's labels; and no legend on the axes."""
    drawn: dict[int, tuple[str, matplotlib.figure.Figure]] = {}
    savefig = matplotlib.figure.Figure.savefig

    def keep(self, fname, *args, **kwargs):
        drawn.setdefault(id(self), (Path(fname).stem, self))
        return savefig(self, fname, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    lines: list[str] = []
    build(study, tmp_path / "report", log=lines.append)
    assert not any("skipped" in line for line in lines), lines
    pngs = len(list((tmp_path / "report" / "figures").glob("*.png")))
    assert f"figures: {pngs} in {tmp_path / 'report' / 'figures'}" in lines  # the final folder
    look = figures_module.styles(prepare(study))
    names = {name.split("-")[0] for name, _ in drawn.values()}
    assert {"budget", "convergence", "ecdf", "front", "curves", "cd"} <= names
    checked = 0
    for name, figure in drawn.values():
        assert legends_on_the_axes(figure) == [], name
        legends = list(figure.legends) + [ax.get_legend() for ax in figure.axes
                                          if ax.get_legend() is not None]
        handles = [(text.get_text(), handle) for legend in legends
                   for text, handle in zip(legend.get_texts(), legend.legend_handles,
                                           strict=True)]
        handles += [(line.get_label(), line) for ax in figure.axes for line in ax.get_lines()]
        for label, handle in handles:
            method = _method(label)
            if method is None:
                continue
            assert isinstance(handle, Line2D), (name, label)
            assert mcolors.same_color(handle.get_color(), look[method]["color"]), (name, label)
            assert handle.get_marker() == look[method]["marker"], (name, label)
            if handle.get_linestyle() not in ("None", ""):
                same = Line2D([], [], linestyle=look[method]["linestyle"]).get_linestyle()
                assert handle.get_linestyle() == same, (name, label)
            checked += 1
        if name.startswith("curves"):
            for ax in figure.axes:
                method = _method(ax.get_title().split(":")[0])
                (fit,) = [line for line in ax.get_lines() if line.get_label() == "fit"]
                assert mcolors.same_color(fit.get_color(), look[method]["color"]), name
                checked += 1
        if name.startswith("cd"):
            # "A (1)" left of the axis, "(12) L" right of it
            labels = {t: _method(t.get_text()) or _method(t.get_text().rpartition(") ")[2])
                      for ax in figure.axes for t in ax.texts}
            texts = {t: m for t, m in labels.items() if m is not None}
            assert sorted(texts.values()) == TWELVE, name
            for text, method in texts.items():
                assert mcolors.same_color(text.get_color(), look[method]["color"]), name
                checked += 1
    assert checked > 12 * len(drawn)
    plt.close("all")


def test_a_profile_panel_of_less_than_a_decade_does_not_overlap_its_tick_labels() -> None:
    """A performance-profile panel whose ratios span less than a decade (log axis) labels no
    minor tick: matplotlib labelled them, and 2x10^0 ... 6x10^0 overlapped."""
    import pandas as pd

    medians = pd.DataFrame({"a": [1.0, 2.0, 1.0, 3.0], "b": [1.5, 1.0, 4.0, 1.0]},
                           index=[f"p{i}" for i in range(4)])
    families = pd.Series(["narrow"] * 4, index=medians.index)
    suite = SimpleNamespace(medians=medians, families=families, family_names=["narrow"],
                            methods=["a", "b"])
    fig = figures_module.profile_figure(SimpleNamespace(methods=["a", "b"]), suite)
    FigureCanvasAgg(fig).draw()
    for ax in fig.axes[:2]:
        assert ax.get_xlim()[1] / ax.get_xlim()[0] < 10  # less than a decade
        assert not [t.get_text() for t in ax.get_xticklabels(minor=True) if t.get_text()]
    plt.close(fig)
