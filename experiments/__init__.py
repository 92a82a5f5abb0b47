"""Experiment configurations (installed as ``metaknot.experiments``)."""
