"""Two 640x480 streams at 30 fps through ``--source pair:A,B`` for 10 minutes: no pair dropped.

    .venv/bin/python benchmarks/bench_pair_source.py [--minutes 10] [--fps 30] [--write-docs]

Two MJPG video files (made here, cached under the system's temporary folder: a textured
scene with a moving square, each frame a 640x480 JPEG of ~90 kB, as a webcam's MJPG) are
played at their rate by :class:`recorder.sources.pair.PairSource`
(:func:`recorder.sources.registry.open_pair`), each on its reader thread with its bounded queue,
exactly as two cameras would be read (grabbed undecoded, decoded on the consumer's side).
The consumer takes the pairs as they become final
(:meth:`~recorder.sources.pair.PairSource.pairs`) and decodes both frames, as a recording
would before writing them. Printed: each window's pairs and rate, each camera's frames
dropped (a reader too slow for its queue, or a reader thread late for its camera by more than
the driver's ring), the queue's bound (seconds and bytes) and each time it overflowed, in
words, frames left unpaired, the pairs' skew, each pair's lag from its later
capture to the consumer holding both images (p50, p99, max), and the CPU time of the whole
process per pair against the frame interval. Targets: every frame of both files paired (none
dropped, none unpaired), every window's rate within 1% of the files' rate. Exits 1 if one is
missed. The machine is shared (2 cores, other work running): the load average at the start
and end is printed beside the figures.
"""

from __future__ import annotations

import argparse
import itertools
import os
import shutil
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from recorder.sources.pair import CameraStream
from recorder.sources.pair_feeds import RING_FRAMES
from recorder.sources.registry import open_pair
from twopose.atomic_write import replacing

FIGURE = "pair_source.txt"
WIDTH, HEIGHT = 640, 480


def make_video(path: Path, *, frames: int, fps: float, seed: int) -> Path:
    """An MJPG file of ``frames`` textured 640x480 frames (kept for the next run)."""
    if path.is_file() and path.stat().st_size > 0:
        return path
    rng = np.random.default_rng(seed)
    # A smooth texture with grain: a webcam's JPEG of a room is tens of kB, not a flat page's.
    base = cv2.resize(rng.integers(0, 255, (60, 80, 3), dtype=np.uint8), (WIDTH, HEIGHT))
    base = cv2.add(base, rng.integers(0, 24, (HEIGHT, WIDTH, 3), dtype=np.uint8))
    partial = path.with_suffix(".part.avi")
    writer = cv2.VideoWriter(str(partial), cv2.VideoWriter.fourcc(*"MJPG"), fps, (WIDTH, HEIGHT))
    for k in range(frames):
        image = base.copy()
        x = int(40 + (WIDTH - 120) * (0.5 + 0.5 * np.sin(k / fps)))
        cv2.rectangle(image, (x, 200), (x + 40, 240), (255, 255, 255), -1)
        cv2.putText(image, str(k), (20, 460), cv2.FONT_HERSHEY_SIMPLEX, 1.5, (0, 0, 0), 3)
        writer.write(image)
    writer.release()
    # OpenCV picks the container by the name's suffix: the file is written under its own
    # name, then copied in through the one atomic writer (a cut run leaves no half video).
    with replacing(path) as tmp:
        shutil.copyfile(partial, tmp)
    partial.unlink()
    return path


def main() -> int:
    """Play two files through a pair source; 0 if every frame was paired at a steady rate."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--fps", type=float, default=30.0)
    parser.add_argument("--window-s", type=float, default=60.0, help="rate shown per window")
    args = parser.parse_args()
    frames = round(args.minutes * 60 * args.fps)
    folder = Path(tempfile.gettempdir()) / "twopose-bench-pair-source"
    folder.mkdir(exist_ok=True)
    print(f"making the two files ({frames} frames each, cached in {folder}) ...", flush=True)
    videos = [
        make_video(folder / f"cam{c}_{frames}_{args.fps:g}.avi", frames=frames, fps=args.fps,
                   seed=c)
        for c in (1, 2)
    ]  # fmt: skip
    load0 = os.getloadavg()[0]
    t_cap1, t_cap2, t_held = [], [], []
    cpu0, wall0 = time.process_time(), time.monotonic()
    with open_pair(f"video:{videos[0]}", f"video:{videos[1]}") as source:
        cams = source.cameras
        for pair in source.pairs():
            # The images are decoded by now (the consumer's side); touching them is the use.
            assert pair.first.image.shape == pair.second.image.shape == (HEIGHT, WIDTH, 3)
            t_held.append(time.monotonic_ns())
            t_cap1.append(pair.first.t_capture_ns)
            t_cap2.append(pair.second.t_capture_ns)
        dropped, late = source.dropped_by_camera, source.late_by_camera
        said, bound = source.drops_said(), source.bound
        deepest, limit = source.deepest_by_camera, round(bound.seconds * args.fps)
    cpu, wall = time.process_time() - cpu0, time.monotonic() - wall0
    load1 = os.getloadavg()[0]
    times = (t_cap1, t_cap2, t_held)
    print(f"each camera's queue: {bound.seconds:g} s of its frames, at most "
          f"{bound.bytes / 2**20:.0f} MiB; past it, the oldest dropped, counted, said")  # fmt: skip
    for k, (n, size) in enumerate(deepest, start=1):
        print(f"camera {k}'s queue at its deepest: {n} frames ({n / args.fps:.2f} s behind, "
              f"{size / 1e6:.1f} MB) of its {limit}")  # fmt: skip
    for line in said:
        print(f"said: {line}")
    return report(args, frames, cams, (dropped, late), times, cpu, wall, (load0, load1))


def report(
    args: argparse.Namespace,
    frames: int,
    cams: tuple[CameraStream, CameraStream],
    losses: tuple[tuple[int, int], tuple[int, int]],
    times: tuple[list[int], list[int], list[int]],
    cpu_s: float,
    wall_s: float,
    load: tuple[float, float],
) -> int:
    """Print the run's table and verdict; 0 if the targets were met."""
    c1, c2, held = (np.asarray(t, dtype=np.int64) for t in times)
    n = c1.size
    interval_ms = 1e3 / args.fps
    print(f"\n{args.minutes:g} min of two {WIDTH}x{HEIGHT} MJPG files at {args.fps:g} fps "
          f"({frames} frames each), played at their rate through pair:video:A,video:B")  # fmt: skip
    for k, cam in enumerate(cams, start=1):
        print(f"camera {k}: {cam.info.width}x{cam.info.height} {cam.fourcc}, clock {cam.clock}")
    print(f"load average (1 min) at the start {load[0]:.2f}, at the end {load[1]:.2f} (2 cores)")
    print(f"\n{'pairs in hand':>14} {'pairs':>7} {'pairs/s':>9}")
    rates = []
    if n:
        start = int(c1[0])  # the first capture; each pair counted when the consumer had it
        step = min(args.window_s, args.minutes * 60)
        edges = np.arange(0, args.minutes * 60 + 1e-9, step)
        for a, b in itertools.pairwise(edges):
            inside = (held - start >= a * 1e9) & (held - start < b * 1e9)
            rate = int(inside.sum()) / (b - a)
            rates.append(rate)
            print(f"{a:>6.0f}-{b:<5.0f} s {int(inside.sum()):>7} {rate:>9.2f}")
    skew_ms = np.abs(c2 - c1) / 1e6 if n else np.zeros(1)
    lag_ms = (held - np.maximum(c1, c2)) / 1e6 if n else np.zeros(1)
    unpaired = (frames - n, frames - n)
    dropped, late = losses
    print(f"\npairs {n} of {frames} frames a camera; unpaired: camera 1 {unpaired[0]}, "
          f"camera 2 {unpaired[1]}; dropped: camera 1 {dropped[0]}, "
          f"camera 2 {dropped[1]}")  # fmt: skip
    print(f"  of those dropped, the reader thread late for its file by over {RING_FRAMES} "
          "intervals: "
          f"camera 1 {late[0]}, camera 2 {late[1]}; the rest: past its queue's bound")  # fmt: skip
    print(f"skew |t2 - t1|: max {skew_ms.max():.3f} ms")
    p50, p99 = np.percentile(lag_ms, [50, 99])
    print(f"from the later capture to both images decoded in hand: p50 {p50:.1f} ms, "
          f"p99 {p99:.1f} ms, max {lag_ms.max():.1f} ms (a frame interval: "
          f"{interval_ms:.1f} ms)")  # fmt: skip
    per_pair_ms = 1e3 * cpu_s / max(n, 1)
    print(f"CPU (the whole process, both readers and the decoding): {per_pair_ms:.2f} ms per "
          f"pair, {100 * per_pair_ms / interval_ms:.0f}% of a frame interval of one core; "
          f"wall {wall_s:.1f} s")  # fmt: skip
    steady = bool(rates) and all(abs(r - args.fps) <= 0.01 * args.fps for r in rates)
    whole = n == frames and dropped == (0, 0)
    print(f"\ntarget: every frame paired, none dropped: {'met' if whole else 'MISSED'}")
    print(f"target: every window's rate within 1% of {args.fps:g}/s: "
          f"{'met' if steady else 'MISSED'}")  # fmt: skip
    return 0 if whole and steady else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
