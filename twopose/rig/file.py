"""The rig file (``rig.toml``): its one reader and the tables ``twopose-analyze rig`` writes.

A rig file holds (docs/rig-file.md): ``format`` (2; a file without is format 1, read as
before with notes), ``[rig]`` (the constants, :class:`twopose.rig.RigConstants`),
``[sigma]`` (each scalar's 1-sigma, for the reader's eye), ``[covariance]`` (the fitted
scalars' whole covariance, which every ``--rig`` region carries), ``[fixed]`` (why a
constant was not fitted), ``[[camera]]`` (each camera the rig was fitted for: any other is
refused) and ``[placing]`` (the operator's placing sigma a board measured, or bounded).
Anything else is refused, a misspelt table (``[placng]``) as much as an unknown key: a
table that would be silently ignored would leave the analyst believing it is used.

Numbers are read by the project's one TOML reader (:func:`twopose.values.toml.read_toml`). No
computation beyond checks; nothing here writes a file.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twopose.camera.model import Intrinsics
from twopose.errors import InputValueError
from twopose.format.entries import UNITS
from twopose.rig.constants import (
    RIG_PARAMETERS,
    SCALARS,
    RigConstants,
    RigCovariance,
    check_plausible,
)
from twopose.uncertainty.noise import PlacingSigma
from twopose.values.checks import Unread
from twopose.values.units import Units, unit_spec

__all__ = [
    "PLACING_KEYS",
    "PLACING_LIMIT_IN",
    "RIG_FILE_FORMAT",
    "RIG_FILE_TABLES",
    "RigFile",
    "camera_tables",
    "covariance_table",
    "load_rig",
    "load_rig_file",
    "placing_table",
]

#: The rig file's format: 2 records the constants' covariance and the cameras; a file
#: without ``format`` is 1 (written before), still read, with notes where it says less.
RIG_FILE_FORMAT = 2
#: What a rig file may hold at its top level, and what each is (docs/rig-file.md).
RIG_FILE_TABLES = {
    "format": "the file's format (2; absent: 1)",
    "rig": "the constants",
    "sigma": "each scalar's 1-sigma",
    "covariance": "the fitted scalars' covariance",
    "fixed": "why a constant was not fitted",
    "camera": "each camera the rig was fitted for",
    "placing": "the operator's placing sigma",
}
#: The most placing sigma a rig file may record (inches): a laptop placed on grid paper by
#: hand is off by a fraction of an inch; beyond 2 in the file is wrong (a typo, a unit).
PLACING_LIMIT_IN = 2.0
#: The ``[placing]`` table's keys and what each holds (docs/rig-file.md).
PLACING_KEYS = {
    "sigma": "the placing error's 1-sigma per translation component (x, y, z)",
    "sigma_sigma": "the estimate's own 1-sigma",
    "upper_bound": "true: sigma is only the most the placing error can be",
    "units": "of sigma and sigma_sigma",
    "measured_by": "the board session(s) that measured it",
    "captures": "how many captures it was measured over",
    "operators": "whose placing it is: the board sessions' operators",
}


@dataclass(frozen=True, kw_only=True)
class RigFile:
    """A rig file's content: its constants and the operator's placing sigma.

    ``constants``: the ``[rig]`` table, with the cameras it was fitted for and its
    covariance; ``placing``: the ``[placing]`` table a board session measured (None: the
    file records none); ``format``: the file's format.
    """

    constants: RigConstants
    placing: PlacingSigma | None = None
    format: int = RIG_FILE_FORMAT


@dataclass(frozen=True, kw_only=True)
class _Camera:
    """One ``[[camera]]`` table (read by the one TOML reader's dataclass builder)."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float


@dataclass(frozen=True, kw_only=True)
class _Covariance:
    """The ``[covariance]`` table."""

    names: tuple[str, ...]
    matrix: tuple[tuple[float, ...], ...]


def placing_table(placing: PlacingSigma, units: Units) -> list[str]:
    """The ``[placing]`` table's lines (what :func:`load_rig_file` reads), in ``units``."""
    inches = unit_spec(units).inches
    spread = placing.sigma_sigma_in / inches
    measured_by = placing.measured_by.replace("\\", "/").replace('"', "'")
    head = (
        "[placing]  # the operator's placing error: an upper bound (the board's captures "
        "show none their corners resolve)"
        if placing.upper_bound
        else "[placing]  # the operator's placing error, measured: every region uses it"
    )
    return [
        head,
        f"sigma = {placing.sigma_in / inches:.6g}",
        *([f"sigma_sigma = {spread:.6g}"] if np.isfinite(spread) else []),
        *(["upper_bound = true"] if placing.upper_bound else []),
        f'units = "{units}"',
        f'measured_by = "{measured_by}"',
        f"captures = {placing.captures}",
        *([f"operators = {_name_list(placing.operators)}"] if placing.operators else []),
    ]


def _name_list(names: tuple[str, ...]) -> str:
    """A TOML array of names (quotes and backslashes escaped)."""
    quoted = (n.replace("\\", "\\\\").replace('"', '\\"') for n in names)
    return "[" + ", ".join(f'"{n}"' for n in quoted) + "]"


def covariance_table(covariance: RigCovariance) -> list[str]:
    """The ``[covariance]`` table's lines: the fitted scalars and their covariance."""
    names = ", ".join(f'"{n}"' for n in covariance.names)
    rows = [
        "  [" + ", ".join(f"{v:.9g}" for v in row) + "],"  # 9 digits: positive definite
        for row in covariance.array()
    ]
    return [
        "[covariance]  # of the fitted scalars, in their units: every --rig region carries it",
        f"names = [{names}]",
        "matrix = [",
        *rows,
        "]",
    ]


def camera_tables(cameras: tuple[Intrinsics, ...]) -> list[str]:
    """One ``[[camera]]`` table per camera the rig was fitted for."""
    lines: list[str] = []
    for k in cameras:
        lines += [
            "[[camera]]  # fitted for this camera: refused for another",
            f"width = {k.width}",
            f"height = {k.height}",
            *(f"{name} = {getattr(k, name)!r}" for name in ("fx", "fy", "cx", "cy")),
            "",
        ]
    return lines[:-1]


def load_rig_file(path: str | Path) -> RigFile:
    """A rig file written by ``twopose-analyze rig``, checked: the one reader.

    Its ``[rig]`` table, checked by :func:`twopose.rig.check_plausible` (the session's
    ground height, image and camera are judged when it is applied,
    :func:`twopose.rig.check_applicable`), its covariance and cameras, and its
    ``[placing]`` table when there is one: a positive finite length up to
    :data:`PLACING_LIMIT_IN`, refused in words otherwise. An unknown table or key, or a
    format this twopose does not know, is refused.
    """
    from twopose.values.toml import read_toml

    what = f"rig file {path}"
    data = _table(read_toml(path, "rig file", InputValueError), RIG_FILE_TABLES, what, top=True)
    version = _format(data.get("format", 1), what)
    table = data.get("rig")
    if not isinstance(table, dict):
        raise InputValueError(f"{what}: no [rig] table; write one with twopose-analyze rig")
    units = table.get("units")
    if units is not None and units not in UNITS:
        raise InputValueError(f"{what}: units must be one of {', '.join(UNITS)}, got {units!r}")
    rig = dataclasses.replace(
        _constants(table, what),
        units=units,
        cameras=_cameras(data.get("camera", []), what),
        covariance=_covariance(data, what),
    )
    _names(data.get("fixed", {}), what, "[fixed]", str)
    check_plausible(rig, what=what)
    return RigFile(
        constants=rig, placing=_placing(data.get("placing"), units, path), format=version
    )


def load_rig(path: str | Path) -> RigConstants:
    """A rig file's constants (:func:`load_rig_file`, which checks the whole file)."""
    return load_rig_file(path).constants


def _table(value: object, known: Iterable[str], where: str, *, top: bool = False) -> dict[str, Any]:
    """A TOML table whose keys are all ``known``, refused in words otherwise.

    What is not read is never silently ignored, as a misspelt key or table would be;
    ``top``: the file's own level, whose keys are mostly tables (named ``[so]``).
    """
    if not isinstance(value, dict):
        raise InputValueError(f"{where} must be a table")
    names = list(known)
    unknown = sorted(set(value) - set(names))
    if unknown:
        shown = [f"[{u}]" for u in unknown] if top else unknown
        noun = "table(s) or key(s)" if top else "key(s)"
        raise InputValueError(
            f"{where}: unknown {noun} {', '.join(shown)}; it holds {', '.join(names)} "
            "(docs/rig-file.md)"
        )
    return value


def _number(value: object, where: str, *, whole: bool = False) -> float:
    """A number the TOML reader gave (``whole``: an integer), refused in words otherwise.

    Every number of a rig file passes here, so the project's one number grammar
    (:mod:`twopose.values.toml`) judges each in one place.
    """
    if isinstance(value, Unread):  # 0x1, 0.0_5, 1_0, nan: the one grammar's words
        value.refuse(where, whole=whole)
    kinds = int if whole else int | float
    if isinstance(value, bool) or not isinstance(value, kinds):
        want = "a whole number" if whole else "a number"
        raise InputValueError(f"{where} must be {want}, got {value!r}")
    # a float keeps the text it was written as (Given): refusals show 1e309, never inf
    return value if isinstance(value, float) else float(value)


def _format(value: object, what: str) -> int:
    number = _number(value, f"{what}: format", whole=True)
    if number < 1:
        raise InputValueError(f"{what}: format must be a whole number (1 or 2), got {value!r}")
    value = int(number)
    if value > RIG_FILE_FORMAT:
        raise InputValueError(
            f"{what} is of format {value}, written by a newer twopose (this one reads "
            f"formats 1 to {RIG_FILE_FORMAT}): update twopose"
        )
    return value


def _constants(table: dict[str, Any], what: str) -> RigConstants:
    """``[rig]``'s constants: only the constants' keys (and ``units``)."""
    from twopose.values.toml import build_dataclass

    _table(table, (*RIG_PARAMETERS, "units"), f"{what}: [rig]")
    numbers = {k: v for k, v in table.items() if k != "units"}
    rig: RigConstants = build_dataclass(RigConstants, numbers, what, InputValueError)
    return rig


def _names(table: object, what: str, where: str, kind: type) -> dict[str, Any]:
    """A table keyed by the constants' scalars (``[sigma]``, ``[fixed]``), checked."""
    table = _table(table, SCALARS, f"{what}: {where}")
    for key, value in table.items():
        if kind is float:
            _number(value, f"{what}: {where} {key}")
        elif not isinstance(value, str):
            raise InputValueError(f"{what}: {where} {key} must be text, got {value!r}")
    return table


def _cameras(tables: object, what: str) -> tuple[Intrinsics, ...]:
    """``[[camera]]``: each camera the rig was fitted for."""
    from twopose.values.toml import build_dataclass

    if not isinstance(tables, list):
        raise InputValueError(f"{what}: camera must be [[camera]] tables (width, height, ...)")
    cameras = []
    for i, table in enumerate(tables):
        where = f"{what}: [[camera]] {i + 1}"
        found = build_dataclass(_Camera, table, where, InputValueError)
        cameras.append(Intrinsics.from_dict(dataclasses.asdict(found), where))
    return tuple(cameras)


def _covariance(data: Mapping[str, Any], what: str) -> RigCovariance | None:
    """``[covariance]``, checked against ``[sigma]``; a file without: its 1-sigmas alone.

    A format-1 file records only ``[sigma]``: the fitted scalars' (a sigma of 0 is a
    constant not fitted) are carried as independent, with a note where the rig is applied.
    """
    from twopose.values.toml import build_dataclass

    sigma = {k: float(v) for k, v in _names(data.get("sigma", {}), what, "[sigma]", float).items()}
    bad = sorted(k for k, v in sigma.items() if not (math.isfinite(v) and v >= 0))
    if bad:
        raise InputValueError(f"{what}: [sigma] {', '.join(bad)} must be finite and >= 0")
    if "covariance" not in data:
        names = tuple(n for n in SCALARS if sigma.get(n, 0.0) > 0)
        if not names:
            return None
        return RigCovariance.of(names, np.diag([sigma[n] ** 2 for n in names]), independent=True)
    found = build_dataclass(
        _Covariance, data["covariance"], f"{what}: [covariance]", InputValueError
    )
    try:
        covariance = RigCovariance(names=found.names, matrix=found.matrix)
    except InputValueError as err:
        raise InputValueError(f"{what}: {err}") from None
    for name, value in covariance.sigma().items():
        stated = sigma.get(name)
        if stated is not None and not math.isclose(stated, value, rel_tol=1e-4, abs_tol=1e-12):
            raise InputValueError(
                f"{what}: [sigma] {name} = {stated:g}, but [covariance] gives it {value:.6g}: "
                "the file was edited by hand; write it again with `twopose-analyze rig`"
            )
    return covariance


def _placing(table: object, rig_units: str | None, path: str | Path) -> PlacingSigma | None:
    """A rig file's ``[placing]`` table, refused in words unless a plausible length."""
    if table is None:
        return None
    what = f"rig file {path}: [placing]"
    table = _table(table, PLACING_KEYS, what)
    units = table.get("units", rig_units)
    if units not in UNITS:
        raise InputValueError(f"{what}: units must be one of {', '.join(UNITS)}, got {units!r}")
    inches = unit_spec(units).inches
    sigma, spread = _placing_numbers(table, units, what)
    measured_by, captures = table.get("measured_by", ""), table.get("captures", 0)
    bound = table.get("upper_bound", False)
    if not isinstance(measured_by, str):
        raise InputValueError(f"{what}: measured_by must be text, got {measured_by!r}")
    if _number(captures, f"{what}: captures", whole=True) < 0:
        raise InputValueError(f"{what}: captures must be a count >= 0, got {captures!r}")
    captures = int(captures)
    operators = table.get("operators", [])
    if not isinstance(operators, list) or not all(isinstance(n, str) for n in operators):
        raise InputValueError(f"{what}: operators must be a list of names, got {operators!r}")
    if not isinstance(bound, bool):
        raise InputValueError(f"{what}: upper_bound must be true or false, got {bound!r}")
    dof = 0.5 * (sigma / spread) ** 2 if spread > 0 else math.inf
    if captures and math.isfinite(dof) and dof > 3 * captures * (1 + 1e-3):
        raise InputValueError(
            f"{what}: sigma_sigma = {spread:g} {units} states the sigma from {dof:.0f} degrees "
            f"of freedom, more than the {3 * captures} components of its {captures} captures; "
            "measure it again with `twopose-analyze rig`"
        )
    try:
        return PlacingSigma(
            sigma_in=float(sigma) * inches,
            sigma_sigma_in=float(spread) * inches,
            measured_by=measured_by or f"rig file {path}",
            captures=captures,
            upper_bound=bound,
            operators=tuple(dict.fromkeys(n.strip() for n in operators if n.strip())),
        )
    except InputValueError as err:
        raise InputValueError(f"{what}: {err}") from None


def _placing_numbers(table: dict[str, object], units: Units, what: str) -> tuple[float, float]:
    """A ``[placing]`` table's sigma and sigma_sigma (NaN: not stated), refused in words."""
    inches = unit_spec(units).inches
    sigma, spread = table.get("sigma"), table.get("sigma_sigma", float("nan"))
    limit = PLACING_LIMIT_IN / inches
    if sigma is None:
        raise InputValueError(f"{what}: sigma is missing (the placing error's 1-sigma, a length)")
    sigma, spread = _number(sigma, f"{what}: sigma"), _number(spread, f"{what}: sigma_sigma")
    if not (np.isfinite(sigma) and 0 < sigma <= limit):
        raise InputValueError(
            f"{what}: sigma = {sigma!r} {units} is not a placing error (a positive length up "
            f"to {limit:g} {units}); measure it again with `twopose-analyze rig` on a board "
            "session, or delete the [placing] table to use the typed resolution"
        )
    if spread < 0 or np.isinf(spread):
        raise InputValueError(f"{what}: sigma_sigma must be a finite length >= 0, got {spread!r}")
    return float(sigma), float(spread)
