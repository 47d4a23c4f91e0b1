"""Frames paired on each camera's fitted clock find the pairs of the true instants that
jittered stamps lose, live and in ``run`` alike (issue 58: `run` made 63 of 81 pairs with
10 ms of stamp jitter). The clocks are the simulator's (``twopose.sim.moving``): free
running, drift, jitter cut at 0.45 of an interval, dropped frames."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from twopose.methods.specs import Method
from twopose.pair.clock_fit import CausalClock, ClockOffset, causal_times
from twopose.pair.live_pairing import LivePairing
from twopose.pair.motion import FingerMotion, Frames, observe, thesis_pair
from twopose.pair.pairing import Pairing, pair_captures, pair_frames
from twopose.pair.stream import StreamNoise, StreamSettings, estimate_stream
from twopose.sim.moving import CameraFrames, ClockSettings, camera_frames
from twopose.values import bounds


def _clocks(
    rng: np.random.Generator, *, jitter_ms: float, drift_ppm: float, drop: float,
    offset_ms: float, seconds: float,
) -> tuple[CameraFrames, CameraFrames, np.ndarray, np.ndarray]:  # fmt: skip
    one = camera_frames(ClockSettings(jitter_s=jitter_ms * 1e-3, drop=drop), seconds, rng)
    two = camera_frames(
        ClockSettings(jitter_s=jitter_ms * 1e-3, drop=drop, drift_ppm=drift_ppm,
                      offset_s=offset_ms * 1e-3),
        seconds, rng,
    )  # fmt: skip
    t1, t2 = (np.round(f.stamp_s * 1e9).astype(np.int64) for f in (one, two))
    return one, two, t1, t2


def _found(p: Pairing, one: CameraFrames, two: CameraFrames) -> tuple[int, int]:
    """How many of the true instants' pairs ``p`` made, and how many there are."""
    ideal = pair_frames(one.true_s * 1e9, two.true_s * 1e9, slop_ns=p.slop_ns)
    truth = set(zip(ideal.i1.tolist(), ideal.i2.tolist(), strict=True))
    return len(truth & set(zip(p.i1.tolist(), p.i2.tolist(), strict=True))), len(truth)


def test_the_stream_estimate_pairs_on_the_fitted_clocks() -> None:
    # What `run` pairs: the stream estimate's own pairing, 2 ms of jitter (the issue's
    # case), 100 ppm, 5% dropped, 20 seeded trials of 3 s. On the stamps 93.6% were found.
    pair, motion = thesis_pair(), FingerMotion()
    found = total = 0
    for seed in range(20):
        rng = np.random.default_rng(seed)
        one, two, t1, t2 = _clocks(rng, jitter_ms=2.0, drift_ppm=100.0, drop=0.05,
                                   offset_ms=12.5, seconds=3.0)  # fmt: skip
        track1, track2 = (
            observe(pair, motion, Frames(true_s=f.true_s, stamps_ns=t), n, line=False)
            for n, (f, t) in enumerate(((one, t1), (two, t2)), start=1)
        )
        offset = ClockOffset(offset_ns=12.5e6, sigma_ns=0.0, method="given", n=0)
        noise = StreamNoise(centroid_px=0.25, theta_deg=0.25)
        est = estimate_stream(Method.POINT, pair, track1, track2, offset,
                              StreamSettings(noise=(noise, noise)))  # fmt: skip
        made = Pairing(i1=est.i1, i2=est.i2, skew_ns=est.skew_ns, slop_ns=1e9 / 60,
                       unpaired1=0, unpaired2=0)  # fmt: skip
        f, n = _found(made, one, two)
        found, total = found + f, total + n
    assert found / total >= 0.98, f"{found} of {total} true pairs"


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    jitter_ms=st.floats(0.0, bounds.JITTER.high),
    drift_ppm=st.floats(-100.0, 100.0),
    drop=st.floats(0.0, 0.5),
    offset_ms=st.floats(-1000.0, 1000.0),
    seconds=st.floats(0.2, 6.0),
)
def test_pairs_on_the_fitted_clocks_over_the_simulators_clocks(
    seed: int, jitter_ms: float, drift_ppm: float, drop: float, offset_ms: float, seconds: float
) -> None:
    rng = np.random.default_rng(seed)
    one, two, t1, t2 = _clocks(rng, jitter_ms=jitter_ms, drift_ppm=drift_ppm, drop=drop,
                               offset_ms=offset_ms, seconds=seconds)  # fmt: skip
    offset = round(offset_ms * 1e6)
    if t1.size < 2 or t2.size < 2:
        return
    p = pair_captures(t1, t2, offset_ns=offset)
    # Each frame at most once, both cameras' frames in order, none beyond the slop.
    assert (np.diff(p.i1) > 0).all()
    assert (np.diff(p.i2) > 0).all()
    assert (np.abs(p.skew_ns) <= p.slop_ns).all()
    # Live, frame by frame as they were taken (other arrival orders pair alike:
    # tests/twopose/pair/test_live_pairing.py), the same pairs.
    live: LivePairing[int] = LivePairing(slop_ns=round(p.slop_ns), offset_ns=offset)
    order = np.argsort(np.r_[t1, t2 - offset], kind="stable")
    cams, index, times = np.r_[[1] * t1.size, [2] * t2.size], np.r_[
        np.arange(t1.size), np.arange(t2.size)], np.r_[t1, t2]  # fmt: skip
    made = [q for k in order for q in live.add(int(cams[k]), int(times[k]), int(index[k]))]
    made += live.end(1) + live.end(2)
    whole = pair_captures(t1, t2, offset_ns=offset, slop_ns=round(p.slop_ns))
    assert [(q.first, q.second) for q in made] == list(
        zip(whole.i1.tolist(), whole.i2.tolist(), strict=True)
    )
    # Each fitted time is the one a live clock gives.
    clock = CausalClock()
    assert [clock.add(t) for t in t1.tolist()] == causal_times(t1).tolist()
    # By the true instants, no pair made is further apart than the slop and what 2 ms of
    # jitter can move two frames (the case; more jitter: the benchmark's sweep).
    # Which of two frames half an interval apart pairs may go either way (the stamps'
    # pairing too), so the pairs' count is the benchmark's and the seeded test's to judge.
    if jitter_ms <= 2.0:
        true_skew = np.abs(two.true_s[p.i2] - one.true_s[p.i1]) * 1e9
        assert (true_skew <= p.slop_ns + (8 * jitter_ms + 1.0) * 1e6).all()
