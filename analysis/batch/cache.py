"""A session's analysis reused by a re-run into the same output folder.

A session's tables (:class:`~analysis.results.SessionResult`) are a function of five
things, and its entry in the cache is named by a digest of all five (:meth:`SessionCache.key`):

* its **identity**: the path it was given by and its continuations' paths, in order, and
  what the run says it is (:class:`~analysis.batch.inputs.SessionIdentity`: its id, label,
  parts and branches). A renamed or copied file, a continuation added or another input
  that changes its label is another session: analysed again;
* its **content**: the SHA-256 of every part's bytes, read in full (never a size or a
  modification time alone);
* the **options**: every field of :class:`~analysis.results.AnalysisOptions` that shapes
  a session's tables, the estimation's and its noise model's (sigma0, the placing sigma)
  included, and the rig's constants with the rig file's SHA-256. The fields marked
  :data:`~analysis.results.RUN_ONLY` (``--include-warned``, ``--figures``,
  ``--session-timeout``) shape the run's summary, figures or time limit and never a
  session's tables: a re-run that changes only them reuses every session's analysis, and
  writes its own outputs anew (their key holds every option);
* the **environment**: every setting read from the environment that a result depends on
  (:func:`twopose.values.environment.results_environment`, the one declared list the code that
  applies them reads too: ``TWOPOSE_MAX_IMAGE_MPIX``, ``TWOPOSE_MAX_CHUNK_MB``), as read
  where the session is analysed;
* for a session pooled with its operator's other sessions of the run, its **prior** from
  them (:func:`analysis.batch.noise_pass.prior_salt`, the ``salt`` of :meth:`SessionCache.key`);
  its first pass (:meth:`SessionCache.noise`) is kept under the session's own key;
* the **code**: twopose's version, a digest of every file of the ``analysis`` and
  ``twopose`` packages, and the versions of Python, NumPy, pandas and OpenCV.

Entries live in ``<out>/.twopose-cache/sessions/<key>.pickle``, written atomically
(:func:`analysis.batch.outputs.write_atomically`); the folder is not an output of the run (not in
its list of outputs) and holds no session file, so it is never read as an input. A run that
finishes removes the entries it did not use: the cache holds the last run's sessions. A
failed session is never cached (a failure may be a time limit or a worker that died). An
entry that cannot be read is ignored with a note and the session analysed again; only the
tables, names and plain values an entry is known to hold are unpickled, never other code.

What a run reuses of the previous run's files (each session's ``results_*.mcap``, the
tables, ``summary.json`` and the report) is checked by the SHA-256 of its bytes, recorded
when it was written: a file edited since, whatever its size and modification time, is
written anew.
"""

from __future__ import annotations

import contextlib
import dataclasses
import enum
import functools
import hashlib
import io
import json
import os
import pickle
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

from twopose.errors import TwoposeError

if TYPE_CHECKING:
    import pandas as pd

    from analysis.batch.inputs import SessionIdentity
    from analysis.batch.noise_pass import NoisePass
    from analysis.results import AnalysisOptions, SessionFailure, SessionResult

__all__ = ["CACHE_FOLDER", "SessionCache", "code_version", "options_digest"]

#: Inside ``--out``: what a run keeps for the next one (not one of its outputs).
CACHE_FOLDER = ".twopose-cache"
_SESSIONS = "sessions"
_SUFFIX = ".pickle"
_FORMAT = 2  # an entry's layout; another one is a miss
_STARTED = ".run-started"  # its modification time: entries older were not used by the run
_OUTPUTS = "outputs.json"  # the last run's outputs: its key and each one's SHA-256
#: The SessionResult fields an entry keeps (the figures are the figure cache's).
_FIELDS = ("session", "metadata", "frames", "trials", "averaging", "views", "rig", "label")
#: The first pass's entries (analysis.batch.noise_pass): their key's salt and their suffix.
_FIRST_PASS, _FIRST_PASS_SUFFIX = "first pass", ".noise.pickle"


@functools.cache
def code_version() -> str:
    """A digest of the code that computes a session's tables: twopose's version, every
    file of the ``analysis`` and ``twopose`` packages, and the versions of the libraries
    that compute (a change to any makes every session be analysed anew)."""
    import cv2
    import numpy
    import pandas

    from twopose import __version__

    root = Path(__file__).resolve().parents[2]
    h = hashlib.sha256(_text(f"{__version__}\0{sys.version}\0{numpy.__version__}\0"))
    h.update(_text(f"{pandas.__version__}\0{cv2.__version__}\0"))
    for package in ("analysis", "twopose"):
        for path in sorted((root / package).rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                h.update(_text(f"\1{path.relative_to(root).as_posix()}\0") + path.read_bytes())
    return h.hexdigest()


def options_digest(options: AnalysisOptions, *, tables_only: bool = False) -> str:
    """A digest of every field of ``options``, nested records and the rig included; with
    ``tables_only``, of those that shape a session's tables (every field but the ones
    :data:`analysis.results.RUN_ONLY` marks: the summary's, the figures', the time limit's)."""
    canonical = _canonical(options)
    if tables_only:
        from analysis.results import shapes_session_tables

        fields = canonical["fields"].items()
        canonical["fields"] = {k: v for k, v in fields if shapes_session_tables(k)}
    return hashlib.sha256(_text(json.dumps(canonical))).hexdigest()


def _canonical(value: Any) -> Any:
    """``value`` as plain JSON, exactly (floats by their ``repr``, which round-trips)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {f.name: _canonical(getattr(value, f.name)) for f in dataclasses.fields(value)}
        return {"type": type(value).__qualname__, "fields": fields}
    if isinstance(value, enum.Enum):
        return {"enum": type(value).__qualname__, "value": _canonical(value.value)}
    if isinstance(value, bool | int | str) or value is None:
        return value
    if isinstance(value, float):
        return {"float": repr(value)}
    if isinstance(value, list | tuple):
        return [_canonical(v) for v in value]
    if isinstance(value, dict):
        return [[_canonical(k), _canonical(v)] for k, v in sorted(value.items(), key=str)]
    if hasattr(value, "tobytes") and hasattr(value, "dtype"):  # a NumPy array or scalar
        digest = hashlib.sha256(value.tobytes()).hexdigest()
        return {"array": [str(value.dtype), list(getattr(value, "shape", ())), digest]}
    return {"repr": f"{type(value).__qualname__}:{value!r}"}


def _text(text: str) -> bytes:
    return text.encode("utf-8", "surrogatepass")


@dataclass(frozen=True)
class SessionCache:
    """The analyses a previous run into ``--out`` kept, and where this run keeps its own.

    Picklable (paths and a digest), so worker processes look in it and add to it too.
    ``reuse`` False (``run --no-reuse``): nothing is read, every session is analysed and
    its entry written afresh for the next run.
    """

    folder: str  # <out>/.twopose-cache/sessions
    destination: str  # <out>: where the previous run's results.mcap files are
    setting: str  # the options' (those that shape a session) and the code's digest
    run_setting: str = ""  # every option's digest: the run's own outputs depend on all
    reuse: bool = True

    @classmethod
    def of(cls, out: str | Path, options: AnalysisOptions, *, reuse: bool = True) -> SessionCache:
        """The cache of the output folder ``out`` for a run with ``options``; marks the
        run's start (entries it neither reuses nor writes are removed by :meth:`prune`)."""
        folder = Path(out) / CACHE_FOLDER / _SESSIONS
        setting = f"{options_digest(options, tables_only=True)}:{code_version()}"
        cache = cls(str(folder), str(out), setting, options_digest(options), reuse)
        try:
            folder.mkdir(parents=True, exist_ok=True)
            _write(folder / _STARTED, b"")
        except (OSError, TwoposeError) as err:
            _note(
                f"cannot keep the sessions' analyses in {folder} ({err}); a re-run analyses again"
            )
        return cache

    def with_options(self, options: AnalysisOptions) -> SessionCache:
        """The same cache, its entries keyed on ``options`` too: a session's own (its rig
        file, :mod:`analysis.rig.scope`), beside everything the run's key holds."""
        own = options_digest(options, tables_only=True)
        return dataclasses.replace(self, setting=f"{self.setting}:{own}")

    def key(
        self, path: str, continuations: Sequence[str], identity: SessionIdentity, salt: str = ""
    ) -> str:
        """The entry's name: a digest of the session's identity, its parts' bytes, the
        options, the environment and the code (see the module docstring); ``salt``: what else
        the session's analysis depends on (its prior from its operator's other sessions,
        :func:`analysis.batch.noise_pass.prior_salt`; the first pass's entry)."""
        from twopose.values.environment import results_environment

        h = hashlib.sha256(_text(f"{_FORMAT}\0{self.setting}\0{salt}\0"))
        h.update(_text(json.dumps(_canonical(results_environment()))))
        h.update(_text(json.dumps(_canonical([str(path), [str(c) for c in continuations]]))))
        h.update(_text(json.dumps(_canonical(identity))))
        for part in (path, *continuations):
            with open(part, "rb") as fh:
                h.update(hashlib.file_digest(fh, "sha256").digest())
        return h.hexdigest()

    def outcome(
        self,
        path: str,
        continuations: Sequence[str],
        identity: SessionIdentity | None,
        results: str | None,
        analyse: Callable[[], SessionResult | SessionFailure],
        salt: str = "",
    ) -> SessionResult | SessionFailure:
        """Session ``path``'s outcome: the kept analysis when its entry is there (see
        :meth:`key`, ``salt`` in it), else ``analyse()``'s, kept for the next run when it
        succeeded and its files did not change while it ran."""
        parts = (path, *continuations)
        try:
            before = [_stamp(p) for p in parts]
            if identity is None:  # as the analysis names it (analysis.session.pipeline)
                from analysis.batch.inputs import SessionIdentity

                identity = SessionIdentity.of_files(path, continuations)
            key = self.key(path, continuations, identity, salt)
        except OSError:  # unreadable: the analysis says why
            return analyse()
        kept = self.load(key, results)
        if kept is not None:
            return dataclasses.replace(kept, analysis_key=key)
        outcome = analyse()
        from analysis.results import SessionResult

        with contextlib.suppress(OSError):
            if isinstance(outcome, SessionResult) and [_stamp(p) for p in parts] == before:
                self.store(key, outcome, results)
                return dataclasses.replace(outcome, analysis_key=key)
        return outcome

    def noise(
        self,
        path: str,
        continuations: Sequence[str],
        identity: SessionIdentity | None,
        compute: Callable[[], NoisePass | SessionFailure],
    ) -> NoisePass | SessionFailure:
        """Session ``path``'s first pass (:mod:`analysis.batch.noise_pass`): its statistics as
        the previous run kept them under the session's key, else ``compute()``'s, kept."""
        from analysis.batch.noise_pass import NoisePass, statistics_from_json, statistics_json

        try:
            if identity is None:
                from analysis.batch.inputs import SessionIdentity

                identity = SessionIdentity.of_files(path, continuations)
            key = self.key(path, continuations, identity, _FIRST_PASS)
        except OSError:
            return compute()
        entry_path = Path(self.folder) / f"{key}{_FIRST_PASS_SUFFIX}"
        if self.reuse:
            with contextlib.suppress(Exception):  # unreadable or another's: computed again
                entry = _SafeUnpickler(io.BytesIO(entry_path.read_bytes())).load()
                if (entry["format"], entry["key"]) == (_FORMAT, key):
                    os.utime(entry_path)  # used by this run: kept by prune
                    return NoisePass(session=path, statistics=statistics_from_json(entry["stats"]))
        done = compute()
        if isinstance(done, NoisePass):
            kept = {"format": _FORMAT, "key": key, "stats": statistics_json(done.statistics)}
            with contextlib.suppress(Exception):  # a saving, never a reason to fail
                _write(entry_path, pickle.dumps(kept, protocol=5))
        return done

    def load(self, key: str, results: str | None) -> SessionResult | None:
        """The session as the entry ``key`` keeps it, with its results.mcap linked to
        ``results`` when asked; None when there is no usable entry (a session to analyse)."""
        if not self.reuse:
            return None
        path = Path(self.folder) / f"{key}{_SUFFIX}"
        try:
            data = path.read_bytes()
        except OSError:
            return None
        try:
            entry = _SafeUnpickler(io.BytesIO(data)).load()
            fields = {name: entry["fields"][name] for name in _FIELDS}
            scene = entry["results_mcap"]
            kept_for = (entry["format"], entry["key"])
        except Exception as err:  # corrupt, truncated, tampered: analysed again, said
            _note(f"ignored the unreadable cached analysis {path} ({type(err).__name__}); "
                  "the session is analysed again")  # fmt: skip
            return None
        if kept_for != (_FORMAT, key):  # renamed or copied in: another session's, or older
            _note(f"ignored the cached analysis {path}: it was kept for another session, "
                  "options or version; the session is analysed again")  # fmt: skip
            return None
        if results is not None and not self._link_scene(scene, Path(results)):
            return None
        from analysis.results import SessionResult

        result = SessionResult(**fields, analysis_reused=True)
        if results is not None and scene["name"] != Path(results).name:
            self.store(key, result, results)  # its results.mcap has another number now
        else:
            os.utime(path)  # used by this run: kept by prune
        return result

    def _link_scene(self, scene: Any, results: Path) -> bool:
        """The previous run's results.mcap of the session, its bytes unchanged since it was
        written (their SHA-256), linked (or else copied) to ``results``; False when there is
        none."""
        if not isinstance(scene, dict):
            return False
        previous = Path(self.destination) / str(scene.get("name", ""))
        try:
            if Path(str(scene.get("name", ""))).name != scene.get("name"):
                return False  # a name that reaches out of the folder: not ours
            if _sha256(previous) != scene.get("sha256"):
                return False
            results.unlink(missing_ok=True)
            try:
                os.link(previous, results)
            except OSError:  # a file system without hard links
                import shutil

                shutil.copy2(previous, results)
        except OSError:
            return False
        return True

    def store(self, key: str, result: SessionResult, results: str | None) -> None:
        """Keep ``result`` (an analysed session, with the results.mcap it wrote, if any)
        under ``key`` for the next run; a failure to write is said, never the run's end."""
        scene = None
        if results is not None:
            try:
                scene = {"name": Path(results).name, "sha256": _sha256(Path(results))}
            except OSError:
                return  # no results.mcap where one was asked: nothing safe to keep
        entry = {
            "format": _FORMAT,
            "key": key,
            "fields": {name: getattr(result, name) for name in _FIELDS},
            "results_mcap": scene,
        }
        try:
            _write(Path(self.folder) / f"{key}{_SUFFIX}", pickle.dumps(entry, protocol=5))
        except Exception as err:  # the cache is a saving, never a reason to fail
            _note(f"cannot keep the analysis of {result.session} for a re-run ({err})")

    def computed(self, name: str, compute: Callable[[], pd.DataFrame]) -> pd.DataFrame:
        """A table that depends on the code alone (the report's seeded sensitivity sweeps),
        as the previous run kept it in ``<out>/.twopose-cache/<name>.pickle`` for the same
        :func:`code_version`; else ``compute()``'s, kept for the next run."""
        path = Path(self.folder).parent / f"{name}{_SUFFIX}"
        key = f"{_FORMAT}:{code_version()}"
        if self.reuse and path.is_file():
            try:
                entry = _SafeUnpickler(io.BytesIO(path.read_bytes())).load()
                if entry["key"] == key:
                    return cast("pd.DataFrame", entry["table"])
            except Exception as err:  # corrupt: computed again, said
                _note(f"ignored the unreadable {path} ({type(err).__name__}); computed again")
        table = compute()
        try:
            _write(path, pickle.dumps({"key": key, "table": table}, protocol=5))
        except Exception as err:  # a saving, never a reason to fail
            _note(f"cannot keep {path} for a re-run ({err})")
        return table

    def outputs(
        self,
        outcomes: Sequence[SessionResult | SessionFailure],
        notes: Sequence[str],
        staging: Path,
        write: Callable[[], list[str]],
    ) -> list[str]:
        """The run's own outputs (tables, summary.json, report) in ``staging``: the
        previous run's, linked, when every session and the ``notes`` on the inputs are the
        same as then and its files' bytes are unchanged (their SHA-256); else ``write()``'s,
        kept for the next run. Their names."""
        from analysis.results import SessionResult

        keys = [o.analysis_key if isinstance(o, SessionResult) else "" for o in outcomes]
        run_key = ""  # a failure, or a session not kept: written anew, never linked
        if keys and all(keys):
            h = hashlib.sha256(_text(f"{_FORMAT}\0{self.setting}\0{self.run_setting}\0"))
            h.update(_text(json.dumps([keys, list(notes)])))
            run_key = h.hexdigest()
        index = Path(self.folder).parent / _OUTPUTS
        if run_key and self.reuse:
            linked = self._link_outputs(index, run_key, staging)
            if linked is not None:
                return linked
        names = write()
        with contextlib.suppress(OSError):  # each file's bytes: what the next run checks
            digests = {n: _sha256(staging / n) for n in names}
            document = json.dumps({"key": run_key, "files": digests}, indent=1)
            with contextlib.suppress(TwoposeError):
                _write(index, document.encode())
        return names

    def written_digests(self) -> dict[str, str]:
        """The SHA-256 of each output the previous run into ``--out`` wrote, by name (its
        figures' among them: :class:`analysis.report.figures.cache.FigureCache` reuses only those
        whose bytes these are); empty when it recorded none."""
        try:
            entry = json.loads((Path(self.folder).parent / _OUTPUTS).read_text(encoding="utf-8"))
            return {str(n): str(v) for n, v in entry["files"].items()}
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            return {}

    def _link_outputs(self, index: Path, run_key: str, staging: Path) -> list[str] | None:
        """The previous run's outputs listed in ``index`` for ``run_key``, each one's bytes
        unchanged since it was written (its SHA-256), linked into ``staging``."""
        try:
            entry = json.loads(index.read_text(encoding="utf-8"))
            if not run_key or entry["key"] != run_key:
                return None
            files = {str(n): str(v) for n, v in entry["files"].items()}
        except (OSError, ValueError, KeyError, TypeError, AttributeError):
            return None
        linked: list[str] = []
        for name, digest in files.items():
            previous, here = Path(self.destination) / name, staging / name
            try:
                if Path(name).name != name or _sha256(previous) != digest:
                    raise FileNotFoundError(name)
                here.unlink(missing_ok=True)
                os.link(previous, here)
            except OSError:  # changed, gone or not linkable: everything written anew
                for done in linked:
                    (staging / done).unlink(missing_ok=True)
                return None
            linked.append(name)
        return linked

    def prune(self) -> None:
        """Remove the entries this run neither reused nor wrote (a finished run's)."""
        folder = Path(self.folder)
        try:
            started = (folder / _STARTED).stat().st_mtime_ns
            entries = list(folder.iterdir())
        except OSError:
            return
        for path in entries:
            try:
                if path.name != _STARTED and path.stat().st_mtime_ns < started:
                    path.unlink()
            except OSError:
                continue


def _stamp(path: str) -> tuple[int, int, int]:
    """What tells a file changed while it was analysed (its bytes are hashed before)."""
    st = os.stat(path)
    return st.st_ino, st.st_size, st.st_mtime_ns


def _sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes (what tells an output was not changed since)."""
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def _write(path: Path, data: bytes) -> None:
    from analysis.batch.outputs import write_atomically

    write_atomically(path, data)


def _note(text: str) -> None:
    from analysis.report.figures.drawer import note

    note(text)


#: What an entry may hold, exactly (module, name): tables, plain values and the enums of
#: a session's metadata; anything else (a file someone else put there) is refused unread.
_ALLOWED = frozenset(
    {
        ("builtins", "slice"),
        ("numpy", "dtype"),
        ("numpy", "ndarray"),
        ("numpy._core.multiarray", "_reconstruct"),
        ("numpy._core.numeric", "_frombuffer"),
        ("numpy.core.multiarray", "_reconstruct"),
        ("numpy.core.numeric", "_frombuffer"),
        ("pandas", "BooleanDtype"),
        ("pandas", "DataFrame"),
        ("pandas", "Float64Dtype"),
        ("pandas", "Index"),
        ("pandas", "Int64Dtype"),
        ("pandas", "RangeIndex"),
        ("pandas", "StringDtype"),
        ("pandas._libs.arrays", "__pyx_unpickle_NDArrayBacked"),
        ("pandas._libs.internals", "_unpickle_block"),
        ("pandas.arrays", "BooleanArray"),
        ("pandas.arrays", "FloatingArray"),
        ("pandas.arrays", "IntegerArray"),
        ("pandas.arrays", "StringArray"),
        ("pandas.core.indexes.base", "_new_Index"),
        ("pandas.core.internals.managers", "BlockManager"),
        ("twopose.methods.specs", "Method"),
        ("twopose.values.units", "Units"),
    }
)


class _SafeUnpickler(pickle.Unpickler):
    """Unpickles only what an entry holds (:data:`_ALLOWED`), so that a file put in the
    cache folder by someone else cannot run code."""

    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in _ALLOWED:
            raise pickle.UnpicklingError(f"{module}.{name} is not what a cached analysis holds")
        return super().find_class(module, name)
