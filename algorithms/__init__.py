"""Optimizers (installed as ``metaknot.algorithms``); each registers itself by name.

=================  ===============================================================
name               method
=================  ===============================================================
``dolphin``        Dolphin Echolocation (Kaveh & Farhoudi 2013), masks and index sets
``ga``             generational genetic algorithm, masks and index sets
``nlopt``          nlopt free-knot optimisation (local and global algorithms)
``uniform``        equally spaced knots
``averaging``      averaging knots (NURBS Book eqs. 9.68-9.69)
``fitpack``        FITPACK's knots (scipy ``splprep``), smoothing factor searched
``random_search``  independent random candidates
=================  ===============================================================
"""

from .baselines import AveragingKnots, FitpackKnots, UniformKnots
from .dolphin import DolphinEcholocation
from .ga import GeneticAlgorithm
from .nlopt_knots import NloptKnots
from .random_search import RandomSearch

__all__ = [
    "AveragingKnots",
    "DolphinEcholocation",
    "FitpackKnots",
    "GeneticAlgorithm",
    "NloptKnots",
    "RandomSearch",
    "UniformKnots",
]
