"""The study sweeper (``hydra/sweeper=study``), on Hydra's public sweeper interface.

Before launching anything it composes and validates every job's configuration (one bad value
fails the sweep, naming the key), skips the runs already in the results store and the
optimizer/encoding pairs that cannot work together (listing them), then launches the rest with
the configured launcher (any ``hydra/launcher`` plugin: joblib, submitit's local and SLURM
launchers) and shows a progress bar over the jobs. The work is done in
:mod:`metaknot.experiments.sweep`; this module stays light, as Hydra imports every plugin.
"""

# no ``from __future__ import annotations``: Hydra's plugin scan runs this module before it is
# in sys.modules, and dataclasses cannot resolve string annotations then
from dataclasses import dataclass, field
from typing import Any

from hydra.core.config_store import ConfigStore
from hydra.plugins.sweeper import Sweeper


@dataclass
class StudySweeperConf:
    _target_: str = "hydra_plugins.metaknot_study_sweeper.study_sweeper.StudySweeper"
    #: Jobs handed to the launcher at once (null: all).
    max_batch_size: Any = None
    #: Swept settings, as on the command line (``seed: range(0,8)``).
    params: Any = field(default_factory=dict)
    #: Runs of one setting (seeds) per launched job: an int, or "auto" (see metaknot's
    #: experiments/sweep.py); fewer, longer jobs pay Hydra's per-job set-up less often.
    runs_per_job: Any = "auto"


ConfigStore.instance().store(group="hydra/sweeper", name="study", node=StudySweeperConf,
                             provider="metaknot")


class StudySweeper(Sweeper):
    """A sweep as a resumable study: validation, resume, skipping and a progress bar."""

    def __init__(self, max_batch_size: Any = None, params: Any = None,
                 runs_per_job: Any = "auto") -> None:
        self.max_batch_size = max_batch_size
        self.params = dict(params or {})
        self.runs_per_job = runs_per_job
        self.hydra_context: Any = None
        self.config: Any = None
        self.launcher: Any = None

    def setup(self, *, hydra_context: Any, task_function: Any, config: Any) -> None:
        from hydra.core.plugins import Plugins

        self.hydra_context, self.config = hydra_context, config
        self.launcher = Plugins.instance().instantiate_launcher(
            hydra_context=hydra_context, task_function=task_function, config=config)

    def sweep(self, arguments: list) -> Any:
        from metaknot.experiments.sweep import sweep

        return sweep(self, arguments)
