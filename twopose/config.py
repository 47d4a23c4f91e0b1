"""The one TOML reader, and the one way TOML tables become typed dataclasses.

The one TOML reader (scenes, plans, calibrations) and the one way TOML tables become typed,
validated dataclasses: unknown keys, wrong types and non-finite numbers are errors that name
the key.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
import types
import typing
from pathlib import Path
from typing import Any, Literal, TypeVar

from twopose.errors import TwoposeError

__all__ = ["build_dataclass", "read_toml"]

T = TypeVar("T")


def read_toml(path: str | Path, what: str, error: type[TwoposeError]) -> dict[str, Any]:
    """A TOML file as a dict; an unreadable or invalid file raises ``error`` naming ``what``."""
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except OSError as err:
        raise error(f"cannot read {what} {path}: {err.strerror}") from err
    except UnicodeDecodeError as err:
        raise error(f"{what} {path} is not UTF-8 text: {err}") from err
    except tomllib.TOMLDecodeError as err:
        raise error(f"{what} {path} is not valid TOML: {err}") from err


def build_dataclass(cls: type[T], data: Any, what: str, error: type[TwoposeError]) -> T:
    """``cls(**data)`` with every key checked against ``cls``'s fields and hints.

    Type hints are checked too, recursively for nested dataclasses; ``error`` messages start with
    ``what``.
    """
    built: T = _build(cls, data, "", what, error)
    return built


def _build(cls: type[Any], data: Any, prefix: str, what: str, error: type[TwoposeError]) -> Any:
    if not isinstance(data, dict):
        raise error(f"{what}: {prefix.rstrip('.') or 'top level'} must be a table")
    hints = typing.get_type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise error(
            f"{what}: unknown key(s) {', '.join(prefix + k for k in unknown)}; "
            f"known here: {', '.join(sorted(names))}"
        )
    kwargs = {k: _convert(hints[k], v, prefix + k, what, error) for k, v in data.items()}
    try:
        return cls(**kwargs)
    except TypeError as err:  # pragma: no cover - guarded by the checks above
        raise error(f"{what}: {prefix or 'top level'}: {err}") from err


def _convert(hint: Any, value: Any, key: str, what: str, error: type[TwoposeError]) -> Any:  # noqa: C901 - one branch per supported type hint
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if dataclasses.is_dataclass(hint):
        return _build(hint, value, key + ".", what, error)  # type: ignore[arg-type]
    if origin is Literal:
        if value not in args:
            raise error(f"{what}: {key} must be one of {list(args)}, got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise error(f"{what}: {key} must be a list, got {value!r}")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(
                _convert(args[0], v, f"{key}[{i}]", what, error) for i, v in enumerate(value)
            )
        if len(value) != len(args):
            raise error(f"{what}: {key} must have {len(args)} items, got {len(value)}")
        return tuple(
            _convert(a, v, f"{key}[{i}]", what, error)
            for i, (a, v) in enumerate(zip(args, value, strict=True))
        )
    if isinstance(hint, types.UnionType):  # pragma: no cover - no unions in Scene today
        raise error(f"{what}: {key} has an unsupported type")
    if hint is float:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise error(f"{what}: {key} must be a finite number, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise error(f"{what}: {key} must be a whole number, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise error(f"{what}: {key} must be a string, got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise error(f"{what}: {key} must be true or false, got {value!r}")
        return value
    raise error(f"{what}: {key} has an unsupported type {hint}")  # pragma: no cover
