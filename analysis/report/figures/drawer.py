"""Session figures off a run's critical path: drawn in one spawned process while this one
analyses the next session (:class:`FigureDrawer`), and drawn so that a figure that fails
is said and shown, never the end of its session's numbers (:func:`draw_session_figures`).
"""

from __future__ import annotations

import contextlib
import io
import os
import pickle
import signal
import sys
import textwrap
import threading
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from analysis.report.figures.cache import FigureCache, FigureJob

__all__ = [
    "FigureDrawer",
    "draw_session_figures",
    "not_drawn_png",
    "note",
    "session_pngs",
    "sigint_blocked",
]

#: What :func:`draw_session_figures` gives: PNGs by figure kind, and why they are not the
#: session's figures ("" when they are).
Drawn = tuple[dict[str, bytes], str]


def draw_session_figures(job: FigureJob) -> Drawn:
    """The session's figures as PNGs (:func:`analysis.report.figures.draw.session_figures`); if
    drawing
    them fails, one image that says so in the first figure's place, and the reason."""
    try:
        from analysis.report.figures.draw import png_bytes, session_figures

        figures = session_figures(
            job.session,
            job.trials,
            job.averaging,
            job.views,
            include_warned=job.include_warned,
            units=job.units,
        )
        return {kind: png_bytes(fig) for kind, fig in figures.items()}, ""
    except Exception as err:  # a bug in a figure must not cost the session its numbers
        reason = f"{type(err).__name__}: {err}"
        return {"scatter": not_drawn_png(job.session, reason)}, reason


def session_pngs(job: FigureJob, cache: FigureCache | None) -> tuple[dict[str, bytes], str, bool]:
    """``job``'s PNGs by kind, why they are not its figures ("" when they are), and whether
    they were reused from ``cache`` (a previous run's) rather than drawn."""
    reused = cache.reuse(job) if cache is not None else None
    if reused is not None:
        return reused, "", True
    pngs, why_not = draw_session_figures(job)
    return pngs, why_not, False


def not_drawn_png(session: str, reason: str) -> bytes:
    """A small PNG saying that ``session``'s figures were not drawn, and why (drawn with
    Pillow: whatever broke the figures may be matplotlib)."""
    from PIL import Image, ImageDraw, PngImagePlugin

    text = f"The figures of {session} were not drawn: {reason}"
    lines = textwrap.wrap(text, 80)[:12] or [text[:80]]
    picture = Image.new("RGB", (520, 16 * len(lines) + 20), "white")
    pen = ImageDraw.Draw(picture)
    for k, line in enumerate(lines):
        pen.text((10, 10 + 16 * k), line, fill=(170, 0, 0))
    info = PngImagePlugin.PngInfo()
    info.add_text("Description", text)
    buf = io.BytesIO()
    picture.save(buf, format="PNG", pnginfo=info)
    return buf.getvalue()


def note(text: str) -> None:
    """Say something the operator should know that does not stop the run (stderr)."""
    sys.stderr.write(f"note: {text}\n")


class FigureDrawer:
    """A child process (``python -m analysis.report.figures.drawer``) that draws sessions' figures
    as
    they are handed over, through its stdin and stdout.

    :meth:`submit` returns at once (a thread feeds the child one session at a time, a
    second reads what it drew), so the caller goes on with the next session;
    :meth:`collect` waits for the drawings, drawing here, at the same time, the sessions
    the child has not started (the run's last sessions are drawn twice as fast). The
    child is a fresh interpreter, not a fork (OpenCV's threads) nor a multiprocessing
    spawn (which would import the caller's main script again). Ctrl-C is the caller's:
    the child ignores it and is ended with the block; it also ends when its stdin closes,
    and at once when this process dies (:func:`analysis.batch.parent_watch.watch_parent`: a
    parent killed mid-session left it drawing, then printing a ``BrokenPipeError``), so it
    never outlives its parent. Sessions a dead child did not draw are drawn here.
    """

    #: Sessions handed to the child before it has returned the first of them.
    IN_FLIGHT = 2

    def __init__(self) -> None:
        import subprocess
        from pathlib import Path

        root = str(Path(__file__).resolve().parents[3])  # this analysis package, not another
        path = os.environ.get("PYTHONPATH")
        env = {**os.environ, "PYTHONPATH": root + (os.pathsep + path if path else "")}
        with sigint_blocked():  # held back in the child too, until it ignores it
            self._child = subprocess.Popen(
                [sys.executable, "-m", "analysis.report.figures.drawer", str(os.getpid())],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                env=env,
            )
        self._submitted: dict[int, FigureJob] = {}
        self._waiting: list[int] = []  # submitted, not yet sent (oldest first)
        self._sent: set[int] = set()  # sent, not yet drawn
        self._drawn: dict[int, Drawn] = {}
        self._closing = False
        self._child_gone = False
        self._ended_early = False
        self._changed = threading.Condition()
        self._threads = [
            threading.Thread(target=self._feed, name="twopose-figures-feed", daemon=True),
            threading.Thread(target=self._read, name="twopose-figures-read", daemon=True),
        ]
        for thread in self._threads:
            thread.start()

    @classmethod
    @contextlib.contextmanager
    def started(cls) -> Iterator[FigureDrawer | None]:
        """A drawer for the block, or None when no process can be started (then the
        figures are drawn in this process, after each session)."""
        try:
            drawer = cls()
        except OSError as err:
            note(f"figures are drawn after each session ({err})")
            yield None
            return
        try:
            yield drawer
        finally:
            drawer.close()

    def submit(self, index: int, job: FigureJob) -> None:
        """Draw ``job``'s figures (``index`` names it in :meth:`collect`)."""
        with self._changed:
            self._submitted[index] = job
            self._waiting.append(index)
            self._changed.notify_all()

    def _feed(self) -> None:
        """Send the oldest waiting session whenever fewer than :data:`IN_FLIGHT` are out;
        close the child's stdin once collecting and nothing waits."""
        stdin = self._child.stdin
        assert stdin is not None
        try:
            while (index := self._next_to_send()) is not None:
                task = (index, self._submitted[index])
                _send(stdin, pickle.dumps(task, protocol=pickle.HIGHEST_PROTOCOL))
            stdin.close()
        except (OSError, ValueError):  # the child is gone: the reader says so
            pass

    def _next_to_send(self) -> int | None:
        with self._changed:
            while not self._child_gone:
                if self._waiting and len(self._sent) < self.IN_FLIGHT:
                    index = self._waiting.pop(0)
                    self._sent.add(index)
                    return index
                if self._closing and not self._waiting:
                    return None
                self._changed.wait()
            return None

    def _read(self) -> None:
        """Take the child's drawings as they come; at its end, what it had is drawn here."""
        stdout = self._child.stdout
        assert stdout is not None
        try:
            while (message := _receive(stdout)) is not None:
                index, figures = pickle.loads(message)
                with self._changed:
                    self._drawn[index] = figures
                    self._sent.discard(index)
                    self._changed.notify_all()
        except (OSError, ValueError, pickle.UnpicklingError):
            pass
        with self._changed:
            self._ended_early = not self._closing or bool(self._sent or self._waiting)
            self._child_gone = True
            self._changed.notify_all()

    def collect(self) -> dict[int, Drawn]:
        """Every submitted session's figures, by index: those the child has not started are
        drawn here meanwhile (newest first, the child takes the oldest), and those a child
        that died did not give."""
        while True:
            with self._changed:
                self._closing = True
                self._changed.notify_all()
                if self._child_gone and self._sent:  # it died with sessions in hand
                    self._waiting += sorted(self._sent)
                    self._sent.clear()
                if not self._waiting:
                    if not self._sent:
                        break
                    self._changed.wait(0.5)
                    continue
                index = self._waiting.pop()
                job = self._submitted[index]
            drawn = draw_session_figures(job)
            with self._changed:
                self._drawn[index] = drawn
        # A child that died may not have been seen by the reader yet (its EOF races with
        # this loop): a non-zero exit code says so as surely.
        if self._ended_early or self._child.poll() not in (None, 0):
            note(
                f"the figure-drawing process ended early (exit code {self._child.poll()}); "
                "the figures it did not draw are drawn here"
            )
        return dict(self._drawn)

    def close(self) -> None:
        """End the child at once, if it still runs (it holds nothing worth waiting for)."""
        import subprocess

        with self._changed:
            self._closing = True
            self._changed.notify_all()
        if self._child.poll() is None:
            self._child.terminate()
            try:
                self._child.wait(5.0)
            except subprocess.TimeoutExpired:
                pass
            finally:  # also on a second Ctrl-C while waiting
                if self._child.poll() is None:
                    self._child.kill()
                    self._child.wait()
        for stream in (self._child.stdin, self._child.stdout):
            with contextlib.suppress(OSError, ValueError):
                if stream is not None:
                    stream.close()


def _send(stream: Any, payload: bytes) -> None:
    stream.write(len(payload).to_bytes(8, "little") + payload)
    stream.flush()


def _receive(stream: Any) -> bytes | None:
    """One message, or None at the end of the stream (or a message cut short)."""
    head = stream.read(8)
    if len(head) < 8:
        return None
    size = int.from_bytes(head, "little")
    payload = bytes(stream.read(size))
    return payload if len(payload) == size else None


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """SIGINT held back (not lost) in this thread while children are started: a child
    inherits the blocked signal and ignores it before unblocking it, so a Ctrl-C during its
    start-up never prints its traceback; ours arrives when the block ends."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _main() -> None:
    """The child: draw every session read from stdin, send each one's figures to stdout;
    stop at the end of stdin (the parent closed it, or died), or when the parent (its pid
    the first argument) is gone, silently. Ctrl-C is the parent's."""
    from analysis.batch.parent_watch import end_quietly_on_closed_pipe, watch_parent

    if len(sys.argv) > 1:
        watch_parent(int(sys.argv[1]))
    end_quietly_on_closed_pipe()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    stdin = sys.stdin.buffer
    stdout = os.fdopen(os.dup(1), "wb")  # the messages' own channel; anything printed
    os.dup2(2, 1)  # to stdout by a library goes to stderr instead
    sys.stdout = sys.stderr
    import analysis.report.figures.draw  # noqa: F401  (matplotlib loads while the first session runs)

    while (message := _receive(stdin)) is not None:
        index, job = pickle.loads(message)
        drawn = draw_session_figures(job)
        _send(stdout, pickle.dumps((index, drawn), protocol=pickle.HIGHEST_PROTOCOL))


if __name__ == "__main__":
    _main()
