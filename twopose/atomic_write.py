"""The one way a file is written in place of another.

Under a temporary name beside it, synced, renamed into place and its folder synced, so a
crash or a full disk leaves the previous file or the new one, never half of one; a symlink
at the destination is replaced, never followed; a folder, FIFO or device there is refused.
Both sides write through it: the analyst's outputs (:mod:`analysis.batch.outputs`) and the
operator's files (the noise history).
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
from collections.abc import Iterator
from pathlib import Path

from twopose.errors import InputValueError, TwoposeError

__all__ = [
    "fsync_path",
    "partial_name",
    "refuse_special",
    "replacing",
    "write_atomically",
    "write_failed",
]


def partial_name(path: Path) -> Path:
    """Where ``path`` is written before it is renamed into place."""
    return path.with_name(f".{path.name}.{os.getpid()}.partial")


def write_failed(path: Path, err: OSError) -> TwoposeError:
    """The error for a write that failed (a full disk says so)."""
    if err.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return TwoposeError(f"cannot write {path}: the disk is full; free some space and run again")
    return TwoposeError(f"cannot write {path}: {err.strerror or err}")


@contextlib.contextmanager
def replacing(path: Path) -> Iterator[Path]:
    """Yield a temporary name beside ``path`` to write in its place.

    Write it by any means; when the block ends, the file is synced, renamed over ``path``
    and the folder synced, so a crash or a full disk leaves the previous file or
    the new one, never half of one. On any failure the temporary file is removed and
    ``path`` is untouched. ``path`` must be a regular file, a symlink (replaced itself,
    never written through) or a new name: a folder, FIFO or device is refused.
    """
    refuse_special(path)
    tmp = partial_name(path)
    try:
        tmp.unlink(missing_ok=True)  # this process's own name: a leftover of a failed write
        yield tmp
        fsync_path(tmp, os.O_RDONLY)
        refuse_special(path)  # again: it may have changed while we wrote
        os.replace(tmp, path)
        fsync_path(path.parent, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as err:
        tmp.unlink(missing_ok=True)
        raise write_failed(path, err) from err
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_atomically(path: Path, data: bytes) -> None:
    """``data`` written to ``path`` through :func:`replacing`."""
    with replacing(path) as tmp:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)


def fsync_path(path: Path, flags: int) -> None:
    """Sync a file or (``O_DIRECTORY``) a folder; a file system that cannot: nothing more."""
    fd = os.open(path, flags)
    try:
        os.fsync(fd)
    except OSError as err:  # a file system that cannot sync a folder: nothing more to do
        if err.errno not in (errno.EINVAL, errno.ENOTSUP):
            raise
    finally:
        os.close(fd)


def refuse_special(path: Path) -> None:
    """Refuse a folder, FIFO, device or socket where a file is to be written.

    A rename would replace ``/dev/null`` itself, or a FIFO a reader is waiting on).
    """
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    except OSError as err:
        raise write_failed(path, err) from err
    if stat.S_ISDIR(mode):
        raise InputValueError(f"{path} is a folder; give a file name to write")
    if not (stat.S_ISREG(mode) or stat.S_ISLNK(mode)):
        raise InputValueError(
            f"{path} is not a regular file (a FIFO, device or socket); give a new file name "
            "or a regular file to replace"
        )
