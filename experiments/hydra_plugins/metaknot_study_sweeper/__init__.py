"""Hydra plugin: the study sweeper of metaknot (``hydra/sweeper=study``)."""
