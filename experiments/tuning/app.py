"""``metaknot tune``: a hyperparameter study with Optuna, tuned on training instances and
judged on held-out ones::

    metaknot tune tune=dolphin n_trials=100
    metaknot tune tune=ga n_trials=50 workers=2
    metaknot tune tune=dolphin storage=postgresql+psycopg://user@host/db   # several machines

Re-running the same command resumes the study (it stops once ``n_trials`` trials finished).
"""

from __future__ import annotations

import signal
import sys
from pathlib import Path
from typing import Any

from ..app import CONFIG_DIR, launch, not_a_setting, unreadable
from ..errors import ConfigError
from ..interrupt import Interrupted, interrupt_on_signals
from ..spec import STUDY, check_value
from ..store import check_writable
from .spec import tune_spec
from .study import TuneSpec

__all__ = ["main", "tune"]



def tune(spec: TuneSpec, *, progress: bool = True) -> dict[str, Any]:
    """Run (or resume) the study, then write its outputs and, unless ``evaluate`` is false,
    judge the best configuration on the held-out instances.

    Returns the paths written and the best trial's value and parameters.
    """
    from . import outputs
    from .runner import (
        fail_running_trials,
        fail_trials_of_dead_workers,
        open_storage,
        open_study,
        references,
        run_workers,
        storage_description,
        worker_name,
    )

    storage = open_storage(spec)  # errors here stop everything before a trial starts
    study = open_study(spec, storage, spec.worker_index)
    print(f"tune {spec.study}: {spec.optimizer} on {len(spec.train)} training instances x "
          f"{len(spec.train_seeds)} seeds, {spec.budget:,} evaluations per run; storage "
          f"{storage_description(spec)}", flush=True)
    try:
        references(spec, study)
    except Interrupted as stop:  # nothing of these runs is stored
        stop.line = (f"tune {spec.study}: interrupted ({signal.Signals(stop.signum).name}) "
                     "while the reference method ran, before any trial; run the same command "
                     "to resume")
        raise
    before = len(study.get_trials(deepcopy=False))
    try:
        spawned = run_workers(spec, progress=progress)
    except Interrupted as stop:  # the workers are stopped: fail what they left running
        ours = {worker_name(), *(worker_name(pid) for pid in stop.workers)}
        fail_running_trials(study, ours)
        outputs.write_trials(spec, study)
        stop.line = (f"{trials_added(spec, study, before, ours)}; interrupted "
                     f"({signal.Signals(stop.signum).name}): its running trials marked FAIL; "
                     "run the same command to resume")
        raise
    for line in fail_trials_of_dead_workers(study, spawned):
        print(line, flush=True)
    ours = {worker_name(), *(worker_name(pid) for _, pid, _ in spawned)}
    print(trials_added(spec, study, before, ours), flush=True)
    try:
        best = study.best_trial
    except ValueError:
        raise RuntimeError(f"study {spec.study!r} has no complete trial; see "
                           f"{spec.study_dir / 'trials.csv'}") from None
    finally:
        outputs.write_trials(spec, study)
    written = {"trials": spec.study_dir / "trials.parquet",
               "best_config": outputs.write_best_config(spec, study)}
    figures = outputs.write_figures(spec, study)
    test_dir = None
    if spec.evaluate:
        print(f"tune {spec.study}: judging trial {best.number} on {len(spec.test)} held-out "
              f"instances x {len(spec.test_seeds)} seeds", flush=True)
        test_dir = outputs.evaluate_held_out(spec, study, workers=spec.workers)
        written["test_study"] = test_dir
    written["report"] = outputs.write_report(spec, study, figures, written["best_config"],
                                             test_dir)
    print(f"best: trial {best.number}, value {best.value:.4g}, {best.params}")
    print(f"run it: {outputs.run_command(written['best_config'])}")
    print(f"report: {written['report']}")
    return {**written, "best_value": best.value, "best_params": best.params}


def trials_added(spec: TuneSpec, study: Any, before: int,
                 workers: set[str] | None = None) -> str:
    """The line saying how many trials this command's ``workers`` (their ``host:pid``; all
    if None) added since the study held ``before`` (by their state: complete, pruned, fail,
    ...), how many other commands' workers added meanwhile, and how many it holds now."""
    from collections import Counter

    trials = study.get_trials(deepcopy=False)
    new = trials[before:]
    mine = [t for t in new if workers is None or t.user_attrs.get("worker", "") in workers]
    states = Counter(trial.state.name.lower() for trial in mine)
    added = len(mine)
    detail = ", ".join(f"{n} {state}" for state, n in sorted(states.items()))
    what = f"added {added} trial{'s' * (added != 1)} ({detail})" if added else "added no trials"
    others = len(new) - added
    meanwhile = f"; other workers added {others}" if others else ""
    return f"tune {spec.study}: {what}{meanwhile}; the study holds {len(trials)}"


def task(cfg: Any) -> None:
    tune(tune_spec(cfg))


def main(argv: list[str] | None = None) -> int:
    """Hand ``argv`` (Hydra overrides) to the ``tuning`` configuration; a bad configuration is
    a one-line error before any trial starts."""
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException

    args = list(sys.argv[1:] if argv is None else argv)
    single = not any(a.startswith("-") for a in args)
    error = not_a_setting(args, "tune=dolphin n_trials=100 workers=2") if single else None
    sweep = bool({"-m", "--multirun"} & set(args))
    error = error or unreadable_setting(args) or (results_dirs_error(args) if sweep else None)
    if error:
        print(f"metaknot tune: error: {error}", file=sys.stderr)
        return 2
    if single:
        try:
            with initialize_config_dir(version_base="1.3", config_dir=str(CONFIG_DIR)):
                cfg = compose("tuning", overrides=args)
            spec = tune_spec(cfg)
            check_writable(spec.study_dir)
        except HydraException as exc:  # a ConfigError too (a CompactHydraException)
            lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
            print(f"metaknot tune: error: {' '.join(lines[:2])}", file=sys.stderr)
            return 2
        try:
            with interrupt_on_signals(anywhere=False):  # not inside a storage's lock
                tune(spec)
        except ConfigError as exc:
            print(f"metaknot tune: error: {exc}", file=sys.stderr)
            return 2
        except Interrupted as stop:  # one line: what the study holds, how to resume
            print(stop.line or f"tune {spec.study}: interrupted; run the same command to "
                  "resume", file=sys.stderr, flush=True)
            return stop.exit_code
        return 0
    try:  # a sweep (-m): its studies one after another, each stopped as a single tune is
        with interrupt_on_signals(anywhere=False):
            return launch(task, "tuning", args)
    except Interrupted as stop:
        print(stop.line or "metaknot tune: interrupted; run the same command to resume",
              file=sys.stderr, flush=True)
        return stop.exit_code


def _settings(args: list[str]) -> list[str]:
    """The settings (Hydra overrides) of a command line, not Hydra's options nor their values."""
    return [a for a in args if ("=" in a and not a.startswith("-")) or a.startswith("~")]


def unreadable_setting(args: list[str]) -> str | None:
    """The first setting of ``args`` Hydra cannot read, in one line (a value beyond ASCII
    unquoted gets its quoted spelling: :func:`~..app.unreadable`), or None."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.errors import HydraException

    parser = OverridesParser.create()
    for arg in _settings(args):
        try:
            parser.parse_overrides([arg])
        except HydraException as exc:
            return unreadable(arg, exc)
    return None


def results_dirs_error(args: list[str]) -> str | None:
    """Why a results folder of a sweep (``-m``; each value of a swept ``results_dir``) cannot
    be used, in one line: a loop of symbolic links, a file, a folder nothing can be written
    into; None if each can. Hydra makes its sweep folder there before any study's settings
    are checked (a traceback before)."""
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from omegaconf import OmegaConf

    folders: list[Any] = [OmegaConf.load(CONFIG_DIR / "tuning.yaml").results_dir]
    for arg in _settings(args):
        if arg.partition("=")[0].lstrip("+") == "results_dir":
            (override,) = OverridesParser.create().parse_overrides([arg])
            folders = list(override.sweep_iterator()) if override.is_sweep_override() else \
                [override.value()]
    try:
        for folder in (str(getattr(f, "text", f)) for f in folders):  # QuotedString: its text
            check_value("results_dir", folder, STUDY["results_dir"])
            check_writable(Path(folder))
    except ConfigError as exc:
        return str(exc)
    return None
