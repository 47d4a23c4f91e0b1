"""Pairs made live, frame by frame as they arrive, are the pairs ``pair_captures`` makes of the
whole stream: over free-running cameras with drift, jitter, dropped frames, an offset and
any arrival order; a stall longer than the window never makes a wrong pair."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from twopose.errors import InputValueError
from twopose.pair.live_pairing import LivePairing
from twopose.pair.pairing import pair_captures, pair_frames

INTERVAL_NS = 33_333_333


def _stream(
    rng: np.random.Generator, n: int, ppm: float, jitter_ns: float, drop: float
) -> np.ndarray:
    """Capture times of a free-running camera: its rate off by ``ppm``, stamps jittered,
    a share ``drop`` of frames dropped; strictly increasing integers."""
    t = np.arange(n) * INTERVAL_NS * (1 + ppm * 1e-6) + rng.uniform(0, INTERVAL_NS)
    t = t + rng.normal(0, jitter_ns, n)
    t = t[rng.random(n) >= drop]
    return np.maximum.accumulate(np.round(t).astype(np.int64) + np.arange(t.size))


def _live(
    t1: np.ndarray, t2: np.ndarray, arrival: np.ndarray, slop: int, offset: int, window: int = 64
) -> list[tuple[int, int, int]]:
    """Feed the frames in ``arrival`` order (within each camera, in order); the pairs made."""
    live: LivePairing[int] = LivePairing(slop_ns=slop, offset_ns=offset, window=window)
    cams = np.r_[np.ones(t1.size, int), np.full(t2.size, 2)]
    index = np.r_[np.arange(t1.size), np.arange(t2.size)]
    times = np.r_[t1, t2]
    made = []
    for k in np.argsort(arrival, kind="stable"):
        made += live.add(int(cams[k]), int(times[k]), int(index[k]))
    made += live.end(1) + live.end(2)
    return [(p.first, p.second, p.skew_ns) for p in made]


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(0, 90),
    ppm=st.floats(-300, 300),
    jitter_ms=st.floats(0, 4),
    drop=st.floats(0, 0.3),
    offset_ms=st.floats(-20, 20),
    lag_ms=st.floats(0, 120),
    slop_share=st.floats(0.1, 0.5),
)
def test_live_pairs_are_the_whole_streams_pairs(
    seed: int,
    n: int,
    ppm: float,
    jitter_ms: float,
    drop: float,
    offset_ms: float,
    lag_ms: float,
    slop_share: float,
) -> None:
    rng = np.random.default_rng(seed)
    offset = round(offset_ms * 1e6)
    t1 = _stream(rng, n, 0.0, jitter_ms * 1e6, drop)
    t2 = _stream(rng, n, ppm, jitter_ms * 1e6, drop) + offset
    # Each frame arrives after its capture by a random lag (camera 2's on its own clock).
    arrival = np.r_[t1, t2 - offset] + rng.uniform(0, lag_ms * 1e6, t1.size + t2.size)
    for c, size in ((0, t1.size), (1, t2.size)):  # one camera's frames come in order
        part = slice(0, t1.size) if c == 0 else slice(t1.size, None)
        arrival[part] = np.maximum.accumulate(arrival[part]) if size else arrival[part]
    slop = round(slop_share * INTERVAL_NS)
    made = _live(t1, t2, arrival, slop, offset)
    whole = pair_captures(t1, t2, offset_ns=offset, slop_ns=slop)
    assert [(a, b) for a, b, _ in made] == list(
        zip(whole.i1.tolist(), whole.i2.tolist(), strict=True)
    )
    assert [s for _, _, s in made] == pytest.approx(whole.skew_ns.tolist(), abs=1)


def test_a_stall_longer_than_the_window_never_makes_a_wrong_pair() -> None:
    rng = np.random.default_rng(3)
    t1 = _stream(rng, 300, 0.0, 1e6, 0.0)
    t2 = _stream(rng, 300, 100.0, 1e6, 0.0)
    t2 = np.r_[t2[:100], t2[200:]]  # camera 2 stalled for 100 frames, then went on
    arrival = np.r_[t1, t2] + rng.uniform(0, 50e6, t1.size + t2.size)
    arrival[:300], arrival[300:] = (
        np.maximum.accumulate(arrival[:300]),
        np.maximum.accumulate(arrival[300:]),
    )
    whole = pair_captures(t1, t2, slop_ns=INTERVAL_NS // 2)
    expected = list(zip(whole.i1.tolist(), whole.i2.tolist(), strict=True))
    made = _live(t1, t2, arrival, INTERVAL_NS // 2, 0, window=16)
    pairs = [(a, b) for a, b, _ in made]
    assert set(pairs) <= set(expected)  # never a wrong pair
    assert pairs == sorted(pairs)
    assert len({a for a, _ in pairs}) == len(pairs) == len({b for _, b in pairs})
    assert len(pairs) >= len(expected) - 2  # at most a pair at the stall's edge missed
    # A camera whose frames come later than the window reaches (here 5 s, 150 frames):
    # its frames find no partner left, and no wrong one.
    late = np.r_[t1, t2 + 5_000_000_000]
    made = _live(t1, t2, late, INTERVAL_NS // 2, 0, window=16)
    assert {(a, b) for a, b, _ in made} <= set(expected)
    assert len(made) < len(expected) // 2


def test_equal_times_pair_at_once_and_a_frame_waits_for_its_neighbours() -> None:
    live: LivePairing[str] = LivePairing(slop_ns=10)
    assert live.add(1, 100, "a") == []
    (pair,) = live.add(2, 100, "b")  # same instant: nothing can come nearer
    assert (pair.first, pair.second, pair.skew_ns) == ("a", "b", 0)
    assert live.add(1, 200, "c") == []
    assert live.add(2, 205, "d") == []  # camera 1's next frame could be nearer to d
    (pair,) = live.add(1, 300, "e")
    assert (pair.first, pair.second, pair.skew_ns) == ("c", "d", 5)
    assert live.given == (3, 2)


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda p: p.add(3, 0, 0), "camera is 1 or 2"),
        (lambda p: (p.add(1, 5, 0), p.add(1, 5, 1)), "capture times must increase"),
        (lambda p: (p.end(2), p.add(2, 9, 0)), "stream has ended"),
        (lambda p: LivePairing(slop_ns=-1), "slop must be a duration"),
        (lambda p: LivePairing(slop_ns=1, window=1), "window must hold 2 frames"),
    ],
)
def test_wrong_use_is_refused_in_words(call: object, words: str) -> None:
    with pytest.raises(InputValueError, match=words):
        call(LivePairing(slop_ns=10))  # type: ignore[operator]


def test_a_pair_whose_nearer_neighbour_fell_out_of_the_window_is_not_made() -> None:
    # Camera 1's frame at 105 is camera 2's 108's nearest, but it rolled out of a window of
    # two while camera 2 was late: pairing 108 with 112 (the nearest left) would be wrong.
    live: LivePairing[str] = LivePairing(slop_ns=10, window=2)
    made = [p for t, k in ((105, "a"), (112, "b"), (300, "c")) for p in live.add(1, t, k)]
    made += live.add(2, 108, "x") + live.add(2, 400, "y") + live.end(1) + live.end(2)
    assert made == []
    whole = pair_frames(np.array([105, 112, 300]), np.array([108, 400]), slop_ns=10)
    assert (whole.i1.tolist(), whole.i2.tolist()) == ([0], [0])  # 105 with 108, not 112
