"""Optimizers (installed as ``metaknot.algorithms``); each registers itself by name."""

from .random_search import RandomSearch

__all__ = ["RandomSearch"]
