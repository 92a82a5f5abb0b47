"""Hyperparameter studies (``metaknot tune``): Optuna studies tuned on training instances and
judged on held-out ones."""

from .app import tune
from .spec import TRAIN_SEED_OFFSET, tune_spec
from .study import Instance, TuneSpec

__all__ = ["TRAIN_SEED_OFFSET", "Instance", "TuneSpec", "tune", "tune_spec"]
