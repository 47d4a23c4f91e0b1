"""``twopose-record new S2.mcap --continue S.mcap``: a session recorded on after a file ends.

``S`` is a session closed normally or salvaged by ``recover``. The continuation takes its
setup (method, units, cameras and their calibration, ground plane, the last ground truth
typed, operator), its guidance (the stop rule, a trial's most poses, the least gain, the
suggestions' reach and grid, the taped target distance: the session entry's ``guidance``,
format 1.5; from an older file, the note its guidance wrote, when it had a stop rule), its
session id (a file from before format 1.3 has none: the first 32
hex digits of its SHA-256 stand for it, so every continuation of it agrees), numbers its
trials after the last trial ``S`` mentions, and records where it continued
(``continues``: the trial, the file's name and SHA-256, the part it continues). Each
recording is a part of its own (a fresh ``part_id``). A file beside ``S`` that already
continues the same part (a second laptop continuing one file) makes this one a new branch
(``continues.branch``: ``B``, ``C``, ...), said once at the start and never refused. The
analysis treats a session and its continuations as one session, each branch's trials
apart (:mod:`twopose.format.identity`). A two-camera session's continuation takes its
stored pair and floor as well (:attr:`Continued.pair`; its stream trials numbered on:
:mod:`recorder.setup.pair_continuation`).
"""

from __future__ import annotations

import dataclasses
import re
import string
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

from twopose.camera.model import Camera
from twopose.errors import InputValueError, SessionFormatError
from twopose.format.entries import (
    FORMAT_VERSION,
    GroundTruth,
    GuidanceRecord,
    Note,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    SimTrajectory,
    StreamWindow,
    Touch,
)
from twopose.format.identity import SessionFile, identify_file
from twopose.format.reader import SessionReader, is_results_file, recover_command
from twopose.methods.specs import Method
from twopose.pair.calibration import PairCalibration
from twopose.values.checks import Vec3
from twopose.values.units import Units

__all__ = ["Continued", "read_continued"]

#: The longest branch name the format allows (``continues.branch``: ``^[A-Z]{0,8}$``).
_MAX_BRANCH = 8
#: The guidance a session before format 1.5 recorded, in the note
#: :meth:`twopose.guidance.advice.Guidance.describe` wrote at its start when it had a stop rule
#: ("guidance: a trial is complete once its 95% region is within 0.8 in, once the next pose
#: would shrink it by less than 10%, or at 6 poses; next poses suggested on the 0.5 in grid
#: within 3 in of the first pose; the target taped 11 in from the first pose").
_OLD_NOTE = re.compile(
    r"^guidance: a trial is complete once its 95% region is within (?P<target_95>\S+) \w+, "
    r"(?:once the next pose would shrink it by less than (?P<share>[0-9.e+-]+)(?P<percent>%)?, )?"
    r"or at (?P<max_poses>\d+) poses; next poses suggested on the (?P<spacing>\S+) \w+ grid "
    r"within (?P<reach>\S+) \w+ of the first pose"
    r"(?:; the target taped (?P<target_distance>\S+) \w+ from the first pose)?$"
)
#: The entries that number a trial: a pose, its truth, a note about it; a stream's window
#: and its touches, a simulation's trajectory (a two-camera session's).
_NUMBERED = (PoseEntry, GroundTruth, Note, StreamWindow, Touch, SimTrajectory)
#: How every MCAP file begins (a session's first bytes, even when it was cut short).
_MCAP_MAGIC = b"\x89MCAP"


@dataclass(frozen=True, kw_only=True)
class Continued:
    """The session a continuation continues, as its file ends."""

    path: Path
    info: SessionInfo
    cameras: tuple[Camera, ...]
    ground: PlaneEntry | None
    last_trial: int  # the last trial the file mentions (0: none)
    truth: tuple[Vec3, ...]  # the last ground truth typed (the setup's)
    sha256: str
    #: A two-camera session's pair as it stored it (session units, its floor: the pair
    #: file's or the typed one); None: a one-camera session.
    pair: PairCalibration | None = None
    #: The continued part's id: the recorded one, or (before format 1.4) the one the
    #: analysis derives for it (:attr:`SessionFile.part_id`).
    part_id: str
    #: Files beside it already continuing the same part, one per part, by name.
    continued_by: tuple[SessionFile, ...] = ()
    #: The guidance the file recorded (format 1.5's session entry, or an older file's
    #: note; None: none recorded).
    guidance: GuidanceRecord | None = None
    #: Who records the continuation (``--operator``; None: the session's operator).
    operator: str | None = None

    @property
    def target95(self) -> float | None:
        """The stop rule the file recorded (its 95% target, session units; None: none)."""
        return None if self.guidance is None else self.guidance.target95

    @property
    def session_id(self) -> str:
        """The session's id: the file's, or (before format 1.3) its content's."""
        return self.info.session_id or self.sha256[:32]

    @property
    def next_trial(self) -> int:
        """The continuation's first trial."""
        return self.last_trial + 1

    def info_for(self, notes: str = "", *, operator: str | None = None) -> SessionInfo:
        """The continuation's opening entry: the same session, created now, recorded by
        ``operator`` (else :attr:`operator`, else the session's own)."""
        said = f"continues {self.path.name} after trial {self.last_trial}"
        who = next((o for o in (operator, self.operator) if o is not None), self.info.operator)
        return dataclasses.replace(
            self.info,
            operator=who,
            format_version=FORMAT_VERSION,
            session_id=self.session_id,
            continues_after_trial=self.last_trial,
            continues_file=self.path.name,
            continues_sha256=self.sha256,
            part_id=uuid.uuid4().hex,
            continues_part=self.part_id,
            continues_branch=self.branch,
            guidance=None,  # the continuation's own, recorded as it starts
            created_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            notes="; ".join(n for n in (notes or self.info.notes, said) if n),
        )

    @property
    def branch(self) -> str | None:
        """The continuation's branch (``continues.branch``).

        The continued part's own when no other file beside it continues it; else the next
        letter after it (the second continuation of a part on no branch is ``B``, the
        third ``C``; the second of a part on ``B`` is ``BB``); None when the format has no
        name left (the analysis then names it).
        """
        own = self.info.continues_branch or ""
        if not self.continued_by:
            return own
        taken = {f.info.continues_branch or "" for f in self.continued_by if f.info is not None}
        letters = string.ascii_uppercase[len(self.continued_by) :]
        free = [own + c for c in letters if own + c not in taken]
        return free[0] if free and len(own) < _MAX_BRANCH else None

    @property
    def fork_warning(self) -> str | None:
        """What to say at the start when another file already continues this part."""
        if not self.continued_by:
            return None
        by = ", ".join(
            f"{Path(f.path).name} (after trial {f.continues_after})" for f in self.continued_by
        )
        branch = f"branch {self.branch}" if self.branch else "another branch"
        return (
            f"{self.path.name} is already continued by {by}: this file starts {branch} of "
            "the session; the analysis keeps each branch's trials apart"
        )

    def check_plan(self, method: Method, units: Units) -> None:
        """Refuse a plan whose setup is not the session's (its trials are recorded on)."""
        if (method, units) != (self.info.method, self.info.units):
            raise InputValueError(
                f"the plan is a {method} session in {units}, {self.path} a {self.info.method} "
                f"session in {self.info.units}: a continuation keeps the session's setup"
            )


def read_continued(path: str | Path, *, operator: str | None = None) -> Continued:
    """What a continuation of ``path`` takes from it (see the module docstring);
    ``operator``: who records the continuation (``--operator``; None: the session's)."""
    src = Path(path)
    not_session = _not_a_session(src)
    if not_session:
        raise InputValueError(f"--continue {src}: {not_session}")
    try:
        with SessionReader(src) as reader:
            info, cameras, ground = reader.info, reader.cameras, reader.ground
            pair = reader.pair
            last = 0
            truth: tuple[Vec3, ...] = ()
            guidance = info.guidance
            # A two-camera session's trials are its streams: their windows and touches.
            streams = (StreamWindow, Touch, Note, SimTrajectory)
            topics = None if pair is None else [c.TOPIC for c in streams]
            for entry in reader.iter_entries(topics):
                trial = getattr(entry, "trial", None)
                if isinstance(entry, _NUMBERED) and trial:
                    last = max(last, int(trial))
                if isinstance(entry, GroundTruth):
                    truth = entry.points_grid
                if isinstance(entry, Note) and entry.trial is None and info.guidance is None:
                    guidance = _old_note(entry.text, guidance)
    except SessionFormatError as err:
        said = str(err).rstrip(".")
        if "not a twopose session" in said:  # a closed MCAP file of something else
            raise InputValueError(
                f"--continue {src}: not a session file: {said}; nothing can be continued "
                "from it (continue the session file `twopose-record new` wrote)"
            ) from None
        if "recover" not in said:
            said += f"; `{recover_command(src)}` salvages what it holds"
        raise InputValueError(
            f"--continue {src}: {said}; then continue from that: --continue FIXED.mcap"
        ) from None
    identity = identify_file(src)
    return Continued(
        path=src,
        info=info,
        cameras=tuple(cameras.values()),
        ground=ground,
        last_trial=last,
        truth=tuple(truth),
        pair=pair,
        sha256=identity.digest,
        part_id=identity.part_id,
        continued_by=_continued_beside(identity),
        guidance=guidance,
        operator=operator,
    )


def _old_note(note: str, before: GuidanceRecord | None) -> GuidanceRecord | None:
    """The guidance a note from before format 1.5 records (``before`` if it records none)."""
    found = _OLD_NOTE.match(note)
    if found is None:
        return before
    try:
        percent = found.group("percent") is not None  # before 1.5: "less than 10%"
        numbers = {k: float(v) for k, v in found.groupdict().items() if v and k != "percent"}
        return GuidanceRecord(
            target95=numbers["target_95"], max_poses=int(numbers["max_poses"]),
            min_gain=numbers.get("share", 0.0) / (100 if percent else 1), reach=numbers["reach"],
            spacing=numbers["spacing"], target_distance=numbers.get("target_distance"),
        )  # fmt: skip
    except (ValueError, InputValueError):  # a note that only looks like one
        return before


def _not_a_session(path: Path) -> str:
    """Why ``path`` is no session file at all ("" when it may be one, whole or cut short).

    A session's file begins with MCAP's magic from its first write, so a file that does
    not (a CSV, a figure) was never one and ``recover`` cannot make it one; an analysis
    results file (``results_*.mcap``) is an MCAP file but no session.
    """
    try:
        with path.open("rb") as stream:
            head = stream.read(len(_MCAP_MAGIC))
    except OSError as err:
        return f"cannot be read ({err.strerror or err})"
    if not head:
        return "not a session file: the file is empty"
    if head != _MCAP_MAGIC:
        kind = f"a {path.suffix.lstrip('.').upper()} file, " if path.suffix else ""
        return (
            f"not a session file ({kind}not MCAP); a session is the .mcap file "
            "`twopose-record new` wrote"
        )
    if is_results_file(path):
        return (
            "not a session file: an analysis results file written by `twopose-analyze run`; "
            "continue the session file it was made from"
        )
    return ""


def _continued_beside(continued: SessionFile) -> tuple[SessionFile, ...]:
    """The files in ``continued``'s folder that already continue its part, one per part.

    Any ``*.mcap`` (in any case) but itself; a file that says nothing of what it is
    (unreadable, no session entry) is passed over quietly.
    """
    src = Path(continued.path)
    try:
        beside = sorted(p for p in src.parent.iterdir() if p.suffix.lower() == ".mcap")
    except OSError:
        return ()
    found: dict[str, SessionFile] = {}
    for path in beside:
        try:
            if not path.is_file() or path.samefile(src):
                continue
        except OSError:
            continue
        other = identify_file(path)
        info = other.info
        if info is None or info.continues_after_trial is None:
            continue
        if info.continues_part == continued.part_id or info.continues_sha256 == continued.digest:
            found.setdefault(other.part_key, other)
    return tuple(found.values())
