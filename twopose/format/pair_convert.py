"""A two-camera session's entries and the pair's core types, each made of the other.

:func:`pair_entry` and :func:`pair_calibration` turn a
:class:`~twopose.pair.calibration.PairCalibration` into the ``/twopose/pair`` entry
(:class:`~twopose.format.stream_entries.PairEntry`) and back (checking it: a rotation,
covariances, a unit floor normal); :func:`clock_offset_entry` and :func:`clock_offset` a
:class:`~twopose.pair.clock.ClockOffset` and its ``/twopose/clock_offset`` entry. Apart from
the entries so that :mod:`twopose.format.entries`, which the core's solvers import, imports
nothing of the pair (no import cycle); the writer, the reader, the replay and ``recover``
use these.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from twopose.camera.model import Intrinsics
from twopose.errors import InputValueError
from twopose.format.stream_entries import ClockOffsetEntry, PairEntry
from twopose.pair.calibration import FloorPlane, PairCalibration
from twopose.pair.clock import ClockOffset
from twopose.pair.holdout import HoldoutCheck
from twopose.values.checks import finite, index, vec3
from twopose.values.units import unit_spec

__all__ = ["clock_offset", "clock_offset_entry", "pair_calibration", "pair_entry"]


def _nullable(x: float) -> float | None:
    return x if math.isfinite(x) else None


def _number(x: float | None) -> float:
    return math.nan if x is None else float(x)


def _rows(values: Any) -> tuple[tuple[float, ...], ...]:
    return tuple(tuple(float(v) for v in row) for row in values)


def pair_calibration(entry: PairEntry) -> PairCalibration:
    """The calibration a ``/twopose/pair`` entry holds, checked.

    Raises :class:`~twopose.errors.InputValueError`, in words, when it is not one.
    """
    floor = check = None
    if entry.floor is not None:
        floor = FloorPlane(normal=np.array(entry.floor["normal"], dtype=np.float64),
                           height=finite(entry.floor["height"], "the floor's height"),
                           cov=np.array(entry.floor["cov"], dtype=np.float64))  # fmt: skip
    if entry.check is not None:
        c = entry.check
        check = HoldoutCheck(
            folds=index(c["folds"], "folds"), spacings=index(c["spacings"], "spacings"),
            worst_sigmas=_number(c["worst_sigmas"]), beyond=index(c["beyond_3_sigma"], "n"),
            median_error=_number(c["median_error"]), median_sigma=_number(c["median_sigma"]),
            jackknife_ratio=tuple(_number(x) for x in c["jackknife_ratio"]),
        )  # fmt: skip
        if check.passed != bool(c["passed"]):
            raise InputValueError("the pair's check: passed disagrees with its worst_sigmas")
    return PairCalibration(
        intrinsics1=Intrinsics.from_dict(entry.intrinsics1, "the pair's camera 1"),
        intrinsics2=Intrinsics.from_dict(entry.intrinsics2, "the pair's camera 2"),
        R_2_to_1=np.array(entry.R_2_to_1, dtype=np.float64),
        t_2_in_1=np.array(vec3(entry.t_2_in_1, "t_2_in_1")),
        cov_extrinsic=np.array(entry.cov_extrinsic, dtype=np.float64),
        rms_px=finite(entry.rms_px, "rms_px"),
        n_views=index(entry.views, "views"),
        units=unit_spec(entry.units).units,
        floor=floor,
        sigma1=entry.sigma1 or {},
        sigma2=entry.sigma2 or {},
        intrinsics_from=entry.intrinsics_from,
        view_names=entry.view_names,
        view_rms_px=tuple(finite(v, "a view's RMS") for v in entry.view_rms_px),
        dropped=entry.dropped,
        check=check,
        cov_factor=finite(entry.cov_factor, "cov_factor"),
    )


def pair_entry(pair: PairCalibration, cameras: tuple[str, str]) -> PairEntry:
    """The entry of ``pair`` for the session's camera 1 and camera 2 (its units kept)."""
    check = None
    if pair.check is not None:
        c = pair.check
        check = {
            "folds": c.folds, "spacings": c.spacings, "beyond_3_sigma": c.beyond,
            "worst_sigmas": _nullable(c.worst_sigmas),
            "median_error": _nullable(c.median_error),
            "median_sigma": _nullable(c.median_sigma),
            "jackknife_ratio": [_nullable(x) for x in c.jackknife_ratio],
            "passed": c.passed,
        }  # fmt: skip
    floor = None
    if pair.floor is not None:
        f = pair.floor
        floor = {"normal": f.normal.tolist(), "height": f.height, "cov": f.cov.tolist()}
    return PairEntry(
        camera1=cameras[0], camera2=cameras[1], units=pair.units,
        R_2_to_1=_rows(pair.R_2_to_1.tolist()), t_2_in_1=vec3(pair.t_2_in_1, "t_2_in_1"),
        cov_extrinsic=_rows(pair.cov_extrinsic.tolist()), cov_factor=pair.cov_factor,
        rms_px=pair.rms_px, views=pair.n_views,
        intrinsics1=pair.intrinsics1.to_dict(), intrinsics2=pair.intrinsics2.to_dict(),
        sigma1=dict(pair.sigma1) or None, sigma2=dict(pair.sigma2) or None, floor=floor,
        intrinsics_from=pair.intrinsics_from, view_names=tuple(pair.view_names),
        view_rms_px=tuple(pair.view_rms_px), dropped=tuple(pair.dropped), check=check,
    )  # fmt: skip


def clock_offset_entry(offset: ClockOffset) -> ClockOffsetEntry:
    """The ``/twopose/clock_offset`` entry of a measured offset."""
    return ClockOffsetEntry(offset_ns=float(offset.offset_ns), sigma_ns=float(offset.sigma_ns),
                            method=offset.method, n=int(offset.n))  # fmt: skip


def clock_offset(entry: ClockOffsetEntry) -> ClockOffset:
    """The offset an entry holds, as the pair's core takes it."""
    return ClockOffset(
        offset_ns=entry.offset_ns, sigma_ns=entry.sigma_ns, method=entry.method, n=entry.n
    )
