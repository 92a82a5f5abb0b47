"""Hydra configuration of ``metaknot run`` (config groups as folders)."""
