"""A batch's sessions in worker processes (``run --jobs N``), stopped at once when asked.

``jobs - 1`` spawned workers take sessions from the front of the list and the calling
process from the back, each claiming a session through a shared flag, so no session runs
twice and no core waits for a worker to start (:func:`run_processes`). A Ctrl-C or SIGTERM
ends the session each worker has in hand at once (its handler raises inside the pool's
call; the parent passes the signal on to workers that did not get it), and the workers end
with the run however it ends (:mod:`analysis.batch.parent_watch`); a kill -9 leaves no warning
of multiprocessing's resource tracker behind.
"""

from __future__ import annotations

import contextlib
import glob
import multiprocessing
import signal
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor, as_completed, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any, Protocol

from analysis.batch.noise_pass import NoisePass
from analysis.report.figures.drawer import sigint_blocked
from analysis.results import SessionFailure, SessionResult
from analysis.session.pipeline import keep_frame_buffers

__all__ = ["STOP_GRACE_S", "Outcome", "Sessions", "run_processes"]

#: What one session's analysis gives: its tables, or why it failed (its first pass: its
#: statistics, :mod:`analysis.batch.noise_pass`).
Outcome = SessionResult | SessionFailure | NoisePass


class Sessions(Protocol):
    """A batch's sessions as the workers take them (:class:`analysis.batch.runner.run`'s batch):
    picklable, each session analysed by its index wherever it runs."""

    @property
    def files(self) -> list[str]: ...

    @property
    def results_mcap(self) -> list[str | None]: ...

    @property
    def images(self) -> bool: ...

    @property
    def on_done(self) -> Callable[[str, bool], None] | None: ...

    def analyse(self, index: int, results: str | None = None, *, images: bool) -> Outcome:
        """Session ``index``'s outcome (its results.mcap written to ``results``)."""
        ...

    def for_workers(self) -> Sessions:
        """The same sessions without what stays in this process (the progress callback)."""
        ...

    def for_session(self, index: int) -> Sessions:
        """What a worker needs for session ``index`` alone (not every session's detections)."""
        ...


_CLAIMS: Any = None  # in worker processes: the shared claim flags of the batch
_BUSY = False  # in a worker process: analysing a session (a Ctrl-C ends that session)
_STOPPED = False  # in a worker process: a Ctrl-C came (no session is started after it)


def _worker_init(claims: Any) -> None:
    """One OpenCV thread per worker: the processes already fill the cores. A Ctrl-C (to
    the process group, or passed on by the parent as it stops) ends the session in hand
    at once, as an exception the pool hands back to the parent, never a traceback of the
    worker's own; an idle worker ignores it (:func:`_interrupt_session`). A parent killed
    outright ends its workers (:func:`analysis.batch.parent_watch.watch_parent`)."""
    import cv2

    from analysis.batch.parent_watch import watch_parent

    watch_parent()
    signal.signal(signal.SIGINT, _interrupt_session)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})  # held back at its start
    global _CLAIMS
    _CLAIMS = claims
    cv2.setNumThreads(1)
    keep_frame_buffers()


def _interrupt_session(_signum: int, _frame: Any) -> None:
    """A worker's Ctrl-C: the session in hand stops here (KeyboardInterrupt inside the
    pool's call, which sends it to the parent as the session's outcome); between sessions
    it is only remembered, so that the worker's own loop is never interrupted."""
    global _STOPPED
    _STOPPED = True
    if _BUSY:
        raise KeyboardInterrupt


#: Who took a session (the shared claim flags' values): nobody yet, the main process, a
#: worker, or nobody, for good (the run is stopping).
_FREE, _BY_MAIN, _BY_WORKER, _STOPPING = 0, 1, 2, 3


def _claim(claims: Any, index: int, by: int = _BY_MAIN) -> bool:
    """Take session ``index`` (for ``by``) unless another already did."""
    with claims.get_lock():
        if claims[index] != _FREE:
            return False
        claims[index] = by
        return True


def _worker_task(index: int, batch: Sessions, results: str | None) -> Outcome | None:
    """A worker's session, or None when the main process took it first (or a Ctrl-C came);
    a Ctrl-C while it is analysed raises KeyboardInterrupt out of it (:func:`_worker_init`)."""
    global _BUSY
    if not _claim(_CLAIMS, index, _BY_WORKER):
        return None
    _BUSY = True
    try:
        if _STOPPED:
            raise KeyboardInterrupt
        return batch.analyse(index, results, images=batch.images)
    finally:
        _BUSY = False


def run_processes(batch: Sessions, jobs: int) -> list[Outcome]:
    """``jobs`` processes: ``jobs - 1`` spawned workers take sessions from the front of the
    list, this (already warm) process from the back, each claiming a session through a
    shared flag; so no session runs twice and no core waits for a worker to start."""
    # Spawned, not forked: a fork after OpenCV has started its thread pool can deadlock.
    files, results, images = batch.files, batch.results_mcap, batch.images
    on_done = batch.on_done
    _quiet_resource_tracker()
    context = multiprocessing.get_context("spawn")
    claims = context.Array("b", len(files))
    outcomes: list[Outcome | None] = [None] * len(files)

    def done(i: int, outcome: Outcome) -> None:
        outcomes[i] = outcome
        if on_done is not None:
            on_done(files[i], isinstance(outcome, SessionResult))

    import cv2

    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # this process is one of the ``jobs``, like each worker
    try:
        with ProcessPoolExecutor(
            max_workers=jobs - 1, mp_context=context, initializer=_worker_init, initargs=(claims,)
        ) as pool:
            futures: list[Future[Outcome | None]] = []
            try:
                with sigint_blocked():  # the workers start as the sessions are submitted
                    task = batch.for_workers()  # what a worker needs
                    futures = [
                        pool.submit(_worker_task, i, task.for_session(i), results[i])
                        for i in range(len(files))
                    ]
                for i in reversed(range(len(files))):
                    if not _claim(claims, i):
                        break  # the workers, going forward, have reached this one
                    here = batch.analyse(i, results[i], images=images)
                    done(i, here)
                index = {fut: i for i, fut in enumerate(futures)}
                for fut in as_completed(futures):  # progress as sessions finish, in any order
                    i = index[fut]
                    if outcomes[i] is not None:
                        continue
                    try:
                        outcome = fut.result()
                    except BrokenProcessPool as err:  # a worker died (killed, out of memory)
                        outcome = SessionFailure(
                            session=files[i],
                            reason=f"{files[i]}: the worker process analysing it died ({err})",
                        )
                    if outcome is not None:
                        done(i, outcome)
            except BaseException:  # Ctrl-C, or this process's own failure: stop at once
                _stop_workers(pool, claims, futures, results)
                raise
    finally:
        cv2.setNumThreads(threads)
    missing = [f for f, o in zip(files, outcomes, strict=True) if o is None]
    assert not missing, f"sessions neither the workers nor this process analysed: {missing}"
    return [o for o in outcomes if o is not None]


def _quiet_resource_tracker() -> None:
    """Start multiprocessing's resource tracker (if this process has none yet) without its
    shutdown warning. The pool's queues and the claim flags are named semaphores the
    tracker removes when this process ends without removing them itself (kill -9); it then
    printed ``resource_tracker: There appear to be 6 leaked semaphore objects to clean up at
    shutdown``, after the run's own output, about semaphores it was removing as designed
    (it does remove them: none is left in /dev/shm)."""
    import sys
    from multiprocessing import resource_tracker

    quiet = "ignore:resource_tracker:UserWarning"  # passed to the tracker as -W
    sys.warnoptions.append(quiet)
    try:
        resource_tracker.ensure_running()
    finally:
        sys.warnoptions.remove(quiet)


#: How long the workers may take to end once stopped (a Ctrl-C ends the session in hand
#: between two Python instructions: milliseconds, unless one call into a library runs long),
#: before they are terminated.
STOP_GRACE_S = 0.5


def _stop_workers(
    pool: ProcessPoolExecutor,
    claims: Any,
    futures: list[Future[Outcome | None]],
    results: list[str | None],
) -> None:
    """End the pool now: queued sessions are dropped and the workers stopped, rather than left
    to finish the batch; the results.mcap a worker was writing leaves no temporary file
    (``.<name>.<pid>.partial``) behind.

    Every session is claimed first, so a worker returns from whatever it is handed next,
    and each worker is sent a Ctrl-C (it may not have had one: a SIGINT or SIGTERM to this
    process alone), which ends the session in hand at once (:func:`_worker_init`); those
    not ended within :data:`STOP_GRACE_S` are terminated. They are not terminated first: a
    worker terminated while it sends its result can leave half a message in the pool's
    result pipe, which the pool's own thread then waits on for ever (a Ctrl-C in CI once
    never returned); a worker that ends its session itself sends a whole one.
    """
    import os

    with claims.get_lock():
        taken = [i for i, by in enumerate(claims[:]) if by == _BY_WORKER]
        claims[:] = [by or _STOPPING for by in claims[:]]
    processes = list((getattr(pool, "_processes", None) or {}).values())
    for process in processes:
        with contextlib.suppress(OSError, ValueError):  # already ended
            if process.pid is not None and process.is_alive():
                os.kill(process.pid, signal.SIGINT)
    pool.shutdown(wait=False, cancel_futures=True)
    # The sessions a worker is analysing (or sending): their whole result, before the end.
    # A worker still starting, or idle, has none to send (or a message too small to be cut).
    in_hand = [futures[i] for i in taken if i < len(futures)]
    with contextlib.suppress(KeyboardInterrupt):  # a second Ctrl-C: stop waiting
        wait(in_hand, timeout=STOP_GRACE_S)
    for process in processes:  # idle now (their results all read), or over the grace
        process.terminate()
    for process in processes:
        process.join(STOP_GRACE_S)
        if process.is_alive():
            process.kill()
            process.join()
    for path in (Path(r) for r in results if r is not None):
        for leftover in path.parent.glob(f".{glob.escape(path.name)}.*.partial"):
            leftover.unlink(missing_ok=True)
