"""Every stop closes the file: Ctrl-C, a second Ctrl-C, SIGTERM and SIGHUP while recording.

While ``twopose-record new`` records (:func:`handled`), those signals do not raise where
they land: a ``KeyboardInterrupt`` raised inside the session writer (a chunk half written,
the index being written on close) would leave a file no reader opens. The first signal
only asks the recording to stop (:class:`Stop`); the recording notices where it is safe
to stop (before each frame, between the procedure's steps, while a suggestion is being
computed, :func:`abandonable`) and closes the file as Ctrl-C always did: the capture in
progress kept and marked incomplete, an undecided one discarded, the summary printed once,
exit 130. Only where the recorder waits for the operator (a prompt at the terminal,
:meth:`Stop.interruptible`) does the signal raise at once, since nothing is being written
there. A second signal never interrupts the closing: it is said once on stderr. In the web
console the server's thread is the main thread; the recording thread sees the same stop.

SIGHUP (the terminal closed, an SSH session dropped) stops the recording as Ctrl-C does,
unless the recorder was started ignoring it (``nohup``), which is kept. kill -9 cannot be
caught: the file then holds everything up to the last flush (``recover`` closes it).
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from types import FrameType
from typing import Any, TypeVar

__all__ = [
    "STOP_SIGNALS",
    "Stop",
    "abandonable",
    "active",
    "check",
    "describe",
    "handled",
    "interruptible",
    "requested",
]

T = TypeVar("T")

#: The signals that stop a recording (each closes the file; SIGKILL cannot be caught).
#: SIGHUP where the system has it (not on Windows).
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    signal.Signals[name] for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)

_NAMES = {signal.SIGINT: "Ctrl-C"}
_POLL_S = 0.05  # how often a wait looks whether the recording is to stop


class Stop:
    """The recording is asked to stop: set once, by the first signal (or the server)."""

    def __init__(self) -> None:
        self.event = threading.Event()
        self.signal: int | None = None  # what stopped it (None: not a signal)
        # Reentrant: the handler may run in the main thread while it holds the lock.
        self._lock = threading.RLock()
        self._interruptible = 0  # the main thread waits for the operator: raise at once
        self._said = False
        self._listeners: list[Callable[[], None]] = []

    @property
    def requested(self) -> bool:
        return self.event.is_set()

    def describe(self) -> str:
        """What stopped the recording, in the operator's words ("Ctrl-C", "SIGTERM")."""
        if self.signal is None:
            return "Ctrl-C"
        return _NAMES.get(signal.Signals(self.signal), signal.Signals(self.signal).name)

    def request(self, sig: int | None = None) -> bool:
        """Ask the recording to stop; True the first time (later requests change nothing)."""
        with self._lock:
            if self.event.is_set():
                return False
            self.signal = sig
            self.event.set()
            listeners = list(self._listeners)
        for listener in listeners:
            listener()
        return True

    def on_request(self, listener: Callable[[], None]) -> None:
        """Call ``listener`` when the stop is requested (at once if it already was)."""
        with self._lock:
            self._listeners.append(listener)
            already = self.event.is_set()
        if already:
            listener()

    def check(self) -> None:
        """Raise KeyboardInterrupt if the recording is to stop (call it where stopping is
        safe: no write to the session half done)."""
        if self.event.is_set():
            raise KeyboardInterrupt

    def say_closing(self) -> None:
        """Say once, on stderr, that the file is being closed (a second signal came, or the
        closing takes long)."""
        with self._lock:
            if self._said:
                return
            self._said = True
        with contextlib.suppress(OSError, ValueError):
            sys.stderr.write("closing the session file...\n")
            sys.stderr.flush()

    @contextlib.contextmanager
    def interruptible(self) -> Iterator[None]:
        """While the main thread waits for the operator (nothing is written meanwhile), a
        stop signal raises KeyboardInterrupt at once; one that came before raises now."""
        if threading.current_thread() is not threading.main_thread():
            self.check()
            yield
            return
        self.check()
        self._interruptible += 1
        try:
            yield
        finally:
            self._interruptible -= 1

    def handle(self, sig: int, _frame: FrameType | None) -> None:
        """The signal handler (the main thread): the first signal asks to stop (and raises
        while the operator is being waited for); every later one is only said."""
        if not self.request(sig):
            self.say_closing()
            return
        if self._interruptible > 0:
            raise KeyboardInterrupt


_active: Stop | None = None


def active() -> Stop | None:
    """The stop of the recording under way in this process (None: none is handled)."""
    return _active


def requested() -> bool:
    """Whether the recording under way is asked to stop."""
    return _active is not None and _active.requested


def check() -> None:
    """Raise KeyboardInterrupt if the recording under way is asked to stop."""
    if _active is not None:
        _active.check()


def describe() -> str:
    """What stopped the recording under way ("Ctrl-C" when nothing is handled)."""
    return _active.describe() if _active is not None else "Ctrl-C"


def interruptible() -> contextlib.AbstractContextManager[None]:
    """:meth:`Stop.interruptible` of the recording under way (nothing without one)."""
    return _active.interruptible() if _active is not None else contextlib.nullcontext()


@contextlib.contextmanager
def handled(*, install: bool = True) -> Iterator[Stop]:
    """Handle the stop signals for the recording inside: the first asks it to stop
    (:meth:`Stop.handle`). Installed from the main thread only (``install``); elsewhere
    the signals are left as they are. Once a stop was asked, later signals are ignored
    after the block: the process is closing."""
    global _active
    stop, before = Stop(), _active
    _active = stop
    previous: dict[signal.Signals, Any] = {}
    if install and threading.current_thread() is threading.main_thread():
        for sig in STOP_SIGNALS:
            current = signal.getsignal(sig)
            if sig.name == "SIGHUP" and current == signal.SIG_IGN:
                continue  # started under nohup: the operator wants it to go on
            previous[sig] = current
            signal.signal(sig, stop.handle)
    try:
        yield stop
    finally:
        _active = before
        for sig, handler in previous.items():
            # Once stopped, the process is closing: a later signal is ignored, also while
            # Python finalizes (which resets a Python handler, so that it would kill).
            signal.signal(sig, signal.SIG_IGN if stop.requested else handler)


def abandonable(fn: Callable[..., T], *args: Any) -> T:
    """``fn(*args)`` computed in a daemon thread while this one waits; when the recording
    is asked to stop meanwhile, KeyboardInterrupt is raised here at once and the
    computation is abandoned (its result is never used; the process exits without it).
    For what only informs the operator (a suggestion), never for what writes the file."""
    done = threading.Event()
    outcome: list[Any] = []

    def run() -> None:
        try:
            outcome.append((True, fn(*args)))
        except BaseException as err:
            outcome.append((False, err))
        finally:
            done.set()

    check()
    worker = threading.Thread(target=run, name="abandonable", daemon=True)
    worker.start()
    while not done.wait(_POLL_S):
        check()
    ok, value = outcome[0]
    if not ok:
        raise value
    return value  # type: ignore[no-any-return]
