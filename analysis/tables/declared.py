"""The other tables' columns, each declared once as ``trials.csv``'s are.

``frames.csv``, ``views.csv``, ``averaging.csv`` and ``summary.csv``: one
:class:`~analysis.tables.trials.Column` per column (name, label, unit kind, domain and
dtype), in the order the files write them. Every layer reads them from here: the
columns' lists and dtypes (:mod:`analysis.tables.columns`), the check of a table read back
(:func:`analysis.tables.read_back.check_results_table`, for ``check`` and ``compare``), and
``docs/analysis.md``'s reference of each table (``docs/trial_columns_table.py``).
:data:`TABLES` holds every declared table by file name, ``trials.csv`` with them.

A table's rows are filled by its stage (:mod:`analysis.tables.rows`, :mod:`analysis.results`),
not by the declaration: no ``fill`` here.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from analysis.tables.trials import (
    COUNT,
    FINITE,
    FLAG,
    NON_NEGATIVE,
    SHARE,
    TEXT,
    TRIAL_TABLE,
    UNIT_KINDS,
    Column,
    Domain,
)
from twopose.methods.specs import METHODS
from twopose.values.units import UNITS

__all__ = [
    "AVERAGING_TABLE",
    "FRAME_TABLE",
    "SUMMARY_TABLE",
    "TABLES",
    "VIEW_TABLE",
    "column_reference",
]

_UNITS = Domain("one of", tuple(UNITS))


def _text(name: str, label: str, group: str, domain: Domain = TEXT) -> Column:
    return Column(name=name, label=label, unit="none", domain=domain, dtype="str", group=group)


def _count(name: str, label: str, group: str) -> Column:
    return Column(name=name, label=label, unit="count", domain=COUNT, dtype="int64", group=group)


def _number(name: str, label: str, group: str, unit: str, domain: Domain) -> Column:
    return Column(name=name, label=label, unit=unit, domain=domain, group=group)


def _length(name: str, label: str) -> Column:
    """A length of ``summary.csv`` (>= 0, in the session's units)."""
    return _number(name, label, "summary", "length", NON_NEGATIVE)


def _trial_key(group: str) -> tuple[Column, ...]:
    """What a row of a per-trial table belongs to: its session, trial and branch (as in
    ``trials.csv``)."""
    return (
        _text("session", "session", group),
        _count("trial", "trial", group),
        _text("branch", "branch", group),
    )


def _xyz(stem: str, label: str, group: str, unit: str = "length", **kw: Any) -> list[Column]:
    """Three columns ``stem`` with ``{}`` an axis (``t_{}``: t_x, t_y, t_z)."""
    domain = kw.pop("domain", FINITE)
    return [
        _number(stem.format(a), label.format(a), group, unit, domain) for a in kw.pop("axes", "xyz")
    ]


def _cameras(group: str) -> Column:
    """How many cameras the row's session has: 1, or 2 (a two-camera session's stream)."""
    return Column(name="cameras", label="cameras", unit="count",
                  domain=Domain("one of", ("1", "2")), dtype="int64", group=group)  # fmt: skip


_F = "frames"
#: ``frames.csv``: every frame's detection (no length in the session's unit, so no units).
#: A two-camera session's (``cameras`` 2): each camera's frames of each stream trial
#: (``trial`` the stream trial's number, as ``trials.csv``'s ``touch`` names it; ``pose``
#: 0, no typed pose; ``frame`` the frame's number in its camera's stream, from 0).
FRAME_TABLE: tuple[Column, ...] = (
    *_trial_key(_F),
    _count("pose", "pose", _F),
    _text("camera", "camera", _F),
    _count("frame", "frame", _F),
    _count("log_time_ns", "log time (ns)", _F),
    Column(name="found", label="target found", unit="none", domain=FLAG, dtype="bool", group=_F),
    _number("col", "centroid column", _F, "pixels", FINITE),
    _number("row", "centroid row", _F, "pixels", FINITE),
    _number("theta_deg", "image line's orientation", _F, "degrees", FINITE),
    _number("area_px", "blob's area", _F, "pixels", NON_NEGATIVE),
    _number("eccentricity", "blob's eccentricity", _F, "none", SHARE),
    _number("pi_estimate", "blob's pi estimate", _F, "none", NON_NEGATIVE),
    _count("n_blobs", "blobs", _F),
    _count("n_candidates", "candidates", _F),
    _text("reason", "why rejected", _F),
    _cameras(_F),
    _count("capture_ns", "capture time (ns, its camera's clock; 0: not recorded)", _F),
)

_V = "views"
#: ``views.csv``: one row per used pose, what the solver used (the report's top views). A
#: two-camera session's (``cameras`` 2): per frame pair of each stream trial (``trial`` the
#: stream trial's number, ``pair`` the pair's from 1), one row per camera (``pose`` 1 or 2,
#: camera 1 at the origin), the pair flagged or used: its ``status``, ``reason`` and
#: ``conditioning``, its time and skew, the camera's detection noise its region carries and
#: where it came from, and its frames' own scatter about a smooth fit in time.
VIEW_TABLE: tuple[Column, ...] = (
    *_trial_key(_V),
    _count("pose", "pose", _V),
    _text("units", "units", _V, _UNITS),
    *_xyz("t_{}", "typed camera centre {}", _V),
    _number("col", "measured column", _V, "pixels", FINITE),
    _number("row", "measured row", _V, "pixels", FINITE),
    _number("theta_deg", "image line's orientation", _V, "degrees", FINITE),
    *_xyz("ray_{}", "unit ray {} (grid frame)", _V, "none"),
    *_xyz("f{}", "focal length {}", _V, "pixels", axes="xy", domain=NON_NEGATIVE),
    *_xyz("c{}", "principal point {}", _V, "pixels", axes="xy"),
    *_xyz("r_{}_deg", "typed rotation about {}", _V, "degrees"),
    _cameras(_V),
    _count("pair", "frame pair (from 1; 0: one camera)", _V),
    _count("pair_time_ns", "pair's time (ns, camera 1's clock; 0: one camera)", _V),
    _number("skew_ms", "pair's skew (camera 2 minus camera 1, on the fitted clocks)", _V,
            "milliseconds", FINITE),
    _text("status", "pair's status", _V),
    _text("reason", "why the pair has no estimate", _V),
    _number("conditioning", "pair's conditioning", _V, "none", NON_NEGATIVE),
    _number("noise_px", "camera's centroid noise (1-sigma; across the line for a finger)", _V,
            "pixels", NON_NEGATIVE),
    _number("noise_deg", "camera's line direction noise (1-sigma)", _V, "degrees",
            NON_NEGATIVE),
    _number("scatter_px", "camera's frames' centroid scatter about a smooth fit (1-sigma)",
            _V, "pixels", NON_NEGATIVE),
    _number("scatter_deg", "camera's frames' line direction scatter (1-sigma)", _V,
            "degrees", NON_NEGATIVE),
    _number("scatter_dof", "that scatter's degrees of freedom (0: not estimated)", _V, "none",
            NON_NEGATIVE),
    _text("noise_source", "where the camera's noise came from, and its frames' scatter", _V),
)  # fmt: skip

_A = "averaging"
#: ``averaging.csv``: each trial's estimate from its first 1..K frames per pose. A
#: two-camera session's (``cameras`` 2): per touch (``trial`` as in ``trials.csv``), the
#: mean of the ``n_frames`` ok pair estimates nearest its time.
AVERAGING_TABLE: tuple[Column, ...] = (
    *_trial_key(_A),
    _count("n_frames", "frames per pose", _A),
    _text("units", "units", _A, _UNITS),
    *_xyz("{}", "estimate {}", _A),
    _number("err", "error", _A, "length", NON_NEGATIVE),
    _cameras(_A),
)

_S = "summary"
#: ``summary.csv``: one row per session and method.
SUMMARY_TABLE: tuple[Column, ...] = (
    _text("session", "session", _S),
    _text("label", "session's label", _S),
    _text("session_id", "session id", _S),
    _text("branch", "branch its trials end on", _S),
    _text("trials_key", "which trials (hashed)", _S),
    _text("method", "method", _S, Domain("one of", tuple(METHODS))),
    _text("units", "units", _S, _UNITS),
    Column(name="cameras", label="cameras", unit="count", domain=Domain("one of", ("1", "2")),
           dtype="int64", group=_S),
    _count("n_trials", "trials", _S),
    _count("n_ok", "ok trials", _S),
    _count("n_warned", "ok trials with a warning", _S),
    _count("n_used", "trials used", _S),
    *_xyz("bias_{}", "bias {}", _S),
    *_xyz("bias_{}_ci95", "bias {}: 95% half-width", _S, domain=NON_NEGATIVE),
    *_xyz("std_{}", "standard deviation {}", _S, domain=NON_NEGATIVE),
    _length("rmse", "RMSE"),
    _length("rmse_ci95_low", "RMSE: 95% interval, low"),
    _length("rmse_ci95_high", "RMSE: 95% interval, high"),
    _length("median_err", "median error"),
    _length("max_err", "largest error"),
    _number("within_1", "share within 1 unit", _S, "share", SHARE),
    _number("coverage95", "truth inside its 95% ellipsoid", _S, "share", SHARE),
    _length("rmse_all_ok", "RMSE, every ok trial"),
    _length("median_err_all_ok", "median error, every ok trial"),
    _length("max_err_all_ok", "largest error, every ok trial"),
    _length("placing_sigma", "placing sigma assumed"),
    _text("placing_source", "placing sigma's source", _S),
    _number("placing_scale", "placing sigma taken over the one assumed", _S, "none",
            NON_NEGATIVE),
    _number("placing_dof", "placing sigma's degrees of freedom", _S, "none", NON_NEGATIVE),
    _text("prior_sessions", "the operator's other sessions pooled", _S),
    _text("floor_unmeasured", "detector's floor not measured at", _S),
    _text("rig_file", "rig file", _S),
    _text("rig_sha256", "rig file's SHA-256", _S),
    _number("sigma0", "sigma0 under the typed model", _S, "none", NON_NEGATIVE),
    _count("sigma0_dof", "sigma0's degrees of freedom", _S),
    _number("sigma0_p", "sigma0's test: p-value", _S, "share", SHARE),
    _number("sigma0_placing_share", "sigma0's test: the placing's share", _S, "share", SHARE),
    _number("sigma0_all", "sigma0 with the flagged trials", _S, "none", NON_NEGATIVE),
    _count("sigma0_all_dof", "its degrees of freedom", _S),
    Column(name="noise_contradicted", label="the data contradict the noise model",
           unit="none", domain=FLAG, dtype="bool", group=_S),
    _number("noise_widening", "largest covariance widening", _S, "none", NON_NEGATIVE),
    _count("n_flagged", "trials flagged", _S),
    _count("n_off_truth", "trials off their truth beyond their regions", _S),
    _length("rmse_uninterpolated", "RMSE, camera 1's paired frame as it is"),
    _number("skew_share", "share of that RMSE interpolation removed", _S, "share", SHARE),
)  # fmt: skip

#: Every declared table, by file name, in the order ``docs/analysis.md`` lists them.
TABLES: Mapping[str, tuple[Column, ...]] = MappingProxyType(
    {
        "trials.csv": TRIAL_TABLE,
        "summary.csv": SUMMARY_TABLE,
        "averaging.csv": AVERAGING_TABLE,
        "frames.csv": FRAME_TABLE,
        "views.csv": VIEW_TABLE,
    }
)


def column_reference(columns: tuple[Column, ...]) -> str:
    """A table's reference for ``docs/analysis.md``, one row per declaration: its name, in
    words, unit and values (``trials.csv`` has its own, with the methods whose trials have
    each column: :func:`analysis.tables.trials.markdown_table`)."""
    rows = ["| column | in words | unit | values |", "| --- | --- | --- | --- |"]
    rows += [
        f"| `{c.name}` | {c.label} | {UNIT_KINDS[c.unit] or '-'} | {c.domain} ({c.dtype}) |"
        for c in columns
    ]
    return "\n".join(rows) + "\n"
