"""Hyperparameter studies (``metaknot tune``): Optuna studies tuned on training instances and
judged on held-out ones."""

from .app import tune
from .spec import TRAIN_SEED_OFFSET, Instance, TuneSpec, tune_spec

__all__ = ["TRAIN_SEED_OFFSET", "Instance", "TuneSpec", "tune", "tune_spec"]
