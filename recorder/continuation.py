"""``twopose-record new S2.mcap --continue S.mcap``: a session recorded on after a file ends.

``S`` is a session closed normally or salvaged by ``recover``. The continuation takes its
setup (method, units, cameras and their calibration, ground plane, the last ground truth
typed, operator), its session id (a file from before format 1.3 has none: the first 32
hex digits of its SHA-256 stand for it, so every continuation of it agrees), numbers its
trials after the last trial ``S`` mentions, and records where it continued
(``continues``: the trial, the file's name and SHA-256). The analysis treats a session
and its continuations as one session (:mod:`analysis.input_set`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import time
from dataclasses import dataclass
from pathlib import Path

from twopose.camera import Camera
from twopose.errors import InputValueError, SessionFormatError
from twopose.format.entries import (
    FORMAT_VERSION,
    GroundPlane,
    GroundTruth,
    Note,
    PoseEntry,
    SessionInfo,
)
from twopose.format.reader import SessionReader
from twopose.methods import Method
from twopose.units import Units
from twopose.values import Vec3

__all__ = ["Continued", "read_continued"]

_CHUNK = 1 << 20


@dataclass(frozen=True, kw_only=True)
class Continued:
    """The session a continuation continues, as its file ends."""

    path: Path
    info: SessionInfo
    cameras: tuple[Camera, ...]
    ground: GroundPlane | None
    last_trial: int  # the last trial the file mentions (0: none)
    truth: tuple[Vec3, ...]  # the last ground truth typed (the setup's)
    sha256: str

    @property
    def session_id(self) -> str:
        """The session's id: the file's, or (before format 1.3) its content's."""
        return self.info.session_id or self.sha256[:32]

    def info_for(self, notes: str = "") -> SessionInfo:
        """The continuation's opening entry: the same session, created now."""
        said = f"continues {self.path.name} after trial {self.last_trial}"
        return dataclasses.replace(
            self.info,
            format_version=FORMAT_VERSION,
            session_id=self.session_id,
            continues_after_trial=self.last_trial,
            continues_file=self.path.name,
            continues_sha256=self.sha256,
            created_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
            notes="; ".join(n for n in (notes or self.info.notes, said) if n),
        )

    def check_plan(self, method: Method, units: Units) -> None:
        """Refuse a plan whose setup is not the session's (its trials are recorded on)."""
        if (method, units) != (self.info.method, self.info.units):
            raise InputValueError(
                f"the plan is a {method} session in {units}, {self.path} a {self.info.method} "
                f"session in {self.info.units}: a continuation keeps the session's setup"
            )


def read_continued(path: str | Path) -> Continued:
    """What a continuation of ``path`` takes from it (see the module docstring)."""
    src = Path(path)
    try:
        with SessionReader(src) as reader:
            info, cameras, ground = reader.info, reader.cameras, reader.ground
            last = 0
            truth: tuple[Vec3, ...] = ()
            for entry in reader.iter_entries():
                trial = getattr(entry, "trial", None)
                if isinstance(entry, PoseEntry | GroundTruth | Note) and trial:
                    last = max(last, int(trial))
                if isinstance(entry, GroundTruth):
                    truth = entry.points_grid
    except SessionFormatError as err:
        said = str(err).rstrip(".")
        if "recover" not in said:
            said += f"; `twopose-record recover {src} -o FIXED.mcap` salvages what it holds"
        raise InputValueError(
            f"--continue {src}: {said}; then continue from that: --continue FIXED.mcap"
        ) from None
    h = hashlib.sha256()
    with src.open("rb") as f:
        while block := f.read(_CHUNK):
            h.update(block)
    return Continued(
        path=src,
        info=info,
        cameras=tuple(cameras.values()),
        ground=ground,
        last_trial=last,
        truth=tuple(truth),
        sha256=h.hexdigest(),
    )
