"""The study sweeper: Hydra's basic sweeper, plus what a resumable study needs.

Before launching anything it composes and validates every job's configuration (one bad value
fails the sweep, naming the key), skips the runs already in the results store and the
algorithm/encoding pairs that cannot work together (listing them), then launches the rest with
the configured launcher and shows a progress bar over the jobs. The work is done in
:mod:`metaknot.experiments.sweep`; this module stays light, as Hydra imports every plugin.
"""

# no ``from __future__ import annotations``: Hydra's plugin scan runs this module before it is
# in sys.modules, and dataclasses cannot resolve string annotations then
from dataclasses import dataclass, field
from typing import Any

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
from hydra.core.config_store import ConfigStore


@dataclass
class StudySweeperConf:
    _target_: str = "hydra_plugins.metaknot_study_sweeper.study_sweeper.StudySweeper"
    max_batch_size: Any = None
    params: Any = field(default_factory=dict)
    #: Runs of one setting (seeds) per launched job: an int, or "auto" (see metaknot's
    #: experiments/sweep.py); fewer, longer jobs pay Hydra's per-job set-up less often.
    runs_per_job: Any = "auto"


ConfigStore.instance().store(group="hydra/sweeper", name="study", node=StudySweeperConf,
                             provider="metaknot")


class StudySweeper(BasicSweeper):
    """Basic sweeper with validation, resume, skipping and a progress bar over jobs."""

    def __init__(self, max_batch_size: Any = None, params: Any = None,
                 runs_per_job: Any = "auto") -> None:
        super().__init__(max_batch_size=max_batch_size, params=params)
        self.runs_per_job = runs_per_job

    def sweep(self, arguments: list) -> Any:
        from metaknot.experiments.sweep import sweep

        return sweep(self, arguments)
