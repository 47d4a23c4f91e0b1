"""The replay: frames decoded and detected in threads give what one thread gives, and the
rig's leave-one-out fit is told the session's units."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd
import pytest

import analysis.session.detection
import analysis.session.pipeline
import twopose.solve.session
from analysis.results import AnalysisOptions
from analysis.session.pipeline import analyse_session
from twopose.solve.session import SessionEstimate


@pytest.mark.parametrize("fixture", ["ground_session", "point_session", "line_session"])
def test_detection_threads_change_nothing(
    fixture: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, request: pytest.FixtureRequest
) -> None:
    session: Path = request.getfixturevalue(fixture)
    runs = {}
    for threads in (0, 3):
        monkeypatch.setattr(analysis.session.detection, "detection_threads", lambda n=threads: n)
        out = tmp_path / f"results_{threads}.mcap"
        runs[threads] = (analyse_session(session, results_path=out), out.read_bytes())
    (serial, serial_mcap), (threaded, threaded_mcap) = runs[0], runs[3]
    for table in ("frames", "trials", "averaging", "views"):
        pd.testing.assert_frame_equal(getattr(serial, table), getattr(threaded, table))
    assert serial_mcap == threaded_mcap


def test_threads_only_where_the_cores_are_this_process_own(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A worker of a --jobs pool sets OpenCV to one thread: no detection threads there."""
    import cv2

    threads = cv2.getNumThreads()
    try:
        cv2.setNumThreads(1)
        assert analysis.session.detection.detection_threads() == 0
    finally:
        cv2.setNumThreads(threads)


def test_no_threads_on_a_process_given_one_core(monkeypatch: pytest.MonkeyPatch) -> None:
    """A process held to one core (taskset, a container's CPU set) has no core for detection
    threads, however many the machine has: they would only take turns with the reader."""
    import os

    if not hasattr(os, "sched_getaffinity"):
        pytest.skip("no CPU affinity on this platform")
    import cv2

    threads = cv2.getNumThreads()
    try:
        cv2.setNumThreads(2)
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
        threads = analysis.session.detection.detection_threads()
        assert threads == analysis.session.detection.DETECTION_THREADS
        monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
        assert analysis.session.detection.detection_threads() == 0
    finally:
        cv2.setNumThreads(threads)


def test_an_undecodable_frame_is_a_rejected_frame_with_threads(
    tmp_path: Path, ground_session: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from twopose.errors import SessionFormatError
    from twopose.format.messages import Frame

    real = Frame.decode

    def flaky(self: Frame, size: Any = None) -> Any:
        if self.sequence % 4 == 1:
            raise SessionFormatError(f"frame {self.sequence} broken")
        return real(self, size)

    monkeypatch.setattr(Frame, "decode", flaky)
    monkeypatch.setattr(analysis.session.detection, "detection_threads", lambda: 2)
    frames = analyse_session(ground_session).frames
    broken = frames[frames["reason"].str.endswith("broken")]
    assert len(broken) > 0
    assert not broken["found"].any()


def test_leave_one_out_reuses_the_sessions_one_estimate(
    ground_session: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--rig-calibration loo`` takes the session's estimate (its units included): the
    session is estimated once, not again for the rig."""
    import analysis.rig.data
    import analysis.rig.fit
    import analysis.session.pipeline

    units: list[str] = []
    estimated: list[int] = []
    real_loo, real_estimate = (
        analysis.rig.fit.loo_calibration,
        twopose.solve.session.estimate_session,
    )

    def loo_spy(session: str, estimate: SessionEstimate, *args: Any) -> Any:
        units.append(estimate.trials.units)
        return real_loo(session, estimate, *args)

    def estimate_spy(*args: Any) -> Any:
        estimated.append(1)
        return real_estimate(*args)

    monkeypatch.setattr(analysis.rig.fit, "loo_calibration", loo_spy)
    monkeypatch.setattr(analysis.session.pipeline, "estimate_session", estimate_spy)
    monkeypatch.setattr(analysis.rig.data, "estimate_session", estimate_spy)
    result = analyse_session(ground_session, AnalysisOptions(rig_calibration="loo"))
    assert units == ["in"]  # the simulated session's units
    assert len(estimated) == 1
    assert "x_rig" in result.trials.columns
