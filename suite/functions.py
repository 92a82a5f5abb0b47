"""Functions ``y = f(x)`` from the knot-placement literature, sampled at fixed abscissae.

Each generator returns ``(x, y)``; ``x`` is the parameter of the fit (function data). The
docstring of each gives its definition and source; where sources disagree, the choice made is
said there.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BSpline

__all__ = ["FUNCTIONS"]

#: Gálvez & Iglesias' abscissae as SHAPES packages them: 256 points, i = 0..255.
_I256 = np.arange(256)


def galvez_f1() -> tuple[np.ndarray, np.ndarray]:
    """f1(x) = 90 / (1 + exp(-100 (x - 0.4))) at x_i = i/256, i = 0..255: a steep logistic
    step. Gálvez & Iglesias' benchmark as packaged by SHAPES (Mohanty & Fahnestock,
    arXiv:1907.12160)."""
    x = _I256 / 256
    return x, 90.0 / (1.0 + np.exp(-100.0 * (x - 0.4)))


def galvez_f2() -> tuple[np.ndarray, np.ndarray]:
    """f2(x) = 1 / (0.01 + (x - 0.3)^2) for x < 0.6, 1 / (0.015 + (x - 0.65)^2) otherwise, at
    x_i = i/256, i = 0..255: two peaks and a jump at 0.6. Gálvez & Iglesias via SHAPES
    (arXiv:1907.12160).

    The branch follows the formula: x = 153/256 = 0.59765625 is on the left branch. SHAPES'
    own samples are reported to put that point on the right one; metaknot keeps the formula's
    reading (one sample differs)."""
    x = _I256 / 256
    return x, np.where(x < 0.6, 1.0 / (0.01 + (x - 0.3) ** 2), 1.0 / (0.015 + (x - 0.65) ** 2))


def galvez_f3() -> tuple[np.ndarray, np.ndarray]:
    """f3(x) = 100 exp(-|10x - 5|) + (10x - 5)^5 / 500 at x_i = i/256, i = 0..255: a cusp on a
    quintic trend. Gálvez & Iglesias via SHAPES (arXiv:1907.12160)."""
    x = _I256 / 256
    return x, 100.0 * np.exp(-np.abs(10.0 * x - 5.0)) + (10.0 * x - 5.0) ** 5 / 500.0


def galvez_f4() -> tuple[np.ndarray, np.ndarray]:
    """f4(x) = sin x + 2 exp(-30 x^2) at x_i = -2 + 4i/256, i = 0..255: a narrow peak on a
    sine. Gálvez & Iglesias via SHAPES (arXiv:1907.12160)."""
    x = -2.0 + 4.0 * _I256 / 256
    return x, np.sin(x) + 2.0 * np.exp(-30.0 * x**2)


def galvez_f5() -> tuple[np.ndarray, np.ndarray]:
    """f5(x) = sin 2x + 2 exp(-16 x^2) + 2 at x_i = -2 + 4i/256, i = 0..255. Gálvez &
    Iglesias via SHAPES (arXiv:1907.12160)."""
    x = -2.0 + 4.0 * _I256 / 256
    return x, np.sin(2.0 * x) + 2.0 * np.exp(-16.0 * x**2) + 2.0


#: The A-spline test functions' sample size (Goepp, Bouaziz & Nuel 2018 leave n to the
#: experiment; metaknot fixes 500).
ASPLINE_N = 500


def aspline_logit() -> tuple[np.ndarray, np.ndarray]:
    """logit: 1 / (1 + exp(-20 (x - 0.5))) on x = linspace(0, 1, 500). Goepp, Bouaziz & Nuel,
    "Spline regression with automatic knot selection" (A-spline), 2018."""
    x = np.linspace(0.0, 1.0, ASPLINE_N)
    return x, 1.0 / (1.0 + np.exp(-20.0 * (x - 0.5)))


def aspline_sine3() -> tuple[np.ndarray, np.ndarray]:
    """sine3: 0.5 sin(6 pi x) + 0.5 on x = linspace(0, 1, 500). Goepp, Bouaziz & Nuel 2018."""
    x = np.linspace(0.0, 1.0, ASPLINE_N)
    return x, 0.5 * np.sin(6.0 * np.pi * x) + 0.5


def aspline_bump() -> tuple[np.ndarray, np.ndarray]:
    """bump: (x + 2 exp(-(16 (x - 0.5))^2)) / 2.5 on x = linspace(0, 1, 500). Goepp, Bouaziz &
    Nuel 2018."""
    x = np.linspace(0.0, 1.0, ASPLINE_N)
    return x, (x + 2.0 * np.exp(-((16.0 * (x - 0.5)) ** 2))) / 2.5


def aspline_spa_het() -> tuple[np.ndarray, np.ndarray]:
    """spa_het: sqrt(x (1 - x)) sin(2 pi (1 + 2^(-3/5)) / (x + 2^(-3/5))) + 0.5 on
    x = linspace(0, 1, 500): spatially heterogeneous smoothness. Goepp, Bouaziz & Nuel 2018."""
    x = np.linspace(0.0, 1.0, ASPLINE_N)
    e = 2.0 ** (-3.0 / 5.0)
    return x, np.sqrt(x * (1.0 - x)) * np.sin(2.0 * np.pi * (1.0 + e) / (x + e)) + 0.5


#: The Donoho–Johnstone signals' sample size.
DJ_N = 1024
_DJ_POS = np.array([0.1, 0.13, 0.15, 0.23, 0.25, 0.40, 0.44, 0.65, 0.76, 0.78, 0.81])


def _dj_t() -> np.ndarray:
    return np.arange(1, DJ_N + 1) / DJ_N  # WaveLab: t = (1:n) ./ n


def dj_blocks() -> tuple[np.ndarray, np.ndarray]:
    """Blocks: sum_j h_j (1 + sign(t - p_j)) / 2 with WaveLab's positions and heights
    h = (4, -5, 3, -4, 5, -4.2, 2.1, 4.3, -3.1, 2.1, -4.2), t = (1..1024)/1024. Donoho &
    Johnstone 1994, as in WaveLab's ``MakeSignal`` (the reference taken where implementations
    differ)."""
    t = _dj_t()
    heights = np.array([4, -5, 3, -4, 5, -4.2, 2.1, 4.3, -3.1, 2.1, -4.2])
    return t, ((1.0 + np.sign(t[:, None] - _DJ_POS)) * heights / 2.0).sum(axis=1)


def dj_bumps() -> tuple[np.ndarray, np.ndarray]:
    """Bumps: sum_j h_j / (1 + |t - p_j| / w_j)^4 with WaveLab's h = (4, 5, 3, 4, 5, 4.2, 2.1,
    4.3, 3.1, 5.1, 4.2) (5.1, not 2.1, for the tenth) and widths w = (.005, .005, .006, .01,
    .01, .03, .01, .01, .005, .008, .005), t = (1..1024)/1024. Donoho & Johnstone 1994,
    WaveLab's ``MakeSignal``."""
    t = _dj_t()
    heights = np.array([4, 5, 3, 4, 5, 4.2, 2.1, 4.3, 3.1, 5.1, 4.2])
    widths = np.array([0.005, 0.005, 0.006, 0.01, 0.01, 0.03, 0.01, 0.01, 0.005, 0.008, 0.005])
    return t, (heights / (1.0 + np.abs(t[:, None] - _DJ_POS) / widths) ** 4).sum(axis=1)


def dj_heavisine() -> tuple[np.ndarray, np.ndarray]:
    """HeaviSine: 4 sin(4 pi t) - sign(t - 0.3) - sign(0.72 - t), t = (1..1024)/1024. Donoho &
    Johnstone 1994, WaveLab's ``MakeSignal``."""
    t = _dj_t()
    return t, 4.0 * np.sin(4.0 * np.pi * t) - np.sign(t - 0.3) - np.sign(0.72 - t)


def dj_doppler() -> tuple[np.ndarray, np.ndarray]:
    """Doppler: sqrt(t (1 - t)) sin(2 pi 1.05 / (t + 0.05)) (epsilon 0.05, WaveLab's),
    t = (1..1024)/1024. Donoho & Johnstone 1994, WaveLab's ``MakeSignal``."""
    t = _dj_t()
    return t, np.sqrt(t * (1.0 - t)) * np.sin(2.0 * np.pi * 1.05 / (t + 0.05))


#: Kang, Chen, Li, Deng & Yang 2015 (CAD 58): the cubic B-spline sampled, with its true knots.
KANG_KNOTS = (0.0439, 0.0653, 0.2293, 0.2367, 0.4821, 0.4907, 0.5408, 0.5408, 0.6209, 0.7051,
              0.9407)
KANG_COEFFICIENTS = (-15, 10, 37, 47, -52, 80, 43, 76, 10, 3, 69, 26, 97, 80, 78)


def kang_spline() -> tuple[np.ndarray, np.ndarray]:
    """A cubic B-spline on [0, 1] with interior knots 0.0439, 0.0653, 0.2293, 0.2367, 0.4821,
    0.4907, 0.5408 (double), 0.6209, 0.7051, 0.9407 and control values -15, 10, 37, 47, -52,
    80, 43, 76, 10, 3, 69, 26, 97, 80, 78, sampled at 1,001 equally spaced points ``i / 1000``:
    a known-answer instance whose true knots can be recovered. The knots lie between data
    parameters (0.0439 between 0.043 and 0.044, ...), so index sets can only come near them;
    free knots with a double knot allowed (``merge_spacing``) reproduce the data. H. Kang,
    F. Chen, Y. Li, J. Deng & Z. Yang, "Knot calculation for spline fitting via sparse
    optimization", Computer-Aided Design 58 (2015)."""
    t = np.concatenate(([0.0] * 4, KANG_KNOTS, [1.0] * 4))
    x = np.linspace(0.0, 1.0, 1001)
    return x, BSpline(t, np.asarray(KANG_COEFFICIENTS, dtype=np.float64), 3)(x)


def runge() -> tuple[np.ndarray, np.ndarray]:
    """Runge's function 1 / (1 + 25 x^2) on x = linspace(-1, 1, 201)."""
    x = np.linspace(-1.0, 1.0, 201)
    return x, 1.0 / (1.0 + 25.0 * x**2)


def humps() -> tuple[np.ndarray, np.ndarray]:
    """MATLAB's ``humps``: 1 / ((x - 0.3)^2 + 0.01) + 1 / ((x - 0.9)^2 + 0.04) - 6 on
    x = linspace(0, 2, 201)."""
    x = np.linspace(0.0, 2.0, 201)
    return x, 1.0 / ((x - 0.3) ** 2 + 0.01) + 1.0 / ((x - 0.9) ** 2 + 0.04) - 6.0


TITANIUM_Y = (0.644, 0.622, 0.638, 0.649, 0.652, 0.639, 0.646, 0.657, 0.652, 0.655, 0.644,
              0.663, 0.663, 0.668, 0.676, 0.676, 0.686, 0.679, 0.678, 0.683, 0.694, 0.699,
              0.710, 0.730, 0.763, 0.812, 0.907, 1.044, 1.336, 1.881, 2.169, 2.075, 1.598,
              1.211, 0.916, 0.746, 0.672, 0.627, 0.615, 0.607, 0.606, 0.609, 0.603, 0.601,
              0.603, 0.601, 0.611, 0.601, 0.608)


def titanium() -> tuple[np.ndarray, np.ndarray]:
    """De Boor's titanium heat data (Jupp 1978; MATLAB's ``titanium.m``): 49 measurements at
    x = 595, 605, ..., 1075, a flat run with one sharp peak; small enough for exhaustive
    search at small K."""
    return np.arange(595.0, 1076.0, 10.0), np.asarray(TITANIUM_Y)


def cubic_bump() -> tuple[np.ndarray, np.ndarray]:
    """A cubic with a narrow bump: x^3 - x + 0.3 exp(-((x - 0.35) / 0.03)^2) on
    x = linspace(-1, 1, 301) (metaknot's definition of this data kind: a smooth trend that
    needs few knots and a local feature that needs several close together)."""
    x = np.linspace(-1.0, 1.0, 301)
    return x, x**3 - x + 0.3 * np.exp(-(((x - 0.35) / 0.03) ** 2))


#: Function instances: id -> (family, generator).
FUNCTIONS = {
    "galvez_f1": ("galvez_iglesias", galvez_f1),
    "galvez_f2": ("galvez_iglesias", galvez_f2),
    "galvez_f3": ("galvez_iglesias", galvez_f3),
    "galvez_f4": ("galvez_iglesias", galvez_f4),
    "galvez_f5": ("galvez_iglesias", galvez_f5),
    "aspline_logit": ("aspline", aspline_logit),
    "aspline_sine3": ("aspline", aspline_sine3),
    "aspline_bump": ("aspline", aspline_bump),
    "aspline_spa_het": ("aspline", aspline_spa_het),
    "dj_blocks": ("donoho_johnstone", dj_blocks),
    "dj_bumps": ("donoho_johnstone", dj_bumps),
    "dj_heavisine": ("donoho_johnstone", dj_heavisine),
    "dj_doppler": ("donoho_johnstone", dj_doppler),
    "kang_spline": ("classic_functions", kang_spline),
    "runge": ("classic_functions", runge),
    "humps": ("classic_functions", humps),
    "titanium": ("classic_functions", titanium),
    "cubic_bump": ("classic_functions", cubic_bump),
}
