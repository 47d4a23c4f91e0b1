"""A run's child processes end with it: each one watches its parent, and exits when it dies.

A run killed with ``kill -9`` (or dying any way that skips its own clean-up) cannot stop its
workers; a spawned worker then blocked for ever (writing a result nobody reads, or waiting
for a session nobody sends), holding the run's stdout open, so ``run ... | tee log`` never
returned. :func:`watch_parent`, called as a child starts (the pool's worker initializer,
the figure drawer's entry point), starts a daemon thread that ends the child at once when
its parent dies (within :data:`POLL_S` where the parent cannot be watched by a pidfd); a
child whose parent died while it was still starting ends as its watch starts.

Why not ``prctl(PR_SET_PDEATHSIG)``: it fires when the parent *thread* that started the
child ends, and a pool may start workers from its manager thread.
"""

from __future__ import annotations

import multiprocessing
import os
import select
import signal
import threading
import time

__all__ = ["EXIT_PARENT_GONE", "POLL_S", "end_quietly_on_closed_pipe", "watch_parent"]

#: The longest a child outlives its parent, where the parent cannot be watched by a pidfd
#: (which wakes the watcher at once) and ``os.getppid()`` is polled instead.
POLL_S = 0.25
#: A child's exit code when it ends because its parent is gone (nobody reads it: 128 + SIGHUP,
#: the shell's code for "the other end hung up").
EXIT_PARENT_GONE = 129


def watch_parent(parent_pid: int | None = None) -> None:
    """End this process (``os._exit``: no traceback, no flush into a pipe nobody reads) as
    soon as ``parent_pid`` is no longer its parent.

    Parameters
    ----------
    parent_pid : int, optional
        The parent to outlive not. Default: the process that started this multiprocessing
        child (:func:`multiprocessing.parent_process`, whose pid was passed before this
        child ran any code, so a parent that already died is seen); in a process no
        multiprocessing parent started, nothing is watched.
    """
    if parent_pid is None:
        parent = multiprocessing.parent_process()
        if parent is None or parent.pid is None:
            return
        parent_pid = parent.pid
    if os.getppid() != parent_pid:  # gone before this process could watch it
        os._exit(EXIT_PARENT_GONE)
    pidfd = _pidfd(parent_pid)
    threading.Thread(
        target=_watch, args=(parent_pid, pidfd), name="twopose-parent-watch", daemon=True
    ).start()


def end_quietly_on_closed_pipe() -> None:
    """Let a write into a pipe whose reader is gone end this process silently (SIGPIPE's
    default action) rather than raise a ``BrokenPipeError`` whose traceback says nothing the
    user can act on: for a child whose stdout is its channel to its parent, a closed pipe
    means the parent is gone or ending it. Call it from the main thread."""
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)


def _pidfd(pid: int) -> int | None:
    """A pidfd of ``pid`` (readable once it exits), or None where the kernel or the
    platform has none; opened while ``pid`` is still this process's parent, so it names
    that process and not a later one given the same pid."""
    opener = getattr(os, "pidfd_open", None)
    if opener is None:
        return None
    try:
        fd: int = opener(pid)
    except OSError:
        return None
    if os.getppid() != pid:  # it died meanwhile: the watcher's first look ends this process
        os.close(fd)
        return None
    return fd


def _watch(parent_pid: int, pidfd: int | None) -> None:
    """Wait for the parent's end: the pidfd turning readable, or this process being given
    another parent (the parent's death re-parents its children at once)."""
    poller = None
    if pidfd is not None:
        poller = select.poll()
        poller.register(pidfd, select.POLLIN)
    while True:
        if poller is None:
            time.sleep(POLL_S)
        elif poller.poll(POLL_S * 1000):
            break
        if os.getppid() != parent_pid:
            break
    os._exit(EXIT_PARENT_GONE)
