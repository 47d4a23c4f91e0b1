"""The cameras' clock offset, measured while a pair records (issue 58 item 2, the recorder's
side).

Each frame recorded is handed to a detection thread (:class:`OffsetMeter`; a camera's
frames' writing never waits for it: when it falls :data:`QUEUE_FRAMES` behind, a frame is
left undetected and counted; files' and folders' wait, :attr:`OffsetMeter.lossless`, so
that the same files record the same offset whatever the load). It finds the method's
target (:func:`twopose.detect.detection.detect`)
and keeps each camera's centroid track (the glove's image line's angle too: its point's
place along the line is fitted, not taken as one point both cameras see) and each frame's
brightness with the frames' capture times. When a trial ends, the offset is measured from
the trial's tracks by the one path the analysis also takes
(:func:`twopose.pair.trial_offset.measure_trial_offset`): from a flash both cameras saw
(each camera's brightness, :class:`twopose.pair.trial_offset.BrightnessMeter`, stepping up
within two frames by a quarter of its level and ten times its frame-to-frame scatter: a
deliberate flash, not a moving hand), and by the rays' smallest gap (the target must move,
and not only along the epipolar lines), the two pooled when both measure it and agree; a
trial that fixes it neither way, or whose two disagree,
is said, in the measurements' words.

The offset of two cameras opened once stays the same through the session (a lag is
decided when a camera starts), so the trials' offsets are **pooled**: their
inverse-variance mean, its 1-sigma widened by the trials' scatter where they disagree
beyond their sigmas (the Birge ratio). The pooled offset is what the recorder writes
after each trial that measured one (``/twopose/clock_offset``: the last one applies).
"""

from __future__ import annotations

import contextlib
import math
import queue
import threading
from types import TracebackType
from typing import TYPE_CHECKING, Self

import numpy as np

from twopose.methods.specs import Method, spec_of
from twopose.pair.clock import ClockOffset
from twopose.pair.trial_offset import (
    FLASH_NOISE,
    FLASH_RISE,
    BrightnessMeter,
    measure_trial_offset,
    pooled_offset,
)

if TYPE_CHECKING:
    from recorder.sources.pair import TimedFrame
    from twopose.pair.calibration import PairCalibration

__all__ = ["FLASH_NOISE", "FLASH_RISE", "QUEUE_FRAMES", "OffsetMeter", "pooled_offset"]

#: How many frames the detection thread may fall behind before frames go undetected.
QUEUE_FRAMES = 60
_END_WAIT_S = 5.0  # how long a trial's end waits for the frames still queued


class OffsetMeter:
    """The detection thread and each trial's tracks (the module docstring); a context
    manager (the thread runs inside it)."""

    def __init__(self, pair: PairCalibration, method: Method) -> None:
        self.pair = pair
        self.target = spec_of(method).target
        self.lines = spec_of(method).uses_image_lines  # the glove's: its angle kept too
        self.floor_px = spec_of(method).floor_in_pair[0]  # the detector's, as the analysis
        self._queue: queue.Queue[tuple[int, int, TimedFrame] | None] = queue.Queue(QUEUE_FRAMES)
        self._tracks: dict[int, list[tuple[int, float, float, float, float]]] = {1: [], 2: []}
        self._lit = {1: BrightnessMeter(), 2: BrightnessMeter()}
        self._trial = 0
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self.skipped = 0  # frames left undetected: the thread was behind
        #: Every frame detected, the recording waiting for the thread when it is behind:
        #: files and folders replayed whole (no frame lost by waiting), so that the same
        #: files record the same offset whatever the load (a second new user's r5 F3c).
        self.lossless = False
        self.measured: list[ClockOffset] = []

    def __enter__(self) -> Self:
        if self.target is not None:
            self._thread = threading.Thread(target=self._run, name="clock offset", daemon=True)
            self._thread.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if self._thread is not None:
            with self._lock:
                self._trial = -1  # what is still queued is dropped
            # Full: the thread sees the trial gone and drains; the daemon ends with the process.
            with contextlib.suppress(queue.Full):
                self._queue.put_nowait(None)

    def begin(self, trial: int) -> None:
        """Trial ``trial`` streams: its tracks start empty."""
        with self._lock:
            self._trial = trial
            self._tracks = {1: [], 2: []}
            self._lit = {1: BrightnessMeter(), 2: BrightnessMeter()}

    def add(self, frame: TimedFrame) -> None:
        """A frame recorded: detected in the thread (skipped and counted when it is behind)."""
        if self._thread is None:
            return
        if self.lossless:
            self._queue.put((self._trial, frame.camera, frame))
            return
        try:
            self._queue.put_nowait((self._trial, frame.camera, frame))
        except queue.Full:
            self.skipped += 1

    def _run(self) -> None:
        from twopose.detect.detection import detect

        assert self.target is not None
        while (item := self._queue.get()) is not None:
            trial, camera, frame = item
            try:
                if trial == self._trial:
                    found = detect(frame.image, self.target)
                    u, v = found.centroid_px if found.found else (math.nan, math.nan)
                    theta = found.theta_deg if found.found else math.nan
                    lit = self._lit[camera](frame.image)  # a flash's (linear)
                    with self._lock:
                        if trial == self._trial:  # NaN where not found, as the analysis
                            self._tracks[camera].append((frame.t_capture_ns, u, v, lit, theta))
            except Exception:
                continue
            finally:
                self._queue.task_done()

    def _drained(self) -> None:
        """Wait (at most :data:`_END_WAIT_S`; replaying files, until done) for the frames
        still queued."""
        done = threading.Event()

        def join() -> None:
            self._queue.join()
            done.set()

        threading.Thread(target=join, daemon=True).start()
        done.wait(None if self.lossless else _END_WAIT_S)

    def end(self, trial: int) -> tuple[ClockOffset | None, str]:
        """The trial ended: its offset measured (a flash both cameras saw, and the rays'
        gap of the moving target, each where it can); the session's pooled offset (None:
        none measured yet) and what the trial gave, in words."""
        if self._thread is None:
            return None, "the clock offset is not measured: the method has no target to track"
        self._drained()
        with self._lock:
            one, two = (np.array(self._tracks[c], dtype=np.float64).reshape(-1, 5) for c in (1, 2))
            self._trial = 0
        trial_offset = measure_trial_offset(
            self.pair, (one[:, 1:3], two[:, 1:3]), (one[:, 0], two[:, 0]), (one[:, 3], two[:, 3]),
            (one[:, 4], two[:, 4]) if self.lines else None, self.floor_px,
        )  # fmt: skip
        pooled = pooled_offset(self.measured) if self.measured else None
        if trial_offset.offset is None:
            why = "; ".join(trial_offset.why)
            return pooled, f"trial {trial} does not fix the clock offset: {why}"
        self.measured.append(trial_offset.offset)
        pooled = pooled_offset(self.measured)
        said = f"trial {trial}: clock offset " + ", ".join(
            f"{o.offset_ns / 1e6:+.2f} ± {o.sigma_ns / 1e6:.2f} ms ({o.method}, {o.n} "
            f"{'frames' if o.method == 'flash' else 'pairs'})"
            for o in trial_offset.found
        )
        if len(trial_offset.found) > 1:
            o = trial_offset.offset
            said += f": {o.offset_ns / 1e6:+.2f} ± {o.sigma_ns / 1e6:.2f} ms pooled"
        if trial_offset.why:  # the way that could not measure it, said (with its hint, a
            # pair given in the wrong order: a new user's r7 K11, the rays' gap left unsaid)
            said += "; " + "; ".join(trial_offset.why)
        if self.skipped:
            said += f"; {self.skipped} frames left undetected so far (the detection was behind)"
        if len(self.measured) > 1:
            said += (
                f"; the session's {pooled.offset_ns / 1e6:+.2f} ± {pooled.sigma_ns / 1e6:.2f} ms "
                f"over {len(self.measured)} measurements"
            )
        return pooled, said
