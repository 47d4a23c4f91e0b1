"""Simulated sessions: the laptop-on-grid procedure with a synthetic camera and known truth.

Per trial the simulated operator picks typed poses on a lattice (``poses.step``), places
the laptop there with an error of ``poses.noise_sigma`` on every translation component
(``poses.rotation_noise_deg`` on every angle), records those as each entry's 1-sigma
``resolution`` (or ``poses.typed_resolution``: an operator who types another), and
captures ``frames`` frames per pose rendered from the *true* pose. Typed poses go to
``/twopose/pose``; the true poses and target go to ``/simulation/truth`` (a board
session's: its true poses and the board's corners). A camera with a
``calibration_sigma`` is recorded with its intrinsics and that sigma, and rendered with true
intrinsics drawn once per session (:func:`calibrated_cameras`). The same seed gives the same
bytes.

A simulated session carries a ``session_id`` and a ``part_id`` like a recorded one, each a
digest of what made it (:func:`recorder.simulate.identity.simulated_ids`: the method,
trials, frames, seed, the whole scene and an operator named): so the same settings write
the same session, and a copy of it (byte, cut, recovered) is known as that session by
every command; other settings are another session.

(Near 600 lines: the one-camera simulation, from the simulated operator's typed poses to the
file; the two-camera one is :mod:`recorder.simulate.pair`, the scene and its rendering
:mod:`twopose.sim`.)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from typing_extensions import override

from recorder.procedure.capture import CaptureSettings
from recorder.procedure.driver import Driver, Placement
from recorder.procedure.recording import record
from recorder.simulate.identity import SIMULATED_OPERATOR, checked_operator, simulated_ids
from recorder.sources.registry import FrameSource, SourceInfo
from twopose.arrays import F64
from twopose.camera.model import Camera, Intrinsics, project_points, rotation_from_angles_deg
from twopose.errors import InputValueError, SceneError
from twopose.format.entries import (
    GroundTruth,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
    TruePose,
    TruthKind,
    TypedEntry,
)
from twopose.format.simulation import BOARD_TRUTH, SimTruthKind
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import LINE_TRUTH, POINT_TRUTH, Method, MethodSpec, spec_of
from twopose.sim.camera import SyntheticCamera, camera_pose, true_intrinsics
from twopose.sim.layout import BOARD_POSES, Layout, board_poses, build_layout, finger_axis
from twopose.sim.scene import CameraParams, PoseParams, Scene
from twopose.values.checks import Vec3
from twopose.values.units import Units, unit_spec

__all__ = [
    "SimulationSummary",
    "calibrated_cameras",
    "draw_trial_poses",
    "poses_per_trial",
    "simulate_session",
    "target_points",
]

# The thesis' running-average script is dated 2011-12-31; simulated clocks start there.
SIMULATION_EPOCH_NS = 1_325_289_600 * 1_000_000_000


_MAX_POSE_DRAWS = 2000
_EDGE_MARGIN_PX = 25.0
#: What a noise-free simulated pose records as its 1-sigma resolution (the format wants > 0).
EXACT_RESOLUTION = 1e-9
#: The random stream of the calibration's error, apart from the session's own (so that the
#: same seed places the same poses with and without a calibration sigma).
_CALIBRATION_STREAM = 0xCA1


@dataclass(frozen=True, kw_only=True)
class SimulationSummary:
    """What :func:`simulate_session` wrote."""

    path: Path
    method: Method
    n_trials: int
    n_poses: int
    n_frames: int
    size_bytes: int


def _vec(a: NDArray[np.float64]) -> Vec3:
    return (float(a[0]), float(a[1]), float(a[2]))


def target_points(
    scene: Scene, method: Method | MethodSpec
) -> tuple[TruthKind, NDArray[np.float64]]:
    """Ground-truth kind and points (grid frame) of ``method`` in ``scene``.

    By what its views meet in (:attr:`twopose.methods.specs.MethodSpec.geometry`): the rays, the
    dot centre; the planes, the finger axis' tip and base (its line); the planes and a
    plane, where the finger axis meets that plane.
    """
    return _spec(method).geometry_cases(_Truth(scene))


def _spec(method: Method | MethodSpec) -> MethodSpec:
    """The spec a caller passes, or a name's (a benchmark's, a test's) looked up."""
    return method if isinstance(method, MethodSpec) else spec_of(method)


@dataclass(frozen=True)
class _Truth:
    """What the scene's target is, for each geometry
    (:class:`twopose.methods.geometry.GeometryCases`)."""

    scene: Scene

    def rays_to_point(self) -> tuple[TruthKind, NDArray[np.float64]]:
        return POINT_TRUTH, np.asarray([self.scene.point.position], dtype=np.float64)

    def planes_to_line(self) -> tuple[TruthKind, NDArray[np.float64]]:
        tip, base = finger_axis(self.scene, None)
        return LINE_TRUTH, np.stack([tip, base])

    def planes_to_plane_point(
        self, plane: ConstraintPlane
    ) -> tuple[TruthKind, NDArray[np.float64]]:
        # The finger points at the plane's point the scene gives, the plane as the layout
        # places it (its offset the scene's ground_height).
        at = plane.point(self.scene.finger.ground_point, self.scene.ground_height)
        return POINT_TRUTH, at[None]


def _typed_plane(scene: Scene, spec: MethodSpec) -> PlaneEntry:
    """The method's plane as the operator types it (a method on none: the ground, as the
    thesis' setup has one): its offset, the scene's ``ground_height``, off by the rig's
    error."""
    plane = spec.plane or GROUND_PLANE
    normal, offset = plane.plane(scene.ground_height + scene.systematic.ground_height_error)
    return PlaneEntry(normal_grid=normal, offset=offset)


def _visible_points(scene: Scene, spec: MethodSpec) -> NDArray[np.float64]:
    if not spec.uses_image_lines:  # the dot
        return np.asarray([scene.point.position], dtype=np.float64)
    tip, base = finger_axis(scene, spec.plane)
    return np.stack([tip, base])


def _lattice(rng: np.random.Generator, lo: float, hi: float, step: float) -> float:
    n = int(np.floor((hi - lo) / step + 1e-9))
    return float(lo + step * rng.integers(0, n + 1)) if n > 0 else float(lo)


def draw_trial_poses(
    scene: Scene, method: Method | MethodSpec, n_poses: int, rng: np.random.Generator
) -> list[
    tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
]:
    """(typed t, typed r, true t, true r) per pose, every target point well inside every view."""
    p = scene.poses
    ranges = [p.x_range, p.y_range, p.z_range]
    rot_ranges = [p.rx_range, p.ry_range, p.rz_range]
    visible = _visible_points(scene, _spec(method))
    for _ in range(_MAX_POSE_DRAWS):
        poses: list[tuple[F64, F64, F64, F64]] = []
        for k in range(n_poses):
            intr = scene.cameras[k % len(scene.cameras)].intrinsics
            if p.moves == "thesis" and k > 0:
                t_typed = poses[k - 1][0] + _thesis_move(rng, p)
            else:
                t_typed = np.array([_lattice(rng, lo, hi, p.step) for lo, hi in ranges])
            r_typed = np.array(
                [_lattice(rng, lo, hi, p.rotation_step_deg) for lo, hi in rot_ranges]
            )
            # The operator's placing/measuring error, on every typed component: this is
            # what each entry's recorded 1-sigma resolution promises the analysis.
            t_placed = t_typed + p.noise_sigma * rng.standard_normal(3)
            r_placed = r_typed + p.rotation_noise_deg * rng.standard_normal(3)
            t_true, r_true = camera_pose(scene.systematic, t_placed, r_placed)
            true_intr = true_intrinsics(scene.systematic, intr)
            if not _in_view(visible, true_intr, rotation_from_angles_deg(r_true), t_true):
                break
            poses.append((t_typed, r_typed, t_true, r_true))
        if len(poses) < n_poses:
            continue
        if _min_baseline(np.array([pose[0] for pose in poses])) >= p.min_baseline:
            return poses
    raise SceneError(
        f"scene: could not place {n_poses} poses at least {p.min_baseline} apart with the target "
        f"in view after {_MAX_POSE_DRAWS} draws; widen poses.*_range or move the target"
    )


def _board_poses(scene: Scene, rng: np.random.Generator) -> list[tuple[F64, F64, F64, F64]]:
    """A board session's poses: (typed t, typed r, true t, true r) at :data:`BOARD_POSES`,
    placed with the scene's typing error and seen through its rig's constants."""
    p = scene.poses
    poses = []
    for t in board_poses(scene):
        t_typed, r_typed = np.array(t, dtype=np.float64), np.zeros(3)
        t_placed = t_typed + p.noise_sigma * rng.standard_normal(3)
        r_placed = r_typed + p.rotation_noise_deg * rng.standard_normal(3)
        t_true, r_true = camera_pose(scene.systematic, t_placed, r_placed)
        poses.append((t_typed, r_typed, t_true, r_true))
    return poses


def calibrated_cameras(scene: Scene, seed: int) -> tuple[Scene, list[Camera]]:
    """The scene as rendered and its cameras as the session records them.

    A camera whose ``calibration_sigma`` is not zero is recorded with its (typed)
    intrinsics and that sigma, and rendered with true ones drawn once per session from
    N(intrinsics, sigma^2), independently per intrinsic: a calibration's error, the same in
    every frame. Without a sigma the scene is returned unchanged.
    """
    keys = ("fx", "fy", "cx", "cy")
    cameras = [
        Camera(
            camera_id=c.id,
            intrinsics=c.intrinsics,
            intrinsics_sigma={
                k: v for k, v in zip(keys, c.calibration_sigma, strict=True) if v > 0
            },
        )
        for c in scene.cameras
    ]
    if not any(cam.intrinsics_sigma for cam in cameras):
        return scene, cameras
    rng = np.random.default_rng([seed, _CALIBRATION_STREAM])
    drawn = []
    for c in scene.cameras:
        fx, fy, cx, cy = np.array([c.fx, c.fy, c.cx, c.cy]) + np.array(
            c.calibration_sigma
        ) * rng.standard_normal(4)
        drawn.append(dataclasses.replace(c, fx=float(fx), fy=float(fy), cx=float(cx), cy=float(cy)))
    return dataclasses.replace(scene, cameras=tuple(drawn)), cameras


def _drawn_note(rendered: Scene, cameras: list[Camera]) -> str:
    """The drawn true intrinsics, for the session's notes ("" when none were drawn)."""
    return "".join(
        f"; {c.id} rendered with fx={c.fx:.3f}, fy={c.fy:.3f}, cx={c.cx:.3f}, cy={c.cy:.3f}"
        for c, cam in zip(rendered.cameras, cameras, strict=True)
        if cam.intrinsics_sigma
    )


def _thesis_move(rng: np.random.Generator, p: PoseParams) -> NDArray[np.float64]:
    """One move of the laptop as in the thesis (section 5.3): along x only, or along x and
    depth z with the depth move the larger; lengths on the typing lattice, either sign."""
    lo, hi = p.move_range
    main = _lattice(rng, lo, hi, p.step) * rng.choice([-1.0, 1.0])
    if rng.random() < 0.5:
        return np.array([main, 0.0, 0.0])
    side = _lattice(rng, p.step, max(abs(main) - p.step, p.step), p.step) * rng.choice([-1, 1])
    return np.array([side, 0.0, main])


def _min_baseline(t_typed: NDArray[np.float64]) -> float:
    """The least distance between two of the (N, 3) typed camera centres (no pair loop)."""
    gaps = np.linalg.norm(t_typed[:, None, :] - t_typed[None, :, :], axis=-1)
    return float(gaps[np.triu_indices(len(t_typed), k=1)].min())


def _in_view(
    points: NDArray[np.float64], intr: Intrinsics, R: NDArray[np.float64], t: NDArray[np.float64]
) -> bool:
    px = project_points(points, intr, R, t)
    m = _EDGE_MARGIN_PX
    return bool(
        np.all(np.isfinite(px))
        and np.all(px[:, 0] > m)
        and np.all(px[:, 0] < intr.width - m)
        and np.all(px[:, 1] > m)
        and np.all(px[:, 1] < intr.height - m)
    )


class _SimClock:
    """The simulated session's clock: time moves only when the simulation moves it."""

    def __init__(self, start_ns: int) -> None:
        self.now = start_ns

    def advance(self, dt_ns: int) -> None:
        self.now += dt_ns

    def __call__(self) -> int:
        return self.now


class _SimulatedCamera(FrameSource):
    """The synthetic camera (:class:`twopose.sim.camera.SyntheticCamera`) at the pose the
    simulated operator really placed it: renders once per pose, exposes every frame anew,
    one frame interval on the clock per frame."""

    def __init__(
        self, scene: Scene, layout: Layout, rng: np.random.Generator, clock: _SimClock
    ) -> None:
        self.synthetic = SyntheticCamera(scene, layout, rng)
        self.scene, self.clock = scene, clock
        self.frame_dt = int(1e9 / scene.sensor.fps)

    @property
    def camera(self) -> CameraParams:
        return self.synthetic.camera

    @camera.setter
    def camera(self, camera: CameraParams) -> None:
        self.synthetic.camera = camera

    def open(self) -> SourceInfo:
        cam = self.camera
        self.info = SourceInfo(
            description="simulated", width=cam.width, height=cam.height, fps=self.scene.sensor.fps
        )
        return self.info

    def set_pose(self, t_grid: Vec3, r_deg: Vec3) -> None:
        # The operator's placement gives the camera's true pose (the rig applied).
        self.synthetic.place_camera(np.asarray(t_grid), np.asarray(r_deg))

    @override
    def read(self, timeout_s: float = 2.0) -> NDArray[np.uint8]:
        self.clock.advance(self.frame_dt)
        return self.synthetic.expose()


class _SimulatedOperator(Driver):
    """Per trial: typed poses drawn on the lattice, placed with the typing error; every
    capture accepted; the truth written at the end of the trial."""

    def __init__(
        self,
        scene: Scene,
        spec: MethodSpec,
        trials: int,
        rng: np.random.Generator,
        clock: _SimClock,
        source: _SimulatedCamera,
    ) -> None:
        self.scene, self.spec, self.trials = scene, spec, trials
        self.rng, self.clock, self.source = rng, clock, source
        self.board = not spec.measures  # a board session: its poses, no ground truth
        self.kind: TruthKind = POINT_TRUTH
        if self.board:  # its simulated truth: the board's corners where it really stood
            truth = scene.board.placement().corners_grid()
        else:
            self.kind, truth = target_points(scene, spec)
        self.truth: tuple[Vec3, ...] = tuple(_vec(p) for p in truth)
        self.pose_dt = int(scene.sensor.seconds_between_poses * 1e9)
        self.drawn: list[tuple[F64, F64, F64, F64]] = []
        self.poses_per_trial = poses_per_trial(scene, spec)

    def next_trial(self, trial: int) -> bool:
        return trial <= self.trials

    def trial_entries(self, trial: int) -> Sequence[TypedEntry]:
        if self.board:
            self.drawn = _board_poses(self.scene, self.rng)
            self.clock.advance(self.pose_dt)
            return ()  # the board's placement is in the session entry
        self.drawn = draw_trial_poses(self.scene, self.spec, self.poses_per_trial, self.rng)
        self.clock.advance(self.pose_dt)
        return (GroundTruth(trial=trial, kind=self.kind, points_grid=self.truth),)

    def place(self, trial: int, pose: int) -> Placement:
        t_typed, r_typed, t_true, r_true = self.drawn[pose - 1]
        self.source.camera = self.scene.cameras[(pose - 1) % len(self.scene.cameras)]
        self.clock.advance(self.pose_dt)
        p = self.scene.poses
        entry = PoseEntry(
            trial=trial,
            pose=pose,
            camera_id=self.source.camera.id,
            t_grid=_vec(t_typed),
            r_deg=_vec(r_typed),
            translation_resolution=max(p.typed_sigma, EXACT_RESOLUTION),
            rotation_resolution_deg=max(p.rotation_noise_deg, EXACT_RESOLUTION),
        )
        return Placement(entry=entry, true_pose=(_vec(t_true), _vec(r_true)))

    def end_trial(self, trial: int) -> Sequence[TypedEntry]:
        cams = self.scene.cameras
        true_poses = tuple(
            TruePose(pose=k, camera_id=cams[(k - 1) % len(cams)].id, t_grid=_vec(t), r_deg=_vec(r))
            for k, (_, _, t, r) in enumerate(self.drawn, start=1)
        )
        self.clock.advance(self.source.frame_dt)
        rig = self.scene.systematic
        constants = None if rig.is_identity else tuple(float(v) for v in rig.vector())
        kind: SimTruthKind = BOARD_TRUTH if self.board else self.kind
        return (
            SimulationTruth(
                trial=trial, poses=true_poses, kind=kind, points_grid=self.truth, rig=constants
            ),
        )


def poses_per_trial(scene: Scene, method: Method | MethodSpec, poses: int | None = None) -> int:
    """How many poses each simulated trial types: a board session's :data:`BOARD_POSES`,
    else ``poses`` or the scene's count."""
    if not _spec(method).measures:
        return len(BOARD_POSES)
    return poses or scene.poses.count


def _scene_with(
    scene: Scene | None,
    pose_noise: float | None,
    poses: int | None,
    typed_resolution: float | None = None,
) -> Scene:
    """The scene with the command line's overrides of its pose noise, the resolution the
    operator types and the pose count."""
    from twopose.values.bounds import POSE_NOISE, TYPED_RESOLUTION

    scene = scene or Scene()
    units = Units(scene.units)  # each length's bound in the scene's units (twopose.values.bounds)
    if pose_noise is not None:
        noise = dataclasses.replace(
            scene.poses, noise_sigma=float(POSE_NOISE.read(pose_noise, units))
        )
        scene = dataclasses.replace(scene, poses=noise)
    if typed_resolution is not None:
        resolution = float(TYPED_RESOLUTION.read(typed_resolution, units))
        typed = dataclasses.replace(scene.poses, typed_resolution=resolution)
        scene = dataclasses.replace(scene, poses=typed)
    if poses is not None:
        scene = dataclasses.replace(scene, poses=dataclasses.replace(scene.poses, count=poses))
    return scene


def _checked_settings(method: Method, trials: int, frames: int, poses: int | None) -> MethodSpec:
    """The method's spec, once the command line's settings are known to make a session."""
    checked = spec_of(method)  # refuses an unknown method, naming the known ones
    if poses is not None and not checked.measures:
        raise InputValueError(
            f"a simulated board session types the {len(BOARD_POSES)} poses of "
            "twopose.sim.layout.BOARD_POSES in each trial; leave --poses out"
        )
    if trials < 1:
        raise InputValueError(f"trials must be >= 1, got {trials}")
    if frames < 1:
        raise InputValueError(f"frames must be >= 1, got {frames}")
    return checked


def _session_info(
    scene: Scene, cameras: list[Camera], spec: MethodSpec, settings: str, ids: tuple[str, str],
    operator: str = SIMULATED_OPERATOR,
) -> SessionInfo:  # fmt: skip
    """The simulated session's opening entry (its ``ids``: :func:`simulated_ids`); its
    notes say how it was made."""
    return SessionInfo(
        method=spec.method,
        units=unit_spec(scene.units).units,
        camera_ids=tuple(c.id for c in scene.cameras),
        operator=operator,
        notes=(
            f"simulated: {settings}, "
            f"poses={scene.poses.count}, pose_noise={scene.poses.noise_sigma}"
            + (
                f", typed_resolution={scene.poses.typed_resolution}"
                if scene.poses.typed_sigma != scene.poses.noise_sigma
                else ""
            )
            + _drawn_note(scene, cameras)
        ),
        created_utc=datetime.fromtimestamp(SIMULATION_EPOCH_NS / 1e9, UTC).isoformat(),
        simulated=True,
        board=None if spec.measures else scene.board.placement(),
        session_id=ids[0],
        part_id=ids[1],
    )


def simulate_session(  # noqa: PLR0913 - keyword-only settings, one per command-line option
    out: str | Path,
    *,
    method: Method,
    trials: int = 15,
    frames: int = 5,
    seed: int = 0,
    scene: Scene | None = None,
    pose_noise: float | None = None,
    poses: int | None = None,
    on_progress: Callable[[], None] | None = None,
    typed_resolution: float | None = None,
    operator: str = SIMULATED_OPERATOR,
) -> SimulationSummary:
    """Simulate a whole session into ``out`` (which must not exist), through the same
    procedure loop as a recording (:func:`recorder.procedure.recording.record`).

    Parameters
    ----------
    out : path-like
        The new session file (never overwritten).
    method : Method
        What the session measures (``board``: a rig-calibration session).
    trials, frames : int
        Trials in the session and frames captured per pose.
    seed : int
        Everything random (clutter, poses, typing error, lighting, noise) comes from it.
    scene : Scene, optional
        Defaults mirror the thesis (f = 525 px, 640x480, h = 9.625 in).
    pose_noise : float, optional
        Overrides ``scene.poses.noise_sigma`` (session units): the real placing error.
    typed_resolution : float, optional
        Overrides ``scene.poses.typed_resolution`` (session units): the placing error each
        pose entry claims (default: the real one; another simulates an operator who types
        a resolution other than their placing error).
    poses : int, optional
        Overrides ``scene.poses.count`` (poses per trial, >= 2).
    operator : str, optional
        Who the session names as its operator (sessions of one operator pool their
        placing error in an analysis).
    on_progress : callable, optional
        Called after every frame rendered and written (``trials * poses * frames`` times).

    Returns
    -------
    SimulationSummary
        What was written: trials, poses, frames and the file.
    """
    spec = _checked_settings(method, trials, frames, poses)
    method = spec.method
    scene, cameras = calibrated_cameras(
        _scene_with(scene, pose_noise, poses, typed_resolution), seed
    )
    rng = np.random.default_rng(seed)
    layout = build_layout(scene, method, rng)  # a board session's: the scene's board alone
    clock = _SimClock(SIMULATION_EPOCH_NS)
    camera = _SimulatedCamera(scene, layout, rng, clock)
    settings = f"seed={seed}, trials={trials}, frames={frames}"
    operator = checked_operator(operator)
    ids = simulated_ids(method, trials, frames, seed, scene, operator)
    info = _session_info(scene, cameras, spec, settings, ids, operator)
    try:
        summary = record(
            out,
            info,
            cameras,
            camera,
            _SimulatedOperator(scene, spec, trials, rng, clock, camera),
            # The operator types the plane's offset (the ground height) off by the rig's error
            # (the true one renders).
            ground=_typed_plane(scene, spec),
            capture=CaptureSettings(frames=frames, on_progress=on_progress),
            writer_options={
                "image_format": scene.sensor.image_format,
                "jpeg_quality": scene.sensor.jpeg_quality,
                "start_ns": SIMULATION_EPOCH_NS,
                "clock": clock,
            },
        )
    except SceneError:  # a scene that cannot be placed
        _remove_if_empty(Path(out))
        raise
    return SimulationSummary(
        path=summary.path,
        method=method,
        n_trials=trials,
        n_poses=trials * poses_per_trial(scene, spec),
        n_frames=summary.n_frames,
        size_bytes=summary.path.stat().st_size,
    )


def _remove_if_empty(path: Path) -> None:
    """A simulation that stopped before its first pose leaves no file (``record`` made
    it new); one that stopped later keeps the trials it simulated."""
    from twopose.format.reader import SessionReader

    if not path.exists():
        return
    with SessionReader(path) as reader:
        poses = reader.message_counts().get(PoseEntry.TOPIC, 0)
    if poses == 0:
        path.unlink()
