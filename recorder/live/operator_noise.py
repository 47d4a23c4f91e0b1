"""The operator's noise file: what the recorder learned of each operator's placing error,
session by session, so that the next session's live result starts from it (issue 54).

A session's live result estimates the placing variance's multiplier from its own trials
and a prior (:mod:`twopose.uncertainty.placing_variance`); a lab's operator records session after
session, and their earlier sessions are that prior, exactly as the analysis pools the
same operator's other sessions of a run
(:func:`twopose.uncertainty.operator_pool.operator_priors`,
one rule). At the end of every recording whose setup names an operator, the recorder adds
the session's trials' misclosures (a few numbers per trial with redundant poses) to the
operator's file; when a recording starts, the file's sessions of the same method, relative
to the same placing sigma (typed, or the same rig file's ``[placing]``), are its prior.

The files live in ``$TWOPOSE_NOISE_DIR``, else ``$XDG_DATA_HOME/twopose/operators``
(``~/.local/share/twopose/operators``), one per operator: ``<name>-<hash>.toml``, the name
made safe for a file name and the hash of the name, case folded, keeping two names apart
("Ada" and "ada" are one operator, :mod:`twopose.values.operators`; a file an earlier
recorder wrote under the hash of the name as typed is still found). Plain
TOML (docs/uncertainty.md lists the keys); delete it to start an operator afresh. A file
that cannot be read is said and set aside, never the recording's end.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from twopose.atomic_write import write_atomically, write_failed
from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.solve.margins import EstimateOptions
from twopose.uncertainty.noise import PlacingPrior
from twopose.uncertainty.operator_pool import SessionNoise, operator_priors
from twopose.values.operators import operator_key
from twopose.values.units import Units, unit_spec

__all__ = ["FORMAT", "LivePrior", "NoiseFile", "live_prior", "noise_dir", "remember_session"]

#: The file's layout; another is set aside (said), never misread.
FORMAT = 1
#: At most this many sessions are kept per operator (the oldest go first).
MAX_SESSIONS = 200


def noise_dir() -> Path:
    """Where the operators' noise files are (see the module)."""
    from twopose.values.environment import NOISE_DIR, XDG_DATA_HOME

    given = NOISE_DIR.text()
    if given:
        return Path(given)
    data = XDG_DATA_HOME.text() or str(Path.home() / ".local" / "share")
    return Path(data) / "twopose" / "operators"


def _safe(operator: str) -> str:
    """The name made safe for a file name (lower case: every spelling of one operator's)."""
    return re.sub(r"[^a-z0-9_-]+", "_", operator.strip().lower()).strip("_")[:40] or "operator"


def _file_name(operator: str) -> str:
    """The operator's file name: the safe name and the hash of the case-folded name."""
    return (
        f"{_safe(operator)}-{hashlib.sha256(operator_key(operator).encode()).hexdigest()[:8]}.toml"
    )


def _file_of(operator: str, folder: Path) -> Path:
    """The operator's noise file in ``folder``: the case-folded name's, else one an earlier
    recorder wrote under the hash of the name as typed then, in any case ("Ada"'s file is
    "ada"'s): its ``operator`` key names them."""
    from twopose.values.toml import read_toml

    path = folder / _file_name(operator)
    if path.is_file() or not folder.is_dir():
        return path
    for older in sorted(folder.glob(f"{_safe(operator)}-*.toml")):
        try:
            named = read_toml(older, "operator noise file", InputValueError).get("operator")
        except InputValueError:  # said when it is read as this operator's, if it is
            continue
        if isinstance(named, str) and operator_key(named) == operator_key(operator):
            return older
    return path


class NoiseFile:
    """One operator's noise file (see the module)."""

    def __init__(self, operator: str, folder: Path | None = None) -> None:
        self.operator = operator.strip()
        self.path = _file_of(self.operator, folder or noise_dir())

    def sessions(self) -> list[dict[str, object]]:
        """Its sessions as recorded; none when there is no file. A file that cannot be
        read raises :class:`InputValueError` saying so."""
        from twopose.values.toml import read_toml

        if not self.path.is_file():
            return []
        data = read_toml(self.path, "operator noise file", InputValueError)
        named = data.get("operator")
        if data.get("format") != FORMAT or not isinstance(named, str):
            named = None
        if named is None or operator_key(named) != operator_key(self.operator):
            raise InputValueError(
                f"{self.path} is not this recorder's noise file of operator {self.operator!r} "
                f"(format {FORMAT}); move it away to start afresh"
            )
        sessions = data.get("session", [])
        if not isinstance(sessions, list):
            raise InputValueError(f"{self.path}: [[session]] must be an array of tables")
        return [s for s in sessions if isinstance(s, dict)]

    def history(
        self, method: Method, reference: str, base_in: float = math.nan
    ) -> list[SessionNoise]:
        """The recorded sessions of ``method`` relative to ``reference``, as statistics.

        ``base_in``: the placing sigma (inches) a ``reference`` other than ``"typed"`` is
        (a rig file's ``[placing]``): an entry written before the file kept each session's
        ``placing_in`` has it. A typed entry without one keeps NaN: it cannot be converted.
        """
        out = []
        for s in self.sessions():  # every session checked: the end adds to the whole file
            stats = _statistics(s, f"{self.path}: a session")
            if s.get("method") == str(method) and s.get("reference") == reference:
                if not math.isfinite(stats.placing_in) and reference != "typed":
                    stats = dataclasses.replace(stats, placing_in=base_in)
                out.append(stats)
        return out

    def prior(
        self, method: Method, reference: str, anchor: PlacingPrior, base_in: float = math.nan
    ) -> PlacingPrior | None:
        """The prior its sessions give a new session of base ``base_in`` (inches; the
        analysis' rule, with the new session as the one left out): None without enough of
        them. Sessions of other typed resolutions pool as placing variances
        (:mod:`twopose.uncertainty.hand`); an older entry without its base is left out
        beside them (:meth:`unconvertible` counts them)."""
        history = self.history(method, reference, base_in)
        if not history:
            return None
        group = f"{self.operator} ({method})"
        empty = SessionNoise(group=group, chi2=np.zeros(0), dof=np.zeros(0, dtype=np.int_),
                             share=np.zeros((0, 1)), z2=np.zeros((0, 1)),
                             placing_in=base_in)  # fmt: skip
        stats = [dataclasses.replace(s, group=group) for s in history] + [empty]
        prior = operator_priors(stats, anchor, who="operator")[-1]
        if prior is None:
            return None
        n = prior.sessions
        source = (
            f"{n} earlier session{'s' if n != 1 else ''} of operator {self.operator} ({method})"
        )
        return PlacingPrior(scale=prior.scale, dof=prior.dof, source=source, sessions=n,
                            anchor_p=prior.anchor_p)  # fmt: skip

    def unconvertible(self, method: Method, reference: str, base_in: float) -> int:
        """How many of the sessions :meth:`prior` leaves out: written before the file kept
        each session's placing sigma, beside sessions (or a new one) whose is known."""
        history = self.history(method, reference, base_in)
        unknown = sum(not math.isfinite(s.placing_in) for s in history)
        return unknown if unknown < len(history) or math.isfinite(base_in) else 0

    def remember(
        self, session: str | Path, method: Method, units: Units, reference: str, stats: SessionNoise
    ) -> None:
        """Add a recorded session's statistics (none: nothing written); the oldest go
        beyond :data:`MAX_SESSIONS`. Written whole, then renamed (:mod:`twopose.atomic_write`)."""
        if not len(stats.chi2):
            return
        sessions = self.sessions()
        for s in sessions:  # a file the start set aside for its numbers is not added to
            _statistics(s, f"{self.path}: a session")
        kept = sessions[-(MAX_SESSIONS - 1) :]
        entry: dict[str, object] = {
            "file": str(session),
            "method": str(method),
            "units": str(units),
            "recorded_utc": datetime.now(UTC).isoformat(timespec="seconds"),
            "reference": reference,
            **({"placing_in": float(stats.placing_in)} if math.isfinite(stats.placing_in) else {}),
            "chi2": [float(v) for v in stats.chi2],
            "dof": [int(v) for v in stats.dof],
            "share": [[float(v) for v in row] for row in stats.share],
            "z2": [[float(v) for v in row] for row in stats.z2],
        }
        text = _document(self.operator, [*kept, entry])
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise write_failed(self.path.parent, err) from err
        write_atomically(self.path, text.encode("utf-8"))


def _statistics(s: dict[str, object], what: str) -> SessionNoise:
    """A recorded session's statistics, refused in words unless well formed."""
    missing = [k for k in ("chi2", "dof", "share", "z2") if k not in s]
    if missing:
        raise InputValueError(f"{what} lacks {', '.join(missing)}; move the file away")
    try:
        chi2 = np.asarray(s["chi2"], dtype=np.float64)
        dof = np.asarray(s["dof"], dtype=np.int_)
        share = np.asarray(s["share"], dtype=np.float64)
        z2 = np.asarray(s["z2"], dtype=np.float64)
    except (TypeError, ValueError) as err:  # a string, or ragged rows: not the recorder's
        raise InputValueError(
            f"{what} holds chi2, dof, share or z2 that are not arrays of numbers; move the "
            "file away"
        ) from err
    T = len(chi2)
    shaped = dof.shape == (T,) and share.ndim == 2 and share.shape == z2.shape
    good = (
        shaped and len(share) == T
        and bool(np.all(np.isfinite(chi2)) and np.all(chi2 >= 0) and np.all(dof > 0))
        and bool(np.all((share >= 0) & (share <= 1)))
        and bool(np.all(np.isfinite(z2)) and np.all(z2 >= 0))
    )  # fmt: skip
    given = s.get("placing_in", math.nan)  # an older file's entry: not known
    number = isinstance(given, int | float) and not isinstance(given, bool)
    base = float(given) if isinstance(given, int | float) and number else -1.0
    if not good or not (math.isnan(base) or (math.isfinite(base) and base > 0)):
        raise InputValueError(f"{what} holds numbers no recorder writes; move the file away")
    return SessionNoise(group="", chi2=chi2, dof=dof, share=share, z2=z2, placing_in=base)


def _document(operator: str, sessions: Sequence[dict[str, object]]) -> str:
    """The file's text: a comment saying what it is, then its keys."""
    lines = [
        "# twopose: what the recorder learned of this operator's placing error, session by",
        "# session (docs/uncertainty.md). The next session's live result starts from it;",
        "# delete the file to start afresh.",
        f"format = {FORMAT}",
        f"operator = {_string(operator)}",
    ]
    for s in sessions:
        lines += ["", "[[session]]"]
        lines += [f"{k} = {_value(v)}" for k, v in s.items()]
    return "\n".join(lines) + "\n"


def _string(text: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped."""
    out = []
    for ch in text:
        if ch in ('"', "\\"):
            out.append("\\" + ch)
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _value(value: object) -> str:
    """A TOML value of the kinds the file holds: strings, numbers, arrays of them."""
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else "nan"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise InputValueError(f"the noise file cannot hold {value!r}")


def _reference(options: EstimateOptions) -> str:
    """What a session's multiplier is relative to: the typed resolution, or a rig file's
    measured ``[placing]`` (its sigma and where it came from)."""
    placing = options.noise.placing
    if placing is None or placing.upper_bound:  # a bound: the regions start from the typed
        return "typed"
    return f"placing {placing.sigma_in:.6g} in ({placing.measured_by or 'given'})"


def _measured_base(options: EstimateOptions) -> float:
    """The base a rig file's measured ``[placing]`` is, in inches (NaN: typed, per pose)."""
    placing = options.noise.placing
    return math.nan if placing is None or placing.upper_bound else placing.sigma_in


@dataclass(kw_only=True)
class LivePrior:
    """The operator's earlier sessions as a recording reads them: the prior at the base
    its poses type (:meth:`at`, known at its first solve, not at its start)."""

    noise_file: NoiseFile
    method: Method
    reference: str
    anchor: PlacingPrior
    _known: dict[float, PlacingPrior | None] = field(default_factory=dict)

    def at(self, base_in: float) -> PlacingPrior | None:
        """The prior of a session of base ``base_in`` (inches); None: too little."""
        if base_in not in self._known:
            try:
                self._known[base_in] = self.noise_file.prior(
                    self.method, self.reference, self.anchor, base_in
                )
            except InputValueError:  # said at the start
                self._known[base_in] = None
        return self._known[base_in]


def live_prior(
    operator: str, method: Method, options: EstimateOptions, units: Units
) -> tuple[EstimateOptions, str, LivePrior | None]:
    """The live result's options with the operator's prior from their noise file, what to
    tell the operator about it ("" when the setup names no operator), and the prior at
    the base the session's poses will type (None: nothing to start from).

    A rig file's measured ``[placing]`` is the base from the start; typed, the prior is
    said as the placing sigma the earlier sessions pooled (a multiplier of each pose's
    typed resolution once one is typed)."""
    if not operator.strip() or not options.noise.test_redundancy:
        return options, "", None
    noise_file = NoiseFile(operator)
    reference, base = _reference(options), _measured_base(options)
    said_base = base if math.isfinite(base) else 1.0  # typed: said in absolute terms
    try:
        earlier = len(noise_file.history(method, reference, base))
        prior = noise_file.prior(method, reference, options.noise.anchor(), said_base)
        old = noise_file.unconvertible(method, reference, said_base)
    except InputValueError as err:
        return options, f"the operator's noise file was set aside: {err}", None
    aside = (
        f"; {old} of them set aside: written before the file kept each session's placing "
        "sigma, they cannot be converted to this one's typed resolution"
        if old
        else ""
    )
    who = f"operator {noise_file.operator} ({method})"
    if prior is None:
        what = (
            f"no earlier session of {who}"
            if not earlier
            else f"the {earlier} earlier session{'s' if earlier != 1 else ''} of {who} "
            f"{'say' if earlier != 1 else 'says'} too little"
        )
        return (
            options,
            (f"placing error: {what}{aside} to start from; this one is kept in {noise_file.path}"),
            None,
        )
    live = LivePrior(
        noise_file=noise_file, method=method, reference=reference,
        anchor=options.noise.anchor(),
    )  # fmt: skip
    if math.isfinite(base):
        noise = dataclasses.replace(options.noise, prior=prior)
        options = dataclasses.replace(options, noise=noise)
        scale = f"placing sigma {prior.scale**0.5:.2g}x the one assumed"
    else:
        sigma = prior.scale**0.5 * said_base / unit_spec(units).inches
        scale = f"their placing sigma {sigma:.2g} {units}, "
        scale += "taken relative to each pose's typed resolution"
    said = f"placing error: starting from {prior.source} ({scale}, {prior.dof:.0f} dof{aside}; "
    return options, said + f"{noise_file.path})", live


def remember_session(
    operator: str, method: Method, units: Units, session: str | Path, options: EstimateOptions,
    stats: SessionNoise | None,
) -> str:  # fmt: skip
    """Add a finished recording's statistics to its operator's noise file; what went
    wrong, in words ("" when it was added, or there was nothing to add)."""
    if not operator.strip() or stats is None or not len(stats.chi2):
        return ""
    try:
        NoiseFile(operator).remember(session, method, units, _reference(options), stats)
    except (InputValueError, OSError) as err:
        return f"the operator's noise file was not updated: {err}"
    return ""
