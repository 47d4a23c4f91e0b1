"""A session's figures as a job with a digest, and the figures a previous run drew.

Drawing a session's figures is most of a run's cost beside decoding its frames. What they
show is a function of the job (:class:`FigureJob`: the session's name, units and tables, and
the rule for warned trials) and of the code that draws them; so a digest of both names the
PNGs exactly. A run writes ``figures.json`` (each session figure's digest) beside its
figures; a re-run into the same folder reuses every PNG whose digest it finds there instead
of drawing it again (:class:`FigureCache`), and says how many it reused: each one's bytes
as that run wrote them (their SHA-256, kept by the session cache:
:meth:`analysis.batch.cache.SessionCache.written_digests`), so a figure edited or
replaced since is drawn again.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Collection, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from analysis.tables.labels import table_units
from twopose.values.units import Units

if TYPE_CHECKING:
    from analysis.results import SessionResult

__all__ = ["FIGURE_INDEX", "FigureCache", "FigureJob", "code_version", "index_document"]

#: The run's index of its session figures: ``{"<png file>": "<digest>"}``.
FIGURE_INDEX = "figures.json"
#: Modules whose source decides what a session figure looks like.
_DRAWING_MODULES = (
    "analysis/report/figures/draw.py",
    "analysis/report/figures/style.py",
    "analysis/report/plane_axes.py",
    "analysis/report/figures/plane.py",
    "analysis/report/figures/topview.py",
    "analysis/report/figures/drawer.py",
    "analysis/session/metrics.py",
    "twopose/methods/planes.py",
    "twopose/methods/topview.py",
)
_PNG = b"\x89PNG\r\n\x1a\n"


@functools.cache
def code_version() -> str:
    """A digest of the drawing code and of matplotlib's version: a change to either makes
    every figure be drawn anew."""
    import matplotlib

    root = Path(__file__).resolve().parents[3]
    h = hashlib.sha256(matplotlib.__version__.encode())
    for name in _DRAWING_MODULES:
        h.update(name.encode() + b"\0" + (root / name).read_bytes())
    return h.hexdigest()


@dataclass(frozen=True, kw_only=True, eq=False)
class FigureJob:
    """What one session's figures are drawn from."""

    session: str
    trials: pd.DataFrame
    averaging: pd.DataFrame
    views: pd.DataFrame
    units: Units | None = None  # the session's, for the axes when it has no trial
    include_warned: bool = False

    @classmethod
    def of(cls, result: SessionResult, *, include_warned: bool = False) -> FigureJob:
        """The figures of an analysed session, warned trials included or not."""
        from analysis.report.answer import with_branch

        return cls(
            session=with_branch(result.name, result.branch),
            trials=result.trials,
            averaging=result.averaging,
            views=result.pose_views,
            units=table_units(result.trials, result.metadata.get("units", "")),
            include_warned=include_warned,
        )

    def digest(self) -> str:
        """The figures' name: the same digest, the same PNGs (:func:`code_version` in it)."""
        h = hashlib.sha256(code_version().encode())
        h.update(_text(f"{self.session}\0{self.units}\0{self.include_warned}"))
        for table in (self.trials, self.averaging, self.views):
            for column in table.columns:
                h.update(_text(f"\1{column}\0{table[column].dtype}\0"))
                values = table[column]
                if pd.api.types.is_numeric_dtype(values) and values.dtype != object:
                    array = values.to_numpy()
                    # A flag with <NA> (within95) gives objects, whose bytes are their
                    # addresses (another in every run): <NA> as NaN.
                    if array.dtype == object:
                        array = values.to_numpy(dtype=float, na_value=float("nan"))
                    h.update(array.tobytes())
                else:  # text: any file name, even one that is not valid UTF-8
                    h.update(_text("\0".join(map(str, values))))
        return h.hexdigest()


def _text(text: str) -> bytes:
    """``text`` as bytes, whatever it holds (a file name's undecodable bytes too)."""
    return text.encode("utf-8", "surrogatepass")


@dataclass(frozen=True)
class FigureCache:
    """The session figures a previous run wrote into ``folder``, by digest and kind.

    Picklable (a path and a table), so worker processes and Dask workers look in it too.
    A missing, unreadable or odd index, or a PNG that is gone or not a PNG, is a miss:
    the figure is drawn.
    """

    folder: str | None = None
    index: Mapping[str, Mapping[str, str]] = field(default_factory=dict)
    #: Each PNG's SHA-256 as the run that wrote it recorded (None: its bytes not checked).
    written: Mapping[str, str] | None = None

    @classmethod
    def of(
        cls,
        folder: str | Path,
        listed: Collection[str] | None = None,
        written: Mapping[str, str] | None = None,
    ) -> FigureCache:
        """What ``folder`` (a previous run's results) holds, of the files ``listed`` (the
        previous run's list of its outputs, when it has one) and whose bytes are those
        ``written`` records (when given); empty when nothing."""
        try:
            listed = json.loads((Path(folder) / FIGURE_INDEX).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return cls(str(folder), written=written)
        index: dict[str, dict[str, str]] = {}
        if isinstance(listed, dict):
            for name, digest in listed.items():
                kind = str(name).split("_", 1)[0]
                mine = listed is None or str(name) in listed
                if isinstance(digest, str) and _plain_png(str(name)) and mine:
                    index.setdefault(digest, {})[kind] = str(name)
        return cls(str(folder), index, written)

    def reuse(self, job: FigureJob, digest: str | None = None) -> dict[str, bytes] | None:
        """The PNGs of ``job`` by kind, as the previous run drew them; None when any is
        missing."""
        names = self.index.get(digest or job.digest())
        if not names or self.folder is None:
            return None
        pngs = {}
        for kind, name in names.items():
            try:
                data = (Path(self.folder) / name).read_bytes()
            except OSError:
                return None
            if not data.startswith(_PNG):
                return None
            if self.written is not None and _sha256(data) != self.written.get(name):
                return None  # edited or replaced since it was written: drawn again
            pngs[kind] = data
        return pngs


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _plain_png(name: str) -> bool:
    """A figure file's name as a run writes it (no folder, no way out of the folder)."""
    return name.endswith(".png") and "/" not in name and "\\" not in name and name[0] != "."


def index_document(digests: Mapping[str, str]) -> bytes:
    """``figures.json``'s bytes: each session figure's file name and its digest."""
    return (json.dumps(dict(sorted(digests.items())), indent=1) + "\n").encode()
