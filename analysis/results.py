"""What an analysis is asked to do and what it gives back: frozen types, no computation."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from analysis.choices import DEFAULT_SESSION_TIMEOUT_S, FigureFormat, RigCalibrationMode
from analysis.report.thesis import Verdicts, thesis_table, verdict_lines, verdicts_by_set
from analysis.tables.columns import RIG_TABLE_COLUMNS, VIEW_COLUMNS, typed
from twopose.detect.thresholds import DotParams, GloveParams
from twopose.rig.constants import RigConstants
from twopose.solve.estimate import EstimateOptions
from twopose.values.choices import P, TargetSpec

__all__ = ["AnalysisOptions", "RunResult", "SessionFailure", "SessionResult"]


#: The metadata of an :class:`AnalysisOptions` field that shapes the run's own outputs (its
#: summary, its figures, its time limit) and never a session's tables: a re-run that
#: changes only such fields reuses every session's analysis (analysis.batch.cache).
RUN_ONLY = {"session_tables": False}


def shapes_session_tables(name: str) -> bool:
    """Whether the :class:`AnalysisOptions` field ``name`` shapes a session's tables (is
    not :data:`RUN_ONLY`): the one reading of the mark (analysis.batch.cache keys on it)."""
    return bool(AnalysisOptions.__dataclass_fields__[name].metadata.get("session_tables", True))


@dataclass(frozen=True, kw_only=True)
class AnalysisOptions:
    """How frames become measurements and measurements become estimates."""

    glove: GloveParams = field(default_factory=GloveParams)
    dot: DotParams = field(default_factory=DotParams)
    # Another target's detector's thresholds (a registered target's record, of its
    # TargetSpec.params type); the glove's and the dot's are the fields above.
    thresholds: tuple[object, ...] = ()
    # How frames are combined and when a near-degenerate trial warns: the one record the
    # recorder's live result and the command line's defaults read too.
    estimate: EstimateOptions = field(default_factory=EstimateOptions)
    # A session still running after this many seconds is stopped and listed as failed, so
    # that one pathological file cannot stall a batch (None: no limit).
    session_timeout_s: float | None = field(default=DEFAULT_SESSION_TIMEOUT_S, metadata=RUN_ONLY)
    # The summary's statistics include ok trials with a near-degeneracy warning.
    include_warned: bool = field(default=False, metadata=RUN_ONLY)
    # The rig's constants (`twopose-analyze rig`): every view corrected before solving.
    rig: RigConstants | None = None
    # "loo": also each trial corrected by the constants its session's other trials give.
    rig_calibration: RigCalibrationMode = "none"
    # Where ``rig`` came from (``run --rig``): recorded in summary.json and the report.
    rig_source: RigSource | None = None
    # ``run --figures``: the static matplotlib figures written, in these formats (png, svg,
    # pdf); none by default: the report's charts are drawn by the reader's browser.
    figures: tuple[FigureFormat, ...] = field(default=(), metadata=RUN_ONLY)

    def thresholds_for(self, target: TargetSpec[P]) -> P:
        """The thresholds ``target``'s detector takes in this run: of its parameter type,
        the glove's, the dot's or one of :attr:`thresholds`; else its defaults."""
        return target.thresholds((self.glove, self.dot, *self.thresholds))


@dataclass(frozen=True, kw_only=True)
class RigSource:
    """The rig file a session's views were corrected by (its nearest ``rig.toml`` up the
    tree, or ``run --rig``'s, :mod:`analysis.rig.scope`): where it was, its content's
    SHA-256, its constants and whether ``--rig`` gave it, so a corrected run is never
    mistaken for an uncorrected one (``trials.csv``'s ``rig_file``, ``summary.json``'s
    ``rig`` and ``rig_files``, the terminal, the report)."""

    path: str
    sha256: str
    constants: RigConstants
    #: Chosen by ``--rig`` (for every session) rather than found up the tree.
    given: bool = False

    def to_json(self) -> dict[str, object]:
        from dataclasses import asdict

        values = {
            k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self.constants).items()
        }
        return {"path": self.path, "sha256": self.sha256, "constants": values, "given": self.given}


def _empty(columns: list[str]) -> pd.DataFrame:
    """A table with no rows, its declared columns and their dtypes."""
    return typed(pd.DataFrame(columns=columns))


@dataclass(frozen=True, kw_only=True)
class SessionResult:
    """One session's tables and what the report says about it."""

    session: str
    metadata: dict[str, str]
    frames: pd.DataFrame
    trials: pd.DataFrame
    averaging: pd.DataFrame
    images: dict[str, bytes] = field(default_factory=dict)  # PNGs by figure kind, if asked
    figures_reused: bool = False  # the images are a previous run's (analysis.report.figures.cache)
    analysis_reused: bool = False  # the tables are a previous run's (analysis.batch.cache)
    analysis_key: str = ""  # its entry in the run's session cache (analysis.batch.cache)
    views: pd.DataFrame = field(default_factory=lambda: _empty(VIEW_COLUMNS))
    rig: pd.DataFrame = field(default_factory=lambda: _empty(RIG_TABLE_COLUMNS))  # rig.csv rows
    #: What names it to a reader: the shortest tail of its path no other input shares
    #: (:attr:`analysis.batch.inputs.InputSet.labels`); its file name when analysed alone.
    label: str = ""
    #: Its place among the run's inputs (failed ones included): the number of every output
    #: file of it (``results_<index>_...``, ``scatter_<index>_...``); -1 outside a run.
    index: int = -1

    @property
    def name(self) -> str:
        """Its label, or its file name."""
        return self.label or Path(self.session).name

    @property
    def pose_views(self) -> pd.DataFrame:
        """Its views of typed poses, which the charts and figures draw per trial (a
        two-camera session's views are its frame pairs per stream trial, not its touches':
        none of them)."""
        return self.views[self.views["cameras"] == 1] if "cameras" in self.views else self.views

    @property
    def session_id(self) -> str:
        """The session it is (a fork's branches and a session's parts around a missing one
        are analysed apart, one id): from its trials, else its path."""
        if "session_id" not in self.trials or self.trials.empty:
            return self.session
        return str(self.trials["session_id"].iloc[0]) or self.session

    @property
    def branch(self) -> str:
        """The branch its trials end on ("" on a session that never forked)."""
        if "branch" not in self.trials or self.trials.empty:
            return ""
        return str(self.trials["branch"].iloc[-1])


@dataclass(frozen=True, kw_only=True)
class SessionFailure:
    """A session that could not be analysed, and why (the batch lists it and goes on)."""

    session: str
    reason: str


@dataclass(frozen=True, kw_only=True)
class RunResult:
    """Everything a run produced (tables as DataFrames, figures as matplotlib Figures)."""

    trials: pd.DataFrame
    summary: pd.DataFrame
    averaging: pd.DataFrame
    frames: pd.DataFrame
    errors: pd.DataFrame
    sessions: tuple[SessionResult, ...]
    views: pd.DataFrame = field(default_factory=lambda: _empty(VIEW_COLUMNS))
    skipped: tuple[str, ...] = ()  # results files of an earlier run found among the inputs
    include_warned: bool = False  # whether the summary counts trials with a warning
    rig: pd.DataFrame = field(default_factory=lambda: _empty(RIG_TABLE_COLUMNS))  # rig.csv
    rig_source: RigSource | None = None  # the rig file every session's views were corrected by
    #: Every rig file the run used, each once (each session's: trials.csv ``rig_file``)
    rig_files: tuple[RigSource, ...] = ()
    #: What the run says about its inputs: copies counted once, board sessions (for
    #: `rig`), empty sessions (analysis.batch.inputs.InputSet.notes)
    input_notes: tuple[str, ...] = ()
    #: The inputs not analysed as given (:attr:`analysis.batch.inputs.InputSet.set_aside`):
    #: what the report's counts count, where ``input_notes`` also says how continuations
    #: and forks were joined (analysed, all of them)
    inputs_set_aside: tuple[str, ...] = ()
    #: The folder the run wrote its outputs into; None when it wrote none (no ``out_dir``
    #: given, or nothing to analyse: then ``--out`` is left as it was).
    written_to: str | None = None
    #: The settings its results depend on (:func:`analysis.gate.settings.settings_of`):
    #: ``summary.json``'s ``settings``, which ``check`` compares with a baseline's.
    settings: dict[str, object] = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        return not self.errors.empty

    @property
    def n_sessions(self) -> int:
        """The sessions analysed (a fork's branches are one session: :attr:`sessions`
        holds each branch on its own)."""
        return len({s.session_id for s in self.sessions})

    def sessions_said(self, verb: str = "") -> str:
        """The sessions analysed in words: ``3 session(s)``, and how some were taken apart
        (:func:`analysis.batch.inputs.sessions_said`)."""
        from analysis.batch.inputs import sessions_said

        return sessions_said(((s.session_id, s.branch) for s in self.sessions), verb)

    @functools.cached_property
    def verdicts(self) -> Verdicts:
        """The run against the thesis, per session set: computed once, read by the
        terminal, ``summary.json`` and the report."""
        return verdicts_by_set(self.trials, include_warned=self.include_warned)

    @property
    def verdict(self) -> list[str]:
        """:attr:`verdicts` as lines (each naming its set when the run has several)."""
        return verdict_lines(self.verdicts)

    @functools.cached_property
    def thesis(self) -> pd.DataFrame:
        """What the thesis reported against this run (``thesis.csv``): computed once."""
        return thesis_table(self.trials, self.averaging, include_warned=self.include_warned)

    @property
    def figures_reused(self) -> int:
        """Sessions whose figures a previous run had drawn (reused, not drawn again)."""
        return sum(s.figures_reused for s in self.sessions)

    @property
    def sessions_reused(self) -> int:
        """Sessions whose analysis a previous run had kept (reused, not analysed again)."""
        return sum(s.analysis_reused for s in self.sessions)
