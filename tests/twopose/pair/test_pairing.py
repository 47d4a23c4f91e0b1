"""Two cameras' frames paired by capture time (twopose.pair.pairing): ApproximateTime's
invariants over random streams, agreement with a brute-force reference, drift, drops."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from twopose.errors import InputValueError
from twopose.pair.motion import CameraClock
from twopose.pair.pairing import pair_frames

INTERVAL = 33_333_333.0


@st.composite
def streams(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Two streams of increasing times (ns): rates, phases, gaps and jitter drawn."""
    n1, n2 = draw(st.integers(0, 60)), draw(st.integers(0, 60))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    scale = draw(st.sampled_from([1.0, 1.0001, 0.97, 2.0, 0.5]))

    def stream(n: int, step: float) -> np.ndarray:
        gaps = step * rng.choice([1.0, 1.0, 1.0, 2.0, 3.0, 0.2], size=n)
        return np.cumsum(gaps + rng.normal(0, 0.05 * step, n).clip(-0.1 * step, None))

    offset = draw(st.floats(-1e9, 1e9))
    slop = draw(st.sampled_from([None, 0.0, INTERVAL / 4, INTERVAL, 10 * INTERVAL]))
    return stream(n1, INTERVAL), stream(n2, INTERVAL * scale) + offset, offset, slop or -1.0


@settings(max_examples=150, deadline=None)
@given(streams())
def test_every_frame_at_most_once_in_order_within_the_slop(
    case: tuple[np.ndarray, np.ndarray, float, float],
) -> None:
    t1, t2, offset, slop = case
    if slop < 0 and 0 < max(t1.size, t2.size) < 2 and min(t1.size, t2.size) == 1:
        with pytest.raises(InputValueError, match="give the slop"):  # no interval to halve
            pair_frames(t1, t2, offset_ns=offset)
        return
    p = pair_frames(t1, t2, offset_ns=offset, slop_ns=None if slop < 0 else slop)
    assert np.unique(p.i1).size == p.i1.size
    assert np.unique(p.i2).size == p.i2.size
    assert (np.diff(p.i1) > 0).all()
    assert (np.diff(p.i2) > 0).all()
    skew = (t2 - offset)[p.i2] - t1[p.i1]
    assert np.allclose(skew, p.skew_ns, atol=1e-3)
    assert (np.abs(p.skew_ns) <= p.slop_ns + 1e-6).all() or p.n_pairs == 0
    assert p.unpaired1 == t1.size - p.n_pairs
    assert p.unpaired2 == t2.size - p.n_pairs
    # The pairs are exactly the mutual nearest neighbours within the slop (brute force).
    assert set(zip(p.i1.tolist(), p.i2.tolist(), strict=True)) == _brute(t1, t2 - offset, p.slop_ns)


def _brute(t1: np.ndarray, t2: np.ndarray, slop: float) -> set[tuple[int, int]]:
    """Mutual nearest neighbours within ``slop``, by the full distance matrix (ties: the
    earlier frame)."""
    if t1.size == 0 or t2.size == 0:
        return set()
    d = np.abs(t1[:, None] - t2[None, :])
    nearest2, nearest1 = d.argmin(axis=1), d.argmin(axis=0)
    return {(i, int(j)) for i, j in enumerate(nearest2) if nearest1[j] == i and d[i, j] <= slop}


def test_drift_drops_and_jitter_leave_the_true_pairs() -> None:
    """A minute of two free-running cameras (camera 2 100 ppm faster, 5% of frames
    dropped): on the true instants the pairing finds every pair of the nearest frames,
    and frames slip past each other without a pair beyond half an interval."""
    rng = np.random.default_rng(3)
    one = CameraClock(drop=0.05).frames(60.0, rng)
    two = CameraClock(phase_s=0.01, drift_ppm=-100, drop=0.05, offset_s=0.25).frames(60.0, rng)
    p = pair_frames(one.stamps_ns, two.stamps_ns, offset_ns=0.25e9)
    true_skew = two.true_s[p.i2] - one.true_s[p.i1]
    assert np.abs(true_skew).max() <= 0.5 / 30 + 1e-9
    # 5% dropped in each: about 10% of the frames lose their partner, no more.
    assert 0.85 * one.true_s.size <= p.n_pairs <= 0.95 * one.true_s.size


def test_a_dropped_frame_leaves_its_partner_unpaired_not_forced_on_a_neighbour() -> None:
    t1 = np.arange(10) * INTERVAL
    t2 = np.delete(np.arange(10) * INTERVAL + 0.4 * INTERVAL, 4)  # camera 2 lost frame 4
    p = pair_frames(t1, t2)
    assert 4 not in p.i1.tolist()
    assert p.n_pairs == 9
    assert p.unpaired1 == 1
    assert p.unpaired2 == 0


def test_a_per_frame_offset_follows_a_drifting_clock() -> None:
    t1 = np.arange(100) * INTERVAL
    drift = 1e-3 * np.arange(100) * INTERVAL  # camera 2's clock gains 1 ms a second
    t2 = t1 + 0.3e9 + drift
    assert pair_frames(t1, t2, offset_ns=0.3e9 + drift).n_pairs == 100
    with pytest.raises(InputValueError, match="one per camera-2 frame"):
        pair_frames(t1, t2, offset_ns=np.zeros(3))


def test_nanoseconds_since_1970_keep_every_nanosecond() -> None:
    epoch = np.int64(1_700_000_000_000_000_000)
    t1 = epoch + np.arange(5, dtype=np.int64) * 33_333_333
    t2 = t1 + 16_666_666  # just under half an interval after
    p = pair_frames(t1, t2)
    assert p.n_pairs == 5
    assert (p.skew_ns == 16_666_666).all()


@pytest.mark.parametrize(
    ("t1", "t2", "words"),
    [
        ([0, 2, 1], [0, 1], "camera 1's capture times must increase"),
        ([0, 1], [0, 0], "camera 2's capture times must increase"),
        ([0, np.nan], [0, 1], "finite"),
    ],
)
def test_times_that_do_not_increase_are_refused(
    t1: list[float], t2: list[float], words: str
) -> None:
    with pytest.raises(InputValueError, match=words):
        pair_frames(np.array(t1, float), np.array(t2, float))


def test_a_negative_slop_is_refused() -> None:
    with pytest.raises(InputValueError, match="slop"):
        pair_frames(np.arange(3.0), np.arange(3.0), slop_ns=-1.0)
