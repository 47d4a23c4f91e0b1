"""The one TOML reader, and the one way TOML tables become typed dataclasses.

The one TOML reader (scenes, plans, rig files, calibrations, tolerance files) and the one
way TOML tables become typed, validated dataclasses: unknown keys, wrong types and
non-finite numbers are errors that name the key.

TOML's grammar of numbers is wider than ours (``1_0``, ``0x5``, ``0o5``, ``0b101``,
``inf``, ``nan``), so the file is read keeping each number's source text (tomlkit) and the
one grammar judges that text (:func:`twopose.values.checks.read_number`), in the words every other
path says; each number keeps its text (:class:`twopose.values.checks.Given`), so a refusal or a
value shown back says it as written (``1e309``, never ``inf``).
"""

from __future__ import annotations

import dataclasses
import math
import re
import types
import typing
from pathlib import Path
from typing import Any, Literal, TypeVar

from twopose.errors import InputValueError, TwoposeError
from twopose.values.checks import NUMBER_GRAMMAR, Given, GivenWhole, Unread, given_text

__all__ = ["build_dataclass", "read_toml"]

T = TypeVar("T")


def read_toml(path: str | Path, what: str, error: type[TwoposeError]) -> dict[str, Any]:
    """A TOML file as a dict; an unreadable or invalid file raises ``error`` naming ``what``.

    Every number comes with its text as written (a float as
    :class:`~twopose.values.checks.Given`, an integer as
    :class:`~twopose.values.checks.GivenWhole`); one
    outside the one grammar (``0x5``, ``1_0``, ``inf``) as :class:`~twopose.values.checks.Unread`,
    which its reader refuses in the one wording, with its own grammar (a count's or any
    number's) and naming its key (arrays counted from 1).
    """
    import tomlkit
    from tomlkit.exceptions import TOMLKitError

    try:
        with open(path, "rb") as fh:
            text = fh.read().decode("utf-8")
    except OSError as err:
        raise error(f"cannot read {what} {path}: {err.strerror}") from err
    except UnicodeDecodeError as err:
        raise error(f"{what} {path} is not UTF-8 text: {err}") from err
    try:
        document = tomlkit.parse(text)
    except (TOMLKitError, ValueError) as err:
        raise error(f"{what} {path} is not valid TOML: {_invalid(text, err)}") from err
    plain: dict[str, Any] = _plain(document, "")
    return plain


def _invalid(text: str, err: Exception) -> str:
    r"""Where and why ``text`` is not TOML, in the standard library parser's words.

    tomlkit (kept for its numbers' text) names the end of a file as the character
    ``'\x00'`` at column 0; :mod:`tomllib` says "at end of document" or the true line and
    column, which is quoted too.
    """
    import tomllib

    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError as std:
        said = str(std)
    else:  # pragma: no cover - the parsers agree on every file tried
        said = str(err).replace("'\\x00'", "the end of the file")
    found = re.search(r"line (\d+)", said)
    line = int(found.group(1)) if found else 0
    lines = text.splitlines()
    return said + (f" ({lines[line - 1].strip()[:60]!r})" if 0 < line <= len(lines) else "")


def _plain(item: Any, key: str) -> Any:
    """A parsed TOML value as plain Python, each number with its text."""
    import tomlkit.items as toml

    if isinstance(item, dict):  # a document, a table, an inline table
        return {k: _plain(v, f"{key}.{k}" if key else k) for k, v in item.items()}
    if isinstance(item, list):  # an array, an array of tables
        return [_plain(v, f"{key}[{i}]") for i, v in enumerate(item, start=1)]
    if isinstance(item, toml.Bool):
        return bool(item)
    if isinstance(item, toml.Integer | toml.Float):
        text = item.as_string().strip()
        if NUMBER_GRAMMAR.fullmatch(text) is None:
            return Unread(text, key)  # 0x5, 1_0, inf, nan: judged, and refused, by its reader
        return GivenWhole(int(item), text) if isinstance(item, toml.Integer) else Given(item, text)
    if isinstance(item, toml.String):
        return str(item)
    return item.unwrap() if hasattr(item, "unwrap") else item


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
    if isinstance(value, Unread) and hint in (float, int):
        try:
            value.refuse(key, whole=hint is int)
        except InputValueError as err:
            raise error(f"{what}: {err}") from None
    if hint is float:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            said = given_text(value) or repr(value)  # as written: 1e309, never inf
            raise error(f"{what}: {key} must be a finite number, got {said}")
        text = given_text(value)
        return float(value) if text is None else Given(float(value), text)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            said = given_text(value) or repr(value)
            raise error(f"{what}: {key} must be a whole number, got {said}")
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
