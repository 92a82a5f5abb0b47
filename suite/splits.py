"""Named subsets of the suite: ``all``, ``base`` (no noise), ``mini`` (one base instance per
family, for quick studies), and a fixed, family-stratified ``train``/``test`` split.

The split is by base instance, in the suite's order within each family: every third (the 3rd,
6th, ...) is a test instance, the others train; a noisy variant goes where its base instance
goes, so nothing of a test instance is seen in training. The config group ``suite`` of
``metaknot run`` holds one file per split (``suite=train``), written from these definitions
(:func:`write_configs`; a test keeps them in step).
"""

from __future__ import annotations

from pathlib import Path

from .instances import base_instances, instances

__all__ = ["SPLITS", "split", "write_configs"]

SPLITS = ("all", "base", "mini", "train", "test")


def _test_bases() -> set[str]:
    test: set[str] = set()
    seen: dict[str, int] = {}
    for instance in base_instances():
        seen[instance.family] = seen.get(instance.family, 0) + 1
        if seen[instance.family] % 3 == 0:
            test.add(instance.id)
    return test


def split(name: str) -> list[str]:
    """The instance ids of the split ``name`` (one of :data:`SPLITS`), in the suite's order.

    Raises
    ------
    ValueError
        For an unknown split.
    """
    if name not in SPLITS:
        raise ValueError(f"unknown suite split {name!r}; choose one of {', '.join(SPLITS)}")
    if name == "base":
        return [i.id for i in base_instances()]
    if name == "mini":
        firsts: dict[str, str] = {}
        for instance in base_instances():
            firsts.setdefault(instance.family, instance.id)
        return list(firsts.values())
    found = instances(plugins=False)
    if name == "all":
        return [i.id for i in found]
    test = _test_bases()
    return [i.id for i in found if (i.base_id in test) == (name == "test")]


def config_text(name: str) -> str:
    """The ``suite=<name>`` config: ``problem=suite`` swept over the split's instances."""
    ids = split(name)
    return (f"# @package _global_\n# The suite split {name!r} ({len(ids)} instances; "
            "metaknot.suite.splits, written by write_configs).\n"
            "# metaknot run -m suite=" + name + " problem.task=tolerance optimizer=ga,dolphin "
            "seed='range(0,10)'\n"
            "defaults:\n  - override /problem: suite\n"
            "hydra:\n  sweeper:\n    params:\n"
            f"      problem.instance: {','.join(ids)}\n")


def write_configs(folder: str | Path) -> list[Path]:
    """Write one ``<split>.yaml`` per split into ``folder`` (the config group ``suite``)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for name in SPLITS:
        path = folder / f"{name}.yaml"
        path.write_text(config_text(name))
        written.append(path)
    return written
