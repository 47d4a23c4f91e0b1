"""Two cameras' frames paired as they arrive.

The pairs :func:`~twopose.pair.pairing.pair_captures` gives for the whole stream, each made
as soon as no later frame can change it. Each frame's stamp is first fitted by its camera's
clock as it arrives (:class:`twopose.pair.clock_fit.CausalClock`: from that camera's frames
up to it, the same time ``pair_captures`` gives it), and the frames are paired on those
times.
:func:`~twopose.pair.pairing.pair_frames` pairs frames that are each other's nearest in time
(mutual nearest neighbours) within the slop. A frame's nearest in the other stream is one of
its two neighbours there, so a pair is final once each of its frames has its neighbour on
both sides in the other stream (or that stream has ended): a live pair waits for the next
frame of each camera, at most a frame interval. :class:`LivePairing` keeps a window of each
camera's recent frames, pairs the window with :func:`pair_frames` on every frame and hands
out the pairs that are final, in order, each frame at most once.

A frame already paired, or passed over by a later pair, is dropped from the window, the last
paired one kept (it stands for every earlier frame: no later frame can pair across it).
Where one camera stalls and the other's frames fill the window, the oldest are dropped and a
pair whose neighbour fell out is not made (never a wrong pair; at most a pair at the edge of
a long stall is missed). No I/O; times are integer nanoseconds.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np

from twopose.errors import InputValueError
from twopose.pair.clock_fit import CausalClock
from twopose.pair.pairing import pair_frames

__all__ = ["LivePair", "LivePairing"]

K = TypeVar("K")


@dataclass(frozen=True, slots=True)
class LivePair(Generic[K]):
    """One pair made live.

    ``first`` camera 1's frame, ``second`` camera 2's, ``skew_ns`` camera 2's fitted capture
    time on camera 1's clock minus camera 1's.
    """

    first: K
    second: K
    skew_ns: int


@dataclass(slots=True)
class _Held(Generic[K]):
    seq: int  # the frame's number among its camera's frames given to the pairing
    t_ns: int  # its fitted time, on camera 1's clock
    key: K


class LivePairing(Generic[K]):
    """Frames of two cameras in, final pairs out (the module docstring).

    Parameters
    ----------
    slop_ns : int
        The largest |skew| of a pair (:func:`pair_frames`' slop; half a frame interval).
    offset_ns : int
        Camera 2's clock minus camera 1's: ``t1 = t2 - offset_ns``.
    window : int
        How many frames of each camera are kept at most.
    """

    def __init__(self, *, slop_ns: int, offset_ns: int = 0, window: int = 64) -> None:
        if slop_ns < 0:
            raise InputValueError(f"the slop must be a duration >= 0 ns, got {slop_ns}")
        if window < 2:
            raise InputValueError(f"the window must hold 2 frames or more, got {window}")
        self.slop_ns, self.offset_ns, self.window = int(slop_ns), int(offset_ns), window
        self._held: tuple[deque[_Held[K]], deque[_Held[K]]] = (deque(), deque())
        self._count = [0, 0]  # frames given, per camera
        self._last = [-1, -1]  # the last paired frame's seq, per camera
        self._rolled = [False, False]  # frames not yet decided fell out of the window
        self._ended = [False, False]
        self._clocks = (CausalClock(), CausalClock())
        self._stamp: list[int | None] = [None, None]  # each camera's last stamp

    def add(self, camera: int, t_ns: int, key: K) -> list[LivePair[K]]:
        """Give camera ``camera``'s next frame; the pairs that became final, in order.

        Parameters
        ----------
        camera : int
            1 or 2.
        t_ns : int
            The frame's capture time on its camera's clock, after the camera's last.
        key : object
            What the pair hands back for this frame.

        Returns
        -------
        list of LivePair
            Each pair's ``skew_ns`` on the fitted clocks.
        """
        c = _index(camera)
        if self._ended[c]:
            raise InputValueError(f"camera {camera}'s stream has ended: no frame comes after")
        last = self._stamp[c]
        if last is not None and int(t_ns) <= last:
            raise InputValueError(
                f"camera {camera}'s capture times must increase: {t_ns} ns came after {last} ns"
            )
        self._stamp[c] = int(t_ns)
        t = self._clocks[c].add(int(t_ns)) - (self.offset_ns if c == 1 else 0)
        held = self._held[c]
        held.append(_Held(self._count[c], t, key))
        self._count[c] += 1
        if len(held) > self.window:
            dropped = held.popleft()
            self._rolled[c] = self._rolled[c] or dropped.seq > self._last[c]
        return self._settle()

    def end(self, camera: int) -> list[LivePair[K]]:
        """Say that camera ``camera``'s stream ended; the pairs that became final.

        Parameters
        ----------
        camera : int
            1 or 2.

        Returns
        -------
        list of LivePair
        """
        self._ended[_index(camera)] = True
        return self._settle()

    def _settle(self) -> list[LivePair[K]]:
        one, two = self._held
        if not one or not two:
            return []
        t1 = np.fromiter((h.t_ns for h in one), np.int64, len(one))
        t2 = np.fromiter((h.t_ns for h in two), np.int64, len(two))
        found = pair_frames(t1, t2, slop_ns=self.slop_ns)
        out: list[LivePair[K]] = []
        for a, b in zip(found.i1.tolist(), found.i2.tolist(), strict=True):
            h1, h2 = one[a], two[b]
            if h1.seq <= self._last[0] or h2.seq <= self._last[1]:
                continue  # made already, or crossing one that was
            if not self._final(h1.t_ns, h2.t_ns, t1, t2):
                break  # neither this pair nor any later one is final yet
            if not self._whole(h1.t_ns, h2.t_ns, t1, t2):
                continue  # a neighbour fell out of the window: not made, never wrong
            out.append(LivePair(h1.key, h2.key, int(h2.t_ns - h1.t_ns)))
            self._last = [h1.seq, h2.seq]
        if out:
            self._forget()
        return out

    def _final(self, ta: int, tb: int, t1: np.ndarray, t2: np.ndarray) -> bool:
        """Whether both frames' nearest in the other stream can no longer change.

        It cannot once the other stream has a frame at or after it, or has ended.
        """
        return (self._ended[1] or int(t2[-1]) >= ta) and (self._ended[0] or int(t1[-1]) >= tb)

    def _whole(self, ta: int, tb: int, t1: np.ndarray, t2: np.ndarray) -> bool:
        """Whether both frames' earlier neighbours in the other stream are in the window."""
        return (not self._rolled[1] or int(t2[0]) <= ta) and (
            not self._rolled[0] or int(t1[0]) <= tb
        )

    def _forget(self) -> None:
        """Drop the frames before the last pair's (that one stays: it stands for them)."""
        for c, held in enumerate(self._held):
            while held and held[0].seq < self._last[c]:
                held.popleft()
            self._rolled[c] = False  # what is left starts at a decided frame

    @property
    def given(self) -> tuple[int, int]:
        """How many frames of each camera were given."""
        return self._count[0], self._count[1]


def _index(camera: int) -> int:
    if camera not in (1, 2):
        raise InputValueError(f"a pair's camera is 1 or 2, got {camera}")
    return camera - 1
