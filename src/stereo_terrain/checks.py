"""Validators shared by the stage configs: each raises :class:`ConfigError` naming the
field, what was expected and what came; and the readers of small text files (rig, config,
``pairs.csv``, ``truth.json``, ``approach.json``) that refuse what is not UTF-8 text, YAML
or JSON before a parser trips on it."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any

from .errors import ConfigError, InputError

#: Integer config fields must fit a C int (OpenCV takes them as one).
INT_LIMIT = 2**31 - 1

#: Real config fields must be no larger in magnitude than this: every setting is metres,
#: pixels, degrees, seconds or a factor, and a value like 1e300 overflowed (or asked for
#: memory without end) deep in a stage instead of being refused here.
FLOAT_LIMIT = 1e9  # (the messages say 1e9)

#: Text files the package reads (rig, config, ``pairs.csv``) larger than this are refused.
MAX_TEXT_BYTES = 64 << 20

#: Brackets nested deeper are refused before a parser recurses into them.
MAX_NESTING = 32


def check_input_file(path: Path, what: str) -> None:
    """:class:`InputError` naming ``what`` and the path unless ``path`` is a regular file:
    missing, a folder, a link that leads nowhere (or round in a loop), or a pipe, socket or
    device (``<(...)``, a FIFO: one without a writer would block the read for ever)."""
    if path.is_dir():
        raise InputError(f"{what} {path} is a folder, not a file")
    if path.is_file():
        return
    if path.exists():
        raise InputError(f"{what} {path} is not a regular file (a pipe, socket or device); give a file")
    if path.is_symlink():
        raise InputError(f"{what} {path} is a link that leads to no file (broken, or a loop)")
    raise InputError(f"{what} not found: {path}")


def read_text_file(path: str | Path, what: str, *, max_bytes: int = MAX_TEXT_BYTES) -> str:
    """The whole file as UTF-8 text; :class:`InputError` naming ``what`` and the path when it
    is missing, a folder, not a regular file, unreadable, too large or not UTF-8."""
    path = Path(path)
    check_input_file(path, what)
    try:
        with path.open("rb") as f:
            data = f.read(max_bytes + 1)
    except FileNotFoundError:
        raise InputError(f"{what} not found: {path}") from None
    except OSError as exc:
        raise InputError(f"{what} {path} is not readable: {exc.strerror}") from None
    if len(data) > max_bytes:
        raise InputError(f"{what} {path} is larger than {max_bytes >> 20} MiB")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} {path} is not UTF-8 text (invalid byte at offset {exc.start})") from None


def nesting_depth(text: str) -> int:
    """Deepest nesting of ``[`` / ``{`` brackets in ``text`` (quotes are not parsed)."""
    depth = best = 0
    for ch in text:
        if ch in "[{":
            depth += 1
            if depth > best:
                best = depth
        elif ch in "]}":
            depth = max(0, depth - 1)
    return best


def load_yaml_file(path: str | Path, what: str) -> Any:
    """Parse a small YAML file (``yaml.safe_load``, keys unique); :class:`InputError` for a
    file that is missing, not UTF-8, nested deeper than :data:`MAX_NESTING`, not YAML, or
    with a key given twice in one mapping (YAML would keep the last silently: a setting
    changed twice in a long config is a mistake to show)."""
    import yaml

    text = read_text_file(path, what)
    if nesting_depth(text) > MAX_NESTING:
        raise InputError(f"{what} {path} nests brackets deeper than {MAX_NESTING} levels")
    try:
        return yaml.load(text, Loader=_unique_key_loader())  # noqa: S506 - a SafeLoader
    except yaml.YAMLError as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{what} {path} is not valid YAML: {first}") from None
    except (RecursionError, ValueError, OverflowError, TypeError) as exc:
        raise InputError(f"{what} {path} is not valid YAML: {type(exc).__name__}") from None


def load_json_file(path: str | Path, what: str) -> Any:
    """Parse a small JSON file; :class:`InputError` naming ``what`` and the path for a file
    that is missing, not UTF-8, nested deeper than :data:`MAX_NESTING` (Python's parser
    recurses: a file of deeply nested brackets would end in a ``RecursionError``) or not
    JSON."""
    text = read_text_file(path, what)
    if nesting_depth(text) > MAX_NESTING:
        raise InputError(f"{what} {path} nests brackets deeper than {MAX_NESTING} levels")
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"{what} {path} is not valid JSON ({exc.msg} at line {exc.lineno})") from None
    except (RecursionError, ValueError) as exc:
        raise InputError(f"{what} {path} is not valid JSON: {type(exc).__name__}: {str(exc)[:200]}") from None


def _unique_key_loader() -> Any:
    """``yaml.SafeLoader`` that refuses a key given twice in one mapping."""
    import yaml

    class UniqueKeyLoader(yaml.SafeLoader):
        def construct_mapping(self, node: Any, deep: bool = False) -> Any:
            seen = set()
            for key_node, _value in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue  # "<<: *base": the base's keys, which this mapping may override
                key = self.construct_object(key_node, deep=deep)
                try:
                    twice = key in seen
                except TypeError:
                    continue  # an unhashable key: the base loader says so, with its line
                if twice:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"key {key!r} given twice (line {key_node.start_mark.line + 1})", None
                    )
                seen.add(key)
            return super().construct_mapping(node, deep)

    return UniqueKeyLoader


def check_fields(config: Any) -> None:
    """Type-check a config dataclass against the types of its defaults.

    A field whose default is an ``int`` must be an integer (not a bool; a ``seed`` one not
    negative), a ``float`` field a finite real number no larger in magnitude than
    :data:`FLOAT_LIMIT`, a ``bool`` field a bool, a ``str`` field a string; a field whose
    default comes from a dataclass (a nested config) must be an instance of it (a mapping
    there is a mistake: ``from_dict`` builds the nested configs). Fields whose default is
    None or another type are left to the config's own checks.
    """
    owner = type(config).__name__
    for f in dataclasses.fields(config):
        if f.default is dataclasses.MISSING:
            factory = f.default_factory
            if factory is dataclasses.MISSING:
                continue
            # a nested config's class, or the class of what a factory function makes
            # (PipelineConfig.rematch_sgbm: a copy of a preset)
            nested = factory if isinstance(factory, type) else type(factory())
            if dataclasses.is_dataclass(nested):
                value = getattr(config, f.name)
                if not isinstance(value, nested):
                    raise ConfigError(
                        f"{owner}.{f.name} must be a {nested.__name__}, got {type(value).__name__} "
                        f"(from a mapping, build the config with {owner}.from_dict)"
                    )
            continue
        default, value = f.default, getattr(config, f.name)
        if isinstance(default, bool):
            ok = isinstance(value, bool)
            want = "true or false"
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool) and abs(value) <= INT_LIMIT
            want = f"an integer of magnitude <= {INT_LIMIT}"
            if ok and f.name == "seed" and value < 0:
                ok, want = False, "an integer >= 0 (a random generator's seed)"
        elif isinstance(default, float):
            ok = (
                isinstance(value, int | float)
                and not isinstance(value, bool)
                and math.isfinite(value)
                and abs(value) <= FLOAT_LIMIT
            )
            want = "a finite number of magnitude <= 1e9"
        elif isinstance(default, str):
            ok = isinstance(value, str)
            want = "a string"
        else:
            continue
        if not ok:
            hint = ""
            if isinstance(value, str) and want != "a string":
                try:
                    float(value)
                    # PyYAML reads 1e-3 (no dot) as text.
                    hint = " (YAML reads a number like 1e-3 as text: write it as 1.0e-3)"
                except ValueError:
                    pass
            raise ConfigError(f"{owner}.{f.name} must be {want}, got {value!r}{hint}")


def check_min(config: Any, minimum: float, *names: str) -> None:
    """Each named field must be >= ``minimum``."""
    for name in names:
        value = getattr(config, name)
        if not value >= minimum:
            raise ConfigError(f"{type(config).__name__}.{name} must be >= {minimum}, got {value}")
