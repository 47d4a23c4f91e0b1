"""What the CI gate checks and how much worse each may get: the checked metrics (one
registry, each with its kind: a length in the session's units, a count of trials, a
share) and the tolerance file that sets their allowances.

An allowance is ``max(absolute, relative * |baseline|)``. A length's absolute allowance
carries a unit: the file's ``units`` (inches when no file is given: the thesis' unit),
converted to each session's units before it is compared, so that ``absolute = 0.05`` in a
file with ``units = "in"`` allows 1.27 mm in a millimetre session and 0.00127 m in a metre
one. A file that gives a length's absolute allowance without ``units`` is refused: a bare
number could be any unit, and read as a session's own it lets a metre session move by
metres.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from analysis.tables.columns import SUMMARY_DOMAINS
from twopose.errors import InputValueError
from twopose.methods.specs import MEASURING_METHODS
from twopose.values.toml import build_dataclass, read_toml
from twopose.values.units import DEFAULT_UNITS, UNITS, Units, unit_factor, unit_spec

__all__ = [
    "CHECKED_METRICS",
    "MAX_RELATIVE",
    "METHODS",
    "Allowance",
    "Metric",
    "Tolerance",
    "load_tolerance",
]

#: The largest relative allowance: a metric may double, no more (a gate that lets RMSE
#: grow fivefold checks nothing; 5 is most likely "5%" meant as 0.05).
MAX_RELATIVE = 1.0


@dataclass(frozen=True, kw_only=True)
class Allowance:
    """How much worse a metric may get: ``max(absolute, relative * |baseline|)``; a
    length's ``absolute`` in its tolerance's ``units``."""

    relative: float = 0.0
    absolute: float = 0.0

    def __post_init__(self) -> None:
        if self.relative < 0 or self.absolute < 0:
            raise InputValueError("a tolerance cannot be negative")
        if not (math.isfinite(self.relative) and math.isfinite(self.absolute)):
            raise InputValueError("a tolerance must be a finite number")
        if self.relative > MAX_RELATIVE:
            raise InputValueError(
                f"a relative tolerance of {self.relative:g} lets a metric grow by "
                f"{self.relative:.0%}: at most {MAX_RELATIVE:g} (100%); is it a percentage? "
                "write 0.10 for 10%"
            )


@dataclass(frozen=True, kw_only=True)
class Tolerance:
    """The allowances of each checked metric. ``units`` is the unit of every length's
    absolute allowance (``rmse``, ``median_err``, ``bias``: |bias_x|, |bias_y|, |bias_z|),
    converted to each session's; ``n_ok``, ``n_used`` and ``n_warned`` count trials,
    ``coverage95`` is a share (0-1)."""

    units: Units = DEFAULT_UNITS
    rmse: Allowance = Allowance(relative=0.10)
    median_err: Allowance = Allowance(relative=0.10)
    bias: Allowance = Allowance(relative=0.10, absolute=0.05)
    n_ok: Allowance = Allowance()
    #: trials left out of the statistics (a warned or failed trial the baseline used)
    n_used: Allowance = Allowance()
    #: trials newly warned (a near-degeneracy the baseline's trial did not have)
    n_warned: Allowance = Allowance()
    coverage95: Allowance = Allowance(absolute=0.05)

    def allowed(self, metric: Metric, baseline: float, units: Units) -> float:
        """How much worse ``metric`` may get from ``baseline``, in a session in ``units``
        (a length's absolute allowance converted from :attr:`units`)."""
        allowance: Allowance = getattr(self, metric.allowance)
        absolute = allowance.absolute
        if metric.is_length:
            absolute *= unit_factor(self.units, units)
        return max(absolute, allowance.relative * abs(baseline))


@dataclass(frozen=True, kw_only=True)
class Metric:
    """One checked metric: its name as printed, its ``summary.csv`` column, the
    :class:`Tolerance` field that allows it, and ``sign``: +1 when larger is worse, -1
    when smaller is. Its kind is its column's domain
    (:data:`analysis.tables.columns.SUMMARY_DOMAINS`):
    a length (in the session's units), a count of trials or a share."""

    name: str
    column: str
    allowance: str
    sign: int
    #: For a count held to its trials: the :class:`analysis.gate.match.TrialChanges` field
    #: naming them, and how a line says them ("" for the others).
    trials: str = ""
    trials_said: str = ""

    @property
    def is_length(self) -> bool:
        """Whether its values (and its absolute allowance) are lengths."""
        return SUMMARY_DOMAINS[self.column] in ("length", "signed")

    def unit(self, units: Units, rows: str = "trials") -> str:
        """The unit its values are in, in a session in ``units``: that unit for a length,
        its ``rows`` for a count (``trials``; a two-camera session's ``touches``), none for
        a share."""
        if self.is_length:
            return units
        return rows if SUMMARY_DOMAINS[self.column] == "count" else ""


#: Every metric ``check`` compares, in the order it prints them.
CHECKED_METRICS = (
    Metric(name="rmse", column="rmse", allowance="rmse", sign=+1),
    Metric(name="median_err", column="median_err", allowance="median_err", sign=+1),
    Metric(name="|bias_x|", column="bias_x", allowance="bias", sign=+1),
    Metric(name="|bias_y|", column="bias_y", allowance="bias", sign=+1),
    Metric(name="|bias_z|", column="bias_z", allowance="bias", sign=+1),
    Metric(name="n_ok", column="n_ok", allowance="n_ok", sign=-1),
    Metric(
        name="n_used",
        column="n_used",
        allowance="n_used",
        sign=-1,
        trials="left_out",
        trials_said="left out of this run's statistics, used by the baseline's",
    ),
    Metric(
        name="n_warned",
        column="n_warned",
        allowance="n_warned",
        sign=+1,
        trials="newly_warned",
        trials_said="warned in this run, not in the baseline",
    ),
    Metric(name="coverage95", column="coverage95", allowance="coverage95", sign=-1),
)
#: The allowances whose absolute value is a length (it needs the file's ``units``).
_LENGTH_ALLOWANCES = tuple(dict.fromkeys(m.allowance for m in CHECKED_METRICS if m.is_length))

#: The methods a tolerance file may name (``[methods.<method>.<metric>]``).
METHODS = tuple(sorted(str(m) for m in MEASURING_METHODS))


def load_tolerance(path: str | Path | None) -> dict[str, Tolerance]:
    """Tolerances by method (``""``: the default) from a TOML file such as::

        units = "in"             # of every absolute length allowance below
        [rmse]
        relative = 0.10          # 10 % of the baseline's RMSE
        [bias]
        absolute = 0.05          # 0.05 in, converted to each session's units
        [methods.ground.rmse]    # a method's own allowance, over the default
        relative = 0.25

    ``None``: the defaults of :class:`Tolerance`. An unknown key anywhere (a metric, an
    allowance's field, a method: ``[methods.piont.rmse]``), a wrong type, a negative or
    non-finite number, an unknown unit, or a length's absolute allowance (but zero) in a file
    without ``units`` is refused, naming the key and the known ones."""
    if path is None:
        return {"": Tolerance()}
    what = f"tolerance file {path}"
    if not Path(path).is_file():  # a FIFO would block the read forever
        raise InputValueError(f"{what}: not a file; give a TOML file (see docs/ci.md)")
    data = read_toml(path, "tolerance file", InputValueError)
    methods = data.pop("methods", {})
    if not isinstance(methods, dict):
        raise InputValueError(f"{what}: methods must be a table of methods ([methods.ground])")
    unknown = sorted(set(methods) - set(METHODS))
    if unknown:
        raise InputValueError(
            f"{what}: unknown method(s) {', '.join('methods.' + m for m in unknown)}; "
            f"known: {', '.join(METHODS)}"
        )
    has_units = "units" in data
    default = _tolerance(Tolerance(), data, what, "", has_units=has_units)
    tolerances = {"": default}
    for method, table in methods.items():
        if isinstance(table, dict) and "units" in table:
            # One unit for the file: a method's own would silently re-read the lengths it
            # inherits from the file's tables in another unit.
            raise InputValueError(
                f"{what}: methods.{method}.units: the unit is the whole file's, given once at "
                f'its top (units = "{DEFAULT_UNITS}")'
            )
        tolerances[method] = _tolerance(
            default, table, what, f"methods.{method}.", has_units=has_units
        )
    return tolerances


def _tolerance(
    base: Tolerance, table: Any, what: str, prefix: str, *, has_units: bool
) -> Tolerance:
    """``table``'s keys over ``base``'s (an allowance given in part keeps the rest)."""
    if not isinstance(table, dict):
        raise InputValueError(f"{what}: {prefix.rstrip('.')} must be a table")
    values = dataclasses.asdict(base)
    for metric, allowance in table.items():
        if not isinstance(allowance, dict):
            continue  # build_dataclass names the key that should be a table
        for field, number in allowance.items():
            if isinstance(number, int | float) and not isinstance(number, bool) and number < 0:
                raise InputValueError(
                    f"{what}: {prefix}{metric}.{field} is {number}: an allowance cannot be negative"
                )
            if _unitless_length(metric, field, number) and not has_units:
                raise InputValueError(
                    f"{what}: {prefix}{metric}.absolute = {number!r} is a length with no unit: "
                    f'add units = "{DEFAULT_UNITS}" (or '
                    f"{', '.join(u for u in UNITS if u != DEFAULT_UNITS)}) at the top of the "
                    "file; it is converted to each session's units"
                )
    units = _units(table.get("units", base.units), f"{what}: {prefix}units")
    merged = values | {
        k: values[k] | v if isinstance(v, dict) and isinstance(values.get(k), dict) else v
        for k, v in table.items()
        if k != "units"  # a unit, not a number: read by _units
    }
    merged.pop("units")
    where = f"{what}: {prefix.rstrip('.')}" if prefix else what
    return dataclasses.replace(
        build_dataclass(Tolerance, merged, where, InputValueError), units=units
    )


def _unitless_length(metric: str, field: str, number: object) -> bool:
    """Whether ``metric.field = number`` is a length that needs a unit (zero is zero in
    any unit; what is no number, ``build_dataclass`` refuses)."""
    is_number = isinstance(number, int | float) and not isinstance(number, bool)
    if not (is_number and math.isfinite(number)):  # type: ignore[arg-type]
        return False
    return field == "absolute" and metric in _LENGTH_ALLOWANCES and number != 0


def _units(given: object, what: str) -> Units:
    """The file's ``units``, or a refusal naming the known ones."""
    if isinstance(given, str):
        try:
            return unit_spec(given).units
        except InputValueError:
            pass
    raise InputValueError(f"{what} must be one of {', '.join(UNITS)}, got {given!r}")
