"""Helpers shared by test modules (real files, written with OpenCV)."""

from __future__ import annotations

import dataclasses
import importlib
import json
import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar

import cv2
import numpy as np
from numpy.typing import NDArray

from twopose.format.entries import CaptureDecision, PoseEntry
from twopose.format.writer import SessionWriter

#: A small synthetic camera (320x240, no supersampling, no clutter): a new pose renders in
#: ~70 ms instead of ~500 ms, and the target is found exactly where it is in the default.
SMALL_SCENE = """
[[cameras]]
id = "cam0"
width = 320
height = 240
fx = 262.5
fy = 262.5
cx = 160.0
cy = 120.0

[sensor]
supersample = 1

[clutter]
count = 0
"""


def write_video(path: Path, n: int, size: tuple[int, int] = (64, 48), step: int = 20) -> Path:
    w = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, size)
    assert w.isOpened()
    for i in range(n):
        w.write(np.full((size[1], size[0], 3), step * i, np.uint8))
    w.release()
    return path


def write_accepted_capture(
    writer: SessionWriter,
    entry: PoseEntry,
    images: Sequence[NDArray[np.uint8] | bytes],
    t0_ns: int,
) -> int:
    """One accepted format 1.1 capture as the recorder writes it: the pose entry bound to a
    new capture number, its frames (arrays, or already-encoded bytes) and window at
    ``t0_ns + 1, + 2, ...``, then the accept decision. Returns the next free time."""
    number = writer.new_capture_number()
    bound = dataclasses.replace(entry, capture=number)
    writer.write_pose(bound, t0_ns)
    t = t0_ns
    with writer.capture(entry.trial, entry.pose, entry.camera_id, number) as cap:
        for image in images:
            t += 1
            if isinstance(image, bytes):
                cap.add_encoded(image, t)
            else:
                cap.add_frame(image, t)
    writer.write_decision(
        CaptureDecision(
            capture=number,
            trial=entry.trial,
            pose=entry.pose,
            camera_id=entry.camera_id,
            decision="accept",
        ),
        t + 1,
    )
    return t + 2


def jpeg_declaring(width: int, height: int) -> bytes:
    """A tiny JPEG (8x8 pixels of data) whose header declares ``width`` x ``height``: a
    decompression bomb for image decoders that trust the header."""
    ok, buf = cv2.imencode(".jpg", np.full((8, 8, 3), 128, np.uint8))
    assert ok
    data = bytearray(buf.tobytes())
    sof = data.index(b"\xff\xc0")  # baseline start-of-frame: length(2) precision(1) H(2) W(2)
    data[sof + 5 : sof + 7] = height.to_bytes(2, "big")
    data[sof + 7 : sof + 9] = width.to_bytes(2, "big")
    return bytes(data)


DASK = Path(sys.executable).with_name("dask")
T = TypeVar("T")


def read_when_complete(
    path: Path,
    parse: Callable[[str], T],
    what: str,
    *,
    timeout_s: float = 60.0,
    writer: subprocess.Popen[Any] | None = None,
) -> T:
    """``parse(text)`` of ``path``, a file another process writes, once it is complete:
    read again until it exists and parses (a writer that does not rename its file into
    place is seen half-written: an empty file, a JSON object without its end), for at
    most ``timeout_s``, or until ``writer`` exits. Gives up saying what it waited for,
    where, and what it last found."""
    deadline = time.monotonic() + timeout_s
    found = "it does not exist"
    while True:
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            found = "it does not exist"
        else:
            try:
                return parse(text)
            except (ValueError, KeyError, TypeError) as error:  # JSONDecodeError: a ValueError
                found = f"it holds {len(text)} characters that do not parse ({error!r})"
        ended = writer is not None and writer.poll() is not None
        if ended or time.monotonic() >= deadline:
            how = f"its writer exited ({writer.returncode})" if ended and writer else ""
            waited = how or f"waited {timeout_s:g} s"
            raise AssertionError(f"{waited} for {what} ({path}) to be complete: {found}")
        time.sleep(0.05)


def read_line_when_printed(
    process: subprocess.Popen[str], pattern: str, what: str, *, timeout_s: float = 60.0
) -> tuple[str, str]:
    """The first line ``process`` prints (to its text stdout, a pipe) that contains
    ``pattern``, and what it printed before: read in a thread, so that a process that
    prints nothing or hangs is given up after ``timeout_s`` (and killed), the message
    saying what was waited for and what came."""
    assert process.stdout is not None
    stream = process.stdout
    before: list[str] = []
    found: list[str] = []

    def read() -> None:
        for line in iter(stream.readline, ""):
            if pattern in line:
                found.append(line)
                return
            before.append(line)

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    reader.join(timeout_s)
    if found:
        return found[0], "".join(before)
    if reader.is_alive():
        process.kill()
        reader.join(10)
        why = f"waited {timeout_s:g} s"
    else:
        why = f"the process ended ({process.wait(timeout=10)})"
    raise AssertionError(
        f"{why} for {what} (a line with {pattern!r}); it printed: {''.join(before)!r}"
    )


def scheduler_address(
    file: Path, scheduler: subprocess.Popen[Any] | None = None, timeout_s: float = 60.0
) -> str:
    """The address in a ``dask scheduler --scheduler-file`` file, once the scheduler has
    written it whole (it writes it in place: an empty file first)."""
    return read_when_complete(
        file,
        lambda text: str(json.loads(text)["address"]),
        "the Dask scheduler's file",
        timeout_s=timeout_s,
        writer=scheduler,
    )


class DaskCluster:
    """``dask scheduler`` and ``workers`` single-threaded ``dask worker`` processes on
    loopback, as an operator starts them (no nanny: a killed worker stays dead, as on a
    machine that was lost). ``close()`` stops them."""

    def __init__(self, folder: Path, workers: int) -> None:
        from distributed import Client

        self.file = folder / "scheduler.json"
        self.workers: list[subprocess.Popen[bytes]] = []
        self.scheduler = self._spawn(
            "scheduler", "--port", "0", "--no-dashboard", "--scheduler-file", str(self.file)
        )
        try:  # a cluster that does not come up is stopped, not left running
            self.address = scheduler_address(self.file, self.scheduler)
            self.workers = [
                self._spawn(
                    "worker", "--scheduler-file", str(self.file), "--nthreads", "1",
                    "--no-nanny", "--no-dashboard", "--name", f"w{k}", "--memory-limit", "0",
                )
                for k in range(workers)
            ]  # fmt: skip
            with Client(self.address, timeout=30) as client:
                client.wait_for_workers(workers, timeout=60)
                # Imported once up front, so that the first task's time is its own work.
                client.run(importlib.import_module, "analysis.session.pipeline")
        except BaseException:
            self.close()
            raise

    @staticmethod
    def _spawn(*args: str) -> subprocess.Popen[bytes]:
        return subprocess.Popen(
            [str(DASK), *args, "--host", "127.0.0.1"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env=os.environ | {"DASK_DISTRIBUTED__WORKER__DAEMON": "False"},
        )

    def close(self) -> None:
        # The workers first, then their scheduler: a worker whose scheduler went first
        # keeps trying to reconnect and ignores SIGTERM for up to 20 s (a test's teardown).
        for group in (self.workers, [self.scheduler]):
            for process in group:
                if process.poll() is None:
                    process.terminate()
            for process in group:
                try:
                    process.wait(timeout=5)
                except subprocess.TimeoutExpired:
                    process.kill()
                    process.wait(timeout=5)


RECORD = Path(sys.executable).with_name("twopose-record")


def start_console(out: Path, *args: str) -> tuple[subprocess.Popen[str], str, str]:
    """``twopose-record new OUT --ui`` (synthetic source, 2 frames) on a free port: the
    process, its URL, and what it printed before the URL (a warning, for --host)."""
    process = subprocess.Popen(
        [str(RECORD), "new", str(out), "--ui", "--source", "synthetic", "--frames", "2", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    line, preamble = read_line_when_printed(process, "http://", "the console's address")
    return process, line.split()[2], preamble


def small_session(folder: Path, *, target95: float | None = 0.8) -> tuple[Path, Path]:
    """A one-trial method 2 session recorded from a plan with :data:`SMALL_SCENE`'s camera
    (about 2 s; with ``target95``, the stop rule it records): the session and the scene
    (``--source synthetic:SCENE`` records on with the same camera)."""
    folder.mkdir(parents=True, exist_ok=True)
    scene, plan, out = folder / "scene.toml", folder / "plan.toml", folder / "S.mcap"
    scene.write_text(SMALL_SCENE)
    guidance = "" if target95 is None else f"[guidance]\ntarget_95 = {target95}\n"
    plan.write_text(
        'method = "ground"\nunits = "in"\nframes = 2\nground_height = 9.625\n'
        'operator = "Ada"\n[camera]\nfocal = 262.5\nprincipal = [160.0, 120.0]\n'
        f"width = 320\nheight = 240\n{guidance}[[trials]]\n"
        "ground_truth = [[1.91, 9.625, 8.375]]\n"
        "poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.5, 0.0, 0.0] }]\n"
    )
    done = subprocess.run(
        [str(RECORD), "new", str(out), "--plan", str(plan), "--source", f"synthetic:{scene}"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    return out, scene


BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load_benchmark(name: str) -> ModuleType:
    """Import ``benchmarks/<name>.py`` as its script sees itself: ``benchmarks/`` on the path.

    A benchmark imports its siblings (``doc_figures``) as top-level modules, because a script's
    own directory is ``sys.path[0]``; a test that loads one must give it the same path.
    """
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    return importlib.import_module(name)


def distinct_copies(session: Path, folder: Path, n: int, stem: str = "s") -> list[Path]:
    """``n`` sessions with ``session``'s trials, each a session of its own: its session
    entry (and the metadata's copy of it) given a session and part id of its own, and an
    extra MCAP metadata record numbering it, so that a batch counts them as ``n`` sessions
    and not as one session copied ``n`` times (twopose.format.identity)."""
    import hashlib

    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for k in range(n):
        path = folder / f"{stem}{k:03d}.mcap"
        ids = hashlib.sha256(f"{session}:{stem}:{k}".encode()).hexdigest()
        rewrite_session(
            session,
            path,
            metadata={"test_copy": {"number": str(k)}},
            ids=(ids[:32], ids[32:]),
        )
        out.append(path)
    return out


def rewrite_session(
    session: Path,
    out: Path,
    *,
    metadata: dict[str, dict[str, str]] | None = None,
    edit: Callable[[str, bytes], bytes] | None = None,
    ids: tuple[str, str] | None = None,
    drop: frozenset[str] = frozenset(),
) -> Path:
    """``session`` copied to ``out`` message by message: with ``metadata`` records added,
    each message's data through ``edit(topic, data)`` (a typed entry edited by hand), with
    ``ids``, its session entry (and the metadata's copy of it) given that session and
    part id, and without the messages of the topics in ``drop`` (a file written before
    they were)."""
    import dataclasses

    from mcap.reader import make_reader
    from mcap.writer import Writer

    from twopose.format.entries import METADATA_NAME, SessionInfo, decode_entry, encode_entry

    def renamed(entry: bytes) -> bytes:
        if ids is None:
            return entry
        info = decode_entry(SessionInfo.SCHEMA_NAME, entry)
        assert isinstance(info, SessionInfo)
        return encode_entry(dataclasses.replace(info, session_id=ids[0], part_id=ids[1]))

    with open(session, "rb") as stream:
        reader = make_reader(stream)
        summary = reader.get_summary()
        assert summary is not None
        kept = [(m.name, dict(m.metadata)) for m in reader.iter_metadata()]
        messages = list(reader.iter_messages(log_time_order=False))
    with open(out, "wb") as sink:
        writer = Writer(sink)
        writer.start(profile="", library="twopose tests")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for sid, schema in summary.schemas.items():
            schemas[sid] = writer.register_schema(schema.name, schema.encoding, schema.data)
        for cid, channel in summary.channels.items():
            channels[cid] = writer.register_channel(
                channel.topic,
                channel.message_encoding,
                schemas.get(channel.schema_id, 0),
                dict(channel.metadata),
            )
        for name, values in [*kept, *(metadata or {}).items()]:
            if name == METADATA_NAME and "session" in values:
                values = {**values, "session": renamed(values["session"].encode()).decode()}
            writer.add_metadata(name, values)
        for _schema, channel, message in messages:
            if channel.topic in drop:
                continue
            data = message.data if edit is None else edit(channel.topic, message.data)
            if channel.topic == SessionInfo.TOPIC:
                data = renamed(data)
            writer.add_message(
                channels[channel.id],
                message.log_time,
                data,
                message.publish_time,
                message.sequence,
            )
        writer.finish()
    return out


def install_extension(root: Path, name: str, code: str) -> Path:
    """Install, under ``root``, an extension as a package would: the module ``name``
    holding ``code`` (its ``register_*`` calls) and a distribution's metadata naming it
    under the entry-point group ``twopose.extensions``.

    A process with ``root`` on its ``PYTHONPATH`` (``sys.path``) then knows what it
    registers, as an installed extension's user would: the command lines, the workers
    they spawn.
    """
    root.mkdir(parents=True, exist_ok=True)
    (root / f"{name}.py").write_text(code, encoding="utf-8")
    info = root / f"{name}-0.1.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text(
        f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n", encoding="utf-8"
    )
    (info / "entry_points.txt").write_text(
        f"[twopose.extensions]\n{name} = {name}\n", encoding="utf-8"
    )
    return root
