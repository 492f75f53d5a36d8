"""Validators shared by the stage configs: each raises :class:`ConfigError` naming the
field, what was expected and what came."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from .errors import ConfigError


def check_fields(config: Any) -> None:
    """Type-check a config dataclass against the types of its defaults.

    A field whose default is an ``int`` must be an integer (not a bool), a ``float`` field a
    finite real number, a ``bool`` field a bool, a ``str`` field a string. Fields whose
    default is None or another type are left to the config's own checks.
    """
    owner = type(config).__name__
    for f in dataclasses.fields(config):
        if f.default is dataclasses.MISSING:
            continue
        default, value = f.default, getattr(config, f.name)
        if isinstance(default, bool):
            ok = isinstance(value, bool)
            want = "true or false"
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
            want = "an integer"
        elif isinstance(default, float):
            ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
            want = "a finite number"
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
        if value < minimum:
            raise ConfigError(f"{type(config).__name__}.{name} must be >= {minimum}, got {value}")
