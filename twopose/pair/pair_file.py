"""``PAIR.toml``: the pair file's one reader and one writer (docs/pair-file.md).

What ``twopose-record calibrate-pair`` writes and ``new --pair`` reads: the pair's relative
pose with its covariance, both cameras' intrinsics (and their 1-sigma), the fit's RMS and
views, the floor plane when a board on the floor was given, and the leave-one-out check.
Versioned (:data:`PAIR_FILE_VERSION`: a newer file is refused, naming the version). Read
through the one TOML reader (:func:`twopose.values.toml.read_toml`) and its tables' one checker
(:func:`twopose.values.toml.build_dataclass`): every number by the one grammar, unknown tables
and keys refused, lengths in the file's ``units``, each refusal naming the file, the table
and the key. The writer never overwrites a file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twopose.camera.model import SIGMA_KEYS, Intrinsics
from twopose.errors import InputValueError, SessionExistsError, TwoposeError
from twopose.pair.calibration import MAX_RMS_PX, MIN_BASELINE_IN, FloorPlane, PairCalibration
from twopose.pair.holdout import HoldoutCheck
from twopose.values.units import UNITS, unit_spec

__all__ = ["PAIR_FILE_VERSION", "PAIR_TABLES", "read_pair_file", "write_pair_file"]

#: The pair file's version: what this twopose writes, and the newest it reads.
PAIR_FILE_VERSION = 1
#: The tables a pair file holds, and what each is (docs/pair-file.md).
PAIR_TABLES = {
    "pair": "the relative pose, its covariance, the fit's RMS and views, the units",
    "camera1": "camera 1's intrinsics (and [camera1.sigma], their 1-sigma)",
    "camera2": "camera 2's intrinsics (and [camera2.sigma], their 1-sigma)",
    "floor": "the floor plane in camera 1's frame, with its covariance (optional)",
    "check": "the leave-one-out check of the covariance (optional)",
}
#: The tables every pair file holds (the others are optional, as PAIR_TABLES says).
_REQUIRED_TABLES = tuple(t for t, what in PAIR_TABLES.items() if "(optional)" not in what)
#: The longest baseline a pair file may state, in inches (5 m): beyond it the numbers are
#: not a pair of cameras on one mount (a wrong ``units``, a typo).
MAX_BASELINE_IN = 5000 / 25.4
#: The highest floor a pair file may state, in inches (10 m).
MAX_FLOOR_IN = 10000 / 25.4

Row3 = tuple[float, float, float]
Row4 = tuple[float, float, float, float]
Row6 = tuple[float, float, float, float, float, float]


@dataclass(frozen=True)
class _PairTable:
    """``[pair]`` as the file writes it."""

    version: int
    units: str
    R_2_to_1: tuple[Row3, Row3, Row3]
    t_2_in_1: Row3
    cov_extrinsic: tuple[Row6, Row6, Row6, Row6, Row6, Row6]
    rms_px: float
    views: int
    cov_factor: float = 1.0
    view_names: tuple[str, ...] = ()
    view_rms_px: tuple[float, ...] = ()
    dropped: tuple[str, ...] = ()
    intrinsics_from: str = ""


@dataclass(frozen=True)
class _SigmaTable:
    """``[cameraN.sigma]``: NaN is "not given" (a file cannot write NaN: it is refused)."""

    fx: float = math.nan
    fy: float = math.nan
    cx: float = math.nan
    cy: float = math.nan
    k1: float = math.nan
    k2: float = math.nan
    p1: float = math.nan
    p2: float = math.nan
    k3: float = math.nan


@dataclass(frozen=True)
class _FloorTable:
    """``[floor]``."""

    normal: Row3
    height: float
    cov: tuple[Row4, Row4, Row4, Row4]


@dataclass(frozen=True)
class _CheckTable:
    """``[check]``."""

    folds: int
    spacings: int
    worst_sigmas: float
    beyond_3_sigma: int
    median_error: float
    median_sigma: float
    jackknife_ratio: Row6
    passed: bool


def read_pair_file(path: str | Path) -> PairCalibration:
    """A pair file, checked (the module docstring), as a :class:`PairCalibration`.

    Raises :class:`~twopose.errors.InputValueError` naming the file, the table and the key
    for anything it cannot take: unreadable, not TOML, a newer version, an unknown table or
    key, a missing one, a number outside the grammar, wrong units, a matrix that is not a
    rotation or a covariance, an implausible baseline or floor.
    """
    from twopose.values.toml import build_dataclass, read_toml

    what = f"pair file {path}"
    data = read_toml(path, "pair file", InputValueError)
    unknown = sorted(set(data) - set(PAIR_TABLES))
    if not set(_REQUIRED_TABLES) & set(data) and {"fx", "fy", "cx", "cy"} <= set(data):
        raise InputValueError(
            f"{what} is one camera's calibration (twopose-record calibrate: fx, fy, cx, cy), "
            "not a pair file: make the pair's with twopose-record calibrate-pair (it takes "
            "each camera's calibration file by --calibration-left and --calibration-right)"
        )
    if unknown:
        # keys of no table: their names, not "[fx]" (they are keys, not tables)
        loose = [k for k in unknown if not isinstance(data[k], dict)]
        if loose:
            raise InputValueError(
                f"{what}: unknown key(s) {', '.join(loose)} outside any table; a pair file "
                f"holds {', '.join(f'[{t}]' for t in PAIR_TABLES)}"
            )
        raise InputValueError(
            f"{what}: unknown table(s) {', '.join(f'[{t}]' for t in unknown)}; a pair file "
            f"holds {', '.join(f'[{t}]' for t in PAIR_TABLES)}"
        )
    for table in _REQUIRED_TABLES:
        if not isinstance(data.get(table), dict):
            raise InputValueError(
                f"{what}: no [{table}] table ({PAIR_TABLES[table]}); write the file with "
                "twopose-record calibrate-pair"
            )
    _check_version(data["pair"].get("version"), what)
    pair = build_dataclass(_PairTable, data["pair"], f"{what}: [pair]", InputValueError)
    tables: dict[str, Any] = {
        name: build_dataclass(kind, data[name], f"{what}: [{name}]", InputValueError)
        for name, kind in (("floor", _FloorTable), ("check", _CheckTable))
        if name in data
    }
    try:
        for name in ("camera1", "camera2"):  # intrinsics as a calibration file's, and sigma
            camera = dict(data[name])
            sigma = camera.pop("sigma", {})
            where = f"{what}: [{name}]"
            tables[name] = _intrinsics(camera, where)
            tables[f"{name}.sigma"] = build_dataclass(
                _SigmaTable, sigma, f"{where}.sigma", InputValueError
            )
        return _calibration(pair, tables)
    except InputValueError as err:  # the intrinsics' and the calibration's own checks
        if str(err).startswith(what):
            raise
        raise InputValueError(f"{what}: {err}") from None


def _intrinsics(table: dict[str, Any], where: str) -> Intrinsics:
    """A camera's table as its intrinsics: its keys and types, then their values, checked."""
    from twopose.values.toml import build_dataclass

    try:
        return build_dataclass(Intrinsics, table, where, InputValueError)
    except InputValueError as err:
        if str(err).startswith(where):
            raise
        raise InputValueError(f"{where}: {err}") from None  # the intrinsics' own check


def _check_version(version: Any, what: str) -> None:
    """A version this twopose reads, or refused naming it."""
    if isinstance(version, bool) or not isinstance(version, int):
        raise InputValueError(
            f"{what}: [pair] version must be a whole number (this twopose writes "
            f"{PAIR_FILE_VERSION}), got {version!r}"
        )
    if not 1 <= version <= PAIR_FILE_VERSION:
        raise InputValueError(
            f"{what}: pair file version {version}; this twopose reads versions 1 to "
            f"{PAIR_FILE_VERSION}: update twopose, or calibrate the pair again"
        )


def _calibration(pair: _PairTable, tables: dict[str, Any]) -> PairCalibration:
    """The tables as a calibration, its units and plausibility checked."""
    intrinsics: list[Intrinsics] = [tables["camera1"], tables["camera2"]]
    floor: _FloorTable | None = tables.get("floor")
    check: _CheckTable | None = tables.get("check")
    if pair.units not in UNITS:
        raise InputValueError(
            f"[pair] units must be one of {', '.join(UNITS)} (the unit of t_2_in_1, the "
            f"floor's height and the board's square), got {pair.units!r}"
        )
    inches = unit_spec(pair.units).inches
    baseline = float(np.linalg.norm(pair.t_2_in_1))
    if baseline * inches > MAX_BASELINE_IN:
        raise InputValueError(
            f"[pair] t_2_in_1 puts the cameras {baseline:g} {pair.units} apart, beyond "
            f"{MAX_BASELINE_IN / inches:g} {pair.units}: are the units right?"
        )
    if baseline * inches < MIN_BASELINE_IN:
        raise InputValueError(
            f"[pair] t_2_in_1 puts the cameras {baseline:g} {pair.units} apart: they share a "
            "centre, and two rays from one centre meet nowhere (calibrate-pair never writes "
            "this)"
        )
    if pair.views < 0:
        raise InputValueError(f"[pair] views must be a count >= 0, got {pair.views}")
    if pair.views and pair.rms_px > MAX_RMS_PX:
        raise InputValueError(
            f"[pair] rms_px {pair.rms_px:g} is above the {MAX_RMS_PX:g} px a board's corners "
            "allow: calibrate-pair never writes such a fit (stills of different moments, a "
            "wrong board or intrinsics); calibrate the pair again"
        )
    sigmas = []
    for name in ("camera1", "camera2"):
        given = {k: getattr(tables[f"{name}.sigma"], k) for k in SIGMA_KEYS}
        sigmas.append({k: v for k, v in given.items() if not math.isnan(v)})
    plane = None
    if floor is not None:
        if floor.height * inches > MAX_FLOOR_IN:
            raise InputValueError(
                f"[floor] height {floor.height:g} {pair.units} is beyond "
                f"{MAX_FLOOR_IN / inches:g} {pair.units}: are the units right?"
            )
        plane = FloorPlane(
            normal=np.array(floor.normal), height=floor.height, cov=np.array(floor.cov)
        )
    return PairCalibration(
        intrinsics1=intrinsics[0],
        intrinsics2=intrinsics[1],
        R_2_to_1=np.array(pair.R_2_to_1, dtype=np.float64),
        t_2_in_1=np.array(pair.t_2_in_1, dtype=np.float64),
        cov_extrinsic=np.array(pair.cov_extrinsic, dtype=np.float64),
        rms_px=pair.rms_px,
        n_views=pair.views,
        units=unit_spec(pair.units).units,
        floor=plane,
        sigma1=sigmas[0],
        sigma2=sigmas[1],
        intrinsics_from=pair.intrinsics_from,
        view_names=pair.view_names,
        view_rms_px=pair.view_rms_px,
        dropped=pair.dropped,
        check=None if check is None else _holdout(check),
        cov_factor=pair.cov_factor,
    )


def _holdout(check: _CheckTable) -> HoldoutCheck:
    """``[check]`` as a :class:`HoldoutCheck`; ``passed`` must be what its numbers say."""
    read = HoldoutCheck(
        folds=check.folds,
        spacings=check.spacings,
        worst_sigmas=check.worst_sigmas,
        beyond=check.beyond_3_sigma,
        median_error=check.median_error,
        median_sigma=check.median_sigma,
        jackknife_ratio=check.jackknife_ratio,
    )
    if read.passed != check.passed:
        raise InputValueError(
            f"[check] passed = {str(check.passed).lower()} but its worst_sigmas is "
            f"{check.worst_sigmas:g} over {check.spacings} spacings"
        )
    return read


def write_pair_file(path: str | Path, pair: PairCalibration) -> None:
    """Write ``pair`` as a pair file (what :func:`read_pair_file` reads back exactly).

    Refuses to overwrite: an existing ``path`` raises :class:`SessionExistsError`.
    """
    text = "\n".join(_lines(pair)) + "\n"
    try:
        with open(path, "x", encoding="utf-8") as fh:
            fh.write(text)
    except FileExistsError as err:
        raise SessionExistsError(f"{path} already exists; choose another pair file") from err
    except OSError as err:
        raise TwoposeError(f"cannot create {path}: {err.strerror}") from err


def _lines(pc: PairCalibration) -> list[str]:
    """The file's lines: ``[pair]``, the cameras, then the floor and the check if any."""
    angles, s_angles = pc.angles_deg, pc.sigma_angles_deg
    lines = [
        "# twopose pair calibration: camera 2's pose in camera 1's frame (docs/pair-file.md)",
        f"# angles (rx, ry, rz; R = Rx Ry Rz) {_vector(angles, '.4f')} deg "
        f"± {_vector(s_angles, '.4f')}; baseline {pc.baseline:.6g} {pc.units}",
        "",
        "[pair]",
        f"version = {PAIR_FILE_VERSION}",
        f'units = "{pc.units}"',
        "# p1 = R_2_to_1 p2 + t_2_in_1 (camera 1's frame: x right, y down, z forward)",
        f"R_2_to_1 = {_matrix(pc.R_2_to_1)}",
        f"t_2_in_1 = {_numbers(pc.t_2_in_1)}",
        "# covariance of (rotation vector in camera 1's frame, rad; t_2_in_1)",
        f"cov_extrinsic = {_matrix(pc.cov_extrinsic)}",
        f"cov_factor = {pc.cov_factor!r}  # the variance factor the leave-one-out asked",
        f"rms_px = {pc.rms_px!r}",
        f"views = {pc.n_views}",
        f"view_names = [{', '.join(_quoted(n) for n in pc.view_names)}]",
        f"view_rms_px = {_numbers(pc.view_rms_px)}",
        f"dropped = [{', '.join(_quoted(n) for n in pc.dropped)}]",
        f"intrinsics_from = {_quoted(pc.intrinsics_from)}",
    ]
    for n, (intrinsics, sigma) in enumerate(
        ((pc.intrinsics1, pc.sigma1), (pc.intrinsics2, pc.sigma2)), start=1
    ):
        d = intrinsics.to_dict()
        lines += ["", f"[camera{n}]"]
        lines += [f"{k} = {d[k]!r}" for k in ("width", "height", "fx", "fy", "cx", "cy")]
        lines.append(f"distortion = {_numbers(intrinsics.distortion)}")
        if sigma:
            lines += ["", f"[camera{n}.sigma]  # 1-sigma of each intrinsic"]
            lines += [f"{k} = {v!r}" for k, v in sigma.items()]
    if pc.floor is not None:
        f = pc.floor
        lines += [
            "",
            "[floor]  # normal . p = height in camera 1's frame; the normal toward the floor",
            f"normal = {_numbers(f.normal)}",
            f"height = {f.height!r}",
            "# covariance of (normal, height)",
            f"cov = {_matrix(f.cov)}",
        ]
    if pc.check is not None:
        c = pc.check
        lines += [
            "",
            "[check]  # leave-one-out: held-out corner spacings against their sigmas",
            f"folds = {c.folds}",
            f"spacings = {c.spacings}",
            f"worst_sigmas = {c.worst_sigmas!r}",
            f"beyond_3_sigma = {c.beyond}",
            f"median_error = {c.median_error!r}",
            f"median_sigma = {c.median_sigma!r}",
            f"jackknife_ratio = {_numbers(c.jackknife_ratio)}",
            f"passed = {str(c.passed).lower()}",
        ]
    return lines


def _numbers(values: Any) -> str:
    return (
        "[" + ", ".join(repr(float(v)) for v in np.asarray(values, dtype=np.float64).ravel()) + "]"
    )


def _matrix(values: Any) -> str:
    return "[" + ", ".join(_numbers(row) for row in np.asarray(values, dtype=np.float64)) + "]"


def _vector(values: Any, spec: str) -> str:
    """Numbers for a comment, rounded as shown (never ``-0.0000``)."""
    digits = int(spec.strip(".f"))
    return "(" + ", ".join(format(round(float(v), digits) + 0.0, spec) for v in values) + ")"


def _quoted(text: str) -> str:
    """A TOML basic string: quotes and backslashes escaped, control characters as escapes."""
    out = text.replace("\\", "\\\\").replace('"', '\\"')
    return (
        '"'
        + "".join(f"\\u{ord(c):04x}" if ord(c) < 0x20 or ord(c) == 0x7F else c for c in out)
        + '"'
    )
