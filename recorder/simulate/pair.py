"""Simulated two-camera sessions: a moving target seen by a pair, each camera on its clock.

``twopose-record simulate OUT.mcap --method M --cameras 2 --speed V --clock-offset-ms D
[--drift-ppm P --jitter-ms J --drop F]`` (issue 58 item 7; :func:`simulate_pair_session`
from Python). Two synthetic cameras fixed to each other share one scene: the pair is the
thesis' (camera 2 six inches to the right of camera 1, toed in 10 degrees:
:func:`twopose.pair.motion.thesis_pair`, in the scene's units, both cameras the scene's
intrinsics, its floor the scene's ground), exact. Per stream trial the method's target,
held by a hand, moves at ``speed`` through four known grid points (the touches, in an
order drawn per trial: :mod:`twopose.sim.moving`), staying :data:`DWELL_S` on each (a
touch is the middle of that stay); each camera takes its frames on its own
free-running clock (a random phase; camera 2's clock ``clock_offset_ms`` ahead of camera
1's and its interval ``drift_ppm`` longer; both cameras' stamps jittered by ``jitter_ms``
and a ``drop`` share of their frames lost). A frame's capture time is its camera's stamp;
it is written (its log time) 40 ms (camera 1) or 45 ms (camera 2) after it was taken. The
session is format 1.6: the pair, each camera's clock ``simulated``, the touches marked by
``schedule`` on camera 1's clock, and per trial the true trajectory, frames' instants and
clocks (``/twopose/sim/trajectory``). No clock offset is written: the analysis measures it.
The same settings and seed write the same bytes, its ``session_id`` and ``part_id`` a
digest of them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from recorder.simulate.identity import SIMULATED_OPERATOR, checked_operator, operator_digest
from recorder.simulate.one_camera import SIMULATION_EPOCH_NS, SimulationSummary
from twopose.arrays import F64
from twopose.camera.model import Camera
from twopose.errors import InputValueError, SceneError
from twopose.format.entries import SessionInfo, SimTrajectory
from twopose.format.simulation import SimClock, SimFrames
from twopose.format.windows import Stream
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method, floor_unmeasured, spec_of
from twopose.pair.calibration import FloorPlane, PairCalibration
from twopose.pair.motion import thesis_pair
from twopose.sim.moving import (
    CameraFrames,
    ClockSettings,
    Flash,
    PairScene,
    Trajectory,
    camera_frames,
    touch_points,
)
from twopose.sim.scene import Scene
from twopose.values import bounds
from twopose.values.units import Units, unit_factor

__all__ = [
    "PAIR_ONLY_OPTIONS",
    "POINT_SAMPLED_WORDS",
    "PairTiming",
    "frame_caveats",
    "refuse_idle_options",
    "simulate_pair_session",
    "simulate_pair_with_progress",
]

#: The options that make sense only with ``--cameras 2``, and those without effect there.
PAIR_ONLY_OPTIONS = (
    "--speed", "--clock-offset-ms", "--drift-ppm", "--jitter-ms", "--drop", "--no-flash",
)  # fmt: skip
_POSE_OPTIONS = ("--frames", "--poses", "--pose-noise", "--typed-resolution")
_PAIR_NEEDS = {
    "--speed": "--speed V (the moving target's speed, session units per second)",
    "--clock-offset-ms": "--clock-offset-ms D (camera 2's capture clock minus camera 1's, "
    "ms; 0: clocks in step)",
}
_IDS = ("cam1", "cam2")
#: Capture to write (log time), per camera, ns.
_LATENCY_NS = (40_000_000, 45_000_000)
#: Camera 1's capture clock at the session's start (a monotonic clock's "since boot").
_CLOCK_BASE_NS = 10**12
_BETWEEN_TRIALS_NS = 10**9
#: How long the target stays at each touch (a finger touching a point pauses on it).
DWELL_S = 0.2
#: The flash both cameras see in each stream trial (``PairTiming.flash``), as an operator
#: fires one: a phone's torch switched on 0.5 s after the trial starts, held 0.4 s (a dozen
#: frames at 30 fps, three at least with half of them dropped), the scene 2.5 times as
#: bright meanwhile; the target waits at its start until :data:`FLASH_HOLD_S`, then moves.
FLASH = Flash(onset_s=0.5, lit_s=0.4, gain=1.5)
FLASH_HOLD_S = 1.1


@dataclass(frozen=True, kw_only=True)
class PairTiming:
    """The moving target's speed (session units/s) and the cameras' clocks.

    ``clock_offset_ms`` camera 2's clock minus camera 1's, ``drift_ppm`` camera 2's frame
    interval's excess over camera 1's, ``jitter_ms`` each stamp's 1-sigma (both
    cameras), ``drop`` the share of each camera's frames lost. Each is read by its
    quantity in :mod:`twopose.values.bounds` (one grammar, one bound) when the session is made.
    ``flash``: a flash both cameras see at each stream trial's start (:data:`FLASH`; the
    target waits for it), which measures any offset; False: none (``--no-flash``), the
    offset is then the moving target's to fix (the rays' gap).
    """

    speed: float
    clock_offset_ms: float
    drift_ppm: float = 0.0
    jitter_ms: float = 0.0
    drop: float = 0.0
    flash: bool = True

    def checked(self, units: Units) -> PairTiming:
        """The timing with every value read by its quantity (``speed`` in ``units``/s)."""
        return PairTiming(
            speed=bounds.SPEED.read(self.speed, units),
            clock_offset_ms=bounds.CLOCK_OFFSET.read(self.clock_offset_ms, units),
            drift_ppm=bounds.DRIFT.read(self.drift_ppm, units),
            jitter_ms=bounds.JITTER.read(self.jitter_ms, units),
            drop=bounds.DROP.read(self.drop, units),
            flash=bool(self.flash),
        )

    def clocks(self, fps: float) -> tuple[ClockSettings, ClockSettings]:
        """Camera 1's and camera 2's clocks."""
        shared = {"fps": fps, "jitter_s": self.jitter_ms * 1e-3, "drop": self.drop}
        return (
            ClockSettings(**shared),
            ClockSettings(**shared, drift_ppm=self.drift_ppm, offset_s=self.clock_offset_ms * 1e-3),
        )


def refuse_idle_options(cameras: int, given: Iterable[str]) -> None:
    """Refuse, in words, a ``simulate`` option without effect or without its partner.

    ``given``: the options given on the command line (their ``--names``).
    """
    given = set(given)
    if cameras == 2:
        idle = [o for o in _POSE_OPTIONS if o in given]
        if idle:
            raise InputValueError(
                f"{', '.join(idle)} {'has' if len(idle) == 1 else 'have'} no effect with "
                "--cameras 2: a pair's trials are streams (frames at the cameras' rate, a "
                "moving target, no typed pose); leave "
                f"{'it' if len(idle) == 1 else 'them'} out"
            )
        missing = [words for o, words in _PAIR_NEEDS.items() if o not in given]
        if missing:
            raise InputValueError(f"--cameras 2 needs {' and '.join(missing)}")
        return
    lonely = [o for o in PAIR_ONLY_OPTIONS if o in given]
    if lonely:
        one = len(lonely) == 1
        raise InputValueError(
            f"{', '.join(lonely)} {'applies' if one else 'apply'} only with --cameras 2 (two "
            f"cameras, a moving target): give --cameras 2 or leave {'it' if one else 'them'} out"
        )


def simulated_pair_ids(
    method: Method, trials: int, seed: int, scene: Scene, timing: PairTiming,
    operator: str = SIMULATED_OPERATOR,
) -> tuple[str, str]:  # fmt: skip
    """The session's ``session_id`` and ``part_id``: halves of one SHA-256 of its settings."""
    values = [float(v) for v in dataclasses.astuple(timing)]  # by value, not as typed
    made = json.dumps(["twopose simulate --cameras 2", method.value, trials, seed, repr(scene)])
    made += json.dumps(values)
    made += operator_digest(operator)
    digest = hashlib.sha256(made.encode()).hexdigest()
    return digest[:32], digest[32:]


def simulated_pair(scene: Scene) -> PairCalibration:
    """The thesis' pair in the scene's units, both cameras the scene's first camera's
    intrinsics (its second's, when it has two), its floor the scene's ground; exact."""
    if len(scene.cameras) > 2:
        raise SceneError(f"a pair is two cameras; the scene has {len(scene.cameras)}")
    units = Units(scene.units)
    base = thesis_pair().in_units(units)
    first = scene.cameras[0].intrinsics
    second = scene.cameras[-1].intrinsics
    floor = FloorPlane(normal=np.array([0.0, 1.0, 0.0]), height=scene.ground_height,
                       cov=np.zeros((4, 4)))  # fmt: skip
    return dataclasses.replace(
        base, intrinsics1=first, intrinsics2=second, floor=floor,
        intrinsics_from="the simulated scene's cameras (exact)",
    )  # fmt: skip


def _checked(method: Method, trials: int, scene: Scene, timing: PairTiming) -> PairTiming:
    if not spec_of(method).measures:  # the name checked once (an unknown one refused)
        raise InputValueError(
            "a board session calibrates one camera's rig from typed poses; --cameras 2 "
            "simulates a moving target for point, line or ground"
        )
    bounds.TRIALS.read(trials, None)
    units = Units(scene.units)
    timing = timing.checked(units)
    path = _path(scene, method, timing)
    with np.errstate(over="ignore"):  # a speed of 5e-324: a path of infinite seconds
        seconds = path.duration_s
    shown = f"{seconds:,.0f}" if seconds < 1e9 else f"{seconds:.3g}"
    said = bounds.SIMULATED_TRIAL.refusal(seconds, None, given=shown)
    if said:  # a slow --speed: a trial of years, its frame count past any array (r5 F12)
        bound = bounds.SIMULATED_TRIAL.high
        still_s = path.hold_s + path.dwell_s * len(path.touches)
        length = float(np.linalg.norm(np.diff(path.waypoints, axis=0), axis=1).sum())
        fastest = length / (bound - still_s)
        raise InputValueError(
            f"{said} (at --speed {bounds.shown(timing.speed)} {units}/s the target's path "
            f"takes that long): a simulated trial lasts at most {bound:g} s (10 minutes: "
            f"{math.ceil(bound * scene.sensor.fps):,} frames a camera at "
            f"{scene.sensor.fps:g} fps, about an hour of rendering): give --speed "
            f"{_up(fastest):g} or more"
        )
    # The rendering's cost is the frames, however they come: many trials, a fast camera.
    frames = trials * math.ceil(seconds * scene.sensor.fps)
    said = bounds.SIMULATED_FRAMES.refusal(frames, None, given=f"{frames:,}")
    if said:
        raise InputValueError(
            f"{said} ({trials:,} trial(s) of {seconds:,.1f} s at {scene.sensor.fps:g} fps): "
            "give fewer --trials, a faster --speed, or a scene of a lower fps"
        )
    return timing


def _up(value: float) -> float:
    """``value`` rounded up to 2 significant digits (a speed that is surely enough)."""
    scale = 10.0 ** (math.floor(math.log10(value)) - 1)
    return math.ceil(value / scale) * scale


def _path(scene: Scene, method: Method, timing: PairTiming) -> Trajectory:
    """The target's path a trial follows at ``timing.speed`` (each trial's touches only
    reorder it)."""
    return Trajectory(
        touches=touch_points(scene, method, simulated_pair(scene)), speed=timing.speed,
        lead=unit_factor(Units.IN, Units(scene.units)), dwell_s=DWELL_S,
        hold_s=FLASH_HOLD_S if timing.flash else 0.0,
    )  # fmt: skip


@dataclass(frozen=True)
class SimulationSize:
    """What a two-camera simulation will render: ``trials`` stream trials of
    ``trial_s`` seconds each, both cameras at ``fps``."""

    trials: int
    trial_s: float
    fps: float
    #: what its frames' regions cannot be trusted for, in words (:func:`frame_caveats`)
    caveats: tuple[str, ...] = ()

    @property
    def frames(self) -> int:
        """Both cameras' frames over every trial (about: each camera's phase and drops
        move it by a frame or a few)."""
        return 2 * self.trials * math.ceil(self.trial_s * self.fps)

    def words(self) -> str:
        each = "" if self.trials == 1 else " each"
        return (
            f"rendering {self.trials} stream trial{'' if self.trials == 1 else 's'} of "
            f"{self.trial_s:,.1f} s{each}: about {self.frames:,} frames (Ctrl-C stops it; "
            "a faster --speed makes shorter trials)"
        ) + "".join(f"\nnote: {c}" for c in self.caveats)


#: Why point-sampled frames are no camera's (docs/figures/detector_floor.txt).
POINT_SAMPLED_WORDS = (
    "sensor.supersample = 1 renders each pixel from one ray, its edges aliased as no "
    "camera's are: the dot's centroid errs about twice the detector's measured floor, so "
    "the regions of these frames are too small; render with 2 or more to judge regions"
)


def frame_caveats(scene: Scene) -> tuple[str, ...]:
    """What a scene's frames' 95% regions cannot be trusted for: point-sampled frames, an
    image size the detector's floor was not measured at."""
    said = [POINT_SAMPLED_WORDS] if scene.sensor.supersample == 1 else []
    sizes = dict.fromkeys((c.width, c.height) for c in scene.cameras)
    said += [w for w in (floor_unmeasured(*size) for size in sizes) if w]
    return tuple(said)


def simulation_size(
    method: Method, trials: int, scene: Scene, timing: PairTiming
) -> SimulationSize:
    """What :func:`simulate_pair_session` will render, known before it renders a frame
    (the target's path at ``timing.speed``; each trial's touches only reorder it)."""
    timing = _checked(method, trials, scene, timing)
    path = _path(scene, method, timing)
    return SimulationSize(trials, path.duration_s, scene.sensor.fps, frame_caveats(scene))


@dataclass(frozen=True, kw_only=True, eq=False)
class _Trial:
    """One stream trial's plan: the path, each camera's frames, where they are written."""

    trial: int
    start_ns: int  # its first log time
    clock_ns: int  # camera 1's capture clock at the trial's true start
    path: Trajectory
    frames: tuple[CameraFrames, CameraFrames]
    light: tuple[F64, F64]  # each frame's light (1: the scene's; more: the flash)


def _plan_trial(
    trial: int, start_ns: int, touches: F64, speed: float, timing: PairTiming, fps: float,
    lead: float, rng: np.random.Generator,
) -> _Trial:  # fmt: skip
    order = rng.permutation(len(touches))
    hold = FLASH_HOLD_S if timing.flash else 0.0
    path = Trajectory(touches=touches[order], speed=speed, lead=lead, dwell_s=DWELL_S, hold_s=hold)
    clocks = timing.clocks(fps)
    frames = (
        camera_frames(clocks[0], path.duration_s, rng),
        camera_frames(clocks[1], path.duration_s, rng),
    )
    light = tuple(
        FLASH.light(f.true_s, (1.0 + 1e-6 * c.drift_ppm) / c.fps)
        if timing.flash
        else np.ones(f.true_s.size)
        for f, c in zip(frames, clocks, strict=True)
    )
    clock = _CLOCK_BASE_NS + (start_ns - SIMULATION_EPOCH_NS)
    return _Trial(
        trial=trial, start_ns=start_ns, clock_ns=clock, path=path, frames=frames,
        light=(light[0], light[1]),
    )  # fmt: skip


def _events(plan: _Trial) -> list[tuple[int, int, int]]:
    """Every frame and touch in write order: (log time, camera (0: a touch), index)."""
    events = [
        (plan.start_ns + round((t + 1e-9 * _LATENCY_NS[c]) * 1e9), c + 1, k)
        for c, frames in enumerate(plan.frames)
        for k, t in enumerate(frames.true_s)
    ]
    events += [(plan.start_ns + round(t * 1e9) + 1, 0, k) for k, t in enumerate(plan.path.touch_s)]
    return sorted(events)


def _write_trial(
    stream: Stream, plan: _Trial, scene: PairScene, on_progress: Callable[[], None] | None
) -> None:
    touches = plan.path.touches
    for log_ns, camera, k in _events(plan):
        if camera == 0:
            t = plan.clock_ns + round(plan.path.touch_s[k] * 1e9)
            point = (float(touches[k, 0]), float(touches[k, 1]), float(touches[k, 2]))
            stream.touch(point, t, "schedule", log_ns)
            continue
        frames = plan.frames[camera - 1]
        light = float(plan.light[camera - 1][k])
        image = scene.frame(camera, plan.path.at(frames.true_s[k : k + 1])[0], light)
        capture = plan.clock_ns + round(frames.stamp_s[k] * 1e9)
        stream.add_frame(_IDS[camera - 1], image, capture, log_ns)
        if on_progress is not None:
            on_progress()


def _on_clock(plan: _Trial, t_s: F64) -> list[int]:
    """Instants (s from the trial's true start) on camera 1's capture clock, ns."""
    return [plan.clock_ns + round(float(t) * 1e9) for t in t_s]


def _truth(plan: _Trial, scene: PairScene, timing: PairTiming, fps: float) -> SimTrajectory:
    """The trial's true motion at every frame's and touch's instant (camera 1's clock)."""
    instants = np.unique(np.concatenate([*(f.true_s for f in plan.frames), plan.path.touch_s]))
    t_ns = _on_clock(plan, instants)
    tips = scene.tip(plan.path.at(instants))
    d = scene.direction
    clocks = timing.clocks(fps)
    pair = scene.pair
    return SimTrajectory(
        trial=plan.trial,
        t_ns=tuple(t_ns),
        points=tuple((float(p[0]), float(p[1]), float(p[2])) for p in tips),
        directions=None if d is None else ((float(d[0]), float(d[1]), float(d[2])),) * len(t_ns),
        length=None if d is None else float(scene.scene.finger.length),
        frames=tuple(
            SimFrames(
                camera_id=cid, true_ns=tuple(plan.clock_ns + round(t * 1e9) for t in f.true_s)
            )
            for cid, f in zip(_IDS, plan.frames, strict=True)
        ),
        clocks=tuple(
            SimClock(
                camera_id=cid,
                fps=c.fps,
                phase_ns=f.phase_s * 1e9,
                drift_ppm=c.drift_ppm,
                jitter_ns=c.jitter_s * 1e9,
                drop=c.drop,
                offset_ns=c.offset_s * 1e9,
                latency_ns=float(latency),
            )
            for cid, c, f, latency in zip(_IDS, clocks, plan.frames, _LATENCY_NS, strict=True)
        ),
        R_2_to_1=tuple((float(r[0]), float(r[1]), float(r[2])) for r in pair.R_2_to_1),  # type: ignore[arg-type]
        t_2_in_1=(float(pair.t_2_in_1[0]), float(pair.t_2_in_1[1]), float(pair.t_2_in_1[2])),
    )


def simulate_pair_session(
    out: str | Path,
    *,
    method: Method,
    timing: PairTiming,
    trials: int = 15,
    seed: int = 0,
    scene: Scene | None = None,
    on_progress: Callable[[], None] | None = None,
    operator: str = SIMULATED_OPERATOR,
) -> SimulationSummary:
    """Simulate a two-camera session into ``out`` (new; the module docstring).

    ``timing`` the target's speed and the clocks (:class:`PairTiming`), ``trials`` stream
    trials, everything random from ``seed``; ``on_progress`` called after each frame.
    """
    scene = scene or Scene()
    timing = _checked(method, trials, scene, timing)
    pair = simulated_pair(scene)
    rng = np.random.default_rng(seed)
    pair_scene = PairScene(scene, method, pair, rng)
    touches = touch_points(scene, method, pair)
    lead = unit_factor(Units.IN, Units(scene.units))  # one inch
    probe = Trajectory(touches=touches, speed=timing.speed, lead=lead, dwell_s=DWELL_S)
    pair_scene.check_in_view(probe.at(np.linspace(0.0, probe.duration_s, 64)))
    operator = checked_operator(operator)
    ids = simulated_pair_ids(method, trials, seed, scene, timing, operator)
    info = _session_info(scene, method, trials, seed, timing, ids, operator)
    cameras = [Camera(camera_id=_IDS[0], intrinsics=pair.intrinsics1),
               Camera(camera_id=_IDS[1], intrinsics=pair.intrinsics2)]  # fmt: skip
    fps = scene.sensor.fps
    n_frames = 0
    with SessionWriter(
        out, info, cameras, pair=pair, start_ns=SIMULATION_EPOCH_NS,
        image_format=scene.sensor.image_format, jpeg_quality=scene.sensor.jpeg_quality,
        clock=lambda: SIMULATION_EPOCH_NS,
    ) as writer:  # fmt: skip
        start = SIMULATION_EPOCH_NS + _BETWEEN_TRIALS_NS
        for trial in range(1, trials + 1):
            plan = _plan_trial(trial, start, touches, timing.speed, timing, fps, lead, rng)
            with writer.stream(trial, start_ns=start) as stream:
                _write_trial(stream, plan, pair_scene, on_progress)
            writer.write_entry(_truth(plan, pair_scene, timing, fps), writer.last_ns)
            n_frames += sum(stream.n_frames.values())
            start = writer.last_ns + _BETWEEN_TRIALS_NS
    path = Path(out)
    return SimulationSummary(
        path=path, method=spec_of(method).method, n_trials=trials, n_poses=0,
        n_frames=n_frames, size_bytes=path.stat().st_size,
    )  # fmt: skip


def _session_info(
    scene: Scene, method: Method, trials: int, seed: int, timing: PairTiming,
    ids: tuple[str, str], operator: str,
) -> SessionInfo:  # fmt: skip
    settings = (
        f"simulated: seed={seed}, trials={trials}, cameras=2, speed={timing.speed}, "
        f"clock_offset_ms={timing.clock_offset_ms}, drift_ppm={timing.drift_ppm}, "
        f"jitter_ms={timing.jitter_ms}, drop={timing.drop}, flash="
        + (
            f"at {FLASH.onset_s:g} s for {FLASH.lit_s:g} s of each trial, {1 + FLASH.gain:g} "
            "times as bright"
            if timing.flash
            else "none"
        )
    )
    return SessionInfo(
        method=spec_of(method).method,
        units=Units(scene.units),
        camera_ids=_IDS,
        operator=operator,
        notes=settings,
        created_utc=datetime.fromtimestamp(SIMULATION_EPOCH_NS / 1e9, UTC).isoformat(),
        simulated=True,
        session_id=ids[0],
        part_id=ids[1],
        clocks=dict.fromkeys(_IDS, "simulated"),
    )


def simulate_pair_with_progress(
    out: Path,
    method: Method,
    trials: int,
    seed: int,
    scene: Scene,
    timing: tuple[float | None, ...],
    *,
    flash: bool = True,
    operator: str = SIMULATED_OPERATOR,
) -> SimulationSummary:
    """``simulate --cameras 2``: :func:`simulate_pair_session` with a bar on stderr.

    ``timing``: speed, clock offset (both given: :func:`refuse_idle_options`), drift,
    jitter and drop (None: 0), as the command line read them; ``flash`` False:
    ``--no-flash``.
    """
    from rich.console import Console
    from rich.progress import Progress

    speed, offset, drift, jitter, drop = timing
    if speed is None or offset is None:
        raise InputValueError(f"--cameras 2 needs {' and '.join(_PAIR_NEEDS.values())}")
    pair_timing = PairTiming(
        speed=speed, clock_offset_ms=offset, drift_ppm=drift or 0.0, jitter_ms=jitter or 0.0,
        drop=drop or 0.0, flash=flash,
    )  # fmt: skip
    with Progress(console=Console(stderr=True), transient=True) as progress:
        task = progress.add_task("frames rendered", total=None)

        size = simulation_size(method, trials, scene, pair_timing)
        # Said before rendering, in a pipe too: a slow --speed is minutes of frames.
        progress.console.print(size.words(), markup=False, highlight=False, soft_wrap=True)
        progress.update(task, total=size.frames)
        return simulate_pair_session(
            out, method=method, timing=pair_timing, trials=trials, seed=seed, scene=scene,
            on_progress=lambda: progress.advance(task), operator=operator,
        )  # fmt: skip
