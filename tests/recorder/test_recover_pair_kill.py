"""A two-camera recording killed with SIGKILL: ``recover`` keeps every closed window.

The recording runs in a real subprocess that writes both cameras' frames in stream
windows and reports each frame it wrote; the test kills it (-9) mid-stream, recovers the
file and replays it: every frame of a window closed before the kill is there with its
capture time, the frames lost are at most the open window's, and the window in progress
is closed ``incomplete`` with recover's reason.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from recorder.recover import RECOVERED_REASON, recover_session
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session

_RECORDING = textwrap.dedent(
    """
    import sys, time
    import numpy as np
    from tests.twopose.format.pair_examples import pair_cameras
    from twopose.format.entries import SessionInfo
    from twopose.format.writer import SessionWriter
    from twopose.methods.specs import Method
    from twopose.pair.motion import thesis_pair
    from twopose.values.units import Units

    pair = thesis_pair()
    info = SessionInfo(method=Method.GROUND, units=Units.IN, camera_ids=("cam1", "cam2"),
                       clocks={"cam1": "monotonic at grab", "cam2": "monotonic at grab"})
    with SessionWriter(sys.argv[1], info, pair_cameras(pair), pair=pair) as writer:
        frame = writer.encode_image(np.full((480, 640, 3), 90, np.uint8))
        with writer.stream(1, window_s=0.05) as stream:
            closed = 0  # frames in windows closed (synced) so far
            for k in range(100_000):
                for cid, lag in (("cam1", 0), ("cam2", 3_000_000)):
                    window = stream.window
                    stream.add_encoded(cid, frame, 10**12 + k * 33_333_333 + lag)
                    if stream.window != window:  # the last one closed with the frame before
                        closed = sum(stream.n_frames.values()) - 1
                    print(stream.window, closed, sum(stream.n_frames.values()), flush=True)
                time.sleep(0.004)
    """
)


@pytest.mark.slow
def test_a_pair_recording_killed_loses_at_most_its_open_window(tmp_path: Path) -> None:
    path = tmp_path / "killed.mcap"
    root = Path(__file__).resolve().parents[2]
    process = subprocess.Popen(
        [sys.executable, "-c", _RECORDING, str(path)],
        cwd=root,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    seen = (0, 0, 0)
    try:
        for line in process.stdout:  # killed a little into its fifth window
            seen = tuple(int(x) for x in line.split())  # type: ignore[assignment]
            if seen[0] >= 5 and seen[2] > seen[1] + 3:
                break
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=30)
    finally:
        if process.poll() is None:
            process.kill()
    assert seen[0] >= 5, "the recording never reached its fifth window"
    window_then, closed_then, _ = seen
    fixed = tmp_path / "fixed.mcap"
    report = recover_session(path, fixed)
    assert report.closed_windows == 2  # each camera's window in progress
    with SessionReader(fixed) as reader:
        (trial,) = read_pair_session(reader).trials
    recovered = len(trial.camera1) + len(trial.camera2)
    # every frame of a window closed before the kill is kept (the kill may come later than
    # the last line read: more may be kept, never fewer)
    assert recovered >= closed_then
    # in order, each with the capture time it was written with
    for stream, lag in ((trial.camera1, 0), (trial.camera2, 3_000_000)):
        k = np.arange(len(stream))
        np.testing.assert_array_equal(stream.capture_ns, 10**12 + k * 33_333_333 + lag)
        windows = stream.windows
        assert all(w.status == "complete" for w in windows[:-1])
        assert windows[-1].status == "incomplete"
        assert windows[-1].reason == RECOVERED_REASON
        assert windows[-1].window >= window_then
        assert RECOVERED_REASON in stream.reason
        # lost at most the open window: every window but the last holds all it says
        assert sum(w.n_frames for w in windows) == len(stream)
