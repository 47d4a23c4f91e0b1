"""Plan files read and checked: a plan's TOML as a :class:`Plan`, before anything is recorded.

Every key must be known and every value within its bounds (see docs/recording.md).
:func:`load_plan` is the one reader; :func:`recorder.setup.plan.record_plan` records what it
returns.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from recorder.setup.rules import (
    DEFAULT_MAX_POSES,
    PLANE_OFFSET_KEY,
    THESIS_FOCAL_PX,
    THESIS_IMAGE_SIZE,
    board_refusal,
    default_principal,
    inherited_words,
    off_plane,
    other_plane_refusal,
    plane_entry,
    thesis_reach,
)
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import InputValueError
from twopose.format.entries import (
    DEFAULT_ROTATION_RESOLUTION_DEG,
    DEFAULT_TRANSLATION_RESOLUTION,
    default_translation_resolution,
)
from twopose.guidance.advice import MIN_GAIN as DEFAULT_MIN_GAIN
from twopose.guidance.advice import Guidance, Reach
from twopose.methods.specs import METHODS, PLANES, Method, MethodSpec, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.values.bounds import (
    BOARD_CORNER,
    BOARD_SQUARE,
    FOCAL,
    FRAMES,
    GRID,
    GROUND_TRUTH,
    IMAGE_SIDE,
    INNER_CORNERS,
    MAX_POSES,
    MIN_GAIN,
    POSE_TRANSLATION,
    PRINCIPAL,
    REACH,
    ROTATION,
    SEED,
    TARGET_DISTANCE,
    TARGET_PRECISION,
    Quantity,
    shown,
)
from twopose.values.checks import Vec3, finite
from twopose.values.toml import read_toml
from twopose.values.units import DEFAULT_UNITS, UNITS, Units

if TYPE_CHECKING:
    from twopose.format.entries import PlaneEntry
    from twopose.format.session_entry import GuidanceRecord


__all__ = ["Plan", "PlannedPose", "PlannedTrial", "continued_plan", "load_plan"]

#: The key a pose names the camera it was taken by ([[trials]] poses' ``camera``).
POSE_CAMERA_KEY = "camera"
#: The keys of each table of a plan, by the table's name.
_TABLE_KEYS = {
    "guidance": {"target_95", "reach", "spacing", "max_poses", "seed"}
    | {"target_distance", "min_gain"},
    "board": {"inner_corners", "square", "first_corner"},
    "camera": {"id", "calibration", "focal", "fx", "fy", "principal", "cx", "cy"}
    | {"width", "height", "distortion"},
    "trials": {"poses", "ground_truth", "keep_off_ground", "max_poses", "start"},
    "poses": {"t", "r_deg", POSE_CAMERA_KEY},
    "resolution": {"translation", "rotation_deg"},
}
#: The keys a plan knows: its top level's (its tables but the poses, which are its trials'),
#: then each table's.
_PLAN_KEYS = {
    "": {"method", "units", "cameras", "frames", "operator", "notes", "adaptive_frames"}
    | (set(_TABLE_KEYS) - {"poses"})
    | {p.setup_key for p in PLANES}  # each plane's offset (method 2's ground_height)
    | {PLANE_OFFSET_KEY},  # or the method's plane's, whichever it is
    **_TABLE_KEYS,
}


def _known_keys(table: Any, kind: str, where: str) -> dict[str, Any]:
    """``table`` as a dict whose keys are all known for ``kind``; else the key is named."""
    if not isinstance(table, dict):
        raise InputValueError(f"plan: {where or 'the plan'} must be a table")
    unknown = sorted(set(table) - _PLAN_KEYS[kind])
    if unknown:
        raise InputValueError(
            f"plan: unknown key {where + '.' if where else ''}{unknown[0]}; "
            f"known here: {', '.join(sorted(_PLAN_KEYS[kind]))}"
        )
    return table


@dataclass(frozen=True, kw_only=True)
class PlannedPose:
    t_grid: Vec3
    r_deg: Vec3 = (0.0, 0.0, 0.0)
    camera_id: str = "cam0"


@dataclass(frozen=True, kw_only=True)
class PlannedTrial:
    poses: tuple[PlannedPose, ...]
    ground_truth: tuple[Vec3, ...] = ()
    #: ``poses = "guided"``: the first pose at ``start``, each next one the recorder's
    #: suggestion, until the trial is precise enough or has ``max_poses`` (issue 36).
    max_poses: int | None = None
    start: PlannedPose | None = None

    @property
    def guided(self) -> bool:
        """Whether the recorder chooses its poses after the first."""
        return self.max_poses is not None


@dataclass(frozen=True, kw_only=True)
class Plan:
    """A whole session to record unattended (scripted rigs, tests)."""

    method: Method
    units: Units
    cameras: tuple[Camera, ...]
    trials: tuple[PlannedTrial, ...]
    frames: int = 5
    adaptive_frames: bool = False  # frames is then the most a pose takes
    # The offset of the method's plane (its spec's ``plane``: method 2's ground height).
    plane_offset: float | None = None
    operator: str = ""
    notes: str = ""
    # Session units: load_plan's default is 1/16 in converted (default_translation_resolution).
    translation_resolution: float = DEFAULT_TRANSLATION_RESOLUTION
    rotation_resolution_deg: float = DEFAULT_ROTATION_RESOLUTION_DEG
    board: BoardPlacement | None = None  # a board session's board and where it stands
    #: ``[guidance]``: suggestions and the stop rule (with guided trials, or to see them)
    guidance: Guidance | None = None
    placing_seed: int = 0  # the simulated operator's placing error on guided poses
    #: The keys its ``[guidance]`` gave (a continuation takes the others from its session).
    guidance_keys: frozenset[str] = frozenset()

    @property
    def spec(self) -> MethodSpec:
        """The plan's method's spec: what its rules read of it."""
        return spec_of(self.method)

    def ground(self) -> PlaneEntry | None:
        """The method's plane at the plan's offset (method 2's ground ``y = h``), or None."""
        return plane_entry(self.spec, self.plane_offset)


def _plane_offset(data: dict[str, Any], spec: MethodSpec, units: Units) -> float | None:
    """The offset of the method's plane, under the plane's key (method 2's
    ``ground_height``) or ``plane_offset`` (the method's plane's, whichever it is): one of
    them required on a plane, another plane's refused (a method on no plane has nothing to
    cut its estimate with, and ignores the planes' own keys as it always did; it refuses
    ``plane_offset``, which can only mean its plane)."""
    plane, method = spec.plane, spec.method
    if plane is None:
        if PLANE_OFFSET_KEY in data:
            raise InputValueError(
                f"plan: {PLANE_OFFSET_KEY}: a {method} session measures on no plane, so nothing "
                "would use it; leave it out"
            )
        return None
    refused = other_plane_refusal(spec, data, str)
    if refused:
        raise InputValueError(f"plan: {refused}")
    given = [k for k in (plane.setup_key, PLANE_OFFSET_KEY) if k in data]
    if len(given) > 1:
        raise InputValueError(
            f"plan: {plane.setup_key} and {PLANE_OFFSET_KEY} both give {plane.name}'s offset: "
            "give one"
        )
    if not given:
        raise InputValueError(
            f"plan: a {method} session needs {plane.setup_key} ({plane.label}, {plane.equation})"
            f" or {PLANE_OFFSET_KEY}"
        )
    return _read(plane.bound, data[given[0]], given[0], units)


def _read(quantity: Quantity, value: Any, where: str, units: Units | None) -> float:
    """A plan's number, read by the quantity's one reader (:mod:`twopose.values.bounds`); a refusal
    names its key."""
    try:
        return quantity.read(value, units, text=False)
    except InputValueError as err:
        raise InputValueError(f"plan: {where}: {err}") from None


def _vec(quantity: Quantity, value: Any, where: str, units: Units | None) -> Vec3:
    """A plan's point (``[x, y, z]``), each number within ``quantity``'s bound."""
    try:
        x, y, z = quantity.read_vector(value, units, text=False)
    except InputValueError as err:
        raise InputValueError(f"plan: {where}: {err}") from None
    return (x, y, z)


def _count(quantity: Quantity, value: Any, where: str) -> int:
    return int(_read(quantity, value, where, None))


def _camera(table: Any) -> Camera:
    """``[camera]``: ``calibration = FILE``, or ``focal`` (or ``fx``/``fy``), ``principal =
    [cx, cy]`` (or ``cx``/``cy``), ``width``, ``height``, ``distortion``; and ``id``."""
    table = _known_keys(table, "camera", "camera")
    camera_id = str(table.get("id", "cam0"))
    if "calibration" in table:  # a file from `twopose-record calibrate`
        from recorder.calibration.camera import load_calibration, load_calibration_sigma

        path = str(table["calibration"])
        return Camera(
            camera_id=camera_id,
            intrinsics=load_calibration(path),
            intrinsics_sigma=load_calibration_sigma(path),
        )
    focal = _read(FOCAL, table.get("focal", THESIS_FOCAL_PX), "camera.focal", None)
    width = _count(IMAGE_SIDE, table.get("width", THESIS_IMAGE_SIZE[0]), "camera.width")
    height = _count(IMAGE_SIDE, table.get("height", THESIS_IMAGE_SIZE[1]), "camera.height")
    try:
        cx, cy = PRINCIPAL.read_vector(
            table.get("principal", list(default_principal((width, height)))), None, text=False
        )
    except InputValueError as err:
        raise InputValueError(f"plan: camera.principal: {err}") from None
    values = {"width": width, "height": height, "fx": focal, "cx": cx, "cy": cy} | table
    values.setdefault("fy", values["fx"])
    return Camera(camera_id=camera_id, intrinsics=Intrinsics.from_dict(values, "plan: [camera]"))


def load_plan(path: str | Path) -> Plan:
    """Read and check a plan file (TOML); every error names the offending key.

    Parameters
    ----------
    path : path-like
        The plan (``docs/examples/ground_plan.toml`` shows every key).

    Returns
    -------
    Plan
        The setup and each trial's typed poses and ground truth, checked by the setup
        rules the terminal and the browser use (:mod:`recorder.setup.rules`).

    Raises
    ------
    InputValueError
        A key is unknown, missing or out of its range; the message names it.
    """
    data = _known_keys(read_toml(path, "plan", InputValueError), "", "")
    method = data.get("method")
    if method not in METHODS:
        raise InputValueError(f"plan: method must be one of {', '.join(METHODS)}, got {method!r}")
    spec = spec_of(Method(method))  # the name from the file, looked up once: its spec travels
    method = spec.method
    units = data.get("units", DEFAULT_UNITS)
    if units not in UNITS:
        raise InputValueError(f"plan: units must be one of {', '.join(UNITS)}, got {units!r}")
    units = Units(units)
    cameras_data = data.get("cameras") or [data.get("camera", {})]
    cameras = tuple(_camera(c) for c in cameras_data)
    frames = _count(FRAMES, data.get("frames", 5), "frames")
    adaptive = data.get("adaptive_frames", False)
    if not isinstance(adaptive, bool):
        raise InputValueError(f"plan: adaptive_frames must be true or false, got {adaptive!r}")
    board_guidance = [k for k in ("guidance", "adaptive_frames") if data.get(k)]
    if not spec.measures and board_guidance:
        raise InputValueError(f"plan: {board_refusal(board_guidance)}")
    height = _plane_offset(data, spec, units)
    res = _known_keys(data.get("resolution", {}), "resolution", "resolution")
    resolution = (
        finite(
            res.get("translation", default_translation_resolution(units)),
            "plan: resolution.translation",
            positive=True,
        ),
        finite(
            res.get("rotation_deg", DEFAULT_ROTATION_RESOLUTION_DEG),
            "plan: resolution.rotation_deg",
            positive=True,
        ),
    )
    board = _board(data.get("board"), spec, units)
    raw_trials = data.get("trials", [])
    if not isinstance(raw_trials, list) or not raw_trials:
        raise InputValueError("plan: no [[trials]]")
    guidance, seed = _guidance(data.get("guidance"), units)
    max_poses = guidance.max_poses if guidance is not None else DEFAULT_MAX_POSES
    trials = tuple(
        _trial(t, i, spec, units, cameras[0].camera_id, height, max_poses)
        for i, t in enumerate(raw_trials, start=1)
    )
    if any(t.guided for t in trials) and not spec.measures:
        raise InputValueError(
            'plan: poses = "guided" needs a target to locate; a board session plans its poses'
        )
    if guidance is None and any(t.guided for t in trials):
        guidance = Guidance(reach=thesis_reach(units), max_poses=max_poses, min_gain=None)
    _refuse_partnerless(data.get("guidance"), guided=any(t.guided for t in trials))
    return Plan(
        method=method,
        units=units,
        cameras=cameras,
        trials=trials,
        frames=frames,
        adaptive_frames=adaptive,
        plane_offset=height,
        operator=str(data.get("operator", "")),
        notes=str(data.get("notes", "")),
        translation_resolution=resolution[0],
        rotation_resolution_deg=resolution[1],
        board=board,
        guidance=guidance,
        placing_seed=seed,
        guidance_keys=frozenset(data.get("guidance") or ()),
    )


def _refuse_partnerless(table: dict[str, Any] | None, *, guided: bool) -> None:
    """Refuse ``[guidance]`` keys that would have no effect: ``min_gain`` ends a trial
    early as ``target_95`` does, with it only; ``max_poses`` caps a stop rule's or a
    guided trial's poses (a planned trial has the poses it lists)."""
    if not table or "target_95" in table:
        return
    idle = [k for k in ("min_gain", "max_poses") if k in table and (k == "min_gain" or not guided)]
    if idle:
        keys = " and ".join(f"guidance.{k}" for k in idle)
        raise InputValueError(
            f"plan: {keys} would have no effect: {'they shape' if len(idle) > 1 else 'it shapes'} "
            "the stop rule, which guidance.target_95 sets"
            + ("" if "min_gain" in idle else ', or a trial of poses = "guided"')
            + ": give it too, or leave them out"
        )


def _guidance(table: Any, units: Units) -> tuple[Guidance | None, int]:
    """``[guidance]``: ``target_95`` (the stop rule's precision, session units), ``reach``
    and ``spacing`` (the lattice of suggested poses; default the thesis'), ``max_poses``,
    ``target_distance`` (taped from the first pose's camera to the target, session units),
    ``min_gain`` (the information-gain stop's least share, with ``target_95``; default
    :data:`twopose.guidance.advice.MIN_GAIN`, 0: none) and ``seed`` (the synthetic operator's
    placing error)."""
    if table is None:
        return None, 0
    g = _known_keys(table, "guidance", "guidance")
    thesis = thesis_reach(units)
    target = g.get("target_95")
    radius = _read(REACH, g.get("reach", thesis.radius), "guidance.reach", units)
    spacing = _read(GRID, g.get("spacing", thesis.spacing), "guidance.spacing", units)
    if spacing > radius:
        raise InputValueError(
            f"plan: guidance.spacing {shown(spacing)} is beyond reach {shown(radius)}"
        )
    max_poses = _count(MAX_POSES, g.get("max_poses", DEFAULT_MAX_POSES), "guidance.max_poses")
    seed = _count(SEED, g.get("seed", 0), "guidance.seed")
    target95 = (
        None if target is None else _read(TARGET_PRECISION, target, "guidance.target_95", units)
    )
    reach = Reach(radius=radius, spacing=spacing)
    distance = g.get("target_distance")
    if distance is not None:
        distance = _read(TARGET_DISTANCE, distance, "guidance.target_distance", units)
    gain = _read(MIN_GAIN, g.get("min_gain", DEFAULT_MIN_GAIN), "guidance.min_gain", units)
    return Guidance(
        reach=reach, target95=target95, max_poses=max_poses, target_distance=distance,
        # As on the command line: the information-gain stop with a target precision only.
        min_gain=(gain or None) if target95 is not None else None,
    ), seed  # fmt: skip


def continued_plan(plan: Plan, record: GuidanceRecord | None) -> tuple[Plan, list[str]]:
    """A plan continuing a session: each guidance setting its ``[guidance]`` does not give
    taken from the session's ``record`` (None: it recorded none); and those taken, in words.
    A plan with no guidance of its own takes the session's whole."""
    if record is None or not plan.spec.measures:
        return plan, []
    g = plan.guidance or Guidance(reach=thesis_reach(plan.units), min_gain=None)
    keys = plan.guidance_keys
    own_target = "target_95" in keys
    target = g.target95 if own_target else record.target95
    stop = target is not None  # a trial's most poses and the least gain are a stop rule's
    offered: dict[str, float | None] = {
        "target_95": None if own_target else record.target95,
        "reach": None if "reach" in keys else record.reach,
        "spacing": None if "spacing" in keys else record.spacing,
        "target_distance": None if "target_distance" in keys else record.target_distance,
        "max_poses": None if "max_poses" in keys or not stop else record.max_poses,
        "min_gain": None if "min_gain" in keys or not stop else record.min_gain,
    }
    taken = {k: v for k, v in offered.items() if v is not None}
    merged = Guidance(
        reach=Reach(radius=taken.get("reach", g.reach.radius),
                    spacing=taken.get("spacing", g.reach.spacing)),
        target95=target, max_poses=int(taken.get("max_poses", g.max_poses)),
        min_gain=(taken.get("min_gain", g.min_gain) or None) if target is not None else None,
        target_distance=taken.get("target_distance", g.target_distance),
    )  # fmt: skip
    return replace(plan, guidance=merged), inherited_words(taken, plan.units)


def _board(table: Any, spec: MethodSpec, units: Units) -> BoardPlacement | None:
    """``[board]`` of a board session: ``inner_corners = [cols, rows]``, ``square`` and
    ``first_corner = [x, y, z]`` (required there, refused elsewhere)."""
    if spec.measures:
        if table is not None:
            raise InputValueError('plan: [board] is for a board session (method = "board")')
        return None
    if table is None:
        raise InputValueError(
            "plan: a board session needs [board]: inner_corners = [cols, rows], square and "
            "first_corner = [x, y, z] (the measured grid point of its first inner corner)"
        )
    b = _known_keys(table, "board", "board")
    missing = sorted({"inner_corners", "square", "first_corner"} - set(b))
    if missing:
        raise InputValueError(f"plan: board.{missing[0]} is missing")
    try:
        cols, rows = (
            int(v) for v in INNER_CORNERS.read_vector(b["inner_corners"], None, text=False)
        )
    except InputValueError as err:
        raise InputValueError(f"plan: board.inner_corners: {err}") from None
    corner = _vec(BOARD_CORNER, b["first_corner"], "board.first_corner", units)
    square = _read(BOARD_SQUARE, b["square"], "board.square", units)
    try:
        return BoardPlacement(inner_corners=(cols, rows), square=square, first_corner=corner)
    except InputValueError as err:
        raise InputValueError(f"plan: [board]: {err}") from err


def _trial(
    table: Any,
    i: int,
    spec: MethodSpec,
    units: Units,
    default_camera: str,
    height: float | None,
    max_poses: int,
) -> PlannedTrial:
    """``[[trials]]`` number ``i``: its poses and its ground truth, checked."""
    t = _known_keys(table, "trials", f"trials[{i}]")
    gt = _truth(t, i, spec, units, height)
    if t.get("poses") == "guided":
        return _guided_trial(t, i, units, default_camera, max_poses, gt)
    for key in ("max_poses", "start"):
        if key in t:
            raise InputValueError(f'plan: trials[{i}].{key} is for poses = "guided" only')
    poses = []
    raw_poses = t.get("poses", [])
    if not isinstance(raw_poses, list):
        raise InputValueError(f"plan: trials[{i}].poses must be a list of poses")
    for j, p in enumerate(raw_poses, start=1):
        where = f"trials[{i}].poses[{j}]"
        p = _known_keys(p, "poses", where)
        tg = _vec(POSE_TRANSLATION, p.get("t"), f"{where}.t", units)
        r_deg = _vec(ROTATION, p.get("r_deg", [0, 0, 0]), f"{where}.r_deg", units)
        poses.append(
            PlannedPose(
                t_grid=tg, r_deg=r_deg, camera_id=str(p.get(POSE_CAMERA_KEY, default_camera))
            )
        )
    if len(poses) < 2:
        raise InputValueError(f"plan: trials[{i}] needs at least 2 poses, got {len(poses)}")
    return PlannedTrial(poses=tuple(poses), ground_truth=gt)


def _guided_trial(
    t: dict[str, Any], i: int, units: Units, camera: str, max_poses: int, gt: tuple[Vec3, ...]
) -> PlannedTrial:
    """A ``poses = "guided"`` trial: where it starts, and its most poses."""
    most = _count(MAX_POSES, t.get("max_poses", max_poses), f"trials[{i}].max_poses")
    start = _vec(POSE_TRANSLATION, t.get("start", [0, 0, 0]), f"trials[{i}].start", units)
    first = PlannedPose(t_grid=start, camera_id=camera)
    return PlannedTrial(poses=(), ground_truth=gt, max_poses=most, start=first)


def _truth(
    t: dict[str, Any], i: int, spec: MethodSpec, units: Units, height: float | None
) -> tuple[Vec3, ...]:
    """A trial's ground truth, checked by the setup rules."""
    where = f"trials[{i}].ground_truth"
    gt = tuple(_vec(GROUND_TRUTH, g, where, units) for g in t.get("ground_truth", []))
    method = spec.method
    if gt and not spec.truth_points:
        raise InputValueError(f"plan: {where}: a board session's truth is its [board], not points")
    if gt and len(gt) != spec.truth_points:
        raise InputValueError(
            f"plan: {where} needs {spec.truth_points} point(s) for {method}, got {len(gt)}"
        )
    if spec.truth_points == 2 and gt and gt[0] == gt[1]:
        raise InputValueError(f"plan: {where}: the line's two points must differ")
    keep = t.get("keep_off_ground", False)
    if not isinstance(keep, bool):
        raise InputValueError(f"plan: trials[{i}].keep_off_ground must be true or false")
    plane = spec.plane
    off = off_plane(plane, gt[0], height, units) if plane and gt and height is not None else ""
    if off and not keep:  # the rule the terminal and the browser apply: kept if confirmed
        raise InputValueError(
            f"plan: {where}: {off}; set keep_off_ground = true in this trial to keep it"
        )
    return gt
