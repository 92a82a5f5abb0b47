"""Parametric curves: open and closed planar curves and curves in space.

Each generator returns the points ``(N, d)``, sampled at equal steps of its curve parameter
(the fits parameterize them themselves). Closed outlines do not repeat their first point at the
end (the usual export of an outline). The docstring of each gives its definition.
"""

from __future__ import annotations

import numpy as np
from scipy.special import fresnel

from metaknot.problems import get_curve

__all__ = ["CLOSED_CURVES", "OPEN_CURVES", "SPACE_CURVES"]


def _turn(n: int, turns: float = 1.0) -> np.ndarray:
    """``n`` angles over ``turns`` full turns, the last one left out (a closed curve)."""
    return np.linspace(0.0, 2.0 * np.pi * turns, n, endpoint=False)


# --- open planar curves ------------------------------------------------------------------------


def archimedean() -> np.ndarray:
    """The seed paper's Archimedean spiral r = 2t, t in [0, pi], 100 points."""
    return get_curve("archimedean").points


def log_spiral() -> np.ndarray:
    """A logarithmic spiral r = exp(0.15 t), t in [0, 4 pi], 300 points: curvature falling
    steadily along the curve."""
    t = np.linspace(0.0, 4.0 * np.pi, 300)
    r = np.exp(0.15 * t)
    return np.column_stack((r * np.cos(t), r * np.sin(t)))


def cycloid() -> np.ndarray:
    """Two arches of a cycloid (t - sin t, 1 - cos t), t in [0, 4 pi], 301 points: a cusp at
    t = 2 pi between two smooth arches."""
    t = np.linspace(0.0, 4.0 * np.pi, 301)
    return np.column_stack((t - np.sin(t), 1.0 - np.cos(t)))


def semicubical() -> np.ndarray:
    """The semicubical parabola (t^2, t^3), t in [-1, 1], 201 points: a cusp at the origin."""
    t = np.linspace(-1.0, 1.0, 201)
    return np.column_stack((t**2, t**3))


def line_and_arc() -> np.ndarray:
    """A straight segment from (-2, 0) to (0, 0) joined tangentially to a half circle of radius
    1 (centre (0, 1)), 100 + 100 points: the curvature jumps from 0 to 1 at the joint."""
    line = np.column_stack((np.linspace(-2.0, 0.0, 100, endpoint=False), np.zeros(100)))
    angle = np.linspace(-np.pi / 2, np.pi / 2, 100)
    arc = np.column_stack((np.cos(angle), 1.0 + np.sin(angle)))
    return np.vstack((line, arc))


def clothoid() -> np.ndarray:
    """An Euler spiral (clothoid) (C(t), S(t)) from scipy's Fresnel integrals, t in [0, 3],
    300 points: curvature growing linearly with arc length."""
    t = np.linspace(0.0, 3.0, 300)
    s, c = fresnel(t)
    return np.column_stack((c, s))


def lissajous_arc() -> np.ndarray:
    """An open arc of a Lissajous curve (sin 3t, sin 2t), t in [0, 0.9 pi], 250 points."""
    t = np.linspace(0.0, 0.9 * np.pi, 250)
    return np.column_stack((np.sin(3.0 * t), np.sin(2.0 * t)))


# --- closed planar outlines --------------------------------------------------------------------


def epitrochoid() -> np.ndarray:
    """The seed paper's epitrochoid (a = 5, b = 1, h = 4), its repeated last point left out:
    360 points."""
    return get_curve("epitrochoid").points[:-1]


def hypotrochoid() -> np.ndarray:
    """A hypotrochoid (R = 5, r = 3, d = 5): ((R - r) cos t + d cos((R - r) t / r),
    (R - r) sin t - d sin((R - r) t / r)), t over 3 turns (the period), 540 points."""
    t = _turn(540, 3.0)
    big, small, d = 5.0, 3.0, 5.0
    k = (big - small) / small
    return np.column_stack(((big - small) * np.cos(t) + d * np.cos(k * t),
                            (big - small) * np.sin(t) - d * np.sin(k * t)))


def rose3() -> np.ndarray:
    """A three-petal rose r = cos 3t, t in [0, pi), 300 points (it passes the origin three
    times)."""
    t = np.linspace(0.0, np.pi, 300, endpoint=False)
    r = np.cos(3.0 * t)
    return np.column_stack((r * np.cos(t), r * np.sin(t)))


def limacon() -> np.ndarray:
    """A limaçon with an inner loop r = 1 + 2 cos t, 300 points."""
    t = _turn(300)
    r = 1.0 + 2.0 * np.cos(t)
    return np.column_stack((r * np.cos(t), r * np.sin(t)))


def cardioid() -> np.ndarray:
    """A cardioid r = 1 + cos t, 300 points: a cusp at the origin."""
    t = _turn(300)
    r = 1.0 + np.cos(t)
    return np.column_stack((r * np.cos(t), r * np.sin(t)))


def superellipse() -> np.ndarray:
    """A superellipse |x|^4 + |y|^4 = 1 (a "squircle"): (sign(cos t) |cos t|^(1/2),
    sign(sin t) |sin t|^(1/2)), 300 points: flat sides, tight corners."""
    t = _turn(300)
    c, s = np.cos(t), np.sin(t)
    return np.column_stack((np.sign(c) * np.abs(c) ** 0.5, np.sign(s) * np.abs(s) ** 0.5))


def heart() -> np.ndarray:
    """A heart (16 sin^3 t, 13 cos t - 5 cos 2t - 2 cos 3t - cos 4t), 300 points: a cusp at the
    top, a sharp tip at the bottom."""
    t = _turn(300)
    return np.column_stack((16.0 * np.sin(t) ** 3, 13.0 * np.cos(t) - 5.0 * np.cos(2.0 * t)
                            - 2.0 * np.cos(3.0 * t) - np.cos(4.0 * t)))


def astroid() -> np.ndarray:
    """An astroid (cos^3 t, sin^3 t), 300 points: four cusps."""
    t = _turn(300)
    return np.column_stack((np.cos(t) ** 3, np.sin(t) ** 3))


# --- curves in space ---------------------------------------------------------------------------


def vivaldi() -> np.ndarray:
    """The seed paper's Vivaldi curve (3-D), its repeated last point left out: 240 points."""
    return get_curve("vivaldi").points[:-1]


def helix() -> np.ndarray:
    """A circular helix (cos t, sin t, 0.2 t), t over 3 turns, 300 points (open)."""
    t = np.linspace(0.0, 6.0 * np.pi, 300)
    return np.column_stack((np.cos(t), np.sin(t), 0.2 * t))


def conical_helix() -> np.ndarray:
    """A conical helix (t cos 4t, t sin 4t, t), t in [0.1, 2 pi], 300 points (open): the
    radius grows with height."""
    t = np.linspace(0.1, 2.0 * np.pi, 300)
    return np.column_stack((t * np.cos(4.0 * t), t * np.sin(4.0 * t), t))


def trefoil() -> np.ndarray:
    """The trefoil knot (sin t + 2 sin 2t, cos t - 2 cos 2t, -sin 3t), 300 points (closed)."""
    t = _turn(300)
    return np.column_stack((np.sin(t) + 2.0 * np.sin(2.0 * t),
                            np.cos(t) - 2.0 * np.cos(2.0 * t), -np.sin(3.0 * t)))


def toroidal_spiral() -> np.ndarray:
    """A toroidal spiral ((2 + 0.5 cos 8t) cos t, (2 + 0.5 cos 8t) sin t, 0.5 sin 8t), 400
    points (closed): eight windings around a torus."""
    t = _turn(400)
    ring = 2.0 + 0.5 * np.cos(8.0 * t)
    return np.column_stack((ring * np.cos(t), ring * np.sin(t), 0.5 * np.sin(8.0 * t)))


def spherical_spiral() -> np.ndarray:
    """A spiral on the unit sphere from pole to pole (sin s cos 10s, sin s sin 10s, cos s), s in
    [0, pi], 300 points (open)."""
    s = np.linspace(0.0, np.pi, 300)
    return np.column_stack((np.sin(s) * np.cos(10.0 * s), np.sin(s) * np.sin(10.0 * s),
                            np.cos(s)))


#: Curve instances: id -> generator.
OPEN_CURVES = {"archimedean": archimedean, "log_spiral": log_spiral, "cycloid": cycloid,
               "semicubical": semicubical, "line_and_arc": line_and_arc,
               "clothoid": clothoid, "lissajous_arc": lissajous_arc}
CLOSED_CURVES = {"epitrochoid": epitrochoid, "hypotrochoid": hypotrochoid, "rose3": rose3,
                 "limacon": limacon, "cardioid": cardioid, "superellipse": superellipse,
                 "heart": heart, "astroid": astroid}
#: Space curves: id -> (generator, closed).
SPACE_CURVES = {"vivaldi": (vivaldi, True), "helix": (helix, False),
                "conical_helix": (conical_helix, False), "trefoil": (trefoil, True),
                "toroidal_spiral": (toroidal_spiral, True),
                "spherical_spiral": (spherical_spiral, False)}
