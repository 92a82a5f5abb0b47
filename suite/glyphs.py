"""Glyph outlines: the digits 0-9 of DejaVu Sans Mono, the monospaced font matplotlib ships.

A digit's outline comes from ``matplotlib.textpath.TextPath`` (the font's quadratic Bézier
contours), each segment evaluated at 32 points, and is resampled at equal arc length. Only the
outer contour is kept (the largest by area): the holes of 0, 4, 6, 8 and 9 are left out, so every
glyph instance is one closed outline.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import cast

import numpy as np

__all__ = ["GLYPH_POINTS", "digit_outline"]

#: Points per glyph outline.
GLYPH_POINTS = 200


def _contours(character: str) -> list[np.ndarray]:
    """The closed contours of ``character`` as dense polylines (first point not repeated)."""
    from matplotlib.bezier import BezierSegment
    from matplotlib.font_manager import FontProperties
    from matplotlib.path import Path
    from matplotlib.textpath import TextPath

    path = TextPath((0.0, 0.0), character, size=1.0,
                    prop=FontProperties(family="DejaVu Sans Mono"))
    contours: list[list[np.ndarray]] = []
    # matplotlib's stubs type the items as segments; they are (segment, code) pairs
    for segment, code in cast(Iterator[tuple[BezierSegment, int]], path.iter_bezier()):
        if code == Path.MOVETO:
            contours.append([])
            continue
        samples = segment(np.linspace(0.0, 1.0, 33)[1:])
        contours[-1].append(np.atleast_2d(samples))
    out = []
    for pieces in contours:
        if not pieces:
            continue
        line = np.vstack(pieces)
        keep = np.concatenate(([True], np.linalg.norm(np.diff(line, axis=0), axis=1) > 1e-12))
        line = line[keep]
        if np.linalg.norm(line[-1] - line[0]) <= 1e-12:
            line = line[:-1]
        out.append(line)
    return out


def _area(line: np.ndarray) -> float:
    x, y = line[:, 0], line[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def digit_outline(digit: int, n_points: int = GLYPH_POINTS) -> np.ndarray:
    """The outer outline of ``digit`` (0-9), ``n_points`` points at equal arc length, starting
    at the contour's first point, not repeated at the end."""
    line = max(_contours(str(int(digit))), key=_area)
    closed = np.vstack((line, line[:1]))
    arc = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))))
    at = np.linspace(0.0, arc[-1], n_points, endpoint=False)
    return np.column_stack([np.interp(at, arc, closed[:, k]) for k in range(2)])
