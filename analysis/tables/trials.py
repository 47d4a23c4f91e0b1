"""``trials.csv``'s columns, each declared once: one :class:`Column` per column.

A declaration holds everything every layer asks of a column: its name, its label in words
(the report's tables, :mod:`analysis.tables.labels`), its unit kind, its domain (what a
value can be; :func:`violations` checks a table against it), its dtype
(:func:`analysis.tables.columns.typed`), and the function that fills it from a trial's result
(:class:`TrialResult`; :func:`trial_table` calls it). :data:`TRIAL_TABLE`
holds them in the order ``trials.csv`` writes them; ``docs/analysis.md``'s column reference
is written from it (``docs/trial_columns_table.py``).

Which columns a method's trials have is read from its spec (each column's ``applies``):
the common ones for every method, the ones its
:attr:`~twopose.methods.specs.MethodSpec.extra_columns` and
:attr:`~twopose.methods.specs.MethodSpec.margins` name, and a line estimate's fits; no column
names a method. A column whose ``fill`` is None is filled
by a later stage (what the trial is: :func:`analysis.tables.rows.with_identity`; the rig's
leave-one-out correction: :mod:`analysis.session.pipeline`; a two-camera session's touches:
:mod:`analysis.session.stream_tables`).

(Near 600 lines: ``trials.csv``'s one table of declarations, every column in the one place
it is declared, the one function that fills the table from them (:func:`trial_table`)
and a column's values as its declared dtype (:func:`as_dtype`);
the other tables' are :mod:`analysis.tables.declared`.)
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from analysis.tables import noise as nc
from twopose.methods.specs import MEASURING_METHODS, METHODS, MethodSpec, spec_of
from twopose.methods.truth import line_errors
from twopose.values.units import UNITS

if TYPE_CHECKING:
    import pandas as pd

    from twopose.arrays import F64
    from twopose.detect.frames import PoseMeasurement
    from twopose.methods.truth import Reported
    from twopose.solve.estimate import PoseView
    from twopose.solve.session import Estimates, SessionEstimate

__all__ = [
    "STATUSES",
    "TRIAL_TABLE",
    "UNIT_KINDS",
    "Column",
    "Domain",
    "TrialResult",
    "as_dtype",
    "column_named",
    "columns_of",
    "group",
    "markdown_table",
    "methods_having",
    "trial_table",
    "violations",
]

#: Each unit kind a column can be in, as the docs name it.
UNIT_KINDS: Mapping[str, str] = {
    "length": "session units",
    "squared length": "session units²",
    "degrees": "degrees",
    "pixels": "pixels",
    "count": "count",
    "milliseconds": "ms",
    "share": "share, 0 to 1",
    "none": "",
}
#: What a trial's ``status`` can be (:class:`twopose.solve.session.Estimates`).
STATUSES = ("ok", "degenerate", "no_detection", "incomplete")


@dataclass(frozen=True)
class Domain:
    """What a column's values can be: ``finite`` (any finite number), ``non-negative``
    (finite and >= 0), ``share`` (0 to 1), ``count`` (a whole number >= 0, always known),
    ``flag`` (true or false; empty when not known), ``text`` (any), or ``one of`` its
    ``values``. An empty number is "not measured", in every numeric domain but ``count``."""

    kind: str
    values: tuple[str, ...] = ()

    def __str__(self) -> str:
        return f"one of {', '.join(self.values)}" if self.kind == "one of" else self.kind

    def holds(self, values: pd.Series) -> bool:
        """Whether every one of ``values`` (a column as :func:`~analysis.tables.columns.typed`
        gives it) is in the domain."""
        return not bool(self.outside(values).any())

    def outside(self, values: pd.Series) -> pd.Series:
        """Which of ``values`` are not in the domain (a boolean Series on their index): a
        number's cell that is no number, or one outside its range; a count's empty cell."""
        import pandas as pd

        if self.kind == "text":
            return pd.Series(data=False, index=values.index)
        if self.kind == "one of":
            return ~values.astype(str).isin(self.values)
        if self.kind == "flag":
            return values.notna() & ~values.isin((True, False))
        numbers = pd.to_numeric(values, errors="coerce").astype(float)
        if self.kind == "count":
            return ~((numbers >= 0) & (numbers == numbers.round()))
        low, high = {"non-negative": (0.0, np.inf), "share": (0.0, 1.0)}.get(
            self.kind, (-np.inf, np.inf)
        )
        inside = numbers.between(low, high) & numbers.abs().lt(np.inf)
        return ~inside & (numbers.notna() | values.notna())

    @property
    def words(self) -> str:
        """What a value of the domain is, for a refusal's message."""
        return {
            "finite": "a finite number or empty",
            "non-negative": "a finite number >= 0, or empty",
            "share": "a share between 0 and 1, or empty",
            "count": "a whole number >= 0",
            "flag": "true, false or empty",
        }.get(self.kind, str(self))


FINITE = Domain("finite")
NON_NEGATIVE = Domain("non-negative")
SHARE = Domain("share")
COUNT = Domain("count")
FLAG = Domain("flag")
TEXT = Domain("text")


@dataclass(frozen=True)
class TrialResult:
    """A session's trials as the pipeline computed them: what every column is filled from
    (one value per trial, in the trials' order)."""

    session: str
    estimate: SessionEstimate
    reported: Reported
    notes: Sequence[str] | None = None
    #: Per trial, why its captures do not make two usable poses ("": they do).
    unmeasured: Sequence[str] | None = None

    @property
    def spec(self) -> MethodSpec:
        """The spec of the trials' method."""
        return self.estimate.trials.spec

    @property
    def est(self) -> Estimates:
        """Every estimate of the trials."""
        return self.estimate.estimates

    @property
    def truth(self) -> F64:
        """(T, 2, 3): each trial's true point (a line: its two ends)."""
        return self.estimate.trials.truth

    @cached_property
    def line(self) -> tuple[F64, F64, F64, F64]:
        """Line trials: the thesis' line against the truth
        (:func:`twopose.methods.truth.line_errors`)."""
        est, truth = self.est, self.truth
        with np.errstate(invalid="ignore"):
            return line_errors(est.point, est.direction, truth[:, 0], truth[:, 1])

    def fit(self, name: str) -> tuple[F64, F64, F64, F64]:
        """Line trials: the ``weighted`` or ``optimal`` line against the truth: its point
        nearest the true midpoint (where there is none, the fit's point), the midpoint, the
        angle and distance errors."""
        return self._fits[name]

    @cached_property
    def _fits(self) -> dict[str, tuple[F64, F64, F64, F64]]:
        fits = {}
        lines = {"weighted": self.est.weighted_line, "optimal": self.est.optimal_line}
        for name, line in lines.items():
            with np.errstate(invalid="ignore"):
                point, mid, angle, dist = line_errors(
                    line[:, 0], line[:, 1], self.truth[:, 0], self.truth[:, 1]
                )
            fits[name] = (np.where(np.isfinite(mid), point, line[:, 0]), mid, angle, dist)
        return fits

    @cached_property
    def spread(self) -> dict[str, Any]:
        """The reported point's uncertainty
        (:func:`twopose.uncertainty.propagate.uncertainty_columns`)."""
        from twopose.uncertainty.propagate import uncertainty_columns

        return uncertainty_columns(self.reported.error, self.reported.cov)


#: What fills a column: one value per trial.
Fill = Callable[[TrialResult], Any]


def every(spec: MethodSpec, name: str) -> bool:  # noqa: ARG001 (a predicate's signature)
    """Every method's trials have the column."""
    return True


def named(spec: MethodSpec, name: str) -> bool:
    """The method's spec names the column: one of its extra columns or its margins."""
    return name in spec.extra_columns or name in spec.margins


def lines(spec: MethodSpec, name: str) -> bool:  # noqa: ARG001
    """The method estimates a line."""
    return spec.estimates_line


def named_or_lines(spec: MethodSpec, name: str) -> bool:
    """The spec names the column, or the method estimates a line."""
    return named(spec, name) or lines(spec, name)


@dataclass(frozen=True, kw_only=True)
class Column:
    """One column of ``trials.csv``, declared once."""

    #: Its name in the CSV file.
    name: str
    #: How the report's tables name it (its unit is added to the header).
    label: str
    #: Its unit kind, a key of :data:`UNIT_KINDS` (``length``: the session's unit).
    unit: str
    #: What its values can be.
    domain: Domain
    #: Its dtype: ``str``, ``int64``, ``float64``, ``bool`` or ``boolean`` (nullable).
    dtype: str = "float64"
    #: Which part of the table it belongs to (``analysis.tables.columns`` lists each part).
    group: str
    #: Which methods' trials have it: a predicate on their spec and the column's name
    #: (:func:`every`; :func:`named`: the spec's extra columns or margins name it;
    #: :func:`lines`: the estimate is a line).
    applies: Callable[[MethodSpec, str], bool] = field(default=every, compare=False)
    #: Its values from a trial's result (None: a later stage fills it).
    fill: Fill | None = field(default=None, compare=False)


def _axes(name: str, values: Callable[[TrialResult], F64] | None, **kw: Any) -> list[Column]:
    """The three columns of an (T, 3) array: ``name`` and ``label`` with ``{}`` as the axis
    (``values``: None, a later stage fills them)."""
    label = kw.pop("label")
    return [
        Column(name=name.format(a), label=label.format(a), fill=_axis(values, i), **kw)
        for i, a in enumerate("xyz")
    ]


def _axis(values: Callable[[TrialResult], F64] | None, i: int) -> Fill | None:
    """Column ``i`` of ``values``' array."""
    if values is None:
        return None
    return lambda t: values(t)[:, i]


def _norm(values: Callable[[TrialResult], F64]) -> Fill:
    """Each row's length of ``values``' (T, 3) array."""
    return lambda t: np.linalg.norm(values(t), axis=1)


def _optimal_point(t: TrialResult) -> F64:
    """A point's reprojection-optimal estimate; a line's: the optimal line's point nearest
    the true midpoint."""
    return t.fit("optimal")[0] if t.spec.estimates_line else t.est.optimal


def _optimal_error(t: TrialResult) -> F64:
    """A point's optimal estimate's error; a line's: its reported point's distance from the
    true midpoint."""
    if t.spec.estimates_line:
        point, mid, _, _ = t.fit("optimal")
    else:
        point, mid = t.est.optimal, t.truth[:, 0]
    error: F64 = np.linalg.norm(point - mid, axis=1)
    return error


def _reasons(t: TrialResult) -> list[str]:
    """Each trial's reason; an incomplete trial's says which captures were set aside."""
    reasons = [str(r) for r in t.est.reason]
    if t.unmeasured is None:
        return reasons
    return [
        why if status == "incomplete" and why else reason
        for reason, status, why in zip(reasons, t.est.status, t.unmeasured, strict=True)
    ]


def _baseline(views: list[PoseView]) -> float:
    """The longest distance between two typed camera centres of a trial (NaN: one pose)."""
    return max(
        (float(np.linalg.norm(a.t_grid - b.t_grid)) for a, b in itertools.combinations(views, 2)),
        default=np.nan,
    )


def _rejected(measurements: list[PoseMeasurement], views: list[PoseView]) -> str:
    """Frames dropped as outliers, per pose: ``"pose 2: 3, 4"`` (frame indices as in
    frames.csv; empty when none)."""
    return "; ".join(
        f"pose {v.pose}: {', '.join(str(i) for i in m.rejected)}"
        for m, v in zip(measurements, views, strict=True)
        if m.rejected
    )


def _per_trial(value: Callable[[TrialResult], object]) -> Fill:
    """The same ``value`` for every trial."""
    return lambda t: [value(t)] * len(t.estimate.trials)


def _text(name: str, label: str, group: str, fill: Fill | None = None, **kw: Any) -> Column:
    return Column(
        name=name, label=label, unit="none", domain=kw.pop("domain", TEXT), dtype="str",
        group=group, fill=fill, **kw,
    )  # fmt: skip


def _length(name: str, label: str, group: str, fill: Fill | None, domain: Domain) -> Column:
    return Column(name=name, label=label, unit="length", domain=domain, group=group, fill=fill)


def _angle(name: str, label: str, group: str, fill: Fill | None, **kw: Any) -> Column:
    return Column(
        name=name, label=label, unit="degrees", domain=NON_NEGATIVE, group=group, fill=fill,
        **kw,
    )  # fmt: skip


def _margin(name: str, label: str) -> Column:
    return _angle(name, label, "margins", lambda t: t.est.margins[name], applies=named)


def _spread(name: str, label: str, unit: str, domain: Domain, dtype: str = "float64") -> Column:
    return Column(
        name=name, label=label, unit=unit, domain=domain, dtype=dtype, group="uncertainty",
        fill=lambda t: t.spread[name],
    )  # fmt: skip


def _line_fit(name: str) -> list[Column]:
    """A line fit's columns beside the thesis' line (``weighted`` or ``optimal``)."""
    words = {"weighted": "weighted fit", "optimal": "optimal line"}[name]
    own: dict[str, Any] = {"group": "line fits", "applies": lines}
    point = _axes(
        f"{{}}_{name}", lambda t: t.fit(name)[0], label=f"{words} {{}}", unit="length",
        domain=FINITE, **own,
    ) if name == "weighted" else []  # fmt: skip
    return [
        *point,
        _angle(f"angle_err_{name}_deg", f"{words}: direction error", "line fits",
               lambda t: t.fit(name)[2], applies=lines),
        Column(name=f"dist_err_{name}", label=f"{words}: distance from the true line",
               unit="length", domain=NON_NEGATIVE, fill=lambda t: t.fit(name)[3], **own),
    ]  # fmt: skip


_RIG: dict[str, Any] = {"group": "rig"}
_AXIS = {"unit": "length", "domain": FINITE}
_ESTIMATE = {"group": "trial", **_AXIS}

#: ``trials.csv``'s columns, in its order (a column a trial's method lacks is empty).
TRIAL_TABLE: tuple[Column, ...] = (
    _text("session", "session", "trial", lambda t: [t.session] * len(t.estimate.trials)),
    _text("label", "session's label", "identity"),
    _text("session_id", "session id", "identity"),
    _text("part", "part", "identity"),
    _text("branch", "branch", "identity"),
    Column(name="trial", label="trial", unit="count", domain=COUNT, dtype="int64",
           group="trial", fill=lambda t: list(t.estimate.trials.trial_ids)),
    _text("method", "method", "trial", _per_trial(lambda t: str(t.estimate.trials.method)),
          domain=Domain("one of", tuple(METHODS))),
    _text("units", "units", "trial", _per_trial(lambda t: str(t.estimate.trials.units)),
          domain=Domain("one of", tuple(UNITS))),
    # 1: a trial of typed poses; 2: a touch of a two-camera session (analysis.session.stream_tables)
    Column(name="cameras", label="cameras", unit="count", domain=Domain("one of", ("1", "2")),
           dtype="int64", group="trial", fill=_per_trial(lambda _: 1)),
    _text("status", "status", "trial", lambda t: t.est.status,
          domain=Domain("one of", STATUSES)),
    _text("reason", "why not measured", "trial", _reasons),
    Column(name="n_views", label="views", unit="count", domain=COUNT, dtype="int64",
           group="trial",
           fill=lambda t: [len(v) if len(v) >= 2 else 0 for v in t.estimate.trials.views]),
    Column(name="conditioning", label="conditioning", unit="none", domain=NON_NEGATIVE,
           group="trial", fill=lambda t: t.est.conditioning),
    *_axes("{}", lambda t: t.reported.point, label="estimate {}", **_ESTIMATE),
    *_axes("gt_{}", lambda t: t.reported.reference, label="truth {}", **_ESTIMATE),
    *_axes("err_{}", lambda t: t.reported.error, label="error {}", **_ESTIMATE),
    _length("err", "error", "trial", _norm(lambda t: t.reported.error), NON_NEGATIVE),
    # line trials: the line's direction and its errors
    *_axes("dir_{}", lambda t: t.est.direction, label="direction {}", unit="none", domain=FINITE,
           group="line", applies=named),
    _angle("angle_err_deg", "direction error", "line", lambda t: t.line[2], applies=named),
    Column(name="dist_err", label="distance from the true line", unit="length",
           domain=NON_NEGATIVE, group="line", applies=named, fill=lambda t: t.line[3]),
    # line trials: the weighted/robust fit and the reprojection-optimal line's errors
    *_line_fit("weighted"),
    *_line_fit("optimal"),
    # points: the reprojection-optimal estimate; lines: the optimal line's reported point
    *_axes("{}_optimal", _optimal_point, label="optimal estimate {}", unit="length",
           domain=FINITE, group="optimal", applies=named_or_lines),
    Column(name="err_optimal", label="optimal estimate's error", unit="length",
           domain=NON_NEGATIVE, group="optimal", applies=named_or_lines, fill=_optimal_error),
    # degeneracy margins (each method's: its spec's margins)
    _margin("parallax_deg", "parallax"),
    _margin("plane_angle_deg", "angle between the planes"),
    _margin("line_plane_angle_deg", "line's angle to the method's plane"),
    _text("warning", "warning", "margins", lambda t: t.estimate.warnings),
    _length("baseline", "baseline", "margins",
            lambda t: [_baseline(v) for v in t.estimate.trials.views], NON_NEGATIVE),
    # the reported point's first-order uncertainty (twopose.uncertainty.propagate.SPREAD_COLUMNS)
    *(_spread(f"sigma_{a}", f"1-sigma {a}", "length", NON_NEGATIVE) for a in "xyz"),
    *(_spread(f"cov_{a}", f"covariance {a}", "squared length", FINITE)
      for a in ("xy", "xz", "yz")),
    *(_spread(f"ci95_{a}", f"95% half-width {a}", "length", NON_NEGATIVE) for a in "xyz"),
    _spread("semiaxis95", "95% region, largest semi-axis", "length", NON_NEGATIVE),
    _spread("nees", "normalized error (NEES)", "none", NON_NEGATIVE),
    _spread("nees_dof", "NEES degrees of freedom", "count", COUNT, "int64"),
    _spread("within95", "truth inside its 95% ellipsoid", "none", FLAG, "boolean"),
    _text("dominant_input", "dominant input", "uncertainty", lambda t: t.reported.dominant),
    Column(name="dominant_share", label="dominant input's share", unit="share", domain=SHARE,
           group="uncertainty", fill=lambda t: t.reported.dominant_share),
    _text("rejected_frames", "frames rejected", "uncertainty",
          lambda t: [_rejected(ms, vs) if ms else "" for ms, vs in
                     zip(t.estimate.measurements, t.estimate.trials.views, strict=True)]),
    # the noise model (twopose.uncertainty.noise): the placing sigma assumed, the misclosure's test,
    # whether the trial's poses disagree (analysis.tables.noise fills them)
    _length("placing_sigma", "placing sigma assumed", "noise", nc.placing_sigma, NON_NEGATIVE),
    _text("placing_source", "placing sigma's source", "noise", nc.placing_source),
    Column(name="placing_scale", label="placing sigma taken over the one assumed",
           unit="none", domain=NON_NEGATIVE, group="noise", fill=nc.placing_scale),
    Column(name="placing_dof", label="placing sigma's degrees of freedom", unit="none",
           domain=NON_NEGATIVE, group="noise", fill=nc.placing_dof),
    _text("prior_sessions", "the operator's other sessions pooled", "noise", nc.prior_sessions),
    _text("floor_unmeasured", "detector's floor not measured at", "noise", nc.floor_unmeasured),
    # the rig file the session used (filled by the pipeline, from its options)
    _text("rig_file", "rig file", "noise"),
    _text("rig_sha256", "rig file's SHA-256", "noise"),
    Column(name="misclosure_chi2", label="misclosure chi-square", unit="none",
           domain=NON_NEGATIVE, group="noise", fill=nc.misclosure_chi2),
    Column(name="misclosure_dof", label="misclosure degrees of freedom", unit="count",
           domain=COUNT, dtype="int64", group="noise", fill=nc.misclosure_dof),
    Column(name="misclosure_p", label="misclosure p-value against the rest", unit="share",
           domain=SHARE, group="noise", fill=nc.misclosure_p),
    Column(name="misclosure_placing_share", label="misclosure: the placing's share",
           unit="share", domain=SHARE, group="noise", fill=nc.misclosure_placing_share),
    Column(name="target_scatter_chi2", label="trials of one target: scatter chi-square",
           unit="none", domain=NON_NEGATIVE, group="noise", fill=nc.target_scatter_chi2),
    Column(name="target_scatter_dof", label="trials of one target: scatter dof", unit="count",
           domain=COUNT, dtype="int64", group="noise", fill=nc.target_scatter_dof),
    Column(name="flagged", label="flagged (poses, other trials or truth)", unit="none", domain=FLAG,
           dtype="boolean", group="noise", fill=nc.flagged),
    _text("flagged_by", "which test flagged it", "noise", nc.flagged_by,
          domain=Domain("one of", ("", *nc.FLAGGED_BY))),
    Column(name="suspect_pose", label="pose named", unit="count", domain=COUNT,
           dtype="int64", group="noise", fill=nc.suspect_pose),
    _text("suspect_axis", "typed component that looks off", "noise", nc.suspect_axis,
          domain=Domain("one of", ("", "x", "y", "z"))),
    _length("suspect_offset", "how far it looks off", "noise", nc.suspect_offset, FINITE),
    _text("disagreement", "the poses' disagreement", "noise", nc.disagreement),
    Column(name="noise_widening", label="covariance widened by", unit="none",
           domain=NON_NEGATIVE, group="noise", fill=nc.noise_widening),
    _text("notes", "operator's notes", "notes",
          lambda t: list(t.notes) if t.notes is not None else [""] * len(t.estimate.trials)),
    # two-camera sessions: the touch a row is, the clock offset, the skew's share of the error
    _text("touch", "which touch (stream trial, touch)", "stream"),
    Column(name="clock_offset_ms", label="clock offset used", unit="milliseconds",
           domain=FINITE, group="stream"),
    Column(name="clock_offset_sigma_ms", label="clock offset's 1-sigma", unit="milliseconds",
           domain=NON_NEGATIVE, group="stream"),
    _text("clock_offset_source", "clock offset's source", "stream",
          domain=Domain("one of", ("", "recorded", "measured", "given"))),
    _length("err_uninterpolated", "error, camera 1's paired frame as it is", "stream", None,
            NON_NEGATIVE),
    Column(name="skew_share", label="share of that error interpolation removed", unit="share",
           domain=SHARE, group="stream"),
    # --rig-calibration loo: each trial corrected by its session's other trials' constants
    *_axes("{}_rig", None, label="rig corrected {}", **_AXIS, **_RIG),
    _length("err_rig", "rig corrected error", "rig", None, NON_NEGATIVE),
    Column(name="within95_rig", label="truth inside its 95% region, rig corrected",
           unit="none", domain=FLAG, dtype="boolean", **_RIG),
    *_axes("dir_{}_rig", None, label="rig corrected direction {}", unit="none",
           domain=FINITE, applies=lines, **_RIG),
    _angle("angle_err_rig_deg", "rig corrected direction error", "rig", None, applies=lines),
    Column(name="dist_err_rig", label="rig corrected distance from the true line",
           unit="length", domain=NON_NEGATIVE, applies=lines, **_RIG),
)  # fmt: skip


def column_named(name: str) -> Column:
    """The declaration of the column ``name`` (KeyError: no column is called so)."""
    return _BY_NAME[name]


def group(name: str) -> list[str]:
    """The names of the columns of one ``group``, in the table's order."""
    return [c.name for c in TRIAL_TABLE if c.group == name]


def columns_of(spec: MethodSpec) -> list[Column]:
    """The columns :func:`trial_table` fills for a trial of the method
    ``spec`` describes, in the table's order: those that apply to it (:attr:`Column.applies`)
    and have a ``fill``. A column its spec names that none declares is a KeyError."""
    unknown = {*spec.extra_columns, *spec.margins} - set(_BY_NAME)
    if unknown:
        raise KeyError(f"{spec.method}: no column declared for {sorted(unknown)}")
    return [c for c in TRIAL_TABLE if c.fill is not None and c.applies(spec, c.name)]


def trial_table(
    session: str,
    estimate: SessionEstimate,
    reported_: Reported,
    notes: Sequence[str] | None = None,
    unmeasured: Sequence[str] | None = None,
) -> pd.DataFrame:
    """One row per trial (``trials.csv``): estimate, truth, error, margins, uncertainty,
    the operator's ``notes``; ``unmeasured`` (per trial, why its captures do not make two
    usable poses) replaces the generic reason of an ``incomplete`` trial. Each column is
    filled by its declaration (:data:`TRIAL_TABLE`): the common ones, and the
    ones the method's spec names, in the table's order."""
    import pandas as pd

    result = TrialResult(session, estimate, reported_, notes, unmeasured)
    filled = [(c, c.fill) for c in columns_of(result.spec) if c.fill is not None]
    table = pd.DataFrame({c.name: fill(result) for c, fill in filled})
    return table.assign(**{c.name: as_dtype(table[c.name], c.dtype) for c, _ in filled})


def as_dtype(values: pd.Series, dtype: str) -> pd.Series:
    """``values`` as ``dtype`` (a :attr:`Column.dtype`); a ``bool`` or ``int64`` column with
    a missing value (which no table should have) as its nullable kin, never a made-up value
    (:func:`analysis.tables.columns.typed` applies it to every table)."""
    from pandas.api.types import pandas_dtype

    if dtype == "str":
        return values.astype(object).where(values.notna(), "").astype("str")
    if dtype in ("bool", "int64") and values.isna().any():
        dtype = "boolean" if dtype == "bool" else "Int64"
    return values.astype(pandas_dtype(dtype))


def violations(table: pd.DataFrame, columns: Iterable[Column] = TRIAL_TABLE) -> list[str]:
    """The declared ``columns`` of ``table`` whose values are outside their domain, each
    said in words (none: the table is as declared)."""
    return [
        f"{c.name}: a value outside its domain ({c.domain})"
        for c in columns
        if c.name in table and not c.domain.holds(table[c.name])
    ]


_BY_NAME: Mapping[str, Column] = {c.name: c for c in TRIAL_TABLE}


def methods_having(column: Column) -> list[str]:
    """The measuring methods (of the registry, in its order) whose trials have ``column``."""
    return [str(m) for m in MEASURING_METHODS if column.applies(spec_of(m), column.name)]


#: What fills a group of columns a trial's result does not: said in the docs' table.
_LATER = {
    "identity": " (the pipeline adds it)",
    "rig": " (with `--rig-calibration loo`)",
    "stream": " (two-camera sessions' rows only)",
}


def markdown_table() -> str:
    """``docs/analysis.md``'s reference of ``trials.csv``'s columns, one row per declaration
    (``docs/trial_columns_table.py`` writes it there)."""
    every = [str(m) for m in MEASURING_METHODS]
    rows = ["| column | in words | unit | values | trials of |", "| --- | --- | --- | --- | --- |"]
    for c in TRIAL_TABLE:
        having = methods_having(c)
        of = "every method" if having == every else ", ".join(having)
        if c.fill is None:
            of += _LATER.get(c.group, "")
        rows.append(
            f"| `{c.name}` | {c.label} | {UNIT_KINDS[c.unit] or '-'} | {c.domain} "
            f"({c.dtype}) | {of} |"
        )
    return "\n".join(rows) + "\n"
