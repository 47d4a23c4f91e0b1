"""Issue 58 (adversarial finding 4): the measured clock offset's sigma is honest on the
simulator's own sessions -- at 100 in/s camera 1's interpolation error between its
frames is carried as a term of the sigma (it was -14.46 +- 0.0024 ms against a true -12.5),
and at 50% dropped frames a mean over a set of frames that changed with the offset made a
false sharp minimum (2.0 +- 7.7e-8 ms against 12.5): now refused in words, or covered."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage

import analysis
from analysis.session.stream import replay_pair_session
from recorder.simulate.pair import PairTiming, simulate_pair_session
from tests.helpers import SMALL_SCENE, rewrite_session
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.stream_entries import Touch
from twopose.methods.specs import Method, spec_of
from twopose.sim.scene import load_scene


@pytest.mark.parametrize(
    ("timing", "seed"),
    [
        (PairTiming(speed=100.0, clock_offset_ms=-12.5, flash=False), 0),
        (PairTiming(speed=10.0, clock_offset_ms=12.5, drop=0.5, flash=False), 0),
    ],
)
def test_a_measured_offset_is_within_its_sigma_or_refused(
    tmp_path: Path, timing: PairTiming, seed: int
) -> None:
    path = tmp_path / "s.mcap"
    simulate_pair_session(path, method=Method.POINT, timing=timing, trials=1, seed=seed)
    try:
        trials = replay_pair_session(path).trials
    except InputValueError as err:  # refused in words: an "I can't", never a wrong "ok"
        refused = str(err)
        trials = ()
    else:
        refused = ""
    if not trials:
        assert "the clock offset" in refused
    for trial in trials:
        offset = trial.offset
        error_ms = offset.offset_ns / 1e6 - timing.clock_offset_ms
        assert abs(error_ms) <= 3 * offset.sigma_ns / 1e6, (error_ms, offset)


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The README's two-camera demo (``simulate --method ground --cameras 2 --speed 10
    --clock-offset-ms 12.5 --trials 1``)."""
    path = tmp_path_factory.mktemp("demo") / "sim.mcap"
    timing = PairTiming(speed=10.0, clock_offset_ms=12.5)
    simulate_pair_session(path, method=Method.GROUND, timing=timing, trials=1, seed=0)
    return path


def test_the_readmes_two_camera_demo_gives_every_touch_ok(demo: Path) -> None:
    # Issue 58: the demo then `run` gave 2 of 4 touches ok: a table decal sat where the
    # finger's base passes in camera 2's view and the glove's mask merged them. The
    # clutter is kept off the target's whole path in both cameras' views now.
    ran = analysis.run([demo])
    assert ran.errors.empty, ran.errors
    assert len(ran.trials) == 4
    assert (ran.trials["status"] == "ok").all(), ran.trials[["touch", "status"]]


def test_a_touch_lost_to_a_camera_names_it_and_the_detectors_reason(
    demo: Path, tmp_path: Path
) -> None:
    """Issue 58 (adversarial 12): the README's demo's failed touches said "the nearest
    pair's fewer than two views"; the row names the camera and why its detector refused.

    The demo's scene no longer loses a touch (its clutter is kept off the finger's path):
    camera 2's frames about one touch are made blank here (a camera that lost the target)."""
    with SessionReader(demo) as reader:
        touches = [e for e in reader.iter_entries([Touch.TOPIC]) if isinstance(e, Touch)]
    touch_ns = sorted(t.time_ns for t in touches)[1]
    blank = cv2.imencode(".jpg", np.full((480, 640, 3), 128, np.uint8))[1].tobytes()

    def blanked(topic: str, data: bytes) -> bytes:
        if topic != "/twopose/camera/cam2/image":
            return data
        image = CompressedImage.FromString(data)
        if abs(image.timestamp.ToNanoseconds() - touch_ns) > 0.2e9:
            return data
        image.data = blank
        return bytes(image.SerializeToString())

    path = rewrite_session(demo, tmp_path / "lost.mcap", edit=blanked)
    rows = analysis.run([path]).trials
    lost = rows[rows["status"] != "ok"]
    assert list(lost["touch"]) == ["trial 1, touch 2"]
    for reason in lost["reason"]:
        assert "fewer than two views" not in reason
        assert re.search(r"not detected by camera 2: \S", reason), reason


def test_the_readmes_demo_measures_its_offset_by_the_flash_and_the_rays_gap(demo: Path) -> None:
    """``simulate`` fires a flash at each stream trial's start (issue 58 item 7); ``run``
    measures the offset from it and the moving target's rays together, as the recorder
    would, within its sigma of the truth (12.5 ms)."""
    (trial,) = replay_pair_session(demo).trials
    assert trial.offset_from == "measured"
    assert trial.offset.method == "flash and ray gap"
    error_ms = trial.offset.offset_ns / 1e6 - 12.5
    assert abs(error_ms) <= 3 * trial.offset.sigma_ns / 1e6, trial.offset


def test_an_offset_beyond_the_old_search_is_measured_from_simulate_through_run(
    tmp_path: Path,
) -> None:
    """The lead's gap (issue 58): simulate accepted +-1000 ms and the rays' gap searched
    +-500, so `run` refused a simulated session beyond it (and nothing measured it). The
    flash measures it, the rays' gap now searches every offset simulate accepts, and the
    two agree; every touch is estimated."""
    scene_file = tmp_path / "small.toml"
    scene_file.write_text(SMALL_SCENE)
    path = tmp_path / "far.mcap"
    offset_ms = -800.0
    timing = PairTiming(speed=20.0, clock_offset_ms=offset_ms)
    simulate_pair_session(
        path, method=Method.POINT, timing=timing, trials=1, seed=1, scene=load_scene(scene_file)
    )
    ran = analysis.run([path])
    assert ran.errors.empty, ran.errors
    rows = ran.trials
    assert (rows["status"] == "ok").all(), rows[["touch", "status", "reason"]]
    measured = rows["clock_offset_ms"].iloc[0]
    sigma = rows["clock_offset_sigma_ms"].iloc[0]
    assert abs(measured - offset_ms) <= 3 * sigma, (measured, sigma)
    assert (rows["clock_offset_source"] == "measured").all()


def test_the_recorder_and_run_measure_the_gloves_offset_alike_its_slide_fitted(
    demo: Path,
) -> None:
    """The glove's detected point is not one point both cameras see (each blob spans its
    own extent of the finger): both sides measure the offset by one path, each frame's
    image line's angle passed so that the point's slide along the finger is fitted. The
    frames handed in far faster than they are detected, as files are replayed: with
    ``lossless`` (files), none is left undetected (a second new user's r5 F3c: the
    recorded offset depended on the machine's load)."""
    from analysis.session.stream import detect_trial
    from recorder.procedure import stream_offset
    from recorder.sources.pair import TimedFrame
    from twopose.format.streams import read_pair_session
    from twopose.pair.trial_offset import measure_trial_offset

    (trial,) = replay_pair_session(demo).trials
    with SessionReader(demo) as reader:
        session = read_pair_session(reader)
        streams = session.trials[0]
        (one, two), _, lit = detect_trial(streams, Method.GROUND)
        meter = stream_offset.OffsetMeter(session.pair, Method.GROUND)
        meter.lossless = True  # as record_stream sets it for files and folders
        with meter:
            meter.begin(1)
            frames = []  # decoded first: handed in back to back, as a file's are read
            for camera, stream in ((1, streams.camera1), (2, streams.camera2)):
                size = (stream.camera.intrinsics.width, stream.camera.intrinsics.height)
                for k, frame in enumerate(stream.frames()):
                    t = int(stream.capture_ns[k])
                    frames.append(TimedFrame(camera, k, t, t, frame.decode(size), ""))
            for timed in frames:
                meter.add(timed)
            recorded, said = meter.end(1)
    assert meter.skipped == 0
    seen = (session.pair, (one.centroid_px, two.centroid_px), (one.t_ns, two.t_ns), lit)
    floor = spec_of(Method.GROUND).floor_in_pair[0]  # both sides' systematic term
    fitted = measure_trial_offset(*seen, (one.theta_deg, two.theta_deg), floor).offset
    as_a_dot = measure_trial_offset(*seen, None, floor).offset
    assert fitted is not None
    assert as_a_dot is not None
    assert trial.offset.offset_ns == fitted.offset_ns != as_a_dot.offset_ns  # run's: fitted
    assert recorded is not None, said
    assert recorded.offset_ns == pytest.approx(fitted.offset_ns, abs=1.0)  # ns: the recorder's
    assert recorded.sigma_ns == pytest.approx(fitted.sigma_ns, abs=1.0)
