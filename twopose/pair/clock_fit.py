"""A camera's frame times fitted by a regular clock, and a measured clock offset.

:func:`regular_times`: a camera's frames are taken at a fixed rate; its stamps' jitter is
the host's, so a line through the stamps over the frame numbers (dropped frames keep their
place) averages the jitter out instead of letting it enter every frame.
:class:`CausalClock`: the same fit made as frames arrive, each frame's fitted time from its
camera's frames up to it and itself (the last :data:`CAUSAL_WINDOW`, since the last gap of
more than :data:`MAX_GAP_INTERVALS` intervals), so that a live pairing and a replay of the
same stamps (:func:`causal_times`) give every frame the same time: what frames are paired
on (:mod:`twopose.pair.pairing`). A frame whose slot on the line is in doubt, and every
frame where the line does not hold (too few frames, stamps too irregular for frame
numbers), keeps its stamp.
:class:`ClockOffset`: what :mod:`twopose.pair.clock` measures. No I/O.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64, Ints
from twopose.errors import InputValueError

__all__ = [
    "CAUSAL_JITTER_SHARE",
    "CAUSAL_WINDOW",
    "MAX_GAP_INTERVALS",
    "MAX_JITTER_SHARE",
    "CausalClock",
    "ClockOffset",
    "RegularTimes",
    "causal_times",
    "regular_times",
]

#: The stamps are too irregular to be fitted by one rate beyond this share of an interval
#: (their frame numbers would be ambiguous): they are then used as they are.
MAX_JITTER_SHARE = 1 / 6
#: The same bound for the clock frames are paired on (:class:`CausalClock`), wider: a
#: frame whose stamp is rounded to the wrong slot is still no further from its true instant
#: than its stamp, so pairing only needs the line itself right (its frame numbers right for
#: most frames, which the fit's unique numbers check); an offset's sigma needs more.
CAUSAL_JITTER_SHARE = 1 / 3
#: The frames a causal fit uses at most (the newest; 5 s at 30 fps).
CAUSAL_WINDOW = 150
#: A camera's stamps further apart than this many of its intervals start its fit anew
#: (between stream trials; the frame numbers across such a gap would rest on the rate's
#: error times the gap).
MAX_GAP_INTERVALS = 16
#: A causal fit needs this many frames (fewer: the stamps as they are).
CAUSAL_MIN_FRAMES = 12


@dataclass(frozen=True, kw_only=True)
class ClockOffset:
    """A measured clock offset: camera 2's clock minus camera 1's (nanoseconds).

    ``sigma_ns`` its 1-sigma, ``method`` how it was measured (``"flash"``, ``"ray gap"``),
    ``n`` the frames (flash: both cameras') or pairs (ray gap) it rests on;
    ``clock_sigma_ns`` the part of ``sigma_ns`` that is the fitted clocks' own error
    (:func:`regular_times`), which two measurements from the same stamps share (0:
    unknown, as for an offset read back from a session).
    """

    offset_ns: float
    sigma_ns: float
    method: str
    n: int
    clock_sigma_ns: float = 0.0


@dataclass(frozen=True, kw_only=True, eq=False)
class RegularTimes:
    """A camera's stamps fitted by a regular clock (:func:`regular_times`).

    ``times_ns`` (N,) the fitted capture times, ``frame`` (N,) each stamp's frame number
    from the first (gaps: dropped frames), ``interval_ns`` the fitted interval,
    ``jitter_ns`` the stamps' scatter about the fit, ``sigma_ns`` (N,) each fitted time's
    1-sigma; ``regular`` False when the stamps were too irregular to fit (then
    ``times_ns`` are the stamps and ``sigma_ns`` their scatter).
    """

    times_ns: F64
    frame: F64
    interval_ns: float
    jitter_ns: float
    sigma_ns: F64
    regular: bool


def regular_times(
    t_ns: ArrayLike,
    *,
    interval_ns: float | None = None,
    max_jitter_share: float = MAX_JITTER_SHARE,
) -> RegularTimes:
    """A camera's frame times fitted by a fixed rate: ``t = a + b k`` over frame numbers k.

    The frame numbers come from the stamps (rounded by the interval, so dropped frames
    keep their place); with ``interval_ns`` unknown, the stamps' median difference starts
    the fit. Stamps too irregular for that (scatter beyond ``max_jitter_share`` of an
    interval, :data:`MAX_JITTER_SHARE` by default, or two on one frame number) are
    returned as they are (``regular`` False).
    """
    t = np.asarray(t_ns, dtype=np.float64).reshape(-1)
    if t.size < 3 or not np.isfinite(t).all():
        raise InputValueError("a camera's clock needs three finite frame times at least")
    origin = t[0]
    x = t - origin
    b = float(np.median(np.diff(x))) if interval_ns is None else float(interval_ns)
    if not b > 0:
        raise InputValueError("the frame times must increase")
    # Frame numbers from each step (one interval, or more across dropped frames), so that
    # a slightly wrong first interval does not slip them over a long stream; then the
    # line, and the numbers again from it.
    k = np.r_[0.0, np.cumsum(np.maximum(np.round(np.diff(x) / b), 1.0))]
    for _ in range(2):
        A = np.column_stack([np.ones_like(k), k])
        (a, b), *_ = np.linalg.lstsq(A, x, rcond=None)
        k = np.round((x - a) / b)
    residual = x - (a + b * k)
    jitter = float(np.sqrt((residual**2).sum() / max(t.size - 2, 1)))
    if jitter > max_jitter_share * b or len(np.unique(k)) != k.size:
        return RegularTimes(
            times_ns=t, frame=k, interval_ns=b, jitter_ns=jitter,
            sigma_ns=np.full(t.size, jitter), regular=False,
        )  # fmt: skip
    # Each fitted time's 1-sigma: the line's prediction error at its frame number.
    km = k.mean()
    spread = max(float(((k - km) ** 2).sum()), 1e-300)
    sigma = jitter * np.sqrt(1.0 / k.size + (k - km) ** 2 / spread)
    return RegularTimes(
        times_ns=origin + a + b * k, frame=k, interval_ns=float(b), jitter_ns=jitter,
        sigma_ns=sigma, regular=True,
    )  # fmt: skip


class CausalClock:
    """One camera's frames' fitted times, each as it arrives (the module docstring).

    :meth:`add` takes the camera's next stamp (integer nanoseconds, its own clock) and gives
    its fitted time: a line ``t = a + b k`` through the frames since the last long gap (at
    most the last :data:`CAUSAL_WINDOW`, the newest included), read at the newest frame's
    number k. The numbers come from :func:`regular_times` until its fit holds (within
    :data:`CAUSAL_JITTER_SHARE`, no frame's slot in doubt), then each new frame takes the
    slot the line puts it in (after the last one's) and the line is fitted again. A frame
    whose slot is in doubt (its stamp within three of the line's 1-sigmas of half an
    interval from it: the next slot could be its own) keeps its stamp and stays out of the
    line, since a wrong slot would put it a whole interval off. With fewer than
    :data:`CAUSAL_MIN_FRAMES` frames, or stamps too irregular for the line, the stamp is the
    time. Fitted times increase strictly (a fit that moved back gives the last time plus
    1 ns).
    """

    def __init__(self) -> None:
        self._stamps: deque[int] = deque(maxlen=CAUSAL_WINDOW)
        self._frame: deque[float] | None = None  # the window's frame numbers, once fitted
        self._line = (0.0, 0.0, 0.0)  # a, b and the stamps' scatter of the last fit
        self._last: int | None = None
        self._latest: int | None = None  # the last stamp given (in the window or not)

    def add(self, t_ns: int) -> int:
        """The next stamp in (after the last), its fitted time out (integer ns)."""
        t = int(t_ns)
        if self._latest is not None and t <= self._latest:
            raise InputValueError(
                f"a camera's capture times must increase: {t} ns came after {self._latest} ns"
            )
        stamps = self._stamps
        if self._latest is not None and t - self._latest > MAX_GAP_INTERVALS * self._interval():
            stamps.clear()  # a new stretch of frames: its own fit
            self._frame = None
        self._latest = t
        fitted = self._fitted(t)
        if self._last is not None and fitted <= self._last:
            fitted = self._last + 1
        self._last = fitted
        return fitted

    def _interval(self) -> float:
        if self._frame is not None:
            return self._line[1]
        if len(self._stamps) < 2:
            return float("inf")
        return float(np.median(np.diff(np.fromiter(self._stamps, np.int64, len(self._stamps)))))

    def _fitted(self, t: int) -> int:
        """The stamp ``t``'s fitted time, the window and its line updated."""
        stamps = self._stamps
        if self._frame is not None:
            slot = self._slot(t)
            if slot is None:  # its slot is in doubt: its stamp, kept out of the line
                return t
            stamps.append(t)
            self._frame.append(slot)
        else:
            stamps.append(t)
        if len(stamps) < CAUSAL_MIN_FRAMES:
            return t
        origin = stamps[0]
        x = (np.fromiter(stamps, np.int64, len(stamps)) - origin).astype(np.float64)
        if self._frame is None:
            fit = regular_times(x, max_jitter_share=CAUSAL_JITTER_SHARE)
            doubt = 0.5 * fit.interval_ns - 3.0 * fit.sigma_ns  # as :meth:`_slot`'s
            if not fit.regular or (np.abs(x - fit.times_ns) > doubt).any():
                return t  # some frame's slot is in doubt: not numbered yet
            self._frame = deque(fit.frame.tolist(), maxlen=CAUSAL_WINDOW)
        k = np.fromiter(self._frame, np.float64, len(self._frame))
        (a, b), *_ = np.linalg.lstsq(np.column_stack([np.ones_like(k), k]), x, rcond=None)
        residual = x - (a + b * k)
        jitter = float(np.sqrt((residual**2).sum() / max(x.size - 2, 1)))
        if not (b > 0 and jitter <= CAUSAL_JITTER_SHARE * b):
            self._frame = None  # the line does not hold: numbered anew from the next frame
            return t
        self._line = (float(a) + origin, float(b), jitter)  # a on the stamps' own clock
        return origin + round(float(a + b * k[-1]))

    def _slot(self, t: int) -> float | None:
        """The frame number the line puts stamp ``t`` at, or None when it is in doubt.

        In doubt unless after the last frame's, and its stamp nearer it than half an
        interval by three of the line's 1-sigmas there (else the next slot could be its own).
        """
        a, b, jitter = self._line
        assert self._frame is not None
        slot = float(np.round((t - a) / b))
        k = np.fromiter(self._frame, np.float64, len(self._frame))
        spread = max(float(((k - k.mean()) ** 2).sum()), 1e-300)
        sigma = jitter * np.sqrt(1.0 / k.size + (slot - k.mean()) ** 2 / spread)
        if slot <= k[-1] or abs(t - (a + b * slot)) > 0.5 * b - 3.0 * sigma:
            return None
        return slot


def causal_times(t_ns: ArrayLike) -> Ints:
    """(N,) int64 a camera's stamps' fitted times, as :class:`CausalClock` gives them live.

    Frame by frame in order (the stamps strictly increasing, integer nanoseconds).
    """
    t = np.asarray(t_ns).reshape(-1)
    if t.size and not np.isfinite(t).all():
        raise InputValueError("a camera's capture times must be finite numbers")
    clock = CausalClock()
    return np.array([clock.add(int(v)) for v in t.tolist()], dtype=np.int64)
