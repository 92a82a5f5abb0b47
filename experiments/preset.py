"""Method presets as data: ``metaknot run --preset FILE``.

A preset names a method, as ``metaknot tune`` writes its best configuration::

    optimizer: {_name_: dolphin, population: 32, pp1: 0.597, power: 0.206}
    encoding: {kind: mask, density: 0.5}     # optional, as are objective: {name: ...}
    label: dolphin-tuned                     # and the label

It is read as plain YAML data and becomes command-line overrides placed before the user's
(``optimizer=dolphin ++optimizer.population=32 ...``), so the user's own overrides win. It can
hold nothing but these settings: no Hydra ``defaults`` or ``hydra`` keys, no ``_target_``,
no interpolation. A Hydra config directory
(``--config-dir``) is code instead: its ``hydra.callbacks`` and ``_target_`` keys call any
Python function. See ``docs/tuning.md``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from .spec import ConfigError, _unknown, run_spec

__all__ = ["check_preset", "expand_preset", "load_preset", "preset_overrides"]

#: A preset's sections and the key of each that names the config group to select.
SECTIONS = {"optimizer": "_name_", "encoding": "kind", "objective": "name"}
KEYS = {*SECTIONS, "label"}


def _short(text: str) -> str:
    """``text`` shortened to about 80 characters (user data in messages)."""
    return text if len(text) <= 80 else text[:77] + "..."


def _quote(value: Any) -> str:
    return _short(repr(value))


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

    file = Path(path)
    try:
        text = file.read_text()
    except FileNotFoundError:
        raise ConfigError(f"--preset: no such file: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"--preset: {path} cannot be read ({exc})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise ConfigError(f"{path}: not valid YAML{where}") from None
    return check_preset(data, str(path))


def check_preset(data: Any, where: str) -> dict[str, Any]:
    """The preset ``data`` (read from ``where``), checked as :func:`load_preset` says."""
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: a preset is a mapping of optimizer, encoding, objective "
                          f"and label; got {_quote(data)}")
    if "defaults" in data:
        raise ConfigError(f"{where}: defaults: not allowed in a preset, which is data (Hydra "
                          "directives and _target_ run code)")
    _refuse_directives(data, where, "")
    try:
        _unknown("", data, KEYS)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    if "optimizer" not in data:
        raise ConfigError(f"{where}: optimizer: missing (a preset names its optimizer)")
    for section in SECTIONS:
        if section in data:
            _check_section(data[section], section, where)
    label = data.get("label")
    _check_scalar(label, "label", where)
    # the settings themselves (names, known keys, types), checked where every run's are; so
    # only known setting names reach the overrides
    try:
        run_spec({"study": "preset", "results_dir": ".", "problem": {"curve": "epitrochoid"},
                  "encoding": data.get("encoding", {"kind": "mask"}),
                  "objective": data.get("objective", {"name": "paper"}),
                  "optimizer": data["optimizer"], "budget": 1, "seed": 0,
                  "label": label}, check_build=False)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    return data


def _refuse_directives(node: dict[str, Any], where: str, prefix: str) -> None:
    """Refuse keys that make Hydra compose configs or call code, at any depth."""
    for key, value in node.items():
        name = f"{prefix}{key}"
        if not isinstance(key, str):
            raise ConfigError(f"{where}: {_short(name)}: keys are names, got {_quote(key)}")
        if key == "_target_" or key == "hydra" or key.startswith(("hydra.", "hydra/")):
            raise ConfigError(f"{where}: {_short(name)}: not allowed in a preset, which is "
                              "data (Hydra directives and _target_ run code)")
        if isinstance(value, dict):
            _refuse_directives(value, where, f"{name}.")


def _check_section(section: Any, name: str, where: str) -> None:
    if not isinstance(section, dict):
        raise ConfigError(f"{where}: {name}: a mapping of settings, got {_quote(section)}")
    for key, value in section.items():
        _check_scalar(value, f"{name}.{key}", where)


def _check_scalar(value: Any, key: str, where: str) -> None:
    """A number, a plain string, a boolean or null (anything else could not be passed as an
    override unchanged)."""
    if value is None or isinstance(value, bool | int):
        return
    if isinstance(value, float):
        if math.isfinite(value):
            return
    elif isinstance(value, str):
        if value.isprintable() and not any(c in value for c in "'\"\\") and "${" not in value:
            return
        raise ConfigError(f"{where}: {_short(key)}: quotes, backslashes and ${{...}} are not "
                          f"allowed in a preset's strings; got {_quote(value)}")
    raise ConfigError(f"{where}: {_short(key)}: a number, a string, true/false or null; got "
                      f"{_quote(value)}")


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
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f"'{value}'"
    return repr(value)


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
