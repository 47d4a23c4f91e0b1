"""Every frame of a session detected, in order: one trial ahead on threads where the
cores allow it (the detections are the same either way), or the detections a run's first
pass found given again; a trial's detected frames turned into its views and frame rows."""

from __future__ import annotations

from collections.abc import Generator, Iterator, Sequence
from typing import Any

from analysis.session.results_mcap import ResultsWriter
from analysis.tables.rows import frame_row
from twopose.camera.model import Intrinsics
from twopose.detect.detection import Detection
from twopose.errors import SessionFormatError
from twopose.format.entries import PoseEntry
from twopose.format.messages import Frame
from twopose.format.trials import PoseCapture, TrialRecord
from twopose.solve.estimate import PoseView, pose_view
from twopose.values.choices import P, TargetSpec

__all__ = [
    "DETECTION_THREADS",
    "Detections",
    "detected",
    "detection_threads",
    "given_detections",
    "trial_views",
]

#: Threads decoding and detecting frames beside the one reading the session and writing
#: what was found (OpenCV and NumPy release the GIL for most of a frame's work).
DETECTION_THREADS = 2

Detections = list[list[Detection]]  # per pose of a trial, per frame


def _detect_frame(
    frame: Frame, size: tuple[int, int], target: TargetSpec[P], params: P
) -> Detection:
    try:
        return target.detect(frame.decode(size), params)
    except SessionFormatError as err:  # one undecodable frame is a rejected frame
        return Detection(found=False, reason=str(err))


def detection_threads() -> int:
    """Threads for :func:`_detected`: none in a process that is one of several workers
    (they set OpenCV to one thread: the cores are taken) or off the main thread (a Dask
    worker's task), else :data:`DETECTION_THREADS` on more than one core."""
    import os
    import threading

    import cv2

    # The cores this process may run on (``taskset``, a container's CPU set), not the
    # machine's: threads on a core the process cannot use only take turns with this one.
    affinity = getattr(os, "sched_getaffinity", None)
    cores = len(affinity(0)) if affinity is not None else (os.cpu_count() or 1)
    if threading.current_thread() is not threading.main_thread() or cv2.getNumThreads() < 2:
        return 0
    return min(DETECTION_THREADS, cores) if cores > 1 else 0


def detected(
    records: Iterator[TrialRecord], target: TargetSpec[P], params: P
) -> Generator[tuple[TrialRecord, Detections], None, None]:
    """Each trial with every frame's detection, in order. With threads, the next trial's
    frames are decoded and detected while this one's are written (one trial ahead, so
    memory stays that of two trials); the detections are the same either way."""
    threads = detection_threads()
    if not threads:
        for record in records:
            yield (
                record,
                [
                    [_detect_frame(f, _size(pc), target, params) for f in pc.frames]
                    for pc in record.poses
                ],
            )
        return
    from collections import deque
    from concurrent.futures import Future, ThreadPoolExecutor

    pool = ThreadPoolExecutor(threads, thread_name_prefix="twopose-detect")
    ahead: deque[tuple[TrialRecord, list[list[Future[Detection]]]]] = deque()
    try:
        for record in records:
            futures = [
                [pool.submit(_detect_frame, f, _size(pc), target, params) for f in pc.frames]
                for pc in record.poses
            ]
            ahead.append((record, futures))
            if len(ahead) > 1:
                done, pending = ahead.popleft()
                yield done, [[f.result() for f in pose] for pose in pending]
        while ahead:
            done, pending = ahead.popleft()
            yield done, [[f.result() for f in pose] for pose in pending]
    finally:  # Ctrl-C, a timeout or a failure: what has not started never will
        pool.shutdown(wait=True, cancel_futures=True)


def given_detections(
    records: Iterator[TrialRecord], known: Sequence[Detections], session: str
) -> Generator[tuple[TrialRecord, Detections], None, None]:
    """Each trial with the detections found before (a run's first pass), in order."""
    for k, record in enumerate(records):
        if k >= len(known) or [len(p) for p in known[k]] != [len(pc.frames) for pc in record.poses]:
            raise SessionFormatError(f"{session} changed since its first pass: analyse it again")
        yield record, list(known[k])


def _size(pc: PoseCapture) -> tuple[int, int]:
    return (pc.camera.intrinsics.width, pc.camera.intrinsics.height)


def trial_views(
    record: TrialRecord,
    detections: Detections,
    session: str,
    rows: list[dict[str, Any]],
    results: ResultsWriter | None,
) -> list[PoseView]:
    """A trial's detected frames (one row each in ``rows``; drawn into ``results``); its
    complete poses."""
    views: list[PoseView] = []
    for pc, dets in zip(record.poses, detections, strict=True):
        if results is not None and pc.frames:
            results.add_pose(pc.entry, pc.frames[0].log_time_ns)
        for j, (frame, det) in enumerate(zip(pc.frames, dets, strict=True)):
            if results is not None:
                results.add_frame(
                    frame, det, f"trial {record.trial} pose {pc.entry.pose} frame {j}"
                )
            rows.append(frame_row(session, record.trial, pc.entry, j, frame, det))
        if pc.complete:
            sigma = dict(pc.camera.intrinsics_sigma)  # the calibration's, if recorded
            views.append(_pose_view(pc.entry, pc.camera.intrinsics, dets, sigma))
    return views


def _pose_view(
    entry: PoseEntry, intrinsics: Intrinsics, dets: list[Detection], sigma: dict[str, float]
) -> PoseView:
    return pose_view(
        entry,
        intrinsics,
        [d.found for d in dets],
        [d.centroid_px for d in dets],
        [d.theta_deg for d in dets],
        sigma,
    )
