"""The output folder of a run: created safely, written atomically, one run at a time.

* Every file a run writes into ``--out`` is listed in ``.twopose-outputs.json`` there. The
  next run into the same folder first removes the files that list names (and only those:
  never a file it did not write), so no stale per-session file of an earlier run survives
  with numbering that no longer matches.
* Every file is written under a temporary name and renamed into place
  (:func:`write_atomically`): a full disk or a crash leaves the previous file or none, never
  half of one, and a symlink at the destination is replaced, never followed.
* ``.twopose-run.lock`` (an advisory ``flock``, released when the process ends, however it
  ends) refuses a second run into the same folder while one is writing.
* A finished run's tables are read back (``check``, ``compare``) with
  :func:`read_results_table`, its sessions named by :func:`session_keys`.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
from collections.abc import Iterable
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Self

from twopose.errors import InputValueError, TwoposeError

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "LOCK_NAME",
    "MANIFEST_NAME",
    "OutputFolder",
    "partial_name",
    "printable_stem",
    "read_results_table",
    "session_keys",
    "write_atomically",
]

MANIFEST_NAME = ".twopose-outputs.json"
LOCK_NAME = ".twopose-run.lock"


def printable_stem(session: str | Path) -> str:
    """A session's file stem for output names: UTF-8-safe, at most 100 characters (names
    are limited to 255 bytes, and a non-UTF-8 name cannot go into a CSV or a page)."""
    stem = Path(session).stem.encode("utf-8", "surrogateescape").decode("utf-8", "replace")
    return stem[:100]


def partial_name(path: Path) -> Path:
    """Where ``path`` is written before it is renamed into place."""
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


def write_failed(path: Path, err: OSError) -> TwoposeError:
    """The error for a write that failed (a full disk says so)."""
    if err.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return TwoposeError(f"cannot write {path}: the disk is full; free some space and run again")
    return TwoposeError(f"cannot write {path}: {err.strerror or err}")


def write_atomically(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` under a temporary name, sync it, and rename it into place;
    on any failure the temporary file is removed and ``path`` is untouched."""
    tmp = partial_name(path)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)  # renames over a symlink; never writes through it
    except OSError as err:
        tmp.unlink(missing_ok=True)
        raise write_failed(path, err) from err
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


class OutputFolder:
    """A run's ``--out`` folder (see the module docstring); a context manager that holds
    the folder's lock."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._lock: int | None = None

    @classmethod
    def prepare(cls, path: str | Path) -> OutputFolder:
        """Create the folder (and parents), take its lock, and remove what the previous run
        wrote there.

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
        out = cls(folder)
        out._take_lock()
        try:
            out._remove_previous()
        except BaseException:
            out.close()
            raise
        return out

    def _take_lock(self) -> None:
        lock = self.path / LOCK_NAME
        try:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o644)
        except OSError as err:
            raise InputValueError(f"cannot lock the output folder {self.path}: {err}") from err
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as err:
            os.close(fd)
            raise InputValueError(
                f"another twopose-analyze run is writing into {self.path}; wait for it to "
                "finish or choose another --out"
            ) from err
        self._lock = fd

    def close(self) -> None:
        """Release the lock (the lock file stays: removing it would race a waiting run)."""
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
        self.close()

    def _manifest(self) -> Path:
        return self.path / MANIFEST_NAME

    def previous_outputs(self) -> list[str]:
        """The file names the previous run listed (an unreadable list counts as empty)."""
        try:
            names = json.loads(self._manifest().read_text(encoding="utf-8"))["files"]
        except (OSError, ValueError, KeyError, TypeError):
            return []
        return [n for n in names if isinstance(n, str) and _plain_name(n)]

    def _remove_previous(self) -> None:
        for name in self.previous_outputs():
            try:
                (self.path / name).unlink(missing_ok=True)  # a symlink itself, not its target
            except OSError as err:
                raise TwoposeError(
                    f"cannot replace {self.path / name} from an earlier run: {err.strerror}"
                ) from err
        for stale in self.path.glob(".*.partial"):  # left by a run that was killed
            with contextlib.suppress(OSError):
                stale.unlink()
        self._manifest().unlink(missing_ok=True)

    def write_bytes(self, name: str, data: bytes) -> None:
        write_atomically(self.path / name, data)

    def record(self, names: Iterable[str]) -> None:
        """List the files this run wrote (those that exist), for the next run to replace."""
        present = sorted({n for n in names if _plain_name(n) and (self.path / n).is_file()})
        text = json.dumps({"written_by": "twopose-analyze run", "files": present}, indent=1)
        self.write_bytes(MANIFEST_NAME, (text + "\n").encode())


def _plain_name(name: str) -> bool:
    """A file name directly inside the folder (a tampered list cannot reach elsewhere)."""
    return bool(name) and name not in (".", "..", MANIFEST_NAME) and Path(name).name == name


def read_results_table(folder: str | Path, name: str) -> pd.DataFrame:
    """``folder/name`` (a CSV table a run wrote), or an error saying how to make it."""
    import pandas as pd

    path = Path(folder) / name
    if not Path(folder).is_dir():
        raise InputValueError(f"{folder} is not a folder: give a run's --out folder")
    try:
        table = pd.read_csv(path, keep_default_na=True)
    except FileNotFoundError as err:
        raise InputValueError(
            f"no {name} in {folder}: give the --out folder of a finished `twopose-analyze run`"
        ) from err
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise InputValueError(f"cannot read {path}: {err}") from err
    missing = {"session", "method"} - set(table.columns)
    if missing:
        raise InputValueError(f"{path} is not a twopose table: no {', '.join(sorted(missing))}")
    return table


def session_keys(sessions: pd.Series) -> pd.Series:
    """Each session's path below the run's common folder: ``sessions/a.mcap`` and
    ``/ci/clone/sessions/a.mcap`` are both ``a.mcap``, so that two runs of the same
    sessions from different places match."""
    paths = [str(s) for s in sessions]
    parents = {os.path.dirname(p) for p in paths}
    try:
        common = os.path.commonpath(list(parents)) if parents and "" not in parents else ""
    except ValueError:  # absolute and relative paths mixed
        common = ""
    return sessions.map(lambda s: os.path.relpath(str(s), common) if common else str(s))
