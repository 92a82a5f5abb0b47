"""Files of a :class:`~metaknot.apps.fit.ToleranceFit` (``metaknot fit --out DIR``).

``fit.json`` (knots, the distinct interior knots and their multiplicities, control points,
degree, metrics, FITPACK's answer, the method),
``knots.csv``, ``control_points.csv``, ``metrics.json``, ``fit.png`` / ``fit.svg`` (the data,
the fitted curve and its knots) and ``fit.dxf`` (the curve as a DXF SPLINE entity, for CAD
tools). All files are written to a temporary folder first and moved into place together, so a
failure leaves no partial output. ``fit.json`` lists the files (``"files"``): with ``force`` a
later fit replaces those, and only those.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .fit import ToleranceFit

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["FILES", "check_destination", "write_fit"]

FILES = ("fit.json", "knots.csv", "control_points.csv", "metrics.json", "fit.png", "fit.svg",
         "fit.dxf")
_MAX_SUMMARY_BYTES = 2**26  # a larger fit.json is not one a fit wrote


def _summary(result: ToleranceFit) -> dict:
    return {
        "degree": result.degree, "closed": result.closed, "method": result.method,
        "metric": result.metric,
        "tolerance": result.tolerance, "knots": result.knots.tolist(),
        "interior_knots": result.interior_knots[0].tolist(),
        "multiplicities": result.interior_knots[1].tolist(),
        "control_points": result.control_points.tolist(), "metrics": result.metrics,
        "fitpack": result.fitpack, "files": list(FILES),
    }


#: How the figure's title names each metric.
_METRIC_NAMES = {"max_deviation": "max deviation", "rmse": "RMSE"}


def _title(result: ToleranceFit) -> str:
    """The figure's title: the control points and the method on one line; the error the
    tolerance bounds (``result.metric``) and the tolerance on the next.

    The tolerance is shown to six significant digits, the error to four unless, so rounded,
    it would read as above the tolerance shown (then to six as well: rounding keeps the
    order, so an error within the tolerance never reads as beyond it).
    """
    m = result.metrics
    tolerance = f"{result.tolerance:.6g}"
    value = f"{m[result.metric]:.4g}"
    if float(value) > float(tolerance):
        value = f"{m[result.metric]:.6g}"
    return (f"{m['n_control_points']} control points ({result.method}; FITPACK: "
            f"{result.fitpack['n_control_points']})\n"
            f"{_METRIC_NAMES.get(result.metric, result.metric)} {value} "
            f"(tolerance {tolerance})")


def _draw(result: ToleranceFit, points: np.ndarray) -> Figure:
    """The figure of ``result``: the data, the fitted curve and its knots, under
    :func:`_title` (function data: x against f(x))."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    u = result.params
    lo, hi = result.parameter_range
    dense = np.linspace(lo, hi, max(2000, 8 * len(u)))
    curve = result.spline(dense)
    breakpoints = np.unique(result.knots[(result.knots >= lo) & (result.knots <= hi)])
    knots = result.spline(breakpoints)
    fig, ax = plt.subplots(figsize=(6.5, 5), constrained_layout=True)
    if points.shape[1] == 1:  # function data: x against f(x)
        ax.plot(u, points[:, 0], ".", ms=3, color="0.55", label="data")
        ax.plot(dense, curve[:, 0], "-", lw=1.3, color="C0", label="fit")
        ax.plot(breakpoints, knots[:, 0], "o", ms=4, mfc="none", color="C3",
                label="knots")
        ax.set_xlabel("x")
    else:
        ax.plot(points[:, 0], points[:, 1], ".", ms=3, color="0.55", label="data")
        ax.plot(curve[:, 0], curve[:, 1], "-", lw=1.3, color="C0", label="fit")
        ax.plot(knots[:, 0], knots[:, 1], "o", ms=4, mfc="none", color="C3", label="knots")
        ax.set_aspect("equal", adjustable="datalim")
    ax.set_title(_title(result), fontsize=9)
    ax.legend(fontsize=8)
    return fig


def _figure(result: ToleranceFit, points: np.ndarray, folder: Path) -> None:
    """Write the figure of ``result`` (:func:`_draw`) as ``fit.png`` and ``fit.svg``."""
    import matplotlib.pyplot as plt

    fig = _draw(result, points)
    for suffix in ("png", "svg"):
        fig.savefig(folder / f"fit.{suffix}", dpi=120)
    plt.close(fig)


def _dxf(result: ToleranceFit, path: Path) -> None:
    import ezdxf

    doc = ezdxf.new("R2010")
    # every coefficient on the full knot vector (a closed outline's first p repeated)
    control = np.asarray(result.spline.c, dtype=np.float64)
    if control.shape[1] == 1:  # function data: the plane curve (x(u), f(u)) with x(u) = u,
        # a spline whose coefficients are the Greville abscissae (exact for clamped knots)
        k = result.degree
        greville = np.array([result.knots[i + 1 : i + k + 1].mean()
                             for i in range(len(control))])
        control = np.column_stack((greville, control[:, 0]))
    if control.shape[1] == 2:
        control = np.column_stack((control, np.zeros(len(control))))
    spline = doc.modelspace().add_open_spline(control[:, :3].tolist(), degree=result.degree,
                                              knots=result.knots.tolist())
    if result.closed:  # DXF's closed, periodic SPLINE
        spline.closed = True
        spline.dxf.flags = spline.dxf.flags | spline.PERIODIC
    doc.saveas(path)


def check_destination(out: str | Path, *, force: bool = False) -> Path:
    """Check that :func:`write_fit` can write into ``out``, before anything is computed.

    ``out`` must be a folder, or not exist yet under a folder (not a file), and hold none of
    ``FILES``; with ``force`` it may hold those a previous fit wrote (the ones its
    ``fit.json`` lists), which are then replaced. Other files are never touched.

    Raises
    ------
    ValueError
        Naming ``out`` and what is in the way, in one line.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: a file of that name exists; give a folder")
    parent = next(folder for folder in (out, *out.parents) if folder.exists())
    if not parent.is_dir():
        raise ValueError(f"--out {out}: {parent} is a file, not a folder")
    clash = [name for name in FILES if os.path.lexists(out / name)]
    if not clash:
        return out
    if not force:
        raise ValueError(f"--out {out} already holds {clash[0]}; --force replaces a previous "
                         "fit's files, or choose another --out folder")
    previous = _previous_fit_files(out)
    foreign = [name for name in clash if name not in previous or not (out / name).is_file()]
    if foreign:
        raise ValueError(f"--out {out}: {foreign[0]} is not a file of a previous fit (its "
                         "fit.json does not list it); --force replaces only those: move it or "
                         "choose another --out folder")
    return out


def _previous_fit_files(out: Path) -> set[str]:
    """The files a previous fit in ``out`` wrote, from its ``fit.json`` (empty if it has none
    a fit wrote)."""
    summary = out / "fit.json"
    try:
        if summary.stat().st_size > _MAX_SUMMARY_BYTES:
            return set()
        files = json.loads(summary.read_text()).get("files")
    except (OSError, ValueError, AttributeError):  # missing, unreadable, not a JSON object
        return set()
    return {name for name in files if name in FILES} if isinstance(files, list) else set()


def write_fit(result: ToleranceFit, points: np.ndarray, out: str | Path, *,
              force: bool = False) -> list[Path]:
    """Write every output file of ``result`` into ``out`` (created if needed). A closed
    curve's ``knots.csv`` and DXF hold the periodic (extended) knot vector, its
    ``control_points.csv`` the distinct control points.

    Raises
    ------
    ValueError
        If ``out`` cannot take the files (:func:`check_destination`): nothing is overwritten
        but, with ``force``, a previous fit's files.
    """
    out = check_destination(out, force=force)
    out.mkdir(parents=True, exist_ok=True)
    points = np.asarray(points, dtype=np.float64)
    points = points[:, None] if points.ndim == 1 else points
    with tempfile.TemporaryDirectory(dir=out, prefix=".fit-") as scratch:
        folder = Path(scratch)
        summary = _summary(result)
        (folder / "fit.json").write_text(json.dumps(summary, indent=1))
        (folder / "metrics.json").write_text(json.dumps(
            {**result.metrics, "method": result.method, "tolerance": result.tolerance,
             "metric": result.metric, "fitpack": result.fitpack}, indent=1))
        np.savetxt(folder / "knots.csv", result.knots[:, None], delimiter=",", header="knot",
                   comments="")
        dims = result.control_points.shape[1]
        header = ",".join(("x", "y", "z")[:dims] if dims <= 3 else
                          [f"c{i}" for i in range(dims)])
        np.savetxt(folder / "control_points.csv", result.control_points, delimiter=",",
                   header=header, comments="")
        _figure(result, points, folder)
        _dxf(result, folder / "fit.dxf")
        for name in FILES:
            shutil.move(folder / name, out / name)
    return [out / name for name in FILES]
