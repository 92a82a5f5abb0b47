"""Method presets as data: ``metaknot run --preset FILE``.

A preset names a method, as ``metaknot tune`` writes its best configuration::

    optimizer: {_name_: dolphin, population: 32, pp1: 0.597, power: 0.206}
    encoding: {kind: mask, density: 0.5}     # optional, as are objective: {name: ...}
    label: dolphin-tuned                     # and the label

It is read as plain YAML data and becomes command-line overrides placed before the user's
(``optimizer=dolphin ++optimizer.population=32 ...``), so the user's own overrides win. It can
hold nothing but these settings, checked by the run schema (:mod:`.spec`): a Hydra
``defaults`` or ``hydra`` key or a ``_target_`` is an unknown setting; no interpolation. A
Hydra config directory (``--config-dir``) is code instead: its ``hydra.callbacks`` and
``_target_`` keys call any Python function. See ``docs/tuning.md``.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Any

from .errors import ConfigError, naming, short
from .spec import NULL, Setting, check_section, check_value, run_spec

__all__ = ["check_preset", "expand_preset", "load_preset", "preset_overrides"]

#: A preset's sections and the key of each that names the config group to select.
SECTIONS = {"optimizer": "_name_", "encoding": "kind", "objective": "name"}
#: A value of a preset: what can be passed as an override unchanged.
SCALAR = Setting((NULL, bool, int, float, str), test=lambda value: not isinstance(value, str) or (
    value.isprintable() and not any(c in value for c in "'\"\\") and "${" not in value),
    expect="a number, true/false, null or a string without quotes, backslashes and ${...}")
SETTINGS = Setting((dict,), expect="a mapping of settings")
#: What a preset holds (the settings of its sections are a run's: :data:`~.spec.RUN`).
PRESET = {"optimizer": SETTINGS, "encoding": replace(SETTINGS, default={"kind": "mask"}),
          "objective": replace(SETTINGS, default={"name": "paper"}),
          "label": replace(SCALAR, default=None)}


def load_preset(path: str | Path) -> dict[str, Any]:
    """Read the preset ``path`` as data and check it.

    Raises
    ------
    ConfigError
        One line naming the file and the key: a key that is not a method's (``optimizer``,
        ``encoding``, ``objective``, ``label`` and the settings of each), a Hydra directive
        (``defaults``, ``hydra...``, ``_target_``), a value that is not a plain number, string,
        boolean or null, or a setting the method does not accept.
    """
    import yaml

    try:
        data = yaml.safe_load(Path(path).read_text())
    except FileNotFoundError:
        raise ConfigError(f"--preset: no such file: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"--preset: {path} cannot be read ({exc})") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise ConfigError(f"{path}: not valid YAML{where}") from None
    return check_preset(data, str(path))


def check_preset(data: Any, where: str) -> dict[str, Any]:
    """The preset ``data`` (read from ``where``), checked as :func:`load_preset` says."""
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: a preset is a mapping of optimizer, encoding, objective "
                          f"and label; got {short(repr(data))}")
    with naming(where, ConfigError):
        preset = check_section("", data, PRESET)
        for section in SECTIONS:
            for key, value in preset[section].items():
                check_value(f"{section}.{key}", value, SCALAR)
        # the settings themselves (names, known keys, types), checked where every run's are; so
        # only known setting names reach the overrides
        run_spec({"study": "preset", "results_dir": ".", "problem": {"curve": "epitrochoid"},
                  **preset, "budget": 1, "seed": 0}, check_build=False)
    return data


def preset_overrides(preset: dict[str, Any]) -> list[str]:
    """The command-line overrides that apply ``preset`` (checked by :func:`check_preset`)."""
    out = []
    for section, name_key in SECTIONS.items():
        if section in preset:
            out.append(f"{section}={preset[section][name_key]}")
            out += [f"++{section}.{key}={_override_value(value)}"
                    for key, value in preset[section].items() if key != name_key]
    if preset.get("label") is not None:
        out.append(f"++label={_override_value(preset['label'])}")
    return out


def _override_value(value: Any) -> str:
    """``value`` in an override: a string quoted, else as JSON (null, true, a finite number)."""
    return f"'{value}'" if isinstance(value, str) else json.dumps(value)


def expand_preset(args: list[str]) -> list[str]:
    """``args`` with ``--preset FILE`` (or ``--preset=FILE``) replaced by the preset's
    overrides, placed just before the other overrides (which therefore win) and after Hydra's
    flags (``-m``, ``--config-dir DIR``, ...).

    Raises
    ------
    ConfigError
        If the preset cannot be used (:func:`load_preset`), or ``--preset`` has no file or is
        given twice.
    """
    rest, files = [], []
    items = iter(args)
    for arg in items:
        if arg == "--preset":
            file = next(items, None)
            if file is None or file.startswith("-"):
                raise ConfigError("--preset: give the preset file: --preset FILE")
            files.append(file)
        elif arg.startswith("--preset="):
            files.append(arg.partition("=")[2])
        else:
            rest.append(arg)
    if not files:
        return rest
    if len(files) > 1:
        raise ConfigError("--preset: given twice; one preset per command")
    first = next((i for i, arg in enumerate(rest)
                  if not arg.startswith("-") and ("=" in arg or arg.startswith("~"))), len(rest))
    return [*rest[:first], *preset_overrides(load_preset(files[0])), *rest[first:]]
