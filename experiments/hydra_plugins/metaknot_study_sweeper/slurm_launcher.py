"""Hydra's submitit SLURM launcher, waiting for every task (``launcher=slurm``).

The work is done in :mod:`metaknot.experiments.slurm`; this module stays light, as Hydra
imports every plugin.
"""

from collections.abc import Sequence
from typing import Any

from hydra_plugins.hydra_submitit_launcher.submitit_launcher import (
    SlurmLauncher as SubmititSlurmLauncher,
)


class SlurmLauncher(SubmititSlurmLauncher):
    """Submits a sweep as one SLURM job array and waits for every task: a task that ended
    without a result (``scancel``, a time limit) is one failed job, reported in the sweep's
    summary, not an exception that ends the sweep while other tasks still run."""

    def launch(self, job_overrides: Sequence[Sequence[str]], initial_job_idx: int) -> Any:
        from metaknot.experiments.slurm import launch

        return launch(self, job_overrides, initial_job_idx)
