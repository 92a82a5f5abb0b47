"""Optimizers (installed as ``metaknot.algorithms``); each registers itself by name.

=================  ===============================================================
name               method
=================  ===============================================================
``dolphin``        Dolphin Echolocation (Kaveh & Farhoudi 2013), masks and index sets
``ga``             generational genetic algorithm, masks and index sets
``nlopt``          nlopt free-knot optimisation (local and global algorithms)
``varpro``         free knots by variable projection (exact Jacobian, Gauss-Newton)
``uniform``        equally spaced knots
``averaging``      averaging knots (NURBS Book eqs. 9.68-9.69)
``fitpack``        FITPACK's knots (:mod:`metaknot.bspline.fitpack`), smoothing factor searched
``random_search``  independent random candidates
``one_plus_one``   (1+1) EA (or (1+λ)), 1/n bit flips or index steps
``local_search``   best-improvement knot removal/insertion/shifts from averaging knots
``free_front``     a front on free knots: averaging knots at every count, each refined
``cmaes``          CMA-ES on free knots (the ``cmaes`` package)
``nevergrad``      any nevergrad optimizer (``nevergrad:NGOpt``, ``nevergrad:CMA``, ...)
``pymoo``          pymoo's GA, DE or BRKGA (``pymoo:GA``, ``pymoo:DE``, ``pymoo:BRKGA``)
=================  ===============================================================

Knot placement methods from the literature, fewest knots within a tolerance
(:mod:`~metaknot.algorithms.literature`):

=====================  ===========================================================
name                   method
=====================  ===========================================================
``newknt``             de Boor's ``newknt``: ``|D^(p+1) f|^(1/(p+1))`` equidistributed
``equidistribution``   feature equidistribution (Razdan 1999; Li et al. 2005; Yeh et al.
                       2020)
``dominant_points``    dominant points, adaptive refinement (Park & Lee 2007)
``lyche_morken``       knot removal by ranked weights (Lyche & Mørken 1987)
``bisection``          bisection and least-squares refinement (Dung & Tjahjowidodo 2017)
``sparse_l1``          L1-sparse jumps of the p-th derivative (Kang et al. 2015)
=====================  ===========================================================
"""

from .baselines import AveragingKnots, FitpackKnots, UniformKnots
from .bisection import Bisection
from .cmaes_adapter import CMAESKnots
from .dolphin import DolphinEcholocation
from .dominant_points import DominantPoints
from .equidistribution import Equidistribution
from .free_front import FreeKnotFront
from .ga import GeneticAlgorithm
from .local_search import LocalSearch
from .lyche_morken import LycheMorken
from .nevergrad_adapter import NevergradOptimizer
from .newknt import NewKnt
from .nlopt_knots import NloptKnots
from .one_plus_one import OnePlusOneEA
from .pymoo_adapter import PymooOptimizer
from .random_search import RandomSearch
from .sparse_l1 import SparseL1
from .variable_projection import VariableProjection

__all__ = [
    "AveragingKnots",
    "Bisection",
    "CMAESKnots",
    "DolphinEcholocation",
    "DominantPoints",
    "Equidistribution",
    "FitpackKnots",
    "FreeKnotFront",
    "GeneticAlgorithm",
    "LocalSearch",
    "LycheMorken",
    "NevergradOptimizer",
    "NewKnt",
    "NloptKnots",
    "OnePlusOneEA",
    "PymooOptimizer",
    "RandomSearch",
    "SparseL1",
    "UniformKnots",
    "VariableProjection",
]
