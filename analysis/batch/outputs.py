"""The output folder of a run: created safely, written atomically, one run at a time.

* A run is one transaction (:class:`OutputFolder`): it writes into a staging folder inside
  ``--out`` and moves its files in only when it has finished, so Ctrl-C, SIGTERM, a crash
  or a full disk leave the previous results exactly as they were and no stray file.
* Every file a run writes into ``--out`` is listed in ``.twopose-outputs.json`` there. The
  commit replaces the files that list names (and only those: never a file it did not
  write), so no stale per-session file of an earlier run survives with numbering that no
  longer matches.
* Every file twopose-analyze writes is written under a temporary name, synced and renamed
  into place, and its folder synced (:func:`replacing`, :func:`write_atomically`: the one
  way): a full disk or a crash leaves the previous file or none, never half of one; a
  symlink at the destination is replaced, never followed; a folder, FIFO or device there
  is refused.
* No output replaces an input (:class:`Inputs`): an output file or folder that is an
  input, lies inside a run folder being read, or (a file) is not a regular file or a new
  name is refused before anything is written.
* An advisory ``flock`` on the folder itself (released when the process ends, however it
  ends; no lock file) refuses a second run into the same folder while one is writing.

A finished run's tables are read back by :mod:`analysis.tables.read_back`.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import stat
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Self

from twopose.atomic_write import (
    fsync_path,
    partial_name,
    refuse_special,
    replacing,
    write_atomically,
)
from twopose.errors import InputValueError, TwoposeError
from twopose.format.reader import STAGING_FOLDER

if TYPE_CHECKING:
    from analysis.batch.inputs import InputSet

__all__ = [
    "LOCK_NAME",
    "MANIFEST_NAME",
    "STAGING_NAME",
    "Inputs",
    "OutputFolder",
    "check_run_outputs",
    "partial_name",
    "printable_stem",
    "replacing",
    "run_inputs",
    "write_atomically",
    "write_file",
]

MANIFEST_NAME = ".twopose-outputs.json"
LOCK_NAME = ".twopose-run.lock"  # twopose before 0.2 locked with this file; removed when seen
STAGING_NAME = STAGING_FOLDER  # inside --out: where a run writes until it commits
_COMMITTING = ".committing"  # in the staging folder: its outputs are being moved in


def printable_stem(session: str | Path) -> str:
    """A session's stem for output names, from its label (``a/session.mcap``:
    ``a_session``, the folders that tell it apart kept): UTF-8-safe, at most 100 characters
    (names are limited to 255 bytes, and a non-UTF-8 name cannot go into a CSV or a page)."""
    path = Path(session)
    stem = "_".join([*path.parent.parts, path.stem]) if not path.is_absolute() else path.stem
    stem = stem.lstrip("._") or path.stem
    return stem.encode("utf-8", "surrogateescape").decode("utf-8", "replace")[:100]


def write_file(path: Path, data: bytes) -> None:
    """``data`` written to ``path`` (:func:`write_atomically`), its folder created if need
    be: a file the user named (``--junit``, ``rig --out``), checked first with
    :meth:`Inputs.check_file`."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise InputValueError(f"cannot create the folder {path.parent}: {err.strerror}") from err
    write_atomically(path, data)


class OutputFolder:
    """A run's ``--out`` folder, written as one transaction (see the module docstring).

    :attr:`path` is where the run writes: a staging folder inside the destination
    (:data:`STAGING_NAME`). Leaving the ``with`` block normally after :meth:`record`
    commits: each listed file replaces its namesake in :attr:`destination`, the previous
    run's other outputs are removed and the new list written, with Ctrl-C and SIGTERM held
    back for those few renames. Leaving it any other way (an error, Ctrl-C, a full disk)
    discards the staging folder: the previous results stay exactly as they were. A run
    killed outright leaves its staging folder, which the next run into the folder rolls
    forward (if it was committing) or removes (if not) before anything else.
    """

    def __init__(self, destination: Path, lock_fd: int) -> None:
        self.destination = destination
        self.path = destination / STAGING_NAME
        self._lock: int | None = lock_fd
        self._recorded = False

    @classmethod
    def prepare(cls, path: str | Path) -> OutputFolder:
        """Create the folder (and parents), take its lock, finish or discard what a killed
        run left, and open a fresh staging folder.

        Raises
        ------
        InputValueError
            ``path`` is an existing file, cannot be created or written to, or another run
            is writing into it.
        """
        folder = Path(path)
        if folder.exists() and not folder.is_dir():
            raise InputValueError(f"--out {folder} is a file; give a folder for the results")
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise InputValueError(
                f"cannot create the output folder {folder}: {err.strerror or err}"
            ) from err
        if not os.access(folder, os.W_OK | os.X_OK):
            raise InputValueError(f"cannot write into the output folder {folder}")
        out = cls(folder, _lock_folder(folder))
        try:
            out._recover()
            out.path.mkdir(exist_ok=True)  # a staging folder that could not be removed: reused
        except BaseException:
            out.close()
            raise
        return out

    def close(self) -> None:
        """Release the lock (a lock on the folder itself: no lock file is left behind)."""
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        try:
            if exc_type is None and self._recorded:
                self.commit()
            else:
                self.discard()
        finally:
            self.close()

    def _manifest(self) -> Path:
        return self.destination / MANIFEST_NAME

    def previous_outputs(self) -> list[str]:
        """The file names the previous run listed (an unreadable list counts as empty)."""
        return _listed(self._manifest())

    def write_bytes(self, name: str, data: bytes) -> None:
        write_atomically(self.path / name, data)

    def record(self, names: Iterable[str]) -> None:
        """List the files this run wrote (those that exist in staging): what the commit
        moves into the destination, and what the next run will replace."""
        present = sorted({n for n in names if _plain_name(n) and (self.path / n).is_file()})
        text = json.dumps({"written_by": "twopose-analyze run", "files": present}, indent=1)
        self.write_bytes(MANIFEST_NAME, (text + "\n").encode())
        self._recorded = True

    def commit(self) -> None:
        """Move the staged outputs into the destination (signals held back meanwhile)."""
        with _signals_held():
            write_atomically(self.path / _COMMITTING, b"")  # from here on: roll forward
            _move_staged(self.path, self.destination)

    def discard(self) -> None:
        """Remove the staging folder: the destination keeps the previous results."""
        shutil.rmtree(self.path, ignore_errors=True)

    def _recover(self) -> None:
        """What a killed run left: a commit half done is finished, anything else staged is
        removed; the lock file of twopose before 0.2 is removed too."""
        if (self.path / _COMMITTING).exists():
            _move_staged(self.path, self.destination)
        shutil.rmtree(self.path, ignore_errors=True)
        with contextlib.suppress(OSError):
            legacy = self.destination / LOCK_NAME
            if legacy.is_file() and not legacy.is_symlink():
                legacy.unlink()


def _lock_folder(folder: Path) -> int:
    """An advisory lock on the folder itself (released when the process ends, however it
    ends); refuses a second run into it while one is writing."""
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as err:
        raise InputValueError(f"cannot lock the output folder {folder}: {err}") from err
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError as err:
        os.close(fd)
        raise InputValueError(
            f"another twopose-analyze run is writing into {folder}; wait for it to "
            "finish or choose another --out"
        ) from err
    return fd


def _listed(manifest: Path) -> list[str]:
    try:
        names = json.loads(manifest.read_text(encoding="utf-8"))["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return []
    return [n for n in names if isinstance(n, str) and _plain_name(n)]


def _move_staged(staging: Path, destination: Path) -> None:
    """The commit (idempotent, so a killed one is finished by the next run): each staged
    output over its namesake, the previous run's other outputs removed, then the new list;
    the destination folder synced."""
    new = _listed(staging / MANIFEST_NAME)
    previous = _listed(destination / MANIFEST_NAME)
    try:
        for name in new:
            if (staging / name).is_file():
                refuse_special(destination / name)
                os.replace(staging / name, destination / name)
        for name in sorted(set(previous) - set(new)):
            (destination / name).unlink(missing_ok=True)  # a symlink itself, not its target
        if (staging / MANIFEST_NAME).is_file():
            os.replace(staging / MANIFEST_NAME, destination / MANIFEST_NAME)
        fsync_path(destination, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as err:
        raise TwoposeError(
            f"cannot move the results into {destination}: {err.strerror or err}; the next "
            "run into it finishes the move"
        ) from err
    shutil.rmtree(staging, ignore_errors=True)


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM held back (not lost) for the commit's few renames."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _plain_name(name: str) -> bool:
    """A file name directly inside the folder (a tampered list cannot reach elsewhere)."""
    return bool(name) and name not in (".", "..", MANIFEST_NAME) and Path(name).name == name


@dataclass(frozen=True, kw_only=True)
class Inputs:
    """What a command reads, which none of its outputs may replace: ``files`` (sessions, a
    rig or tolerance file) and ``folders`` (run folders being read, wholly). Paths are
    compared by what they are on disk (symlinks resolved, by device and inode), so another
    spelling, a symlink or a hard link to an input is the input."""

    files: tuple[Path, ...] = ()
    folders: tuple[Path, ...] = ()

    def check_file(self, option: str, path: Path | None, *, beside: Path | None = None) -> None:
        """Refuse ``path`` as the file ``option`` writes when it is an input, lies inside
        an input folder, or is anything but a regular file or a new name (a folder, FIFO,
        device). ``beside``: a folder the same command writes its own files into, where
        this file must be ``.xml`` so as not to replace one of them."""
        if path is None:
            return
        where = f"{option} {path}"
        target = _stat(path)  # follows a symlink: what a write could reach
        if target is not None:
            if stat.S_ISDIR(target.st_mode):
                raise InputValueError(f"{where} is a folder; give a file name")
            if not stat.S_ISREG(target.st_mode):
                raise InputValueError(
                    f"{where} is not a regular file (a FIFO, device or socket); give a new "
                    "file name"
                )
            for f in self.files:
                if _same(target, f):
                    raise InputValueError(f"{where} is the input {f}; give a new file name")
            self._no_link_into_folders(where, target)
        self._outside_folders(where, path)
        ancestor = _nearest_existing(path.parent)
        if ancestor is not None and not ancestor.is_dir():
            raise InputValueError(f"{where}: {ancestor} is not a folder")
        if beside is not None and _inside(beside, path):
            raise InputValueError(f"{where} is the folder the results go to; give a file name")
        if beside is not None and _inside(path, beside) and path.suffix != ".xml":
            raise InputValueError(
                f"{where} is in {beside}, where the run writes its own files: give it a name "
                "ending in .xml, or write it elsewhere"
            )

    def check_folder(self, option: str, path: Path) -> None:
        """Refuse ``path`` as the folder ``option`` writes into when it is not a folder,
        is or lies inside an input folder, or directly holds an input file."""
        where = f"{option} {path}"
        target = _stat(path)
        if target is not None and not stat.S_ISDIR(target.st_mode):
            what = "a file" if stat.S_ISREG(target.st_mode) else "not a folder"
            raise InputValueError(f"{where} is {what}; give a folder for the results")
        self._outside_folders(where, path)
        if target is not None:
            for f in self.files:
                parent = _stat(f.parent)
                if parent is not None and os.path.samestat(parent, target):
                    raise InputValueError(
                        f"{where} holds the input {f}; give a folder of its own for the "
                        f"results (e.g. {path / 'results'})"
                    )

    def _no_link_into_folders(self, where: str, target: os.stat_result) -> None:
        """A file with other names (a hard link) is refused when one of them lies in an
        input folder: writing it would change what is being read."""
        if target.st_nlink < 2:
            return
        for folder in self.folders:
            for f in _files_below(folder):
                if _same(target, f):
                    raise InputValueError(
                        f"{where} is the file {f} of the run folder {folder} being read (a "
                        "hard link to it); give a new file name"
                    )

    def _outside_folders(self, where: str, path: Path) -> None:
        for folder in self.folders:
            if _inside(path, folder):
                raise InputValueError(
                    f"{where} is, or is inside, the run folder {folder} being read; "
                    "write it elsewhere"
                )


def _files_below(folder: Path) -> Iterator[Path]:
    """Every file below ``folder`` (none when it cannot be listed)."""
    for root, _dirs, names in os.walk(folder):
        for name in names:
            yield Path(root) / name


def _stat(path: Path) -> os.stat_result | None:
    try:
        return os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None
    except OSError as err:
        raise InputValueError(f"cannot examine {path}: {err.strerror or err}") from err


def _same(st: os.stat_result, other: Path) -> bool:
    theirs = _stat(other)
    return theirs is not None and os.path.samestat(st, theirs)


def _inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` (existing or not) is ``folder`` or lies below it, symlinks resolved;
    an existing ``folder`` is compared by device and inode, a new one by its path."""
    resolved = _resolved(path)
    theirs = _stat(folder)
    if theirs is None:
        mine = _resolved(folder)
        return resolved == mine or mine in resolved.parents
    for ancestor in (resolved, *resolved.parents):
        st = _stat(ancestor)
        if st is not None and os.path.samestat(st, theirs):
            return True
    return False


def _resolved(path: Path) -> Path:
    try:
        return path.resolve()
    except (OSError, RuntimeError) as err:  # a symlink loop
        raise InputValueError(f"cannot resolve {path}: {err}") from err


def _nearest_existing(path: Path) -> Path | None:
    for ancestor in (path, *path.parents):
        if os.path.lexists(ancestor):
            return ancestor
    return None


def check_run_outputs(
    sessions: InputSet, out: Path, junit: Path | None, *rigs: Path | None
) -> None:
    """``run``'s ``--out`` and ``--junit`` checked against its inputs (:class:`Inputs`):
    its sessions and the rig files they use."""
    inputs = run_inputs(sessions, *rigs)
    inputs.check_folder("--out", out)
    inputs.check_file("--junit", junit, beside=out)


def run_inputs(sessions: InputSet, *more: Path | None) -> Inputs:
    """The files a ``run`` or ``rig`` reads: its resolved sessions (a folder is only
    searched: results may go below it; the results files of an earlier run found there are
    not read, so its output folder stays ours, run after run) and ``more`` (a rig file)."""
    files = tuple(Path(p) for p in sessions.paths)
    return Inputs(files=files + tuple(p for p in more if p is not None))
